"""`grid`: Markov localisation on a lattice, against the simulator's true pose and against brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation import LOCALISERS, GridBayes, HeadingPrior, Motion, Prior, make_localiser
from localisation.beam_model import lattice_costs
from localisation.scan import process_scan
from toolkit.robots.sim import SimRobot
from toolkit.world import ConfigError, Map, Pose, Scan, angle_diff, load_map, map_from_dict


def _scan(m: Map, pose: Pose, seed: int = 0) -> Scan:
    return process_scan(SimRobot(m, pose, rng=seed).ultrascan(), reference="min").scan


def _off(est_pose: Pose, truth: Pose) -> tuple[float, float]:
    return est_pose.distance_to(truth), abs(math.degrees(float(angle_diff(est_pose.theta, truth.theta))))


@pytest.fixture(scope="module")
def map1() -> Map:
    return load_map("map1")


def test_registered_with_options_of_its_own(map1: Map) -> None:
    assert LOCALISERS.get("grid") is GridBayes
    g = make_localiser("grid", map1, rng=0, lattice_step=4, clearance_cm=10.0)
    assert isinstance(g, GridBayes) and g.lattice.step == 4
    near = make_localiser("grid", map1, rng=0, lattice_step=4, clearance_cm=4.0)
    assert isinstance(near, GridBayes) and len(near.lattice) > len(g.lattice)  # the clearance reaches the lattice
    assert float(np.min(map1.wall_distance(g.lattice.xy))) >= 8.5
    with pytest.raises(ConfigError, match="max_particles"):  # amcl's particle options are not the grid's
        make_localiser("grid", map1, rng=0, max_particles=10)
    for unused in ("z_hit", "max_beams", "lobe_rays"):  # nor are the parts of its model a lattice never calls
        with pytest.raises(ConfigError, match=unused):
            make_localiser("grid", map1, rng=0, **{unused: 1})
    assert g.lattice.xy.shape[0] > 100 and not g.estimate().converged  # uniform before any scan


def test_one_scan_is_the_exact_posterior_of_the_lattice(map1: Map) -> None:
    # the belief after one update from uniform is exp(-costs / 2) normalised over every lattice pose
    truth = Pose(50.0, 30.0, 0.5)
    g = GridBayes(map1, rng=0, lattice_step=4)
    g.update(_scan(map1, truth))
    rel, meas = g.measurement.readings(_scan(map1, truth))
    costs = -0.5 * lattice_costs(g.lattice, rel, meas, g.measurement.lattice_model(), max_beams=0)
    want = np.exp(costs - costs.max())
    want /= want.sum()
    got = np.exp(g._log_belief)
    assert np.allclose(got, want, atol=1e-12) and got.shape == (len(g.lattice), g.table.n_angles)
    cloud = g.cloud()
    assert cloud is not None
    poses, weights = cloud
    assert math.isclose(float(weights.sum()), 1.0) and np.all(np.diff(weights) <= 1e-15)  # most probable first
    best = np.unravel_index(int(np.argmax(want)), want.shape)
    assert np.allclose(poses[0], [*g.lattice.xy[best[0]], best[1] * 2 * math.pi / g.table.n_angles])
    err_cm, err_deg = _off(g.estimate().pose, truth)
    assert err_cm < 5.0 and err_deg < 5.0


def test_global_then_tracking_follows_the_true_pose(map1: Map) -> None:
    g = make_localiser("grid", map1, rng=3, lattice_step=3)
    robot = SimRobot(map1, Pose(20.0, 20.0, 0.3), rng=5)  # map1 is an L: the legs keep to its lower arm
    g.update(process_scan(robot.ultrascan(), reference="min").scan)
    for turn, dist in [(0.5, 20.0), (-0.8, 15.0)]:
        robot.turn(turn)
        robot.move(dist)
        g.predict(Motion(turn_rad=turn))
        g.predict(Motion(distance_cm=dist))
        g.update(process_scan(robot.ultrascan(), reference="min").scan)
    err_cm, err_deg = _off(g.estimate().pose, robot.true_pose)
    assert err_cm < 5.0 and err_deg < 6.0, (err_cm, err_deg)


def test_predict_carries_the_mass_by_the_motion_and_drops_what_hits_a_wall(map1: Map) -> None:
    start = Pose(20.0, 30.0, 0.0)
    g = GridBayes(map1, rng=1, lattice_step=2, motion_noise=0.02, turn_noise=0.01)
    g.reset(Prior(start, np.diag([1.0, 1.0, 1e-4])))
    g.predict(Motion(distance_cm=20.0))
    moved = g.estimate().pose
    assert abs(moved.x - 40.0) < 1.5 and abs(moved.y - 30.0) < 1.5 and abs(moved.theta) < 0.03
    g.predict(Motion(distance_cm=40.0))  # into the wall x = 60: every draw is lost, the belief starts again
    assert g._uniform and not g.estimate().converged
    seed_a = GridBayes(map1, rng=7, lattice_step=2)
    seed_b = GridBayes(map1, rng=7, lattice_step=2)
    for loc in (seed_a, seed_b):
        loc.reset(Prior(start, np.diag([4.0, 4.0, 0.01])))
        loc.predict(Motion(distance_cm=15.0))
    assert np.array_equal(seed_a._log_belief, seed_b._log_belief)  # the same seed, the same belief


def test_a_heading_prior_weighs_the_first_update_after_the_turns(map1: Map) -> None:
    truth = Pose(50.0, 30.0, 0.5)
    g = GridBayes(map1, rng=0, lattice_step=4)
    g.reset(HeadingPrior(truth.theta - 1.0, math.radians(10.0)))
    g.predict(Motion(turn_rad=1.0))  # the belief is uniform: only the prior turns
    assert g._heading_prior is not None and math.isclose(g._heading_prior.heading_rad, truth.theta)
    g.update(_scan(map1, truth))
    assert g._heading_prior is None
    _, err_deg = _off(g.estimate().pose, truth)
    assert err_deg < 5.0


def test_a_point_symmetric_room_leaves_two_modes() -> None:
    # a rectangle turned by 180 degrees about its centre is itself: (50, 30, 0.4) and (150, 70, 0.4 + pi)
    # read the same ranges; the lattice's nodes lie at different offsets from the two, so with the ideal
    # sonar's 1 cm sigma their masses differ, but neither is negligible
    room = map_from_dict({"name": "rectangle", "boundary": [[0, 0], [200, 0], [200, 100], [0, 100]]})
    truth = Pose(50.0, 30.0, 0.4)
    g = GridBayes(room, rng=0, lattice_step=4)
    g.update(_scan(room, truth))
    modes = g.modes
    assert len(modes) == 2 and not g.estimate().converged
    twin = Pose(150.0, 70.0, truth.theta + math.pi)
    found = sorted(min(_off(md.pose, t) for md in modes) for t in (truth, twin))
    assert all(cm < 5.0 and deg < 5.0 for cm, deg in found), found
    assert min(md.weight for md in modes) > 0.05


def test_a_prior_narrower_than_a_cell_is_widened_to_one(map1: Map) -> None:
    # the global strategy restarts a fix from the localiser's own estimate, and a grid fix on one lattice
    # pose has a zero covariance: the prior is then the cell around it, not a singular matrix
    g = GridBayes(map1, rng=0, lattice_step=2)
    start = Pose(20.5, 30.5, 0.0)
    g.reset(Prior(start, np.zeros((3, 3))))
    err_cm, err_deg = _off(g.estimate().pose, start)
    assert err_cm < 1.5 and err_deg < 1.0
    wide = np.diag([9.0, 9.0, 0.01])
    assert np.array_equal(g._no_narrower_than_a_cell(wide), wide)  # a prior wider than a cell is kept as given
