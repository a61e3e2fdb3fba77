"""Path metrics on hand-made paths with known answers, and clearance against shapely."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.metrics import PathMetrics, count_turns, heading_changes, path_length, path_metrics, turn_angle
from toolkit.world import CollisionChecker, load_map


def test_length_turns_and_angle_of_a_staircase() -> None:
    p = np.array([[0, 0], [10, 0], [10, 10], [20, 10], [20, 20]])
    assert path_length(p) == 40.0
    assert count_turns(p) == 3
    assert turn_angle(p) == pytest.approx(3 * math.pi / 2)
    np.testing.assert_allclose(heading_changes(p), [math.pi / 2, -math.pi / 2, math.pi / 2])


def test_small_and_repeated_heading_changes() -> None:
    # a 0.5 degree kink is below the default threshold, a repeated waypoint is no turn
    kink = np.array([[0, 0], [10, 0], [20, 10 * math.tan(math.radians(0.5))]])
    assert count_turns(kink) == 0
    assert count_turns(kink, threshold_rad=math.radians(0.1)) == 1
    repeated = np.array([[0, 0], [5, 0], [5, 0], [10, 0]])
    assert count_turns(repeated) == 0 and turn_angle(repeated) == 0.0
    # a U-turn is one turn of pi
    u = np.array([[0, 0], [10, 0], [0, 0]])
    assert count_turns(u) == 1 and turn_angle(u) == pytest.approx(math.pi)


def test_degenerate_paths() -> None:
    assert path_length(np.empty((0, 2))) == 0.0
    assert path_length([[1, 2]]) == 0.0
    assert count_turns([[1, 2]]) == 0 and turn_angle([[0, 0], [1, 1]]) == 0.0


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(st.floats(-100, 100), st.floats(-100, 100)), min_size=2, max_size=8))
def test_metrics_are_invariant_to_rotation_and_reversal(points: list[tuple[float, float]]) -> None:
    p = np.array(points)
    a = 0.7
    rot = p @ np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]])
    assert path_length(rot) == pytest.approx(path_length(p), rel=1e-9, abs=1e-9)
    assert path_length(p[::-1]) == pytest.approx(path_length(p), rel=1e-12, abs=1e-12)
    assert turn_angle(p[::-1]) == pytest.approx(turn_angle(p), rel=1e-9, abs=1e-9)
    assert 0 <= count_turns(p) <= max(len(p) - 2, 0)
    assert turn_angle(p) <= math.pi * max(len(p) - 2, 0) + 1e-9


def test_path_metrics_against_shapely_clearance() -> None:
    m = load_map("map1")
    checker = CollisionChecker(m, 8.0)
    path = np.array([[20.0, 20.0], [20.0, 80.0], [80.0, 80.0]])
    met = path_metrics(path, checker, reference_length=100.0, reference_turns=1)
    assert isinstance(met, PathMetrics)
    assert met.length_cm == 120.0 and met.turns == 1
    assert met.turn_angle_rad == pytest.approx(math.pi / 2)
    assert met.length_ratio == pytest.approx(1.2) and met.turn_ratio == 1.0
    # independent: distance from the waypoints' disc edge to the walls, sampled densely
    t = np.linspace(0, 1, 601)[:, None]
    dense = np.vstack([path[0] + t * (path[1] - path[0]), path[1] + t * (path[2] - path[1])])
    clear = m.wall_distance(dense) - 8.0
    assert met.min_clearance_cm == pytest.approx(clear.min(), abs=0.05)
    assert met.mean_clearance_cm == pytest.approx(clear.mean(), abs=0.5)
    d = met.to_dict()
    assert set(d) == {"length_cm", "turns", "turn_angle_rad", "min_clearance_cm", "mean_clearance_cm",
                      "length_ratio", "turn_ratio"}


def test_ratios_without_references_and_zero_turns() -> None:
    m = load_map("map1")
    checker = CollisionChecker(m, 8.0)
    straight = np.array([[20.0, 20.0], [20.0, 80.0]])
    met = path_metrics(straight, checker)
    assert math.isnan(met.length_ratio) and math.isnan(met.turn_ratio)
    assert path_metrics(straight, checker, reference_turns=0).turn_ratio == 1.0  # 0 / 0 is 1
    assert path_metrics(np.array([[20.0, 20.0], [20, 80], [50, 80]]), checker, reference_turns=0).turn_ratio == math.inf
    empty = path_metrics(np.empty((0, 2)), checker)
    assert empty.length_cm == 0.0 and math.isnan(empty.min_clearance_cm)
