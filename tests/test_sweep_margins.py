"""`toolkit.real_sonar.margins`: how far a sonar model prefers a sweep's waypoint to every other place, checked
where the answer is known: a place with a twin (a point-symmetric room) and a place without one."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import real_nxt_arena

from toolkit.real_sonar.margins import sweep_margins
from toolkit.real_sonar.sweeps import Sweep, SweepSet, sweep_angles
from toolkit.world import Map, NxtSonar, map_from_dict

MODEL = NxtSonar()
RECTANGLE = map_from_dict({"name": "rectangle", "boundary": [[0, 0], [200, 0], [200, 100], [0, 100]]})


def _sweep_set(m: Map, x: float, y: float, heading_deg: float, seed: int = 0) -> SweepSet:
    ang = sweep_angles(72, 5.0, "ccw")
    r = MODEL.measure(m.walls, np.array([x, y]), math.radians(heading_deg) + ang, np.random.default_rng(seed))
    return SweepSet(Path("simulated"), m, (Sweep("sim", "s0", x, y, ang, np.asarray(r, dtype=float), step_deg=5.0),))


@pytest.mark.parametrize("seed", [0, 1])
def test_a_distinct_place_is_preferred(seed: int) -> None:
    # (126, 100) of the real arena: its walls at every side differ from any other place's
    (margin,) = sweep_margins(MODEL, _sweep_set(real_nxt_arena(), 126.5, 100.5, 30.0, seed))
    assert margin > 3.0


def test_a_twin_place_cannot_be_preferred() -> None:
    # a rectangle looks the same from (30.5, 40.5) and from its point reflection (169.5, 59.5) turned by
    # 180 degrees: both are lattice poses, so the twin explains the sweep as well, up to the range table's
    # 1 cm cells (well under a nat here, against more than 3 at a distinct place)
    (margin,) = sweep_margins(MODEL, _sweep_set(RECTANGLE, 30.5, 40.5, 10.0))
    assert abs(margin) < 1.0


def test_radii_checked() -> None:
    with pytest.raises(ValueError, match="near_cm < far_cm"):
        sweep_margins(MODEL, _sweep_set(RECTANGLE, 30.5, 40.5, 0.0), near_cm=30.0, far_cm=20.0)
