"""Grid A*: the paper's baseline, on an 8-connected grid over the configuration space.

Grid nodes sit at ``(xmin + i * resolution, ymin + j * resolution)`` over the map's bounding box,
or, with ``resolution=None`` on a map imported from a grid, at the centres of the map's own cells.
A node is usable when the shared checker finds the robot there free, and a move between
neighbouring nodes when the checker finds the swept disc free; both are asked once per (map,
radius, grid) in one batch and kept, so later queries on the same map only search. Start and goal
join the grid through straight segments to the free nodes within ``connect_radius`` of them
(without corner cutting, a start or goal exactly on a node uses that node alone). The returned
path is the gridded one, unsmoothed, as in the paper's comparison: A* paths turn at many grid
nodes, which is exactly what the paper's min-turn planner avoids.

Without corner cutting (the default on a map's own cells, as the Moving AI benchmarks define it) a
diagonal move is allowed only when both straight moves beside it are; with a point robot on the
map's cells this reproduces the published octile optimal lengths exactly.
"""

from __future__ import annotations

import heapq
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from toolkit.world import ConfigError

from .base import Planner, PlanningProblem, PlanStatus, Solution
from .declarations import ASTAR_PARAMS

__all__ = ["AStarPlanner"]

_MOVES = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))
_SQRT2 = math.sqrt(2.0)


@dataclass
class _Lattice:
    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    free: NDArray[np.bool_]
    neighbours: list[list[tuple[int, float]]]
    cutting: bool
    build_s: float


class AStarPlanner(Planner):
    """8-connected grid A* on the configuration space.

    Parameters
    ----------
    resolution : float or None
        Grid spacing in cm (default 2 cm); None puts the nodes at the centres of the map's own cells
        (a map imported from a grid).
    connect_radius : float or None
        Start and goal connect to free grid nodes within this distance (cm); None means
        ``2 * resolution`` (or two cells).
    corner_cutting : bool or None
        Whether a diagonal move may pass a blocked neighbour's corner; None means allowed on a
        spaced grid and forbidden on the map's own cells.

    Notes
    -----
    The heuristic is the Euclidean distance to the goal (admissible and consistent), so the result is
    the shortest path over the grid graph plus the start and goal connections. ``info`` reports
    ``expanded`` nodes, ``grid_nodes``, ``free_nodes`` and ``grid_build_s`` (0 when cached).
    """

    name = "astar"
    params = ASTAR_PARAMS

    def __init__(self, resolution: float | None = 2.0, connect_radius: float | None = None,
                 corner_cutting: bool | None = None) -> None:
        if resolution is not None and not (math.isfinite(resolution) and resolution > 0):
            raise ConfigError(f"resolution must be a positive number of cm or None, got {resolution!r}")
        if connect_radius is not None and not (math.isfinite(connect_radius) and connect_radius > 0):
            raise ConfigError(f"connect_radius must be a positive number of cm, got {connect_radius!r}")
        self.resolution = None if resolution is None else float(resolution)
        self._connect = None if connect_radius is None else float(connect_radius)
        self.corner_cutting = corner_cutting
        self._cache: dict[tuple[int, float], _Lattice] = {}

    def spacing(self, problem: PlanningProblem) -> float:
        """Node spacing (cm) for `problem`'s map."""
        if self.resolution is not None:
            return self.resolution
        if problem.map.grid is None:
            raise ConfigError(f"astar with resolution=None needs a map imported from a grid; {problem.map.name!r} "
                             "is polygonal (give a resolution in cm)")
        return problem.map.grid.cell_cm

    @property
    def connect_radius(self) -> float:
        """Start/goal connection radius (cm) for the configured resolution (2 cm when it is None)."""
        return self._connect if self._connect is not None else 2.0 * (self.resolution or 1.0)

    def grid(self, problem: PlanningProblem) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The grid's x and y coordinates (cm) for `problem`'s map."""
        if self.resolution is None:
            centres = problem.map.grid.centres() if problem.map.grid is not None else None
            if centres is None:
                self.spacing(problem)  # raises the explanation
                raise AssertionError
            return centres[0, :, 0].astype(np.float64), centres[:, 0, 1].astype(np.float64)
        xmin, ymin, xmax, ymax = problem.map.bounds
        res = self.resolution
        xs = np.asarray(xmin + res * np.arange(math.floor((xmax - xmin) / res) + 1), dtype=np.float64)
        ys = np.asarray(ymin + res * np.arange(math.floor((ymax - ymin) / res) + 1), dtype=np.float64)
        return xs, ys

    def _lattice(self, problem: PlanningProblem) -> tuple[_Lattice, bool]:
        key = (id(problem.map), problem.robot_radius)
        hit = self._cache.get(key)
        if hit is not None:
            return hit, True
        t0 = time.perf_counter()
        checker = problem.checker
        xs, ys = self.grid(problem)
        nx, ny = len(xs), len(ys)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        pts = np.column_stack([gx.ravel(), gy.ravel()])  # node index = i * ny + j
        free = np.asarray(checker.point_free(pts), dtype=bool).reshape(nx, ny)
        # every move between free neighbours, checked once in a batch per direction
        ok: dict[tuple[int, int], NDArray[np.bool_]] = {}
        ii, jj = np.nonzero(free)
        for di, dj in _MOVES:
            a = np.zeros((nx, ny), dtype=bool)
            ti, tj = ii + di, jj + dj
            inside = (ti >= 0) & (ti < nx) & (tj >= 0) & (tj < ny)
            si, sj, ti, tj = ii[inside], jj[inside], ti[inside], tj[inside]
            both = free[ti, tj]
            si, sj, ti, tj = si[both], sj[both], ti[both], tj[both]
            a[si, sj] = checker.segments_free(np.column_stack([xs[si], ys[sj]]), np.column_stack([xs[ti], ys[tj]]))
            ok[(di, dj)] = a
        cutting = self.corner_cutting if self.corner_cutting is not None else self.resolution is not None
        if not cutting:
            for di, dj in _MOVES[4:]:
                side_i, side_j = ok[(di, 0)], ok[(0, dj)]
                a = ok[(di, dj)]
                a &= side_i & side_j  # both straight moves beside the diagonal from the same node
        step = float(xs[1] - xs[0]) if nx > 1 else 1.0
        neighbours: list[list[tuple[int, float]]] = [[] for _ in range(nx * ny)]
        for di, dj in _MOVES:
            cost = step * (_SQRT2 if di and dj else 1.0)
            for u in np.flatnonzero(ok[(di, dj)].ravel()).tolist():
                neighbours[u].append((u + di * ny + dj, cost))
        lat = _Lattice(xs, ys, free.ravel(), neighbours, cutting, time.perf_counter() - t0)
        self._cache = {key: lat}  # one map at a time: a lattice can be large
        return lat, False

    def _solve(self, problem: PlanningProblem) -> Solution:
        checker = problem.checker
        lat, cached = self._lattice(problem)
        deadline = time.perf_counter() + problem.time_limit
        xs, ys = lat.xs, lat.ys
        nx, ny = len(xs), len(ys)
        free = lat.free
        info: dict[str, Any] = {"grid_nodes": nx * ny, "free_nodes": int(free.sum()), "expanded": 0,
                                "grid_build_s": 0.0 if cached else lat.build_s}
        radius = self._connect if self._connect is not None else 2.0 * self.spacing(problem)
        n = nx * ny
        start_id, goal_id = n, n + 1

        def node_xy(k: int) -> tuple[float, float]:
            if k == start_id:
                return float(problem.start[0]), float(problem.start[1])
            if k == goal_id:
                return float(problem.goal[0]), float(problem.goal[1])
            i, j = divmod(k, ny)
            return float(xs[i]), float(ys[j])

        def near(p: NDArray[np.float64]) -> NDArray[np.intp]:
            i0, i1 = np.searchsorted(xs, [p[0] - radius, p[0] + radius])
            j0, j1 = np.searchsorted(ys, [p[1] - radius, p[1] + radius])
            ii, jj = np.meshgrid(np.arange(i0, i1), np.arange(j0, j1), indexing="ij")
            k = (ii * ny + jj).ravel()
            d = np.hypot(xs[ii.ravel()] - p[0], ys[jj.ravel()] - p[1])
            on_node = d <= 1e-9
            if on_node.any() and not lat.cutting:  # that node alone: no shortcut off the grid
                return k[on_node & free[k]]
            return k[free[k] & (d <= radius)]

        # start -> nearby nodes, nearby nodes -> goal (and start -> goal when they are that close)
        s_near, g_near = near(problem.start), near(problem.goal)
        node_pts = lambda ks: np.column_stack([xs[ks // ny], ys[ks % ny]])  # noqa: E731
        s_ok = checker.segments_free(np.repeat(problem.start[None], len(s_near), axis=0), node_pts(s_near))
        g_ok = checker.segments_free(node_pts(g_near), np.repeat(problem.goal[None], len(g_near), axis=0))
        start_edges = s_near[s_ok].tolist()
        goal_edges = set(g_near[g_ok].tolist())
        if not start_edges or not goal_edges:
            which = "start" if not start_edges else "goal"
            return Solution(None, PlanStatus.NO_PATH, info, f"{which} cannot reach the grid")

        gxy = (float(problem.goal[0]), float(problem.goal[1]))

        def h(k: int) -> float:
            x, y = node_xy(k)
            return math.hypot(x - gxy[0], y - gxy[1])

        g_cost: dict[int, float] = {start_id: 0.0}
        parent: dict[int, int] = {start_id: -1}
        closed: set[int] = set()
        heap: list[tuple[float, float, int]] = [(h(start_id), 0.0, start_id)]
        direct = float(np.hypot(*(problem.goal - problem.start)))
        if direct <= radius and checker.segment_free(problem.start, problem.goal):
            g_cost[goal_id] = direct
            parent[goal_id] = start_id
            heapq.heappush(heap, (direct, -direct, goal_id))
        sxy = node_xy(start_id)
        start_nbrs = [(v, math.hypot(node_xy(v)[0] - sxy[0], node_xy(v)[1] - sxy[1])) for v in start_edges]
        neighbours = lat.neighbours
        expanded = 0
        while heap:
            _, _neg_g, u = heapq.heappop(heap)
            if u in closed:
                continue
            if u == goal_id:
                seq = [u]
                while parent[seq[-1]] >= 0:
                    seq.append(parent[seq[-1]])
                info["expanded"] = expanded
                return Solution(np.array([node_xy(k) for k in seq[::-1]]), PlanStatus.EXACT, info)
            closed.add(u)
            expanded += 1
            if expanded % 4096 == 0 and time.perf_counter() >= deadline:
                info["expanded"] = expanded
                return Solution(None, PlanStatus.TIMEOUT, info)
            gu = g_cost[u]
            nbrs = start_nbrs if u == start_id else neighbours[u]
            if u in goal_edges:
                ux, uy = node_xy(u)
                nbrs = [*nbrs, (goal_id, math.hypot(ux - gxy[0], uy - gxy[1]))]
            for v, cost in nbrs:
                if v in closed:
                    continue
                gv = gu + cost
                if gv < g_cost.get(v, math.inf) - 1e-12:
                    g_cost[v] = gv
                    parent[v] = u
                    heapq.heappush(heap, (gv + h(v), -gv, v))
        info["expanded"] = expanded
        return Solution(None, PlanStatus.NO_PATH, info, "no path on the grid")
