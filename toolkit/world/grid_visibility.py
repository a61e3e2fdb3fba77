"""Exact visibility between lattice points of a grid map, by sweeping rows of cells (compiled with numba).

The point robot's rules are those of `toolkit.world.grid_kernel`: a segment is free when it runs
through free cells, along grid lines that border at least one free cell, and through no pinch (a
lattice point where two blocked cells meet diagonally). This module answers the question a
visibility graph asks -- which lattice points does a lattice point ``u`` see -- without testing
every pair: it sweeps the rows of cells above ``u`` (and, mirrored, below), carrying the set of ray
directions still unblocked as a sorted list of intervals. A blocked cell removes the open interval
of directions whose rays cross its interior; a pinch removes the single direction through it; the
vertical ray along the column line through ``u`` is removed where both cells beside it are blocked.
The sweep stops when no direction survives, so its cost grows with the area ``u`` sees, not with
the size of the map.

Directions are integer vectors ``(dx, dy)`` from ``u`` (every interval end passes through a lattice
point), compared by the sign of their cross product, so the result is exact: no tolerance anywhere.
Coordinates are in cell units as in `toolkit.world.grid_kernel` (cell ``(i, j)`` is
``[i, i + 1] x [j, j + 1]``, ``free[j, i]``; lattice arrays are indexed ``[y, x]``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .arrays import IntArray
from .grid_kernel import grid_pinches

__all__ = ["GridVisibility", "grid_reflex_corners", "grid_visibility_edges", "grid_visible_points", "seen_from",
           "tangent_corners"]


# interval arrays: columns lo_dx, lo_dy, lo_open, hi_dx, hi_dy, hi_open ("lo" is the smaller angle
# from +x, i.e. the right end of the interval on a row above u)
_LDX, _LDY, _LOP, _HDX, _HDY, _HOP = 0, 1, 2, 3, 4, 5

# The helpers below are compiled for one explicit signature each: called with literal constants
# (``_push(out, n, x, y, 0, 0, 0, 0)``) numba would otherwise compile a version per combination of
# literals (eleven of `_push`), tripling the first, uncached compilation.
_GRIDS = "boolean[:, ::1], boolean[:, ::1], boolean[:, ::1]"  # free cells, pinches, targets
_GROWN = "Tuple((int64[:, ::1], int64))"  # a growable output array and its rows filled


@njit("int64(int64, int64, int64, int64)", cache=True)
def _cmp(ax: int, ay: int, bx: int, by: int) -> int:
    """Sign of angle(a) - angle(b) for directions in the closed upper half-plane (never opposite)."""
    c = ax * by - ay * bx
    return -1 if c > 0 else (1 if c < 0 else 0)


@njit("int64[:, ::1](int64[:, ::1], int64, int64, int64, int64, int64, int64, int64)", cache=True)
def _push(buf: IntArray, n: int, ldx: int, ldy: int, lop: int, hdx: int, hdy: int, hop: int) -> IntArray:
    if n == buf.shape[0]:
        bigger = np.empty((2 * n, 6), dtype=np.int64)
        bigger[:n] = buf
        buf = bigger
    buf[n, 0], buf[n, 1], buf[n, 2], buf[n, 3], buf[n, 4], buf[n, 5] = ldx, ldy, lop, hdx, hdy, hop
    return buf


@njit("boolean(int64, int64, int64, int64, int64, int64)", cache=True)
def _nonempty(ldx: int, ldy: int, lop: int, hdx: int, hdy: int, hop: int) -> bool:
    c = _cmp(ldx, ldy, hdx, hdy)
    return c < 0 or (c == 0 and lop == 0 and hop == 0)


@njit("boolean(int64[::1], int64, int64)", cache=True)
def _contains(iv: IntArray, dx: int, dy: int) -> bool:
    a = _cmp(iv[_LDX], iv[_LDY], dx, dy)
    b = _cmp(dx, dy, iv[_HDX], iv[_HDY])
    return (a < 0 or (a == 0 and iv[_LOP] == 0)) and (b < 0 or (b == 0 and iv[_HOP] == 0))


@njit("float64(int64, int64, int64)", cache=True)
def _x_at(dx: int, dy: int, h: int) -> float:
    return dx * h / dy


@njit("boolean(boolean[:, ::1], int64, int64)", cache=True)
def _blocked(free: NDArray[np.bool_], i: int, j: int) -> bool:
    return not (0 <= j < free.shape[0] and 0 <= i < free.shape[1] and free[j, i])


@njit("UniTuple(int64, 2)(int64[::1], int64, int64, int64, int64, int64, int64)", cache=True)
def _row_range(iv: IntArray, ux: int, h0: int, h1: int, lo: int, hi: int, pad: int) -> tuple[int, int]:
    """Columns that rays of `iv` can reach between row lines h0 and h1 (a superset), clipped to [lo, hi]."""
    xs0 = ux + _x_at(iv[_HDX], iv[_HDY], h0)
    xs1 = ux + _x_at(iv[_HDX], iv[_HDY], h1)
    xs2 = ux + _x_at(iv[_LDX], iv[_LDY], h0)
    xs3 = ux + _x_at(iv[_LDX], iv[_LDY], h1)
    a = max(lo, math.floor(min(xs0, xs1)) - pad)
    b = min(hi, math.floor(max(xs2, xs3)) + pad)
    return a, b


@njit(f"{_GROWN}({_GRIDS}, int64, int64, int64[::1], int64[:, ::1], int64)", cache=True)
def _scan_up(free: NDArray[np.bool_], pinch: NDArray[np.bool_], target: NDArray[np.bool_], ux: int, uy: int,
             first: IntArray, out: IntArray, n_out: int) -> tuple[IntArray, int]:
    """Append to `out` the target lattice points strictly above row line ``uy`` that ``(ux, uy)`` sees.

    `first` is the initial interval of directions (six ints). Rows of cells are swept upwards; each
    interval still alive is cut by the blocked cells its rays cross, and by the pinches on the row
    lines. Visible targets are recorded as they are reached.
    """
    h_cells, w_cells = free.shape
    cur = np.empty((16, 6), dtype=np.int64)
    nxt = np.empty((16, 6), dtype=np.int64)
    cur[0] = first
    n_cur = 1
    h = 0
    while n_cur > 0:
        if h > 0:  # row line y: record the targets the rays reach, then cut the rays through pinches
            y = uy + h
            n_nxt = 0
            for k in range(n_cur):
                piece = cur[k].copy()
                a, b = _row_range(piece, ux, h, h, 0, w_cells, 1)
                for x in range(b, a - 1, -1):  # right to left: from low angles to high angles
                    if not _contains(piece, x - ux, h):
                        continue
                    if target[y, x]:
                        out = _push(out, n_out, x, y, 0, 0, 0, 0)
                        n_out += 1
                    if pinch[y, x]:  # keep [lo, d) and go on with (d, hi]
                        if _nonempty(piece[_LDX], piece[_LDY], piece[_LOP], x - ux, h, 1):
                            nxt = _push(nxt, n_nxt, piece[_LDX], piece[_LDY], piece[_LOP], x - ux, h, 1)
                            n_nxt += 1
                        piece[_LDX], piece[_LDY], piece[_LOP] = x - ux, h, 1
                if _nonempty(piece[0], piece[1], piece[2], piece[3], piece[4], piece[5]):
                    nxt = _push(nxt, n_nxt, piece[0], piece[1], piece[2], piece[3], piece[4], piece[5])
                    n_nxt += 1
            cur, nxt = nxt, cur
            n_cur = n_nxt
            if y == h_cells:  # the top of the grid: nothing beyond
                break
        j = uy + h  # the row of cells between row lines h and h + 1 (relative to u)
        n_nxt = 0
        for k in range(n_cur):
            piece = cur[k].copy()
            alive = True
            a, b = _row_range(piece, ux, h, h + 1, -1, w_cells, 1)
            for i in range(a, b + 1):  # left to right: shadows fall from high angles to low ones
                if not _blocked(free, i, j):
                    continue
                if i >= ux:  # the cell's open shadow (s, e) of directions, s the lower angle
                    sx, sy, ex, ey = i + 1 - ux, h, i - ux, h + 1
                else:
                    sx, sy, ex, ey = i + 1 - ux, h + 1, i - ux, h
                if _cmp(sx, sy, piece[_HDX], piece[_HDY]) >= 0:
                    continue  # the shadow lies above the piece
                if _cmp(ex, ey, piece[_LDX], piece[_LDY]) <= 0:
                    break  # below the piece, and the shadows further right lie lower still
                if _nonempty(ex, ey, 0, piece[_HDX], piece[_HDY], piece[_HOP]):  # [e, hi] is done
                    nxt = _push(nxt, n_nxt, ex, ey, 0, piece[_HDX], piece[_HDY], piece[_HOP])
                    n_nxt += 1
                if _nonempty(piece[_LDX], piece[_LDY], piece[_LOP], sx, sy, 0):  # go on with [lo, s]
                    piece[_HDX], piece[_HDY], piece[_HOP] = sx, sy, 0
                else:
                    alive = False
                    break
            if alive:
                nxt = _push(nxt, n_nxt, piece[0], piece[1], piece[2], piece[3], piece[4], piece[5])
                n_nxt += 1
        cur, nxt = nxt, cur
        n_cur = n_nxt
        if _blocked(free, ux - 1, j) and _blocked(free, ux, j):  # the column line through u is a wall here
            n_nxt = 0
            for k in range(n_cur):
                iv = cur[k]
                if _contains(iv, 0, 1):
                    if _nonempty(iv[_LDX], iv[_LDY], iv[_LOP], 0, 1, 1):
                        nxt = _push(nxt, n_nxt, iv[_LDX], iv[_LDY], iv[_LOP], 0, 1, 1)
                        n_nxt += 1
                    if _nonempty(0, 1, 1, iv[_HDX], iv[_HDY], iv[_HOP]):
                        nxt = _push(nxt, n_nxt, 0, 1, 1, iv[_HDX], iv[_HDY], iv[_HOP])
                        n_nxt += 1
                else:
                    nxt = _push(nxt, n_nxt, iv[0], iv[1], iv[2], iv[3], iv[4], iv[5])
                    n_nxt += 1
            cur, nxt = nxt, cur
            n_cur = n_nxt
        h += 1
    return out, n_out


@njit(f"{_GROWN}({_GRIDS}, int64, int64, int64, int64[:, ::1], int64)", cache=True)
def _walk_row(free: NDArray[np.bool_], pinch: NDArray[np.bool_], target: NDArray[np.bool_], ux: int, uy: int,
              step: int, out: IntArray, n_out: int) -> tuple[IntArray, int]:
    """Append the targets seen along row line ``uy`` from ``(ux, uy)`` towards ``step`` (+1 or -1)."""
    w_cells = free.shape[1]
    x = ux
    while True:
        i = x if step > 0 else x - 1  # the cells on either side of the piece of grid line
        if _blocked(free, i, uy - 1) and _blocked(free, i, uy):
            break
        x += step
        if target[uy, x]:
            out = _push(out, n_out, x, uy, 0, 0, 0, 0)
            n_out += 1
        if pinch[uy, x] or x == 0 or x == w_cells:
            break
    return out, n_out


@njit(cache=True)
def seen_from(free: NDArray[np.bool_], pinch: NDArray[np.bool_], target: NDArray[np.bool_],
               free_f: NDArray[np.bool_], pinch_f: NDArray[np.bool_], target_f: NDArray[np.bool_], ux: int, uy: int,
               sigma: int, big: int, out: IntArray) -> tuple[IntArray, int]:
    """Targets seen from lattice point (ux, uy), in rows ``(x, y, ...)`` of `out` (grown when full).

    ``sigma`` 0 looks in all directions; +-1 only along directions ``(dx, dy)`` with
    ``dx * dy * sigma <= 0``, the lines tangent to a reflex corner whose blocked cell lies in the
    quadrant ``(qx, qy)`` with ``qx * qy = sigma``. ``*_f`` are the arrays mirrored upside down,
    `big` a bound larger than any direction's ``|dx|`` (`GridVisibility` prepares all of them).
    Returns the (possibly new) `out` and the number of rows filled.
    """
    h_cells = free.shape[0]
    n_out = 0
    first = np.empty(6, dtype=np.int64)
    for half in range(2):  # 0: rows above, 1: rows below (the mirrored grid)
        s = sigma if half == 0 else -sigma
        first[1], first[4] = 1, 1
        if s == 0:
            first[0], first[2], first[3], first[5] = big, 1, -big, 1
        elif s > 0:  # dx <= 0 above
            first[0], first[2], first[3], first[5] = 0, 0, -big, 1
        else:
            first[0], first[2], first[3], first[5] = big, 1, 0, 0
        if half == 0:
            out, n_out = _scan_up(free, pinch, target, ux, uy, first, out, n_out)
        else:
            n0 = n_out
            out, n_out = _scan_up(free_f, pinch_f, target_f, ux, h_cells - uy, first, out, n_out)
            for k in range(n0, n_out):
                out[k, 1] = h_cells - out[k, 1]
    out, n_out = _walk_row(free, pinch, target, ux, uy, 1, out, n_out)
    out, n_out = _walk_row(free, pinch, target, ux, uy, -1, out, n_out)
    return out, n_out


@njit(cache=True)
def tangent_corners(free: NDArray[np.bool_], pinch: NDArray[np.bool_], target: NDArray[np.bool_],
                    free_f: NDArray[np.bool_], pinch_f: NDArray[np.bool_], target_f: NDArray[np.bool_], ux: int,
                    uy: int, sigma: int, big: int, corners: IntArray, quad: IntArray, ids: IntArray,
                    out: IntArray) -> tuple[IntArray, IntArray]:
    """Ids of the reflex corners (`target`) that lattice point (ux, uy) sees along lines tangent at the
    corner, looking as `seen_from` does with `sigma`; (ux, uy) itself is left out. Returns the ids and
    the (possibly grown) scratch array `out`."""
    out, n = seen_from(free, pinch, target, free_f, pinch_f, target_f, ux, uy, sigma, big, out)
    found = np.empty(n, dtype=np.int64)
    m = 0
    for k in range(n):
        w = ids[out[k, 1], out[k, 0]]
        dx, dy = ux - corners[w, 0], uy - corners[w, 1]
        if (dx != 0 or dy != 0) and dx * dy * quad[w, 0] * quad[w, 1] <= 0:
            found[m] = w
            m += 1
    return found[:m], out


def grid_reflex_corners(free: NDArray[np.bool_]) -> tuple[IntArray, IntArray]:
    """Lattice points where exactly one of the four cells around is blocked (outside counts as blocked).

    Returns
    -------
    (xy, quadrant)
        (n, 2) lattice points ``(x, y)`` and (n, 2) the side of the blocked cell (``qx, qy`` in +-1).
        These are the reflex corners of the free space; none of them is a pinch.
    """
    h, w = free.shape
    p = np.zeros((h + 2, w + 2), dtype=bool)
    p[1:-1, 1:-1] = free
    sw, se, nw, ne = p[:-1, :-1], p[:-1, 1:], p[1:, :-1], p[1:, 1:]
    blocked = np.stack([~sw, ~se, ~nw, ~ne]).astype(np.int8)
    y, x = np.nonzero(blocked.sum(axis=0) == 1)
    which = np.argmax(blocked[:, y, x], axis=0)  # 0 sw, 1 se, 2 nw, 3 ne
    qx = np.where(which % 2 == 1, 1, -1)
    qy = np.where(which >= 2, 1, -1)
    return np.column_stack([x, y]).astype(np.int64), np.column_stack([qx, qy]).astype(np.int64)


@dataclass(frozen=True, eq=False)
class GridVisibility:
    """A grid prepared for visibility sweeps: free cells, pinches, reflex corners and their ids.

    ``corners`` ((n, 2) lattice points) and ``quadrants`` ((n, 2), the side of each corner's
    blocked cell) come from `grid_reflex_corners`; ``ids[y, x]`` is a corner's index or -1;
    ``arrays`` are the arguments `seen_from` takes before ``ux``.
    """

    free: NDArray[np.bool_]
    corners: IntArray
    quadrants: IntArray
    ids: IntArray
    arrays: tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_],
                  NDArray[np.bool_]]
    big: int

    @classmethod
    def of(cls, free: NDArray[np.bool_]) -> GridVisibility:
        free = np.ascontiguousarray(free, dtype=bool)
        xy, quad = grid_reflex_corners(free)
        target = np.zeros((free.shape[0] + 1, free.shape[1] + 1), dtype=bool)
        target[xy[:, 1], xy[:, 0]] = True
        ids = np.full(target.shape, -1, dtype=np.int64)
        ids[xy[:, 1], xy[:, 0]] = np.arange(len(xy))
        return cls(free, xy, quad, ids, *_sweep_arrays(free, target))


def _sweep_arrays(free: NDArray[np.bool_], target: NDArray[np.bool_]) -> tuple[Any, int]:
    """`seen_from`'s grid arguments (the arrays and their mirror images) and its direction bound."""
    pinch = grid_pinches(free)
    free_f, pinch_f, target_f = (np.ascontiguousarray(a[::-1]) for a in (free, pinch, target))
    return (free, pinch, target, free_f, pinch_f, target_f), 4 * (free.shape[0] + free.shape[1] + 4)


def grid_visible_points(free: NDArray[np.bool_], target: NDArray[np.bool_], x: int, y: int) -> IntArray:
    """The lattice points flagged in `target` ((H + 1, W + 1), ``[y, x]``) that lattice point ``(x, y)`` sees.

    Exact under the point robot's rules (see the module docstring); ``(x, y)`` itself is not listed.
    """
    (f, p, t, f_f, p_f, t_f), big = _sweep_arrays(np.ascontiguousarray(free, dtype=bool),
                                                  np.ascontiguousarray(target, dtype=bool))
    out, n = seen_from(f, p, t, f_f, p_f, t_f, int(x), int(y), 0, big, np.empty((64, 6), dtype=np.int64))
    return np.asarray(out[:n, :2])


@njit(cache=True)
def _edges(free: NDArray[np.bool_], pinch: NDArray[np.bool_], target: NDArray[np.bool_], free_f: NDArray[np.bool_],
           pinch_f: NDArray[np.bool_], target_f: NDArray[np.bool_], xy: IntArray, quad: IntArray, ids: IntArray,
           big: int) -> IntArray:
    edges = np.empty((1024, 2), dtype=np.int64)
    n_edges = 0
    out = np.empty((64, 6), dtype=np.int64)
    for u in range(xy.shape[0]):
        seen, out = tangent_corners(free, pinch, target, free_f, pinch_f, target_f, xy[u, 0], xy[u, 1],
                                    quad[u, 0] * quad[u, 1], big, xy, quad, ids, out)
        for w in seen:
            if w <= u:
                continue
            if n_edges == edges.shape[0]:
                bigger = np.empty((2 * n_edges, 2), dtype=np.int64)
                bigger[:n_edges] = edges
                edges = bigger
            edges[n_edges, 0], edges[n_edges, 1] = u, w
            n_edges += 1
    return edges[:n_edges].copy()


def grid_visibility_edges(free: NDArray[np.bool_]) -> tuple[IntArray, IntArray]:
    """The whole visibility graph of a grid map's reflex corners, restricted to lines tangent at both ends.

    These are the only edges a shortest path of a point robot can use between two corners (it bends
    only at reflex corners, and only around them). Its size grows with how far the corners see
    each other; a search that needs only part of it scans corners as it reaches them instead.

    Returns
    -------
    (corners, edges)
        (n, 2) lattice points (`grid_reflex_corners`) and (e, 2) index pairs ``i < j``.
    """
    gv = GridVisibility.of(free)
    f, p, t, f_f, p_f, t_f = gv.arrays
    return gv.corners, np.asarray(_edges(f, p, t, f_f, p_f, t_f, gv.corners, gv.quadrants, gv.ids, gv.big))
