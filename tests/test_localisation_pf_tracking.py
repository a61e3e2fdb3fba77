"""paper-pf tracking: a weak scan leaves the predicted belief as it is (one mode or several); coarse
tables track by exact rays (a thin ray or the sonar's lobe)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation import Motion, Prior
from localisation.models import range_table
from localisation.particle_filter import Mode, ParticleFilter
from localisation.scan import process_scan
from toolkit.robots.sim import SimRobot
from toolkit.world import NxtSonar, Pose, angle_diff, load_map

MAP1 = load_map("map1")


def _spread(pf: ParticleFilter) -> tuple[float, float]:
    cov = pf.estimate().cov
    return math.sqrt(cov[0, 0] + cov[1, 1]), math.degrees(math.sqrt(cov[2, 2]))


TRUTH = Pose(30.0, 30.0, 0.3)


def _two_reading_spreads(seed: int, option: str, modes: tuple[Mode, ...] = ()) -> tuple[
        tuple[float, float], dict[bool, tuple[float, float]]]:
    """Spread of a tracked cloud (3 cm, 5 degrees around the truth) before, and after one update with
    two readings a degree apart, with the boolean `option` of `ParticleFilter` on and off; `modes`
    make the belief ambiguous."""
    full = SimRobot(MAP1, TRUTH, rng=seed).ultrascan()
    two = full.subset(np.isin(np.arange(len(full)), [0, 1]))
    spreads = {}
    for on in (True, False):
        pf = ParticleFilter(MAP1, rng=seed, **{option: on})
        pf.reset(Prior(TRUTH, np.diag([9.0, 9.0, math.radians(5.0) ** 2])))
        pf._modes = list(modes)
        before = _spread(pf)
        pf.update(two)
        spreads[on] = _spread(pf)
    return before, spreads


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_two_readings_do_not_spread_the_tracked_cloud(seed: int) -> None:
    """Two readings a degree apart constrain one distance: the rest of the belief stays as predicted."""
    before, spreads = _two_reading_spreads(seed, "tracking_prior")
    assert spreads[True][0] <= 1.1 * before[0] and spreads[True][1] <= 1.2 * before[1], (before, spreads)
    # the moves that target the likelihood alone wander along what the two readings leave open
    assert spreads[False][0] > 1.5 * before[0] and spreads[False][1] > 2.0 * before[1], (before, spreads)


def _drive(pf: ParticleFilter, sonar: str | NxtSonar, seed: int) -> tuple[float, float]:
    """Largest position and heading error (cm, degrees) of `pf` tracking a robot with `sonar` on map1."""
    robot = SimRobot(MAP1, Pose(20.0, 20.0, 0.0), sonar=sonar, rng=seed)
    pf.reset(Prior(Pose(21.0, 19.0, math.radians(2.0))))
    worst, worst_h = 0.0, 0.0
    for turn, dist in [(0.0, 20.0), (0.0, 20.0), (math.pi / 2, 20.0), (0.0, 15.0), (-math.pi / 2, 10.0)]:
        robot.turn(turn)
        out = robot.move(dist)
        pf.predict(Motion(turn, out.distance_cm))
        pf.update(process_scan(robot.ultrascan()).scan)
        est = pf.estimate().pose
        worst = max(worst, est.distance_to(robot.true_pose))
        worst_h = max(worst_h, abs(math.degrees(angle_diff(est.theta, robot.true_pose.theta))))
    return worst, worst_h


def test_coarse_thin_ray_tables_track_by_exact_rays() -> None:
    """Under a budget that forces cells coarser than 1 cm, tracking updates cast rays exactly (and
    track as closely as with the 1 cm table); a 1 cm table keeps the table."""
    coarse = range_table(MAP1, memory_mb=4.0, lattice_step=2)
    assert coarse.resolution_cm > 1.0
    assert ParticleFilter(MAP1, rng=0, range_memory_mb=4.0).tracking_exact
    assert not ParticleFilter(MAP1, rng=0).tracking_exact
    assert not ParticleFilter(MAP1, rng=0, beam_width_deg=20.0).tracking_exact
    worst, worst_h = _drive(ParticleFilter(MAP1, rng=3, range_memory_mb=4.0), "ideal", 3)
    assert worst < 1.5 and worst_h < 3.0, (worst, worst_h)


def test_an_ambiguous_belief_moves_its_modes_with_the_robot() -> None:
    """The estimate of an ambiguous belief (its best mode's pose) follows the motion."""
    pf = ParticleFilter(MAP1, rng=0)
    pf.reset(Prior(Pose(20.0, 20.0, 0.0)))
    pf._modes = [Mode(Pose(20.0, 20.0, 0.0), 0.6, -1.0, 600), Mode(Pose(80.0, 80.0, math.pi), 0.4, -2.0, 400)]
    pf.predict(Motion(math.pi / 2, 10.0))
    est = pf.estimate()
    assert not est.converged
    assert est.pose.distance_to(Pose(20.0, 30.0, math.pi / 2)) < 1e-9
    assert abs(angle_diff(est.pose.theta, math.pi / 2)) < 1e-9
    assert pf.modes[1].pose.distance_to(Pose(80.0, 70.0, -math.pi / 2)) < 1e-9


def test_coarse_lobe_tables_track_by_the_exact_lobe() -> None:
    """With the NXT's lobe on a table coarser than 1 cm, tracking updates cast the lobe's rays as the
    sonar model does, and track an NXT robot within a centimetre and 1.5 degrees (the 4 cm table of
    the lobe's whole-degree minimum strays 2-4 degrees in heading on this drive)."""
    lobe = {"beam_width_deg": 20.0, "beam_rays": 9, "critical_incidence_deg": 40.0, "max_range_cm": 255.0}
    pf = ParticleFilter(MAP1, rng=5, range_memory_mb=4.0, **lobe)
    assert pf.tracking_exact and pf.tracking_prior_modes
    # the sensor whose lobe the filter is told (the hardware-facts model's 20 degrees and 40)
    worst, worst_h = _drive(pf, NxtSonar.hardware_facts(), 5)
    assert worst < 1.0 and worst_h < 1.5, (worst, worst_h)


@pytest.mark.parametrize("seed", [0, 1])
def test_an_ambiguous_belief_keeps_its_prior_per_mode(seed: int) -> None:
    """Two readings leave an ambiguous belief (several modes) where the per-mode prior has it; without
    that prior the moves wander along what the readings leave open."""
    modes = (Mode(TRUTH, 0.6, -1.0, 600), Mode(Pose(35.0, 30.0, 0.3), 0.4, -1.0, 400))
    before, spreads = _two_reading_spreads(seed, "tracking_prior_modes", modes)
    assert spreads[True][0] <= 1.2 * before[0] and spreads[True][1] <= 1.3 * before[1], (before, spreads)
    assert spreads[False][0] > 1.5 * before[0] and spreads[False][1] > 2.0 * before[1], (before, spreads)
