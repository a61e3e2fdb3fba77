"""The robot-time reference ``fastest``: least robot time over the visibility graph, turns charged.

The robot drives a polyline by stopping at each waypoint, turning in place to the next segment and
driving it (`toolkit.world.robot_time_s`). ``fastest`` searches the visibility graph of
``shortest`` (`planners.reference.ShortestPathPlanner`: start, goal and the reflex vertices of the
polygonal configuration space, edges tangent at both ends) with the heading the robot arrived with as
part of the state: a state is a directed edge ``(p, u)``, and leaving it along ``(u, w)`` costs the
turn at ``u`` (by `toolkit.world.RobotTiming.turn`, the stop-and-turn time included) and the drive of
``(u, w)``. Dijkstra's search with the straight-line drive time as its heuristic finds the least
robot time over the paths that bend only at the graph's vertices.

What it is. Over those paths it is exact. A path of least robot time for a robot with no fixed
stop-and-turn cost (``stop_turn_s = 0``, the default) is taut: pulling any path tight in its
homotopy class makes it no longer and turns it no more, so it bends only at reflex vertices; the
answer is then the optimum for the polygonal configuration space (with the length tolerance of
``shortest``, `planners.reference`). With a fixed cost per turn a path bending in free space, with
fewer turns, can be faster: the reference is then an upper bound on the optimum, and ``info`` says so
(``reference_kind``).

It needs the polygon maps' complete graph: on a point robot's grid map (whose graph ``shortest``
fills lazily) it reports an error. On large maps it searches ``shortest``'s graph of 16-gon walls, as
``shortest`` does there (seconds on the depot's 4082 walls).
"""

from __future__ import annotations

import heapq
import math
from typing import Any, ClassVar

import numpy as np

from toolkit.world import RobotTiming
from toolkit.world.arrays import FloatArray

from .base import PlanningProblem, PlanStatus, Solution
from .declarations import FastestOptions
from .reference import ShortestPathPlanner, _tangent

__all__ = ["FastestPlanner", "least_time_path"]


class FastestPlanner(ShortestPathPlanner):
    """Least robot time over the reflex-vertex visibility graph (module notes: exact, or an upper bound).

    Parameters
    ----------
    options : FastestOptions, optional
        As for `planners.reference.ShortestPathPlanner` (`planners.declarations.FastestOptions`), whose
        one objective is robot-time.
    **overrides
        Options on top of `options` by name.
    """

    name = "fastest"
    options_model = FastestOptions
    objectives = ("robot-time",)
    large_map_options: ClassVar[Any] = {"n_sides": 16}  # as shortest: the graph it searches

    def _solve(self, problem: PlanningProblem) -> Solution:
        checker = problem.checker
        g = self._graph(problem)
        start, goal = problem.start, problem.goal
        exact = problem.timing.stop_turn_s == 0
        info: dict[str, Any] = {"graph_nodes": len(g.nodes),
                                "reference_kind": "exact" if exact else "upper bound (fixed cost per turn)"}
        if checker.segment_free(start, goal):
            return Solution(np.array([start, goal]), PlanStatus.EXACT, info)
        vg = g.extra["search"]
        if vg.lazy:
            return Solution(None, PlanStatus.ERROR, info, "the robot-time reference needs a polygonal map's graph")
        prv, nxt = g.extra["prev"], g.extra["next"]
        seen = []
        for p, forward in ((start, True), (goal, False)):
            cand = np.flatnonzero(_tangent(g.nodes, prv, nxt, np.broadcast_to(p, g.nodes.shape)))
            ends = np.repeat(p[None], len(cand), axis=0)
            ok = checker.segments_free(ends, g.nodes[cand]) if forward else checker.segments_free(g.nodes[cand], ends)
            seen.append(cand[ok])
        adjacency = [vg.pool[vg.first[u]:vg.first[u] + vg.count[u]] for u in range(len(g.nodes))]
        seq = least_time_path(g.nodes, adjacency, start, goal, seen[0], seen[1], problem.timing)
        if seq is None:
            return Solution(None, PlanStatus.NO_PATH, info)
        path = np.vstack([start, g.nodes[seq], goal])
        info["length_tolerance_cm"] = self._length_tolerance(problem, path)
        return Solution(path, PlanStatus.EXACT, info)


def _turn(a: FloatArray, b: FloatArray, c: FloatArray) -> float:
    """Heading change (rad) at `b` of the polyline a -> b -> c."""
    u, v = b - a, c - b
    return abs(math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1]))


def least_time_path(nodes: FloatArray, adjacency: list[Any], start: FloatArray, goal: FloatArray,
                    from_start: Any, to_goal: Any, timing: RobotTiming) -> list[int] | None:
    """The node sequence of the least robot time from `start` to `goal` over the graph (None: no path).

    States are directed edges (predecessor, node); the start is predecessor -1. `from_start` are the
    nodes the start sees, `to_goal` those that see the goal, `adjacency[u]` the nodes `u` sees.
    """
    m = len(nodes)
    points = np.vstack([nodes, start[None], goal[None]])
    s_idx, g_idx = m, m + 1
    sees_goal = np.zeros(m, dtype=bool)
    sees_goal[np.asarray(to_goal, dtype=np.int64)] = True
    speed = timing.drive_speed_cm_s

    def h(u: int) -> float:
        return float(np.hypot(*(goal - points[u]))) / speed

    best: dict[tuple[int, int], float] = {}
    parent: dict[tuple[int, int], tuple[int, int] | None] = {}
    heap: list[tuple[float, float, tuple[int, int]]] = []
    for u in np.asarray(from_start, dtype=np.int64).tolist():
        c = timing.move(float(np.hypot(*(points[u] - start))))
        best[(s_idx, u)], parent[(s_idx, u)] = c, None
        heapq.heappush(heap, (c + h(u), c, (s_idx, u)))
    while heap:
        _, c, state = heapq.heappop(heap)
        if c > best.get(state, math.inf):
            continue
        p, u = state
        if u == g_idx:
            seq = []
            back: tuple[int, int] | None = parent[state]
            while back is not None:
                seq.append(back[1])
                back = parent[back]
            return seq[::-1]
        nexts = list(adjacency[u].tolist()) + ([g_idx] if sees_goal[u] else [])
        for w in nexts:
            if w == p:
                continue
            step = (timing.turn(_turn(points[p], points[u], points[w]))
                    + timing.move(float(np.hypot(*(points[w] - points[u])))))
            nxt = (u, w)
            if c + step < best.get(nxt, math.inf):
                best[nxt], parent[nxt] = c + step, state
                heapq.heappush(heap, (c + step + (0.0 if w == g_idx else h(w)), c + step, nxt))
    return None
