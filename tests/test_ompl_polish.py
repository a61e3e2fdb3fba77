"""The polish of OMPL's optimising planners (`planners.ompl_polish`): headings lined up, checked shortcuts.

Ground truth is independent of the planner's checker: shapely (the path inside the map and at least the
radius from every wall) and FCL's checker. Every planning call is the same seed with and without the
polish, so the unpolished path is the one the polish started from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from planners import PlanningProblem, PlanResult, make_planner
from planners.ompl_objective import RobotTimeObjective, se2_space
from planners.ompl_planners import OmplPlanner
from planners.ompl_polish import MAX_EMPTY, aligned_se2_path, aligned_yaws, polish_polyline
from toolkit.world import RobotTiming, load_map, make_checker, map_from_dict, objective_cost, robot_time_s

RADIUS = 8.0
TIMING = RobotTiming(drive_speed_cm_s=12.0, turn_rate_deg_s=60.0, stop_turn_s=0.4)
"""A robot with a fixed time per stop-and-turn: a shortcut that adds a vertex must pay for it."""


def _plan(name: str, objective: str, polish: bool | None, map_name: str = "map2", seed: int = 4) -> PlanResult:
    m = load_map(map_name)
    budget = 0.5 if name == "ompl:FMT" else 0.1  # FMT*: polls for its batch of samples and their neighbours
    assert m.start is not None and m.target is not None
    problem = PlanningProblem.create(m, RADIUS, m.start, m.target, budget, rng=seed, timing=TIMING)
    fmt = {"settings": {"NumSamples": 500}} if name == "ompl:FMT" else {}
    return make_planner(name, objective=objective, polish=polish, **fmt).plan(problem)


def _free_by_ground_truth(map_name: str, path: np.ndarray) -> bool:
    m = load_map(map_name)
    line = shapely.LineString(path)
    shapely_free = bool(m.polygon.covers(line)) and float(line.distance(m.wall_lines)) >= RADIUS - 1e-6
    return shapely_free and bool(make_checker(m, RADIUS, "fcl").path_free(path))


@pytest.mark.parametrize(("name", "objective"), [("rrtstar", "robot-time"), ("ompl:FMT", "robot-time"),
                                                 ("rrtstar", "length"), ("ompl:BITstar", "length")])
def test_the_polished_path_is_free_never_costs_more_and_keeps_its_ends(name: str, objective: str) -> None:
    raw, polished = _plan(name, objective, False), _plan(name, objective, True)
    assert raw.success and polished.success
    assert _free_by_ground_truth("map2", polished.path)
    assert np.array_equal(polished.path[0], raw.path[0]) and np.array_equal(polished.path[-1], raw.path[-1])
    cost = objective_cost(objective, polished.path, TIMING)
    assert cost <= objective_cost(objective, raw.path, TIMING) + 1e-9
    assert polished.objective_cost == pytest.approx(cost)
    info = polished.info
    assert info["cost_after_polish"] == pytest.approx(cost, rel=1e-12)
    assert info["progress"][-1][2] == info["cost_after_polish"]  # the last sample is the returned path
    assert info["polish_checks"] > 0 and polished.collision_checks >= raw.collision_checks + info["polish_checks"]
    if objective == "robot-time":  # the planner's SE(2) cost, then its polyline's: never below the polyline's
        assert info["cost_before_polish"] >= info["cost_aligned_headings"] - 1e-9
        assert info["cost_aligned_headings"] == pytest.approx(robot_time_s(raw.path, TIMING), rel=1e-9)


def test_fmt_under_robot_time_gains_from_both_steps() -> None:
    """FMT*'s one batch of SE(2) samples keeps random headings: lining them up is worth seconds, and the
    shortcuts more."""
    info = _plan("ompl:FMT", "robot-time", True).info
    assert info["cost_before_polish"] > info["cost_aligned_headings"] > info["cost_after_polish"]


def test_with_aligned_headings_the_se2_cost_is_the_polyline_robot_time() -> None:
    m = load_map("map2")
    _space, si = se2_space(m.bounds, make_checker(m, RADIUS))
    si.setup()
    rng = np.random.default_rng(0)
    start, goal = np.array([20.0, 20.0]), np.array([130.0, 90.0])
    for _ in range(5):  # polylines that turn both ways, by small and large angles
        path = np.vstack([start, rng.uniform([10, 10], [150, 110], size=(4, 2)), goal])
        objective = RobotTimeObjective(si, TIMING, tuple(start), tuple(goal))
        cost = aligned_se2_path(si, path).cost(objective).value()
        assert cost == pytest.approx(robot_time_s(path, TIMING), rel=1e-12)
        turned = aligned_se2_path(si, path)
        turned.getState(2).setYaw(aligned_yaws(path)[2] + math.pi)  # a heading outside its segments'
        assert turned.cost(objective).value() > cost + 1e-6


def test_polish_takes_no_shortcut_that_costs_the_robot_more() -> None:
    """Over a wall (point robot) with 5 s per stop-and-turn: cutting the bend's corner saves a few cm of
    drive and costs a stop, so under robot time the path keeps its one bend;
    under length it wraps both of the wall's top corners."""
    wall = map_from_dict({"name": "one-wall",
                          "boundary": [[0, 0], [48, 0], [48, 40], [52, 40], [52, 0], [100, 0], [100, 60], [0, 60]]})
    checker = make_checker(wall, 0.0)
    timing = RobotTiming(drive_speed_cm_s=12.0, turn_rate_deg_s=60.0, stop_turn_s=5.0)
    path = np.array([[20.0, 20.0], [50.0, 55.0], [80.0, 20.0]])
    by_time = polish_polyline(path, checker, "robot-time", timing, np.random.default_rng(1))
    by_length = polish_polyline(path, checker, "length", timing, np.random.default_rng(1))
    assert checker.path_free(by_time) and checker.path_free(by_length)
    assert len(by_time) == 3 and len(by_length) >= 4
    assert robot_time_s(by_time, timing) <= robot_time_s(path, timing) < robot_time_s(by_length, timing)
    assert objective_cost("length", by_length) < objective_cost("length", by_time)


def test_polish_off_and_stop_at_first_leave_the_solution_as_found() -> None:
    assert "cost_after_polish" not in _plan("rrtstar", "length", False).info
    m = load_map("map2")
    assert m.start is not None and m.target is not None
    problem = PlanningProblem.create(m, RADIUS, m.start, m.target, 0.1, rng=4, timing=TIMING)
    first = make_planner("rrtstar", stop_at_first=True).plan(problem)
    assert first.success and "cost_after_polish" not in first.info
    connect = make_planner("ompl:RRTConnect")  # stops at its first path: no objective to polish under
    assert isinstance(connect, OmplPlanner) and connect.polish is False


def test_an_out_and_back_spur_is_cut_and_counted_as_turns() -> None:
    """A path that drives out and back (two half turns) loses the spur under either objective."""
    room = map_from_dict({"name": "room", "boundary": [[0, 0], [100, 0], [100, 60], [0, 60]]})
    checker = make_checker(room, 0.0)
    path = np.array([[10.0, 10.0], [30.0, 10.0], [40.0, 10.0], [30.0, 10.0], [30.0, 50.0]])
    for objective in ("length", "robot-time"):
        out = polish_polyline(path, checker, objective, TIMING, np.random.default_rng(2))
        assert checker.path_free(out) and out[0].tolist() == [10.0, 10.0] and out[-1].tolist() == [30.0, 50.0]
        assert np.all(np.hypot(*np.diff(out, axis=0).T) > 0)  # no repeated waypoint
        assert robot_time_s(out, TIMING) < robot_time_s(path, TIMING) - 2 * 180 / 60  # both half turns gone


def test_by_default_only_robot_time_is_polished() -> None:
    """Unset, the polish follows the objective: robot-time's sampled headings need it; a length run stays the
    planner's own path, as the raw and simplified comparisons of `bench planners` report it."""
    for objective, polished in (("robot-time", True), ("length", False)):
        default, chosen = _plan("rrtstar", objective, None), _plan("rrtstar", objective, polished)
        assert ("cost_after_polish" in default.info) is polished
        assert np.array_equal(default.path, chosen.path)


def test_a_straight_path_of_many_waypoints_is_one_segment_without_a_check() -> None:
    """An informed planner's straight solution comes with hundreds of waypoints on the line (1568 on a
    turtlebot3_world query): they go without a check, and the path is the same line."""
    room = map_from_dict({"name": "room", "boundary": [[0, 0], [100, 0], [100, 60], [0, 60]]})
    checker = make_checker(room, 0.0)
    path = np.column_stack([np.linspace(10.0, 90.0, 2001), np.linspace(10.0, 50.0, 2001)])
    for objective in ("length", "robot-time"):
        before = checker.checks
        out = polish_polyline(path, checker, objective, TIMING, np.random.default_rng(0))
        assert out.tolist() == [[10.0, 10.0], [90.0, 50.0]]
        assert checker.checks - before <= 2 * MAX_EMPTY  # the partial shortcuts' tries at most, no pair scan
