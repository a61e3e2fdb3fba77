"""Grid A* on a heading lattice: the robot's own cost of every move, turns included.

A state is a lattice node and the heading the robot arrived with: one of the 8 lattice directions
(`planners.astar_search.MOVES`), or the heading of the straight join that brought it from the start
(index 8; free when the start lies on the node). A move from a state drives to a neighbour and first
turns in place from the state's heading to the move's; it costs

    per_cm * length + per_rad * |turn| + per_turn * [turn > 0]

so the search minimises, exactly over the lattice's paths (8 headings, 45-degree turns):

- robot time: ``per_cm = 1 / speed``, ``per_rad = 1 / turn rate``, ``per_turn = stop-and-turn time``
  (`toolkit.world.RobotTiming`), in seconds;
- turns: ``per_turn = 1`` and ``per_cm = 1 / W`` with ``W`` ten times the map's bounding-box perimeter
  (fewest turns, ties broken by length).

The goal is a virtual state reached from a node that joins it by a free segment (a last turn to the
join's heading, then the join). The heuristic, ``per_cm`` times the straight-line distance to the
goal, is admissible. The search is a binary-heap A* compiled by numba over flat arrays of
``9 * nodes`` states.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .astar_search import MOVES

__all__ = ["lattice_search", "warm_up_lattice"]

_DI = np.array([m[0] for m in MOVES], dtype=np.int64)
_DJ = np.array([m[1] for m in MOVES], dtype=np.int64)
_ANGLE = np.array([math.atan2(m[1], m[0]) for m in MOVES], dtype=np.float64)
_H = 9  # headings per node: the 8 moves and the start's join


@njit(cache=True)
def _turn(a: float, b: float) -> float:
    """|b - a| wrapped to [0, pi] (rad); 0 when `a` is NaN (a free heading)."""
    if a != a:
        return 0.0
    d = (b - a) % (2.0 * math.pi)
    return min(d, 2.0 * math.pi - d)


@njit(cache=True)
def _step_cost(heading: float, angle: float, length: float, w: NDArray[np.float64]) -> float:
    t = _turn(heading, angle)
    return w[0] * length + w[1] * t + (w[2] if t > 1e-9 else 0.0)


@njit(cache=True)
def _search(moves: NDArray[np.uint8], xs: NDArray[np.float64], ys: NDArray[np.float64], step: float,
            start_nodes: NDArray[np.int64], start_len: NDArray[np.float64], start_head: NDArray[np.float64],
            goal_len: NDArray[np.float64], goal_head: NDArray[np.float64], gx: float, gy: float,
            direct: float, w: NDArray[np.float64]) -> tuple[float, NDArray[np.int64], int]:
    ny = len(ys)
    n = len(moves)
    goal = n * _H
    cost = np.full(goal + 1, np.inf)
    parent = np.full(goal + 1, -2, dtype=np.int64)
    join_head = np.full(n, np.nan)
    heap = [(0.0, np.int64(0))]
    heap.pop()
    if direct < np.inf:
        cost[goal] = w[0] * direct
        parent[goal] = -1
        heap.append((cost[goal], np.int64(goal)))
    for k in range(len(start_nodes)):
        u = start_nodes[k]
        s = u * _H + 8
        c = w[0] * start_len[k]
        if c < cost[s]:
            cost[s] = c
            parent[s] = -1
            join_head[u] = start_head[k]
            i, j = u // ny, u % ny
            heapq.heappush(heap, (c + w[0] * math.hypot(xs[i] - gx, ys[j] - gy), np.int64(s)))
    expanded = 0
    while heap:
        f, s = heapq.heappop(heap)
        if s == goal:
            break
        u, h = s // _H, s % _H
        i, j = u // ny, u % ny
        g = cost[s]
        if f > g + w[0] * math.hypot(xs[i] - gx, ys[j] - gy) + 1e-12:
            continue  # stale entry
        expanded += 1
        heading = join_head[u] if h == 8 else _ANGLE[h]
        if goal_len[u] < np.inf:
            c = g + (_step_cost(heading, goal_head[u], goal_len[u], w) if goal_len[u] > 1e-9 else 0.0)
            if c < cost[goal]:
                cost[goal] = c
                parent[goal] = s
                heapq.heappush(heap, (c, np.int64(goal)))
        bits = moves[u]
        for d in range(8):
            if not (bits >> d) & 1:
                continue
            v = (i + _DI[d]) * ny + (j + _DJ[d])
            length = step * (1.0 if d < 4 else math.sqrt(2.0))
            c = g + _step_cost(heading, _ANGLE[d], length, w)
            t = v * _H + d
            if c < cost[t]:
                cost[t] = c
                parent[t] = s
                heapq.heappush(heap, (c + w[0] * math.hypot(xs[i + _DI[d]] - gx, ys[j + _DJ[d]] - gy), np.int64(t)))
    if cost[goal] == np.inf:
        return np.inf, np.empty(0, dtype=np.int64), expanded
    seq = []
    s = parent[goal]
    while s >= 0:
        seq.append(s // _H)
        s = parent[s]
    out = np.empty(len(seq), dtype=np.int64)
    for k in range(len(seq)):
        out[k] = seq[len(seq) - 1 - k]
    return cost[goal], out, expanded


def lattice_search(moves: NDArray[np.uint8], xs: NDArray[np.float64], ys: NDArray[np.float64], step: float,
                   start: NDArray[np.float64], starts: tuple[NDArray[np.int64], NDArray[np.float64]],
                   goal: NDArray[np.float64], goals: tuple[NDArray[np.int64], NDArray[np.float64]],
                   direct: float, weights: tuple[float, float, float]) -> tuple[float, NDArray[np.int64], int]:
    """The least-cost lattice path from `start` to `goal` (module notes) as (cost, node indices, expanded).

    Parameters
    ----------
    moves, xs, ys, step
        The lattice (`planners.astar`): move bits per node, node coordinates (cm), spacing (cm).
    start, goal : (2,) ndarray
        The query (cm).
    starts, goals : (nodes, join lengths in cm)
        The nodes the start and the goal join by free segments.
    direct : float
        Length (cm) of a free direct start-goal segment, or inf.
    weights : (per_cm, per_rad, per_turn)
        The cost of a move (module notes).

    Returns
    -------
    (float, ndarray, int)
        The cost (inf: no path), the nodes from the first to the last (empty for the direct segment or
        no path), and the states expanded.
    """
    ny = len(ys)
    s_nodes, s_len = starts
    g_nodes, g_len = goals
    sx, sy = xs[s_nodes // ny], ys[s_nodes % ny]
    s_head = np.where(s_len > 1e-9, np.arctan2(sy - start[1], sx - start[0]), np.nan)
    goal_len = np.full(len(moves), np.inf)
    goal_head = np.zeros(len(moves))
    goal_len[g_nodes] = g_len
    goal_head[g_nodes] = np.arctan2(goal[1] - ys[g_nodes % ny], goal[0] - xs[g_nodes // ny])
    return _search(moves, xs, ys, float(step), s_nodes.astype(np.int64), s_len.astype(np.float64), s_head,
                   goal_len, goal_head, float(goal[0]), float(goal[1]), float(direct),
                   np.asarray(weights, dtype=np.float64))


def warm_up_lattice() -> None:
    """Compile (or load from numba's cache) the search before a timed query: a 2 x 1 lattice."""
    xs, ys = np.array([0.0, 1.0]), np.array([0.0])
    moves = np.array([1, 2], dtype=np.uint8)
    one = (np.array([0], dtype=np.int64), np.array([0.0]))
    lattice_search(moves, xs, ys, 1.0, np.zeros(2), one, np.array([1.0, 0.0]),
                   (np.array([1], dtype=np.int64), np.array([0.0])), math.inf, (1.0, 1.0, 0.0))
