"""The conformant checker against shapely ground truth, and planning a path that is free at two starts."""

from __future__ import annotations

import math

import numpy as np
import shapely

from planners.base import PlanningProblem, make_planner
from toolkit.world import ConformantChecker, Pose, RigidMove, load_map, make_checker

RADIUS = 8.0
BELIEVED, OTHER = Pose(126, 168, 0.0), Pose(30, 54, math.pi)  # two of the course's waypoints


def _free_by_shapely(m, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    inside = shapely.contains_xy(m.polygon, a[:, 0], a[:, 1])
    return inside & (shapely.distance(lines, m.wall_lines) >= RADIUS)


def _moved(move: RigidMove, pts: np.ndarray) -> np.ndarray:
    """The rigid move by hand (independent of `RigidMove.points`)."""
    d = pts - [BELIEVED.x, BELIEVED.y]
    turn = OTHER.theta - BELIEVED.theta
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    return d @ rot.T + [OTHER.x, OTHER.y]


def test_segments_are_free_only_when_free_at_every_start_as_shapely_says() -> None:
    m = load_map("co333-arena")
    move = RigidMove(BELIEVED, OTHER)
    both = ConformantChecker(make_checker(m, RADIUS), [move])
    rng = np.random.default_rng(3)
    a, b = rng.uniform(0, 210, (4000, 2)), rng.uniform(0, 210, (4000, 2))
    want = _free_by_shapely(m, a, b) & _free_by_shapely(m, _moved(move, a), _moved(move, b))
    got = both.segments_free(a, b)
    assert 100 < int(want.sum()) < len(a) - 100  # both answers occur
    assert np.array_equal(got, want)
    assert np.array_equal(both.point_free(a), want_points := (
        shapely.contains_xy(m.polygon, *a.T) & (shapely.distance(shapely.points(a), m.wall_lines) >= RADIUS)
        & shapely.contains_xy(m.polygon, *_moved(move, a).T)
        & (shapely.distance(shapely.points(_moved(move, a)), m.wall_lines) >= RADIUS)))
    assert 0 < int(want_points.sum()) < len(a)


def test_a_planned_path_is_free_at_both_starts_where_the_plain_one_is_not() -> None:
    m = load_map("co333-arena")
    base, move = make_checker(m, RADIUS), RigidMove(BELIEVED, OTHER)
    start, goal = np.array([BELIEVED.x, BELIEVED.y]), np.array([30.0, 54.0])
    plain = make_planner("min-turn").plan(PlanningProblem(m, base, start, goal, 0.5, np.random.default_rng(0)))
    safe = make_planner("min-turn").plan(PlanningProblem(m, ConformantChecker(base, [move]), start, goal, 0.5,
                                                         np.random.default_rng(0)))
    assert plain.success and safe.success
    path = np.asarray(safe.path, dtype=float)
    assert base.path_free(path) and base.path_free(_moved(move, path))
    assert not base.path_free(_moved(move, np.asarray(plain.path, dtype=float)))  # the twin would have hit a wall
