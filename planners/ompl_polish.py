"""Polishing an OMPL planner's solution under the planner's own objective (length or robot time).

What the robot drives, and what the benchmark scores, is the 2-D polyline of a solution. Under
robot time OMPL plans over SE(2) (`planners.ompl_objective`): every intermediate state carries a
sampled heading, and a motion is charged the turn from the state's heading to the segment's, the
drive, and the turn to the next state's heading. The SE(2) cost of a path is therefore at least the
robot time of its polyline, equal only when each vertex's heading lies between its two segments'
headings; an anytime planner spends iterations lining the headings up (FMT*'s single batch never
does). Two steps, both exact:

1. **Headings** (`aligned_yaws`): every vertex takes the heading of the segment it arrives by (the
   start that of the first segment). Then a motion turns at its start by exactly the polyline's turn
   at that vertex and not at all on arrival, so the SE(2) cost of the path *equals* the robot time of
   its polyline (`toolkit.world.robot_time_s`), fixed stop-and-turn time included.
2. **Shortcuts** (`polish_polyline`): vertex reduction (drop the waypoints between two vertices joined
   by a free segment), OMPL-style partial shortcuts (join two random points on the path's segments)
   and pulls (move a waypoint toward the chord of its neighbours), each kept only when the path's
   cost under the objective drops (robot time by the robot's own account, `RobotTiming.move` and
   `RobotTiming.turn` with the problem's timing, or length) and its new segments are free by the
   shared checker's `segment_free` (the rest of the path is made of pieces of free segments). Rounds
   of pulls and shortcuts repeat until one gains less than 0.01 % of the cost. So the polished path is
   collision-free whenever the input was, keeps its end points and never costs more (checked at the
   end with `toolkit.world.objective_cost`; the input is returned otherwise).

Why not OMPL's `PathSimplifier` with the objective (``PathSimplifier(si, goal, objective)``; read in
OMPL's ``src/ompl/geometric/src/PathSimplifier.cpp``)? Its ``reduceVertices`` and
``collapseCloseVertices`` never consult the objective (they are length moves), ``smoothBSpline`` is a
length move too, and its ``shortcutPath`` / ``partialShortcutPath`` do compare the objective's
``motionCost`` sums, but over SE(2) they keep the stale sampled headings of the vertices and give new
states interpolated headings: the costs compared are the SE(2) costs that step 1 is there to remove,
not the robot time of the polyline. Robot time is not a sum over 2-D segments (a turn depends on two),
so no objective over the plane expresses it for OMPL's simplifier either. Vertex reduction and partial
shortcuts with length as the cost are OMPL's ``reduceVertices`` and ``partialShortcutPath`` under its
length objective: under ``length`` the planner is polished by the same mechanism and the same stopping rule,
so the comparison between the objectives stays fair.
"""

from __future__ import annotations

import bisect
import itertools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import ompl.geometric as og
from numpy.typing import ArrayLike, NDArray

from toolkit.world import CollisionChecker, RobotTiming, objective_cost

from .metrics import drop_straight

__all__ = ["MAX_EMPTY", "aligned_se2_path", "aligned_yaws", "distinct_waypoints", "polish_polyline",
           "polish_solution"]

MAX_EMPTY = 20
"""Partial shortcuts tried in a row without a change before the polish stops."""
_EPS_CM = 1e-9
_RANGE_RATIO = 0.33
"""A partial shortcut joins two points at most this fraction of the path's length apart (OMPL's
``partialShortcutPath`` default, over vertex indices there)."""
_MAX_TRIES = 2000
"""At most this many partial shortcuts in all (a bound on the polish's time; not reached on the bundled maps)."""
_ROUNDS = 10
"""At most this many rounds of pulls and partial shortcuts after the first shortcuts."""
_CONVERGED = 1e-4
"""A round that lowers the cost by less than this fraction of it ends the polish."""
_SNAP_RATIO = 0.005
"""A shortcut's end within this fraction of the path's length of a vertex is the vertex (OMPL's
``snapToVertex`` default)."""
_LOG_SPANS = (math.log(_SNAP_RATIO), math.log(_RANGE_RATIO))
"""A partial shortcut's span, as a fraction of the path's length, is drawn log-uniformly between the
snap and the range ratios: short cuts at a corner are as likely as long ones (OMPL draws the span
uniformly, and most long cuts on a long path hit a wall; measured on map2-3: 1.002 against 1.005 of
the least robot time, at about the same number of checks)."""


def distinct_waypoints(points: ArrayLike) -> NDArray[np.float64]:
    """The waypoints of `points` (k, 2) cm without repeats (a waypoint within 1e-9 cm of the one before)."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        return p.copy()
    step = np.hypot(*np.diff(p, axis=0).T)
    keep = np.concatenate([[True], step > _EPS_CM])
    out = p[keep]
    if len(out) >= 2 and not keep[-1]:
        out[-1] = p[-1]  # the exact goal, not the waypoint it repeats
    return out


def aligned_yaws(points: ArrayLike) -> NDArray[np.float64]:
    """Each waypoint's heading (rad) for the SE(2) path whose cost is the polyline's robot time: the
    heading of the segment it is reached by, the start's that of the first segment (module notes, step 1).

    >>> aligned_yaws([[0, 0], [10, 0], [10, 10]]).round(4).tolist()
    [0.0, 0.0, 1.5708]
    """
    p = distinct_waypoints(points)
    if len(p) < 2:
        return np.zeros(len(p))
    d = np.diff(p, axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0])
    return np.concatenate([heading[:1], heading])


Polyline = list[tuple[float, float]]


def aligned_se2_path(si: Any, points: ArrayLike) -> Any:
    """OMPL's SE(2) path through `points` (cm) with `aligned_yaws`: its cost under
    `planners.ompl_objective.RobotTimeObjective` is the polyline's robot time.

    Parameters
    ----------
    si : ompl.base.SpaceInformation
        Of an `ompl.base.SE2StateSpace`.
    points : (k, 2) array_like
    """
    p = distinct_waypoints(points)
    path = og.PathGeometric(si)
    space = si.getStateSpace()
    for (x, y), yaw in zip(p.tolist(), aligned_yaws(p).tolist(), strict=True):
        state = space.allocState()
        state.setX(x)
        state.setY(y)
        state.setYaw(yaw)
        path.append(state)
    return path


def _window_cost(objective: str, timing: RobotTiming) -> Callable[[Polyline], float]:
    """The cost of a short polyline (no repeated waypoints) under `objective`: its length (cm), or its
    robot time (s) by the robot's own account, `RobotTiming.move` per segment and `RobotTiming.turn`
    per heading change (plain floats: a window is a few waypoints, where numpy's overhead dominates)."""
    if objective == "length":
        return lambda q: sum(math.dist(a, b) for a, b in itertools.pairwise(q))

    def robot_time(q: Polyline) -> float:
        q = [point for k, point in enumerate(q) if k == 0 or point != q[k - 1]]  # a repeat is no turn
        total = sum(timing.move(math.dist(a, b)) for a, b in itertools.pairwise(q))
        for (ax, ay), (bx, by), (cx, cy) in zip(q, q[1:], q[2:], strict=False):
            ux, uy, vx, vy = bx - ax, by - ay, cx - bx, cy - by
            total += timing.turn(math.atan2(ux * vy - uy * vx, ux * vx + uy * vy))
        return total

    return robot_time


def polish_polyline(points: ArrayLike, checker: CollisionChecker, objective: str, timing: RobotTiming,
                    rng: np.random.Generator, max_empty: int = MAX_EMPTY) -> NDArray[np.float64]:
    """A free polyline shortened under `objective` by checked shortcuts (module notes, step 2).

    Parameters
    ----------
    points : (k, 2) array_like
        A collision-free path (cm) of the checker's robot.
    checker : CollisionChecker
        The shared checker: every new segment is checked by its `segment_free` (counted in its checks).
    objective : {"length", "robot-time"}
        What a change must lower: the polyline's length (cm) or its robot time (s) under `timing`.
    timing : RobotTiming
    rng : numpy.random.Generator
        Draws the partial shortcuts' ends.
    max_empty : int
        Partial shortcuts tried in a row without a change before stopping.

    Returns
    -------
    (m, 2) ndarray
        The polished path: same end points, repeated waypoints dropped, cost never above the input's
        (`toolkit.world.objective_cost`).
    """
    p = distinct_waypoints(points)
    if len(p) < 3:
        return p
    before = objective_cost(objective, p, timing)
    p = drop_straight(p)  # an informed planner's straight solution: hundreds of waypoints on the line
    tolerance = 1e-12 * max(before, 1.0)  # a smaller gain is rounding, not a gain
    cost = _window_cost(objective, timing)
    q: Polyline = [(float(x), float(y)) for x, y in p.tolist()]
    q = _reduce_vertices(q, checker, cost, tolerance)
    q = _partial_shortcuts(q, checker, cost, tolerance, rng, max_empty)
    for _ in range(_ROUNDS):  # until a round gains less than _CONVERGED of the cost
        start = cost(q)
        q = _pull_vertices(q, checker, cost, tolerance)
        q = _partial_shortcuts(q, checker, cost, tolerance, rng, max_empty)
        if cost(q) > start * (1.0 - _CONVERGED):
            break
    q = _reduce_vertices(q, checker, cost, tolerance)
    out = np.array(q, dtype=float)
    if objective_cost(objective, out, timing) > before:  # every change lowered the cost: never expected
        return p
    return out


def _window_gain(q: Polyline, i: int, j: int, middle: Polyline, cost: Callable[[Polyline], float]) -> float:
    """How much the cost drops when the waypoints strictly between `i` and `j` are replaced by `middle`:
    the costs of the windows from the waypoint before `i` to the one after `j` (both costs are sums of
    segment and vertex terms, so the rest of the path cancels)."""
    lo, hi = max(i - 1, 0), min(j + 2, len(q))
    return cost(q[lo:hi]) - cost(q[lo:i + 1] + middle + q[j:hi])


def _reduce_vertices(q: Polyline, checker: CollisionChecker, cost: Callable[[Polyline], float],
                     tolerance: float) -> Polyline:
    """From each waypoint in turn, jump to the farthest later one joined by a free segment that lowers the cost."""
    i = 0
    while i < len(q) - 2:
        for j in range(len(q) - 1, i + 1, -1):
            if _window_gain(q, i, j, [], cost) > tolerance and checker.segment_free(q[i], q[j]):
                q = q[:i + 1] + q[j + 1:] if q[j] == q[i] else q[:i + 1] + q[j:]  # out and back: one waypoint
                break
        i += 1
    return q


def _point_at(q: Polyline, cum: list[float], t: float, snap: float) -> tuple[int, tuple[float, float], bool]:
    """The point at arc length `t` (cm) of `q` (`cum`: the arc length at each waypoint): the index of its
    segment's first waypoint, the point, and whether it is that waypoint (within `snap` cm; a point within
    `snap` of the segment's end is the end)."""
    k = min(max(bisect.bisect_right(cum, t) - 1, 0), len(q) - 2)
    if t - cum[k] <= snap:
        return k, q[k], True
    if cum[k + 1] - t <= snap:
        return k + 1, q[k + 1], True
    u = (t - cum[k]) / (cum[k + 1] - cum[k])
    (ax, ay), (bx, by) = q[k], q[k + 1]
    return k, (ax + u * (bx - ax), ay + u * (by - ay)), False


def _partial_shortcuts(q: Polyline, checker: CollisionChecker, cost: Callable[[Polyline], float], tolerance: float,
                       rng: np.random.Generator, max_empty: int) -> Polyline:
    """Join two random points of the path (at most `_RANGE_RATIO` of its length apart) by a straight
    segment when that lowers the cost and the segment is free; stop after `max_empty` tries in a row
    without a change (or `_MAX_TRIES` in all)."""
    cum = list(itertools.accumulate((math.dist(a, b) for a, b in itertools.pairwise(q)), initial=0.0))
    empty = 0
    for _ in range(_MAX_TRIES):
        if empty >= max_empty:
            break
        empty += 1
        total = cum[-1]
        t0 = float(rng.uniform(0.0, total))
        span = math.exp(float(rng.uniform(_LOG_SPANS[0], _LOG_SPANS[1]))) * total
        t1 = min(max(t0 + span if rng.uniform() < 0.5 else t0 - span, 0.0), total)
        i, a, a_is_vertex = _point_at(q, cum, min(t0, t1), _SNAP_RATIO * total)
        j, b, b_is_vertex = _point_at(q, cum, max(t0, t1), _SNAP_RATIO * total)
        if not b_is_vertex:
            j += 1  # b lies inside segment (j, j+1): the waypoints kept after it start at j + 1
        if j - i < 2:
            continue  # no waypoint between the two points to cut
        middle = [point for point, vertex in ((a, a_is_vertex), (b, b_is_vertex)) if not vertex]
        if _window_gain(q, i, j, middle, cost) <= tolerance or not checker.segment_free(a, b):
            continue
        q = q[:i + 1] + middle + q[j:]
        cum = list(itertools.accumulate((math.dist(u, v) for u, v in itertools.pairwise(q)), initial=0.0))
        empty = 0
    return q


def polish_solution(points: ArrayLike, cost: float, checker: CollisionChecker, objective: str, timing: RobotTiming,
                    seed: int, si: Any, ompl_objective: Any) -> tuple[NDArray[np.float64], dict[str, float]]:
    """An OMPL planner's solution polished under its objective (both steps), and what it did.

    Parameters
    ----------
    points : (k, 2) array_like
        The solution's waypoints (cm), free for `checker`, with the query's exact end points.
    cost : float
        The planner's own cost of its solution: its length (cm), or its robot time over SE(2) with the
        headings the planner sampled (s).
    checker : CollisionChecker
    objective : {"length", "robot-time"}
    timing : RobotTiming
    seed : int
        Seeds the partial shortcuts (the planning call's OMPL seed: the same path again for the same seed).
    si, ompl_objective : Any
        The planner's space information and OMPL objective (robot-time: SE(2) and `RobotTimeObjective`).

    Returns
    -------
    path : (m, 2) ndarray
    info : dict
        ``cost_before_polish`` (`cost`), ``cost_aligned_headings`` (the same path with `aligned_yaws`:
        its polyline's robot time), ``cost_after_polish``, ``polish_time_s`` and ``polish_checks``.
    """
    t0 = time.perf_counter()
    checks0 = checker.checks
    p = distinct_waypoints(points)
    polished = polish_polyline(p, checker, objective, timing, np.random.default_rng(seed))
    if objective == "robot-time":
        aligned = float(aligned_se2_path(si, p).cost(ompl_objective).value())
        after = float(aligned_se2_path(si, polished).cost(ompl_objective).value())
    else:
        aligned = objective_cost(objective, p, timing)
        after = objective_cost(objective, polished, timing)
    return polished, {"cost_before_polish": cost, "cost_aligned_headings": aligned, "cost_after_polish": after,
                      "polish_time_s": time.perf_counter() - t0, "polish_checks": checker.checks - checks0}


_PULLS = tuple(0.5**k for k in range(1, 8))
"""Fractions of the way to its neighbours' chord a waypoint is pulled, largest first."""


def _pull_vertices(q: Polyline, checker: CollisionChecker, cost: Callable[[Polyline], float],
                   tolerance: float) -> Polyline:
    """Move each interior waypoint toward the nearest point of the chord of its neighbours, by the largest
    fraction of the way (`_PULLS`) that keeps both its segments free and lowers the cost."""
    for k in range(1, len(q) - 1):
        (ux, uy), (vx, vy), (wx, wy) = q[k - 1], q[k], q[k + 1]
        dx, dy = wx - ux, wy - uy
        if dx == 0.0 and dy == 0.0:
            continue  # the path goes out and back: no chord to pull toward (a shortcut removes it)
        t = min(max(((vx - ux) * dx + (vy - uy) * dy) / (dx * dx + dy * dy), 0.0), 1.0)
        mx, my = ux + t * dx, uy + t * dy
        for s in _PULLS:
            v = (vx + s * (mx - vx), vy + s * (my - vy))
            if (_window_gain(q, k - 1, k + 1, [v], cost) > tolerance and checker.segment_free(q[k - 1], v)
                    and checker.segment_free(v, q[k + 1])):
                q = [*q[:k], v, *q[k + 1:]]
                break
    return q
