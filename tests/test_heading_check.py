"""The heading check (`localisation.heading_check`) against sweeps simulated at a known true heading."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation.heading_check import MIN_OFFSET_DEG, check_heading
from localisation.scan import sweep_angles
from toolkit.world import IdealSonar, NxtSonar, Pose, Scan, load_map

TRACK = sweep_angles(2.0, 15.0, (-90.0, 0.0, 90.0))  # a mission's check sweep


def _cases(n: int, seed: int) -> list[tuple[str, np.ndarray, float]]:
    """`n` positions per paper map at least 12 cm from the walls, each with a heading."""
    rng = np.random.default_rng(seed)
    out = []
    for name in ("map1", "map2", "map3"):
        m = load_map(name)
        kept = 0
        while kept < n:
            xy = m.sample_free(1, rng=rng)[0]
            if m.wall_distance(xy) >= 12.0:
                out.append((name, xy, float(rng.uniform(-math.pi, math.pi))))
                kept += 1
    return out


def test_nxt_sweeps_find_a_turn_that_slipped_and_rarely_call_a_right_heading_off() -> None:
    sonar = NxtSonar().simulated()
    rng = np.random.default_rng(7)
    false_alarms = found = 0
    cases = _cases(12, seed=3)
    for name, xy, heading in cases:
        m = load_map(name)
        belief = Pose(*(xy + rng.normal(0.0, 1.0, 2)), heading)  # a fix's position error
        right = sonar.measure(m.walls, xy[None, :], heading + TRACK, rng=rng).ravel()
        false_alarms += check_heading(m, belief, Scan.from_readings(TRACK, right), sonar).off
        slip = math.radians(25.0) * rng.choice([-1.0, 1.0])
        wrong = sonar.measure(m.walls, xy[None, :], heading + slip + TRACK, rng=rng).ravel()
        check = check_heading(m, belief, Scan.from_readings(TRACK, wrong), sonar)
        found += check.off and abs(check.offset_rad - slip) <= math.radians(8.0)
    # measured over 180 cases per heading error: about 1 % false alarms, 80 % found (module docstring)
    assert false_alarms <= 2, false_alarms
    assert found >= 0.65 * len(cases), (found, len(cases))


def test_ideal_readings_give_the_offset_exactly() -> None:
    m = load_map("map2")
    sonar = IdealSonar()
    for name, xy, heading in _cases(3, seed=11)[3:6]:
        assert name == "map2"
        for slip_deg in (-30.0, 0.0, 17.0):
            readings = sonar.measure(m.walls, xy[None, :], heading + math.radians(slip_deg) + TRACK).ravel()
            check = check_heading(m, Pose(float(xy[0]), float(xy[1]), heading), Scan.from_readings(TRACK, readings))
            assert math.degrees(check.offset_rad) == pytest.approx(slip_deg, abs=1.0)
            assert check.off == (abs(slip_deg) >= MIN_OFFSET_DEG)


def test_a_sweep_without_readings_says_nothing() -> None:
    m = load_map("map1")
    empty = Scan(TRACK, np.full(TRACK.size, np.inf), np.zeros(TRACK.size, dtype=bool))
    check = check_heading(m, Pose(50.0, 50.0, 0.0), empty)
    assert check.readings == 0 and not check.off
