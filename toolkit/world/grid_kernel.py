"""Exact segment checks on a cell grid for a point robot, compiled with numba.

A segment lies in the closed free space of a grid map when every piece of it between two grid
lines lies in a free cell, every piece running along a grid line borders at least one free cell
(a line between two blocked cells, or along the map's border, is a wall), and it passes through no
corner where two blocked cells meet diagonally (a pinch). The function below walks the segment's
crossings with the grid lines in order and checks exactly that; its cost grows with the number of
cells the segment crosses, not with the number of walls in the map. These are the rules of the
grid path-planning benchmarks (Moving AI, GPPC any-angle).

Coordinates are in cell units: cell ``(i, j)`` is ``[i, i + 1] x [j, j + 1]``, ``free[j, i]``;
``pinch[j, i]`` flags the lattice point ``(i, j)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["grid_pinches", "grid_points_free", "grid_segments_free"]

_EPS = 1e-9


def grid_pinches(free: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Lattice points (shape (H + 1, W + 1), ``[j, i]``) where two free cells meet only diagonally."""
    h, w = free.shape
    p = np.zeros((h + 2, w + 2), dtype=bool)
    p[1:-1, 1:-1] = free
    sw, se, nw, ne = p[:-1, :-1], p[:-1, 1:], p[1:, :-1], p[1:, 1:]
    return np.asarray((sw & ne & ~se & ~nw) | (se & nw & ~sw & ~ne))


@njit(cache=True)
def _free(free: NDArray[np.bool_], i: int, j: int) -> bool:
    return 0 <= j < free.shape[0] and 0 <= i < free.shape[1] and free[j, i]


@njit(cache=True)
def _point_free(free: NDArray[np.bool_], u: float, v: float) -> bool:
    fi, fj = math.floor(u), math.floor(v)
    on_i = abs(u - round(u)) <= _EPS
    on_j = abs(v - round(v)) <= _EPS
    i_lo, i_hi = (round(u) - 1, round(u)) if on_i else (fi, fi)
    j_lo, j_hi = (round(v) - 1, round(v)) if on_j else (fj, fj)
    for i in range(i_lo, i_hi + 1):
        for j in range(j_lo, j_hi + 1):
            if _free(free, i, j):
                return True
    return False


@njit(cache=True)
def _first_line(p0: float, dp: float) -> tuple[int, int]:
    """The first grid line crossed after the start (moving by `dp`) and the direction of travel."""
    if dp > _EPS:
        return math.floor(p0) + 1, 1
    if dp < -_EPS:
        return math.ceil(p0) - 1, -1
    return 0, 0


@njit(cache=True)
def _crossing(k: int, step: int, p0: float, dp: float) -> float:
    return (k - p0) / dp if step != 0 else math.inf


@njit(cache=True)
def _piece_free(free: NDArray[np.bool_], mu: float, mv: float, on_u: bool, on_v: bool, u0: float,
                v0: float) -> bool:
    """Whether the open piece of segment around (mu, mv), between two grid lines, is free."""
    if on_u:  # runs along the vertical grid line u = u0: a wall when both sides are blocked
        k = round(u0)
        jj = math.floor(mv)
        return _free(free, k - 1, jj) or _free(free, k, jj)
    if on_v:
        k = round(v0)
        ii = math.floor(mu)
        return _free(free, ii, k - 1) or _free(free, ii, k)
    return _free(free, math.floor(mu), math.floor(mv))


@njit(cache=True)
def _segment_free(free: NDArray[np.bool_], pinch: NDArray[np.bool_], u0: float, v0: float, u1: float,
                  v1: float) -> bool:
    du, dv = u1 - u0, v1 - v0
    if abs(du) <= _EPS and abs(dv) <= _EPS:
        return _point_free(free, u0, v0)
    on_u = abs(du) <= _EPS and abs(u0 - round(u0)) <= _EPS
    on_v = abs(dv) <= _EPS and abs(v0 - round(v0)) <= _EPS
    ku, su = _first_line(u0, du)
    kv, sv = _first_line(v0, dv)
    tu, tv = _crossing(ku, su, u0, du), _crossing(kv, sv, v0, dv)
    t_prev = 0.0
    while True:  # walk the grid-line crossings in order; stop at the first blocked piece
        t_next = min(tu, tv, 1.0)
        if t_next - t_prev > _EPS:
            tm = 0.5 * (t_prev + t_next)
            if not _piece_free(free, u0 + tm * du, v0 + tm * dv, on_u, on_v, u0, v0):
                return False
        if t_next >= 1.0 - _EPS:
            return True
        pu, pv = u0 + t_next * du, v0 + t_next * dv
        ru, rv = round(pu), round(pv)
        if abs(pu - ru) <= _EPS and abs(pv - rv) <= _EPS:  # a corner passed strictly inside the segment
            if 0 <= rv < pinch.shape[0] and 0 <= ru < pinch.shape[1] and pinch[rv, ru]:
                return False
        if tu <= t_next:
            ku += su
            tu = _crossing(ku, su, u0, du)
        if tv <= t_next:
            kv += sv
            tv = _crossing(kv, sv, v0, dv)
        t_prev = t_next


@njit(cache=True)
def _segments_free(free: NDArray[np.bool_], pinch: NDArray[np.bool_], a: NDArray[np.float64],
                   b: NDArray[np.float64]) -> NDArray[np.bool_]:
    out = np.empty(a.shape[0], dtype=np.bool_)
    for k in range(a.shape[0]):
        out[k] = _segment_free(free, pinch, a[k, 0], a[k, 1], b[k, 0], b[k, 1])
    return out


@njit(cache=True)
def _points_free(free: NDArray[np.bool_], p: NDArray[np.float64]) -> NDArray[np.bool_]:
    out = np.empty(p.shape[0], dtype=np.bool_)
    for k in range(p.shape[0]):
        out[k] = _point_free(free, p[k, 0], p[k, 1])
    return out


def grid_segments_free(free: NDArray[np.bool_], pinch: NDArray[np.bool_], a: NDArray[np.float64],
                       b: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each segment ``a[k] -> b[k]`` (cell units, (n, 2) arrays) lies in the closed free space."""
    return np.asarray(_segments_free(free, pinch, np.ascontiguousarray(a, dtype=np.float64),
                                     np.ascontiguousarray(b, dtype=np.float64)))


def grid_points_free(free: NDArray[np.bool_], p: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each point (cell units, (n, 2)) lies in the closure of a free cell."""
    return np.asarray(_points_free(free, np.ascontiguousarray(p, dtype=np.float64)))
