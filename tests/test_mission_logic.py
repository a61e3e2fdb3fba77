"""The mission's control logic with stand-ins for the localiser and the planner.

The stand-ins live here only (they are not registered plug-ins): an oracle localiser that reads the
simulator's true pose with Gaussian noise, and a visibility-graph planner over the c-space vertices.
They isolate the mission's own decisions (watchdog handling, re-planning, final correction, failure
statuses) from the quality of the real localiser and planner; the real stack is tested in
tests/test_mission.py.
"""

from __future__ import annotations

import heapq
import math
from typing import Any

import numpy as np
import pytest

from localisation.base import LOCALISERS, Localiser, Motion, PoseEstimate, Prior
from localisation.procedure import LocalisationResult
from planners.base import Planner, PlanningProblem, PlanStatus, Solution
from toolkit.mission import Action, MissionConfig, Outcome, run_mission
from toolkit.robots.sim import MotionNoise, SimRobot
from toolkit.world import Map, Pose, Scan, load_map, map_from_dict, wrap_angle


class OracleLocaliser(Localiser):
    """Reads the simulator's true pose (plus noise) on every update; dead-reckons on predict."""

    def __init__(self, map: Map, robot: SimRobot, sd_cm: float = 0.3, sd_rad: float = 0.005,
                 converge: bool = True, rng: Any = 0) -> None:
        super().__init__(map, rng=rng)
        self.robot = robot
        self.sd_cm, self.sd_rad = sd_cm, sd_rad
        self.converge = converge
        self.pose = Pose(0.0, 0.0, 0.0)
        self.known = False
        self.updates = 0

    def reset(self, prior: Prior | None = None) -> None:
        self.known = prior is not None
        if prior is not None:
            self.pose = prior.mean
        self.updates = 0

    def predict(self, motion: Motion) -> None:
        th = wrap_angle(self.pose.theta + motion.turn_rad)
        d = motion.distance_cm
        self.pose = Pose(self.pose.x + d * math.cos(th), self.pose.y + d * math.sin(th), th)

    def update(self, scan: Scan) -> None:
        t = self.robot.true_pose
        e = self.rng.normal(0.0, [self.sd_cm, self.sd_cm, self.sd_rad])
        self.pose = Pose(t.x + e[0], t.y + e[1], t.theta + e[2])
        self.known = True
        self.updates += 1

    def estimate(self) -> PoseEstimate:
        cov = np.diag([self.sd_cm**2, self.sd_cm**2, self.sd_rad**2])
        return PoseEstimate(self.pose, cov, self.known and self.converge, self.updates)


OracleLocaliser.name = "oracle"  # set after class creation: stays out of the registry


def oracle_localise(robot: Any, localiser: Localiser, prior: Prior | None = None, rng: Any = None,
                    **options: Any) -> LocalisationResult:
    """Stand-in for localisation.procedure.look: one scan, one update (the sweep options are ignored)."""
    localiser.reset(prior)
    localiser.update(robot.ultrascan())
    est = localiser.estimate()
    return LocalisationResult(est, scans=1, iterations=1, converged=est.converged)


class VisibilityPlanner(Planner):
    """Shortest path over the vertices of the c-space polygon (Dijkstra), checked by the shared checker."""

    def _solve(self, problem: PlanningProblem) -> Solution:
        cs = problem.map.free_space(problem.checker.robot_radius + 0.05)
        rings = [cs] if cs.geom_type == "Polygon" else list(getattr(cs, "geoms", []))
        verts = [np.asarray(r.exterior.coords)[:-1] for r in rings if not r.is_empty]
        pts = np.vstack([problem.start, problem.goal, *verts]) if verts else np.vstack([problem.start, problem.goal])
        n = len(pts)
        ii, jj = np.triu_indices(n, 1)
        free = problem.checker.segments_free(pts[ii], pts[jj])
        adj: dict[int, list[tuple[int, float]]] = {k: [] for k in range(n)}
        for a, b, ok in zip(ii, jj, free, strict=True):
            if ok:
                w = float(np.hypot(*(pts[a] - pts[b])))
                adj[a].append((b, w))
                adj[b].append((a, w))
        dist = {0: 0.0}
        prev: dict[int, int] = {}
        heap = [(0.0, 0)]
        while heap:
            d, u = heapq.heappop(heap)
            if u == 1:
                break
            if d > dist.get(u, math.inf):
                continue
            for v, w in adj[u]:
                if d + w < dist.get(v, math.inf):
                    dist[v], prev[v] = d + w, u
                    heapq.heappush(heap, (d + w, v))
        if 1 not in dist:
            return Solution(None, PlanStatus.NO_PATH)
        path = [1]
        while path[-1] != 0:
            path.append(prev[path[-1]])
        return Solution(pts[path[::-1]], PlanStatus.EXACT)


VisibilityPlanner.name = "visibility"


def _mission(m: Map, start: Pose, target: Any, seed: int = 0, *, noise: MotionNoise | None = None,
             converge: bool = True, sd_cm: float = 0.3, config: MissionConfig | None = None) -> tuple[Any, SimRobot]:
    robot = SimRobot(m, start, noise=noise, rng=seed)
    loc = OracleLocaliser(m, robot, sd_cm=sd_cm, converge=converge, rng=seed + 1)
    report = run_mission(robot, m, target, planner=VisibilityPlanner(), localiser=loc,
                         procedure=oracle_localise, rng=seed, config=config, truth=robot)
    return report, robot


@pytest.mark.parametrize("name", ["map1", "map2", "map3", "pillars"])
@pytest.mark.parametrize("model", ["botsim", "absolute"])
def test_mission_reaches_preset_target(name: str, model: str) -> None:
    m = load_map(name)
    assert m.start is not None and m.target is not None
    report, robot = _mission(m, Pose(*m.start, 1.0), m.target, seed=3, noise=MotionNoise(model))
    assert report.success, report.status
    true_err = robot.true_pose.distance_to(m.target)
    assert report.final_error_cm == pytest.approx(true_err)
    assert true_err < 2.0
    assert report.collisions == robot.collisions == 0
    assert report.counts.watchdog_stops == robot.watchdog_stops
    assert report.path_length_cm == pytest.approx(robot.odometry_cm)
    assert report.times.robot_time_s == pytest.approx(robot.robot_time_s)
    assert report.poses.final_pose == robot.true_pose
    # the driven path cannot be shorter than the straight line nor the first plan shorter than it
    assert report.path_length_cm >= np.hypot(*(m.target - m.start)) - 3.0
    assert report.planned_length_cm >= np.hypot(*(m.target - m.start)) - 3.0
    assert report.trace[-1].true_pose == robot.true_pose


def test_target_in_wall_is_a_status_not_an_exception() -> None:
    m = load_map("map1")
    report, robot = _mission(m, Pose(20, 20, 0), (3.0, 50.0))
    assert not report.success
    assert report.outcome is Outcome.TARGET_IN_WALL and "in a wall" in report.status
    assert robot.odometry_cm == 0.0  # nothing was driven


def test_target_outside_map() -> None:
    m = load_map("map1")
    report, _ = _mission(m, Pose(20, 20, 0), (80.0, 20.0))  # the notch of map1 is outside
    assert not report.success
    assert report.outcome is Outcome.TARGET_OUTSIDE, report.status


def test_unreachable_target() -> None:
    # two rooms joined by a 10 cm gap: too narrow for a robot of radius 8 cm
    m = map_from_dict({"name": "split", "boundary": [[0, 0], [60, 0], [60, 25], [65, 25], [65, 0], [120, 0],
                                                      [120, 60], [65, 60], [65, 35], [60, 35], [60, 60], [0, 60]]})
    report, robot = _mission(m, Pose(20, 30, 0), (100.0, 30.0))
    assert not report.success
    assert report.outcome is Outcome.UNREACHABLE, report.status
    assert robot.collisions == 0


def test_lost_robot() -> None:
    m = load_map("map2")
    report, _ = _mission(m, Pose(30, 20, 0), m.target, converge=False)
    assert not report.success
    assert report.outcome is Outcome.LOST, report.status
    assert report.counts.relocalisations == 0
    strategy = MissionConfig().global_localisation
    finals = [s for s in report.trace if s.action == Action.LOCALISE and "not converged" in s.note]
    assert len(finals) == strategy.attempts
    assert Action.PLAN not in [s.action for s in report.trace]
    # between attempts the mission explored, within the limit of moves per attempt
    moves = [s for s in report.trace if s.action == Action.EXPLORE_MOVE]
    assert 0 < len(moves) <= strategy.attempts * strategy.max_explore_moves


def _first_fix_off(loc: OracleLocaliser, dx_cm: float = 0.0, dy_cm: float = 0.0) -> OracleLocaliser:
    """`loc` whose first update leaves its pose off by (`dx_cm`, `dy_cm`); the later ones are true."""
    original = loc.update
    calls = {"n": 0}

    def off_once(scan: Scan) -> None:
        original(scan)
        calls["n"] += 1
        if calls["n"] == 1:
            loc.pose = Pose(loc.pose.x + dx_cm, loc.pose.y + dy_cm, loc.pose.theta)

    loc.update = off_once  # type: ignore[method-assign]
    return loc


def test_watchdog_stop_leads_to_turnback_relocalise_replan() -> None:
    # a first fix 20 cm short in y drives the robot at the top wall of map1: the watchdog must stop it
    m = load_map("map1")
    robot = SimRobot(m, Pose(20, 75, math.pi / 2), rng=5)
    loc = _first_fix_off(OracleLocaliser(m, robot, sd_cm=0.2, rng=1), dy_cm=-20.0)
    cfg = MissionConfig().with_options(**{"fix.relocalise_every_cm": None, "fix.first_leg_cm": None,
                                          "global_localisation.confirm": False})
    report = run_mission(robot, m, (20.0, 88.0), planner=VisibilityPlanner(), localiser=loc,
                         procedure=oracle_localise, rng=0, config=cfg, truth=robot)
    assert robot.true_pose.distance_to((20.0, 88.0)) < 2.0
    assert report.success, report.status
    assert robot.collisions == 0
    assert report.counts.watchdog_stops == robot.watchdog_stops >= 1
    actions = [s.action for s in report.trace]
    k = actions.index(Action.TURNBACK)
    assert actions[k + 1] == Action.RELOCALISE and Action.PLAN in actions[k + 2:]
    assert report.counts.replans >= 1


def test_report_to_dict_is_json() -> None:
    import json

    m = load_map("map1")
    report, _ = _mission(m, Pose(20, 20, 0.3), m.target)
    d = json.loads(json.dumps(report.to_dict()))
    assert d["outcome"] == "reached" and report.outcome is Outcome.REACHED
    for key in ("success", "final_error_cm", "completion_s", "robot_time_s", "path_length_cm", "planned_length_cm",
                "turns", "collisions", "watchdog_stops", "relocalisations", "replans", "map", "planner", "localiser",
                "seed", "start", "target", "final_pose", "final_estimate", "status", "outcome", "trace", "plans"):
        assert key in d
    assert d["start"] == [20.0, 20.0, pytest.approx(math.degrees(0.3))]
    assert d["turns"] == sum(1 for s in report.trace if s.action in (Action.TURN, Action.CORRECT_TURN)
                             and abs(s.turn_rad) > math.radians(0.5))


def test_a_wrong_single_place_fix_is_caught_by_the_confirmation() -> None:
    # map3's rooms are identical: a localiser that collapses on the twin room (90 cm off) on its first
    # fix must not send the robot "home" in the wrong room
    m = load_map("map3")
    assert m.start is not None and m.target is not None
    robot = SimRobot(m, Pose(*m.start, 0.5), rng=2)
    loc = _first_fix_off(OracleLocaliser(m, robot, sd_cm=0.2, rng=3), dx_cm=90.0)
    report = run_mission(robot, m, m.target, planner=VisibilityPlanner(), localiser=loc,
                         procedure=oracle_localise, rng=0, truth=robot)
    assert report.success, report.status
    assert robot.true_pose.distance_to(m.target) < 2.0
    assert any("disagree" in s.note for s in report.trace)


class _Unbuildable(OracleLocaliser):
    """A localiser whose construction fails the test: it must never be built."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        raise AssertionError("the localiser should not be built for a target in a wall")


_Unbuildable.name = "test-unbuildable"  # not in the class body, which would register it for every test


def test_target_in_a_wall_is_reported_before_the_localiser_is_built() -> None:
    m = load_map("map1")
    robot = SimRobot(m, Pose(20.0, 20.0, 0.0), rng=0)
    with LOCALISERS.added({_Unbuildable.name: _Unbuildable}):
        report = run_mission(robot, m, (3.0, 50.0), localiser=_Unbuildable.name, rng=0)
    assert not report.success and report.outcome is Outcome.TARGET_IN_WALL
    assert report.localiser == "test-unbuildable" and robot.robot_time_s == 0.0
    with pytest.raises(KeyError):  # an unknown localiser name still fails at once
        run_mission(robot, m, (80.0, 80.0), localiser="no-such-filter", rng=0)


def test_trace_actions_are_the_enum_and_unknown_ones_are_refused() -> None:
    m = load_map("map1")
    report, _ = _mission(m, Pose(20, 20, 0.3), m.target)
    assert report.trace and all(isinstance(s.action, Action) for s in report.trace)
    assert [s["action"] for s in report.to_dict()["trace"]] == [s.action.value for s in report.trace]
    with pytest.raises(ValueError, match="'wander' is not a valid Action"):
        Action("wander")
