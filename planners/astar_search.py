"""The compiled search of grid A*: a 4-ary heap of integer keys in flat arrays, no Python object per node.

The lattice is a row-major array of nodes (node ``i * ny + j`` at ``(xs[i], ys[j])``) with one byte
per node whose bit ``d`` allows the move ``MOVES[d]``; straight moves cost ``step`` and diagonal ones
``step * sqrt(2)``. A query is a set of source nodes with their costs from the start, a set of
target nodes with their costs to the goal, and possibly a direct start-goal cost; the goal is a
virtual node (index ``n``) reached from a target node or directly from the start.

Keys and ties. An open node's key is one 64-bit integer: f = g + h in units of ``2**-F_BITS`` steps
above ``H_BITS`` bits of h in quarter steps, so the heap compares one number, ties in f go to the
smaller h (the larger g: the node nearer the goal) and equal keys leave in a fixed order. On the
lattice every f is ``step * (a + b * sqrt(2))`` for integers a and b; two different such values of
paths under ``3 * 10**5`` moves differ by more than the key's unit, so the keys order them exactly
and the path found is the shortest on the lattice. With straight joins to the start or goal (off
the lattice), f values closer than the unit may swap, and the path found is at most one unit
(``2**-20`` step) longer than the shortest. The path's reported length is always its own, summed
from its coordinates.

A node whose cost improves is pushed again and its stale entries are skipped when they come up
(each node is expanded once: the heuristics are consistent). The workspace (costs, parents, heap)
lives as long as the lattice: a stamp per node says which search last wrote it, so a query touches
only the nodes it reaches instead of clearing arrays of the map's size.

The heuristic is the octile distance when the goal is a lattice node reached only through the
lattice (exact and consistent there: every path is made of the moves it counts), otherwise the
Euclidean distance (admissible for the straight joins to the goal too).

The search runs in chunks of expansions so that the caller can check its time budget between
them; `warm_up` compiles (or loads from numba's cache) every kernel before the first timed query.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["MAX_STEPS", "MOVES", "SearchOutcome", "Workspace", "search", "warm_up"]

MOVES = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))
"""Lattice moves ``(di, dj)``; bit ``d`` of a node's move byte allows ``MOVES[d]`` (straight ones first)."""

F_BITS = 20  # f in units of 2**-20 step
H_BITS = 18  # h (the tie-break) in quarter steps, saturated at 2**18 - 1
_H_MAX = (1 << H_BITS) - 1
MAX_STEPS = float(1 << (63 - H_BITS - F_BITS))
"""Largest f (in steps) a key holds: 2**25, about 33 million steps."""

_DI = np.array([m[0] for m in MOVES], dtype=np.int64)
_DJ = np.array([m[1] for m in MOVES], dtype=np.int64)
_SQRT2 = math.sqrt(2.0)
_ARITY = 4  # children per heap node: half the levels of a binary heap, siblings side by side in memory
_CHUNK = 1 << 16  # expansions between two looks at the clock

FOUND, EXHAUSTED, BUDGET, FULL = 0, 1, 2, 3


@njit(cache=True, inline="always")
def _heuristic(x: float, y: float, gx: float, gy: float, octile: bool) -> float:
    dx = abs(x - gx)
    dy = abs(y - gy)
    if octile:
        return dx + dy + (_SQRT2 - 2.0) * min(dx, dy)
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True, inline="always")
def _key(f: float, h: float, fscale: float, hscale: float) -> int:
    hq = int(h * hscale + 0.5)
    if hq > _H_MAX:
        hq = _H_MAX
    return (int(f * fscale + 0.5) << H_BITS) | hq


@njit(cache=True, inline="always")
def _push(hk: NDArray[np.int64], hn: NDArray[np.int32], size: int, key: int, node: int) -> int:
    k = size
    while k > 0:
        p = (k - 1) // _ARITY
        if hk[p] <= key:
            break
        hk[k] = hk[p]
        hn[k] = hn[p]
        k = p
    hk[k] = key
    hn[k] = node
    return size + 1


@njit(cache=True, inline="always")
def _pop(hk: NDArray[np.int64], hn: NDArray[np.int32], size: int) -> int:
    """Remove the first entry (read it at index 0 before); returns the new size."""
    size -= 1
    if size == 0:
        return 0
    key, node = hk[size], hn[size]
    k = 0
    while True:
        first = _ARITY * k + 1
        if first >= size:
            break
        best, best_key = first, hk[first]
        for c in range(first + 1, min(first + _ARITY, size)):
            if hk[c] < best_key:
                best, best_key = c, hk[c]
        if best_key >= key:
            break
        hk[k] = best_key
        hn[k] = hn[best]
        k = best
    hk[k] = key
    hn[k] = node
    return size


@njit(cache=True)
def _begin(ny: int, xs: NDArray[np.float64], ys: NDArray[np.float64], gx: float, gy: float, octile: bool,
           fscale: float, hscale: float, sources: NDArray[np.int64], source_g: NDArray[np.float64],
           targets: NDArray[np.int64], target_cost: NDArray[np.float64], direct: float, stamp: int,
           mark: NDArray[np.int32], tag: NDArray[np.int32], goal_cost: NDArray[np.float64], g: NDArray[np.float64],
           parent: NDArray[np.int32], hk: NDArray[np.int64], hn: NDArray[np.int32]) -> int:
    """Put the sources (and the goal, when the start joins it directly) in the heap; mark the targets."""
    goal = mark.shape[0] - 1
    opened = 2 * stamp
    for k in range(targets.shape[0]):
        tag[targets[k]] = stamp
        goal_cost[targets[k]] = target_cost[k]
    size = 0
    for k in range(sources.shape[0]):
        v = sources[k]
        gv = source_g[k]
        if mark[v] == opened and gv >= g[v]:
            continue
        mark[v] = opened
        g[v] = gv
        parent[v] = -1
        i = v // ny
        h = _heuristic(xs[i], ys[v - i * ny], gx, gy, octile)
        size = _push(hk, hn, size, _key(gv + h, h, fscale, hscale), v)
    if direct < math.inf:
        mark[goal] = opened
        g[goal] = direct
        parent[goal] = -1
        size = _push(hk, hn, size, _key(direct, 0.0, fscale, hscale), goal)
    return size


@njit(cache=True)
def _expand(moves: NDArray[np.uint8], ny: int, xs: NDArray[np.float64], ys: NDArray[np.float64], step: float,
            gx: float, gy: float, octile: bool, fscale: float, hscale: float, stamp: int, limit: int,
            state: NDArray[np.int64], mark: NDArray[np.int32], tag: NDArray[np.int32],
            goal_cost: NDArray[np.float64], g: NDArray[np.float64], parent: NDArray[np.int32],
            hk: NDArray[np.int64], hn: NDArray[np.int32]) -> int:
    """Expand at most `limit` nodes; `state` holds (heap size, expansions) between calls.

    ``mark[v]`` is ``2 * stamp`` while `v` is open in this search and ``2 * stamp + 1`` once expanded.
    """
    goal = mark.shape[0] - 1
    opened, closed = 2 * stamp, 2 * stamp + 1
    diagonal = step * _SQRT2
    capacity = hn.shape[0]
    offset = np.empty(8, dtype=np.int64)
    for d in range(8):
        offset[d] = _DI[d] * ny + _DJ[d]
    size = state[0]
    expanded = state[1]
    stop = expanded + limit
    status = EXHAUSTED
    while size > 0:
        if expanded >= stop:
            status = BUDGET
            break
        if size + 9 > capacity:  # one expansion pushes at most 9 entries
            status = FULL
            break
        u = hn[0]
        size = _pop(hk, hn, size)
        if mark[u] == closed:
            continue  # a stale entry
        mark[u] = closed
        if u == goal:
            status = FOUND
            break
        expanded += 1
        gu = g[u]
        i = u // ny
        j = u - i * ny
        bits = moves[u]
        for d in range(8):
            if not (bits >> d) & 1:
                continue
            v = u + offset[d]
            seen = mark[v]
            gv = gu + (step if d < 4 else diagonal)
            if seen == closed or (seen == opened and gv >= g[v]):
                continue
            mark[v] = opened
            g[v] = gv
            parent[v] = u
            h = _heuristic(xs[i + _DI[d]], ys[j + _DJ[d]], gx, gy, octile)
            size = _push(hk, hn, size, _key(gv + h, h, fscale, hscale), v)
        if tag[u] == stamp:
            gv = gu + goal_cost[u]
            if mark[goal] != opened or gv < g[goal]:
                mark[goal] = opened
                g[goal] = gv
                parent[goal] = u
                size = _push(hk, hn, size, _key(gv, 0.0, fscale, hscale), goal)
    state[0] = size
    state[1] = expanded
    return status


@njit(cache=True)
def _trace(parent: NDArray[np.int32]) -> NDArray[np.int64]:
    """The lattice nodes from the start to the goal (the goal's parents, in order)."""
    goal = parent.shape[0] - 1
    count = 0
    v = parent[goal]
    while v >= 0:
        count += 1
        v = parent[v]
    out = np.empty(count, dtype=np.int64)
    v = parent[goal]
    k = count - 1
    while v >= 0:
        out[k] = v
        k -= 1
        v = parent[v]
    return out


@dataclass(eq=False)
class Workspace:
    """The search's arrays for a lattice of `n` nodes (plus the goal), reused by every query on it:
    about 21 bytes per node, and a heap of 12 bytes per entry that starts at ``n // 8 + 64``
    entries and doubles when a search fills it."""

    n: int
    stamp: int = 0
    mark: NDArray[np.int32] = field(init=False)
    tag: NDArray[np.int32] = field(init=False)
    goal_cost: NDArray[np.float64] = field(init=False)
    g: NDArray[np.float64] = field(init=False)
    parent: NDArray[np.int32] = field(init=False)
    hk: NDArray[np.int64] = field(init=False)
    hn: NDArray[np.int32] = field(init=False)

    def __post_init__(self) -> None:
        size = self.n + 1
        self.mark = np.zeros(size, dtype=np.int32)
        self.tag = np.zeros(size, dtype=np.int32)
        self.goal_cost = np.zeros(size)
        self.g = np.zeros(size)
        self.parent = np.full(size, -1, dtype=np.int32)
        self.hk, self.hn = np.zeros(self.n // 8 + 64, dtype=np.int64), np.zeros(self.n // 8 + 64, dtype=np.int32)

    def grow(self, size: int, at_least: int = 0) -> None:
        """Double the heap's capacity (or more, to `at_least`), keeping its first `size` entries."""
        capacity = max(2 * len(self.hn), at_least)
        hk, hn = np.zeros(capacity, dtype=np.int64), np.zeros(capacity, dtype=np.int32)
        hk[:size], hn[:size] = self.hk[:size], self.hn[:size]
        self.hk, self.hn = hk, hn

    def next_stamp(self) -> int:
        """A stamp no node carries yet (``mark`` holds twice the stamp: cleared every 2**30 - 2 searches)."""
        if self.stamp >= (1 << 30) - 2:
            self.mark[:] = 0
            self.tag[:] = 0
            self.stamp = 0
        self.stamp += 1
        return self.stamp

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.mark, self.tag, self.goal_cost, self.g, self.parent, self.hk, self.hn))


@dataclass(frozen=True)
class SearchOutcome:
    """How a search ended: the lattice nodes of the path (None when there is none; empty when the
    start joins the goal directly), the expansions, and whether the time budget ended it."""

    nodes: NDArray[np.int64] | None
    expanded: int
    timed_out: bool = False


def search(moves: NDArray[np.uint8], xs: NDArray[np.float64], ys: NDArray[np.float64], step: float,
           ws: Workspace, goal_xy: tuple[float, float], sources: NDArray[np.int64], source_g: NDArray[np.float64],
           targets: NDArray[np.int64], target_cost: NDArray[np.float64], direct: float, *, octile: bool,
           deadline: float = math.inf) -> SearchOutcome:
    """A* from the sources to the goal through the targets (see the module docstring).

    Parameters
    ----------
    moves : (n,) uint8
        Allowed moves per node (bit ``d``: ``MOVES[d]``); a move never leaves the lattice.
    xs, ys : float arrays
        Node coordinates (cm); ``n == len(xs) * len(ys)``.
    step : float
        Cost of a straight move (cm).
    ws : Workspace
        The lattice's reusable arrays.
    goal_xy : (float, float)
        The goal (cm), for the heuristic.
    sources, source_g : arrays
        Nodes the start joins and the cost of each join (cm).
    targets, target_cost : arrays
        Nodes that join the goal and the cost of each join (cm).
    direct : float
        Cost of the direct start-goal join (cm), ``inf`` when there is none.
    octile : bool
        Use the octile heuristic (only when the goal is a lattice node joined at zero cost, alone).
    deadline : float
        `time.perf_counter` value after which the search gives up.
    """
    stamp = ws.next_stamp()
    ny = len(ys)
    gx, gy = float(goal_xy[0]), float(goal_xy[1])
    fscale, hscale = float(1 << F_BITS) / step, 4.0 / step
    if len(ws.hn) < len(sources) + 1:
        ws.grow(0, len(sources) + 1)
    size = _begin(ny, xs, ys, gx, gy, octile, fscale, hscale, sources, source_g, targets, target_cost, float(direct),
                  stamp, ws.mark, ws.tag, ws.goal_cost, ws.g, ws.parent, ws.hk, ws.hn)
    state = np.array([size, 0], dtype=np.int64)
    while True:
        status = _expand(moves, ny, xs, ys, float(step), gx, gy, octile, fscale, hscale, stamp, _CHUNK, state,
                         ws.mark, ws.tag, ws.goal_cost, ws.g, ws.parent, ws.hk, ws.hn)
        expanded = int(state[1])
        if status == FOUND:
            return SearchOutcome(_trace(ws.parent), expanded)
        if status == EXHAUSTED:
            return SearchOutcome(None, expanded)
        if status == FULL:
            ws.grow(int(state[0]))
        elif time.perf_counter() >= deadline:
            return SearchOutcome(None, expanded, timed_out=True)


def warm_up(moves: NDArray[np.uint8], xs: NDArray[np.float64], ys: NDArray[np.float64], step: float,
            ws: Workspace) -> None:
    """Compile (or load from numba's cache) every kernel with this lattice's types, by a one-node search."""
    one = np.zeros(1, dtype=np.int64)
    cost = np.zeros(1)
    search(moves, xs, ys, step, ws, (float(xs[0]), float(ys[0])), one, cost, one, cost, math.inf, octile=True)
