"""A* over a visibility graph whose edges are found as the search reaches each node (compiled with numba).

`ShortestPathPlanner` keeps one `VisibilityGraph` per (map, radius). Its adjacency lists live in
one pool: ``first[u]`` is where node ``u``'s list starts (-1 while unknown) and ``count[u]`` its
length. A polygon map's lists are all filled when the graph is built (every tangent pair checked).
A grid map's are filled lazily: the first time the search expands a reflex corner, a row sweep
(`toolkit.world.grid_visibility.seen_from`) lists the corners it sees along its tangent lines, and
the list is kept for later queries. A query therefore scans only the corners inside its A* ellipse,
and a map of 10^5 edges needs no all-pairs preprocessing.

The heuristic is the straight-line distance to the goal, which is consistent, so the first time
the goal leaves the open list its distance is the shortest over the graph.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

from toolkit.world.arrays import FloatArray, IntArray
from toolkit.world.grid_visibility import GridVisibility, tangent_corners

__all__ = ["VisibilityGraph"]


@njit(cache=True)
def _scan_node(u: int, arrays: tuple, corners: IntArray, quad: IntArray, ids: IntArray, big: int,
               first: IntArray, count: IntArray, pool: IntArray, n_pool: int, out: IntArray) -> tuple:
    free, pinch, target, free_f, pinch_f, target_f = arrays
    seen, out = tangent_corners(free, pinch, target, free_f, pinch_f, target_f, corners[u, 0], corners[u, 1],
                                quad[u, 0] * quad[u, 1], big, corners, quad, ids, out)
    n = seen.shape[0]
    if n_pool + n > pool.shape[0]:
        bigger = np.empty(max(2 * pool.shape[0], n_pool + n), dtype=np.int64)
        bigger[:n_pool] = pool[:n_pool]
        pool = bigger
    first[u] = n_pool
    pool[n_pool:n_pool + n] = seen
    n_pool += n
    count[u] = n_pool - first[u]
    return pool, n_pool, out


@njit(cache=True)
def _astar(nodes: FloatArray, start: FloatArray, goal: FloatArray, s_idx: IntArray, goal_seen: NDArray[np.bool_],
           lazy: bool, arrays: tuple, corners: IntArray, quad: IntArray, ids: IntArray, big: int,
           first: IntArray, count: IntArray, pool: IntArray, n_pool: int) -> tuple:
    n = nodes.shape[0]
    s_node, g_node = n, n + 1
    dist = np.full(n + 2, np.inf)
    parent = np.full(n + 2, -1, dtype=np.int64)
    done = np.zeros(n + 2, dtype=np.bool_)
    out = np.empty((64, 6), dtype=np.int64)
    dist[s_node] = 0.0
    heap = [(math.hypot(goal[0] - start[0], goal[1] - start[1]), s_node)]
    scanned = 0
    while len(heap) > 0:
        _, u = heapq.heappop(heap)
        if done[u]:
            continue
        done[u] = True
        if u == g_node:
            break
        if u == s_node:
            ux, uy = start[0], start[1]
            lo, hi = 0, s_idx.shape[0]
        else:
            ux, uy = nodes[u, 0], nodes[u, 1]
            if first[u] < 0:
                if not lazy:
                    continue
                pool, n_pool, out = _scan_node(u, arrays, corners, quad, ids, big, first, count, pool, n_pool, out)
                scanned += 1
            lo, hi = int(first[u]), int(first[u] + count[u])
            if goal_seen[u]:
                d = dist[u] + math.hypot(goal[0] - ux, goal[1] - uy)
                if d < dist[g_node]:
                    dist[g_node] = d
                    parent[g_node] = u
                    heapq.heappush(heap, (d, g_node))  # type: ignore[misc]
        for k in range(lo, hi):
            w = int(s_idx[k] if u == s_node else pool[k])
            if done[w]:
                continue
            d = dist[u] + math.hypot(nodes[w, 0] - ux, nodes[w, 1] - uy)
            if d < dist[w]:
                dist[w] = d
                parent[w] = u
                heapq.heappush(heap, (d + math.hypot(goal[0] - nodes[w, 0], goal[1] - nodes[w, 1]), w))  # type: ignore[misc]
    return dist[g_node], parent, pool, n_pool, scanned


_NO_GRID = GridVisibility.of(np.ones((1, 1), dtype=bool))


@dataclass(eq=False)
class VisibilityGraph:
    """Nodes (cm) and their adjacency lists, complete (polygon maps) or filled as searches reach them (grids).

    Use `from_edges` for a graph whose edges are known, `from_grid` for a grid map's reflex corners.
    """

    nodes: FloatArray
    grid: GridVisibility = field(default=_NO_GRID)
    lazy: bool = False
    first: IntArray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    count: IntArray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    pool: IntArray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    n_pool: int = 0
    scanned: int = 0
    origin: FloatArray = field(default_factory=lambda: np.zeros(2))
    cell_cm: float = 1.0

    @classmethod
    def from_edges(cls, nodes: FloatArray, iu: IntArray, ju: IntArray) -> VisibilityGraph:
        """A complete graph from its undirected edges ``iu[k] -- ju[k]``."""
        m = len(nodes)
        a = np.concatenate([iu, ju]).astype(np.int64)
        b = np.concatenate([ju, iu]).astype(np.int64)
        order = np.argsort(a, kind="stable")
        count = np.bincount(a, minlength=m).astype(np.int64)
        first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
        return cls(nodes, first=first, count=count, pool=b[order], n_pool=len(b))

    @classmethod
    def from_grid(cls, grid: GridVisibility, origin: FloatArray, cell_cm: float) -> VisibilityGraph:
        """The reflex corners of a grid map (cm: ``origin + cell_cm * corner``), scanned as searches reach them."""
        m = len(grid.corners)
        origin = np.asarray(origin, dtype=float)
        return cls(origin + cell_cm * grid.corners, grid=grid, lazy=True, first=np.full(m, -1, dtype=np.int64),
                   count=np.zeros(m, dtype=np.int64), pool=np.empty(max(1024, 8 * m), dtype=np.int64),
                   origin=origin, cell_cm=float(cell_cm))

    def seen_from(self, point: FloatArray) -> IntArray | None:
        """Grid corners that `point` sees along lines tangent at the corner, when `point` is a lattice point.

        None when the graph is not a grid's or `point` lies off the lattice (the caller then checks
        the candidates itself).
        """
        if not self.lazy:
            return None
        cell = (np.asarray(point, dtype=float) - self.origin) / self.cell_cm
        xy = np.round(cell)
        h, w = self.grid.free.shape
        if np.abs(cell - xy).max() > 1e-9 or not (0 <= xy[0] <= w and 0 <= xy[1] <= h):
            return None
        f, p, t, f_f, p_f, t_f = self.grid.arrays
        g = self.grid
        seen, _ = tangent_corners(f, p, t, f_f, p_f, t_f, int(xy[0]), int(xy[1]), 0, g.big, g.corners, g.quadrants,
                                  g.ids, np.empty((64, 6), dtype=np.int64))
        return np.asarray(seen)

    @property
    def arcs(self) -> int:
        """Adjacency entries known so far (each undirected edge counts twice once both ends are scanned)."""
        return self.n_pool

    def search(self, start: FloatArray, goal: FloatArray, start_nodes: IntArray,
               goal_seen: NDArray[np.bool_]) -> tuple[float, list[int]]:
        """Shortest distance from `start` to `goal` and the node sequence between them ([] if none).

        `start_nodes` are the nodes `start` sees (checked by the caller), `goal_seen[u]` whether node
        ``u`` sees `goal`; the direct segment is the caller's to test.
        """
        g = self.grid
        d, parent, self.pool, self.n_pool, scanned = _astar(
            self.nodes, np.asarray(start, dtype=float), np.asarray(goal, dtype=float),
            np.asarray(start_nodes, dtype=np.int64), np.asarray(goal_seen, dtype=np.bool_), self.lazy, g.arrays,
            g.corners, g.quadrants, g.ids, g.big, self.first, self.count, self.pool, self.n_pool)
        self.scanned += int(scanned)
        if not math.isfinite(d):
            return math.inf, []
        m = len(self.nodes)
        seq = []
        u = int(parent[m + 1])
        while u != m:
            seq.append(u)
            u = int(parent[u])
        return float(d), seq[::-1]
