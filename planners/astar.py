"""Grid A*: the paper's baseline, on an 8-connected grid over the configuration space.

Grid nodes sit at ``(xmin + i * resolution, ymin + j * resolution)`` over the map's bounding box. A
node is usable when the shared checker finds the robot disc there free (one batch point check), and a
move between neighbouring nodes when the checker finds the swept disc free (checked lazily, when A*
first needs the move, and at most once per move). Start and goal join the grid through straight
segments to the free nodes within ``connect_radius`` of them. The returned path is the gridded one,
unsmoothed, as in the paper's comparison: A* paths turn at many grid nodes, which is exactly what the
paper's min-turn planner avoids.
"""

from __future__ import annotations

import heapq
import math
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .base import Planner, PlanningProblem

__all__ = ["AStarPlanner"]

_MOVES = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))


class AStarPlanner(Planner):
    """8-connected grid A* on the configuration space.

    Parameters
    ----------
    resolution : float
        Grid spacing in cm (default 2 cm).
    connect_radius : float or None
        Start and goal connect to free grid nodes within this distance (cm); None means
        ``2 * resolution``.

    Notes
    -----
    The heuristic is the Euclidean distance to the goal (admissible and consistent), so the result is
    the shortest path over the grid graph plus the start and goal connections. ``info`` reports
    ``expanded`` nodes, ``grid_nodes`` and ``free_nodes``.
    """

    name = "astar"

    def __init__(self, resolution: float = 2.0, connect_radius: float | None = None) -> None:
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive number of cm, got {resolution!r}")
        if connect_radius is not None and not (math.isfinite(connect_radius) and connect_radius > 0):
            raise ValueError(f"connect_radius must be a positive number of cm, got {connect_radius!r}")
        self.resolution = float(resolution)
        self.connect_radius = 2.0 * self.resolution if connect_radius is None else float(connect_radius)

    def grid(self, problem: PlanningProblem) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The grid's x and y coordinates (cm) for `problem`'s map."""
        xmin, ymin, xmax, ymax = problem.map.bounds
        res = self.resolution
        xs = np.asarray(xmin + res * np.arange(math.floor((xmax - xmin) / res) + 1), dtype=np.float64)
        ys = np.asarray(ymin + res * np.arange(math.floor((ymax - ymin) / res) + 1), dtype=np.float64)
        return xs, ys

    def _solve(self, problem: PlanningProblem) -> tuple[Any, ...]:
        checker = problem.checker
        deadline = time.perf_counter() + problem.time_limit
        xs, ys = self.grid(problem)
        nx, ny = len(xs), len(ys)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts = np.column_stack([gx.ravel(), gy.ravel()])  # node index = i * ny + j
        free = np.asarray(checker.point_free(pts), dtype=bool)
        info: dict[str, Any] = {"grid_nodes": len(pts), "free_nodes": int(free.sum()), "expanded": 0}
        n = len(pts)
        start_id, goal_id = n, n + 1
        coords = np.vstack([pts, problem.start, problem.goal])

        def near(p: NDArray[np.float64]) -> NDArray[np.intp]:
            d = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1])
            return np.flatnonzero(free & (d <= self.connect_radius))

        # start -> nearby nodes, nearby nodes -> goal (and start -> goal when they are that close)
        s_near, g_near = near(problem.start), near(problem.goal)
        s_ok = checker.segments_free(np.repeat(problem.start[None], len(s_near), axis=0), pts[s_near])
        g_ok = checker.segments_free(pts[g_near], np.repeat(problem.goal[None], len(g_near), axis=0))
        start_edges = s_near[s_ok]
        goal_edges = {int(i) for i in g_near[g_ok]}
        if not len(start_edges) or not goal_edges:
            which = "start" if not len(start_edges) else "goal"
            return None, f"{which} cannot reach the grid", info

        memo: dict[tuple[int, int], bool] = {}
        goal = problem.goal
        h = np.hypot(coords[:, 0] - goal[0], coords[:, 1] - goal[1])
        g_cost = {start_id: 0.0}
        parent = {start_id: -1}
        closed: set[int] = set()
        heap: list[tuple[float, float, int]] = [(float(h[start_id]), 0.0, start_id)]
        if float(np.hypot(*(problem.goal - problem.start))) <= self.connect_radius and checker.segment_free(
            problem.start, problem.goal
        ):
            g_cost[goal_id] = float(np.hypot(*(problem.goal - problem.start)))
            parent[goal_id] = start_id
            heapq.heappush(heap, (g_cost[goal_id], -g_cost[goal_id], goal_id))
        while heap:
            _, _neg_g, u = heapq.heappop(heap)
            if u in closed:
                continue
            if u == goal_id:
                seq = [u]
                while parent[seq[-1]] >= 0:
                    seq.append(parent[seq[-1]])
                return coords[seq[::-1]], "exact", info
            closed.add(u)
            info["expanded"] += 1
            if info["expanded"] % 256 == 0 and time.perf_counter() >= deadline:
                return None, "timeout", info
            gu = g_cost[u]
            if u == start_id:
                nbrs = [int(v) for v in start_edges]
            else:
                i, j = divmod(u, ny)
                cand: list[int] = []
                for di, dj in _MOVES:
                    a, b = i + di, j + dj
                    if 0 <= a < nx and 0 <= b < ny:
                        v = a * ny + b
                        if free[v] and v not in closed:
                            cand.append(v)
                unknown = [v for v in cand if (min(u, v), max(u, v)) not in memo]
                if unknown:
                    ok = checker.segments_free(np.repeat(pts[u][None], len(unknown), axis=0), pts[unknown])
                    for v, o in zip(unknown, ok, strict=True):
                        memo[(min(u, v), max(u, v))] = bool(o)
                nbrs = [v for v in cand if memo[(min(u, v), max(u, v))]]
                if u in goal_edges:
                    nbrs.append(goal_id)
            for v in nbrs:
                gv = gu + float(np.hypot(*(coords[v] - coords[u])))
                if gv < g_cost.get(v, math.inf) - 1e-12:
                    g_cost[v] = gv
                    parent[v] = u
                    heapq.heappush(heap, (gv + float(h[v]), -gv, v))
        return None, "no path on the grid", info
