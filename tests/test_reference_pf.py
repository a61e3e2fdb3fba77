"""`paper-pf` against the plainly written reference filter (`localisation.reference_pf`) on the same scans.

Both are judged against the simulator's true pose, and against each other: the speed-ups of
`paper-pf` (range tables, lattice starts, annealing, modes) may change its cost, not its answer.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation import Localiser, Motion, Prior, make_localiser
from localisation.reference_pf import ReferenceParticleFilter
from toolkit.robots.sim import SimRobot
from toolkit.world import Pose, Scan, angle_diff, load_map

SEEDS = range(8)
ANGLES = np.radians(np.arange(0.0, 360.0, 5.0))  # 72 readings: enough for both, quick for the reference


def _robot(map_name: str, seed: int) -> SimRobot:
    m = load_map(map_name)
    rng = np.random.default_rng(seed)
    xy = m.sample_free(1, 8.0, rng)[0]
    return SimRobot(m, Pose(xy[0], xy[1], rng.uniform(-math.pi, math.pi)), sonar="ideal", sensor_noise=1.0, rng=seed)


def _off(truth: Pose) -> Prior:
    """A prior 5 cm and 6 degrees off the truth, with a spread that covers that."""
    return Prior(Pose(truth.x + 4.0, truth.y - 3.0, truth.theta + math.radians(6.0)),
                 np.diag([36.0, 36.0, math.radians(10.0) ** 2]))


def _heading_deg(a: Pose, b: Pose) -> float:
    return math.degrees(abs(angle_diff(a.theta, b.theta)))


def _both(map_name: str, seed: int, **reference: float) -> tuple[Localiser, Localiser]:
    m = load_map(map_name)
    return ReferenceParticleFilter(m, rng=seed, **reference), make_localiser("paper-pf", m, rng=seed)  # type: ignore[arg-type]


@pytest.mark.parametrize("map_name", ["map1", "map2", "map3"])
def test_from_a_prior_both_find_the_truth_and_agree(map_name: str) -> None:
    errors: dict[str, list[float]] = {"reference": [], "paper-pf": []}
    for seed in SEEDS:
        robot = _robot(map_name, seed)
        truth, scan = robot.true_pose, robot.ultrascan(ANGLES)
        estimates = {}
        for name, loc in zip(errors, _both(map_name, seed), strict=True):
            loc.reset(_off(truth))
            loc.update(scan)
            estimates[name] = est = loc.estimate().pose
            errors[name].append(est.distance_to(truth))
            assert _heading_deg(est, truth) <= 3.0, (name, seed)
        apart = estimates["reference"].distance_to(estimates["paper-pf"])
        assert apart <= 3.0 and _heading_deg(estimates["reference"], estimates["paper-pf"]) <= 3.0, (seed, apart)
    medians = {name: float(np.median(e)) for name, e in errors.items()}
    assert max(medians.values()) <= 1.5, medians
    assert abs(medians["reference"] - medians["paper-pf"]) <= 1.0, medians


def test_both_follow_a_move_and_the_next_scan() -> None:
    for seed in SEEDS:
        robot = _robot("map1", seed)
        truth = robot.true_pose
        first = robot.ultrascan(ANGLES)
        # a turn towards the map's middle and a short drive (the simulator adds its noise to both)
        turn = float(angle_diff(math.atan2(52.0 - truth.y, 53.0 - truth.x), truth.theta))
        robot.turn(turn)
        outcome = robot.move(10.0)
        second = robot.ultrascan(ANGLES)
        estimates = []
        for loc in _both("map1", seed):
            loc.reset(_off(truth))
            loc.update(first)
            loc.predict(Motion(turn, outcome.distance_cm))
            loc.update(second)
            est = loc.estimate().pose
            assert est.distance_to(robot.true_pose) <= 2.5 and _heading_deg(est, robot.true_pose) <= 3.0, seed
            estimates.append(est)
        assert estimates[0].distance_to(estimates[1]) <= 3.0, seed


@pytest.mark.slow
def test_from_nothing_both_find_a_distinct_place() -> None:
    # map1 has no twin places: a uniform start must end at the truth for both filters (the reference
    # weighs with a wider sigma, the paper's uniform particles being far sparser than its peak)
    for seed in range(3):
        robot = _robot("map1", seed)
        truth, scan = robot.true_pose, robot.ultrascan(ANGLES)
        estimates = []
        for loc in _both("map1", seed, n_particles=20000, sensor_sigma_cm=3.0, iterations=20):
            loc.reset(None)
            loc.update(scan)
            est = loc.estimate()
            assert est.converged and est.pose.distance_to(truth) <= 6.0 and _heading_deg(est.pose, truth) <= 4.0, seed
            estimates.append(est.pose)
        assert estimates[0].distance_to(estimates[1]) <= 6.0, seed


def test_the_reference_reads_the_walls_it_should() -> None:
    # its ranges are the exact distances to the walls: in map1's outer square, from a known pose
    m = load_map("map1")
    ref = ReferenceParticleFilter(m, rng=0)
    xmin, ymin = m.bounds[:2]
    pose = np.array([[xmin + 10.0, ymin + 12.0, 0.0]])
    ranges = ref.expected_ranges(pose, np.radians([180.0, 270.0]))[0]
    assert ranges == pytest.approx([10.0, 12.0])
    # no-echo readings carry nothing: a scan of them leaves the cloud as it was
    before = ref.cloud()
    ref.update(Scan.from_readings(ANGLES[:4], np.full(4, np.inf)))
    after = ref.cloud()
    assert np.array_equal(before[0], after[0]) and np.array_equal(before[1], after[1])
