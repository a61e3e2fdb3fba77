"""A uniform grid over the wall segments and the compiled (numba) queries that use it.

Ray casting, the disc checks of `CollisionChecker` and the sonar models all ask "which walls are
near this ray / point / segment?". Testing every wall costs O(W) per query; this index makes it
O(walls near the query):

* the map's bounding box is cut into square cells of side ``h`` (about two cells per wall, see
  `EdgeIndex.build`); each wall is listed in every cell its segment passes through (the cells are
  grown by a tiny margin, so a wall through a cell corner is listed in all four);
* a ray walks the cells it crosses in order (Amanatides and Woo's traversal) and tests the walls of
  each cell with the same formula as `ray_wall_distances`; it stops in the first cell whose exit lies
  beyond the nearest hit found, so the answer is the exact first hit, not an approximation;
* a disc or a swept disc (capsule) tests the walls of the cells its bounding strip overlaps.

Every answer equals the brute-force one (same arithmetic, the index only skips walls that cannot
matter); the tests compare both, and shapely, on random queries.
"""

from __future__ import annotations

import math
import threading
import weakref
from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import FloatArray, IntArray

__all__ = ["ALONG_CM", "EdgeIndex", "edge_index"]


_MARGIN = 1e-7
"""Relative growth of each cell (times the cell side) when listing walls: rounding can never drop a wall."""

ALONG_CM = 1e-9
"""A ray parallel to a wall and this close (cm) to its line runs along the wall: it stops at the wall's
nearer end (or at once, from a point on the wall). A thin wall met end-on is hit, not seen through."""

_jit = numba.njit(cache=True, nogil=True)


@_jit
def _cell(v: float, lo: float, h: float, n: int) -> int:
    """Index of the cell of coordinate v on an axis of n cells of side h from lo, clamped to [0, n - 1]."""
    return min(max(math.floor((v - lo) / h), 0), n - 1)


@_jit
def _clip_segment_box(x1: float, y1: float, x2: float, y2: float,
                      bx0: float, by0: float, bx1: float, by1: float) -> bool:
    """Whether the segment (x1, y1)-(x2, y2) meets the closed box [bx0, bx1] x [by0, by1] (Liang-Barsky)."""
    t0, t1 = 0.0, 1.0
    dx, dy = x2 - x1, y2 - y1
    for k in range(4):
        if k == 0:
            p, q = -dx, x1 - bx0
        elif k == 1:
            p, q = dx, bx1 - x1
        elif k == 2:
            p, q = -dy, y1 - by0
        else:
            p, q = dy, by1 - y1
        if p == 0.0:
            if q < 0.0:
                return False
        else:
            r = q / p
            if p < 0.0:
                if r > t1:
                    return False
                if r > t0:
                    t0 = r
            else:
                if r < t0:
                    return False
                if r < t1:
                    t1 = r
    return True


@_jit
def _fill_cells(walls: FloatArray, x0: float, y0: float, h: float, nx: int, ny: int,
                counts: IntArray, items: IntArray, start: IntArray, fill: bool) -> int:
    """List every wall in the cells it passes through: count (fill=False) or write (fill=True)."""
    m = _MARGIN * h
    total = 0
    for e in range(walls.shape[0]):
        ax, ay, bx, by = walls[e, 0], walls[e, 1], walls[e, 2], walls[e, 3]
        i0 = _cell(min(ax, bx) - m, x0, h, nx)
        i1 = _cell(max(ax, bx) + m, x0, h, nx)
        j0 = _cell(min(ay, by) - m, y0, h, ny)
        j1 = _cell(max(ay, by) + m, y0, h, ny)
        for i in range(i0, i1 + 1):
            cx0 = x0 + i * h
            for j in range(j0, j1 + 1):
                cy0 = y0 + j * h
                if _clip_segment_box(ax, ay, bx, by, cx0 - m, cy0 - m, cx0 + h + m, cy0 + h + m):
                    c = i * ny + j
                    if fill:
                        items[start[c] + counts[c]] = e
                    counts[c] += 1
                    total += 1
    return total


@_jit
def _ray_hit(walls: FloatArray, e: int, ox: float, oy: float, dx: float, dy: float) -> float:
    """Distance along the ray to segment row e of `walls` (inf if it misses); `ray_wall_distances`' arithmetic."""
    x1, y1 = walls[e, 0], walls[e, 1]
    ex, ey = walls[e, 2] - x1, walls[e, 3] - y1
    qx, qy = x1 - ox, y1 - oy
    denom = dx * ey - dy * ex
    if not abs(denom) > 1e-12:  # parallel: a hit only when the ray runs along the wall (`ALONG_CM`)
        t1 = qx * dx + qy * dy
        t2 = t1 + ex * dx + ey * dy
        if abs(qx * dy - qy * dx) <= ALONG_CM and max(t1, t2) >= 0.0:
            return max(min(t1, t2), 0.0)
        return np.inf
    t = (qx * ey - qy * ex) / denom
    u = (qx * dy - qy * dx) / denom
    if t >= 0.0 and u >= 0.0 and u <= 1.0:
        return t
    return np.inf


@_jit
def _insert(best_t: FloatArray, best_w: IntArray, t: float, e: int) -> None:
    """Insert the crossing (t, e) into the sorted k-nearest lists (ties: lower wall index first)."""
    k = best_t.size
    if t > best_t[k - 1] or (t == best_t[k - 1] and e >= best_w[k - 1]):
        return
    for s in range(k):
        if best_w[s] == e:
            return  # the same wall met again from another cell
    pos = k - 1
    while pos > 0 and (t < best_t[pos - 1] or (t == best_t[pos - 1] and e < best_w[pos - 1])):
        best_t[pos] = best_t[pos - 1]
        best_w[pos] = best_w[pos - 1]
        pos -= 1
    best_t[pos] = t
    best_w[pos] = e


@_jit
def _cast_rays(cell_walls: FloatArray, x0: float, y0: float, h: float, nx: int, ny: int, start: IntArray,
               items: IntArray, empty: NDArray[np.int32], ox: FloatArray, oy: FloatArray, ang: FloatArray, slack: float,
               max_t: float, out_t: FloatArray, out_w: IntArray) -> None:
    """First k crossings of each ray (k = out_t.shape[1]) within `slack` cm of the first one.

    ``cell_walls[q]`` is wall ``items[q]`` (the walls copied in cell order, for memory locality).
    With k = 1 this is plain ray casting: the nearest hit and its wall (inf, -1 for none). ``empty[c]``
    is the chessboard distance from cell c to the nearest cell listing a wall (0 for such a cell):
    the ray crosses the wall-free square around an empty cell in one step. Crossings beyond `max_t`
    are not reported (and the walk stops there).
    """
    k = out_t.shape[1]
    gx1, gy1 = x0 + nx * h, y0 + ny * h
    bt = np.empty(k)
    bw = np.empty(k, dtype=np.int64)
    for r in range(ox.size):
        px, py = ox[r], oy[r]
        dx, dy = math.cos(ang[r]), math.sin(ang[r])
        for s in range(k):
            bt[s] = np.inf
            bw[s] = -1
        # clip the ray to the grid's box
        t_in, t_out = 0.0, np.inf
        if dx != 0.0:
            ta, tb = (x0 - px) / dx, (gx1 - px) / dx
            t_in, t_out = max(t_in, min(ta, tb)), min(t_out, max(ta, tb))
        elif px < x0 or px > gx1:
            t_out = -1.0
        if dy != 0.0:
            ta, tb = (y0 - py) / dy, (gy1 - py) / dy
            t_in, t_out = max(t_in, min(ta, tb)), min(t_out, max(ta, tb))
        elif py < y0 or py > gy1:
            t_out = -1.0
        if t_in <= t_out:
            ex, ey = px + t_in * dx, py + t_in * dy
            i = _cell(ex, x0, h, nx)
            j = _cell(ey, y0, h, ny)
            step_i = 1 if dx > 0.0 else -1
            step_j = 1 if dy > 0.0 else -1
            if dx != 0.0:
                nxt_x = (x0 + (i + (1 if dx > 0.0 else 0)) * h - px) / dx
                dtx = h / abs(dx)
            else:
                nxt_x, dtx = np.inf, np.inf
            if dy != 0.0:
                nxt_y = (y0 + (j + (1 if dy > 0.0 else 0)) * h - py) / dy
                dty = h / abs(dy)
            else:
                nxt_y, dty = np.inf, np.inf
            while True:
                c = i * ny + j
                d = empty[c] - 1
                if d >= 1:
                    # the (2d + 1)-cell square around this cell holds no wall: leave it in one step
                    tx = np.inf if dx == 0.0 else (x0 + (i + d + 1 if dx > 0.0 else i - d) * h - px) / dx
                    ty = np.inf if dy == 0.0 else (y0 + (j + d + 1 if dy > 0.0 else j - d) * h - py) / dy
                    tb = min(tx, ty)
                    if tb > max_t:
                        break
                    qx, qy = px + tb * dx, py + tb * dy
                    ni = min(max(math.floor((qx - x0) / h), i - d), i + d)
                    nj = min(max(math.floor((qy - y0) / h), j - d), j + d)
                    if tx <= ty:
                        ni = i + d + 1 if dx > 0.0 else i - d - 1
                    if ty <= tx:
                        nj = j + d + 1 if dy > 0.0 else j - d - 1
                    i, j = ni, nj
                    if i < 0 or i >= nx or j < 0 or j >= ny:
                        break
                    nxt_x = np.inf if dx == 0.0 else (x0 + (i + (1 if dx > 0.0 else 0)) * h - px) / dx
                    nxt_y = np.inf if dy == 0.0 else (y0 + (j + (1 if dy > 0.0 else 0)) * h - py) / dy
                    continue
                for q in range(start[c], start[c + 1]):
                    t = _ray_hit(cell_walls, q, px, py, dx, dy)
                    if t < np.inf and t <= bt[0] + slack:
                        _insert(bt, bw, t, items[q])
                # every crossing nearer than this cell's exit has been seen (up to the rounding margin)
                seen = min(nxt_x, nxt_y) - _MARGIN * h
                if seen > max_t or (bt[0] < np.inf and (seen >= bt[0] + slack or seen >= bt[k - 1])):
                    break
                if nxt_x < nxt_y:
                    i += step_i
                    nxt_x += dtx
                else:
                    j += step_j
                    nxt_y += dty
                if i < 0 or i >= nx or j < 0 or j >= ny:
                    break
        for s in range(k):
            keep = bt[s] <= bt[0] + slack and bt[s] <= max_t
            out_t[r, s] = bt[s] if keep else np.inf
            out_w[r, s] = bw[s] if keep else -1


@_jit
def _point_segment_distance(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """Exact distance from a point to a segment (GEOS's formula, so ties fall as in shapely)."""
    if ax == bx and ay == by:
        return math.hypot(px - ax, py - ay)
    len2 = (bx - ax) * (bx - ax) + (by - ay) * (by - ay)
    r = ((px - ax) * (bx - ax) + (py - ay) * (by - ay)) / len2
    if r <= 0.0:
        return math.hypot(px - ax, py - ay)
    if r >= 1.0:
        return math.hypot(px - bx, py - by)
    s = ((ay - py) * (bx - ax) - (ax - px) * (by - ay)) / len2
    return abs(s) * math.sqrt(len2)


@_jit
def _orient(ax: float, ay: float, bx: float, by: float, cx: float, cy: float) -> int:
    v = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    return 1 if v > 0.0 else (-1 if v < 0.0 else 0)


@_jit
def _on_segment(ax: float, ay: float, bx: float, by: float, px: float, py: float) -> bool:
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@_jit
def _segment_segment_distance(ax: float, ay: float, bx: float, by: float,
                              cx: float, cy: float, dx: float, dy: float) -> float:
    """Exact distance between segments ab and cd: 0 when they meet, else the nearest endpoint distance."""
    o1 = _orient(ax, ay, bx, by, cx, cy)
    o2 = _orient(ax, ay, bx, by, dx, dy)
    o3 = _orient(cx, cy, dx, dy, ax, ay)
    o4 = _orient(cx, cy, dx, dy, bx, by)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return 0.0
    if (o1 == 0 and _on_segment(ax, ay, bx, by, cx, cy)) or (o2 == 0 and _on_segment(ax, ay, bx, by, dx, dy)) or \
            (o3 == 0 and _on_segment(cx, cy, dx, dy, ax, ay)) or (o4 == 0 and _on_segment(cx, cy, dx, dy, bx, by)):
        return 0.0
    d = _point_segment_distance(ax, ay, cx, cy, dx, dy)
    d = min(d, _point_segment_distance(bx, by, cx, cy, dx, dy))
    d = min(d, _point_segment_distance(cx, cy, ax, ay, bx, by))
    return min(d, _point_segment_distance(dx, dy, ax, ay, bx, by))


@_jit
def _capsules_clear(cell_walls: FloatArray, x0: float, y0: float, h: float, nx: int, ny: int, start: IntArray,
                    items: IntArray, a: FloatArray, b: FloatArray, radius: float, out: NDArray[np.bool_],
                    stamp: IntArray, base: int) -> None:
    """out[s] = no wall closer than `radius` to segment s (a[s] -> b[s]; a point when a == b).

    ``cell_walls[q]`` is wall ``items[q]`` (each cell's walls side by side in memory). For a segment,
    ``stamp[e] == base + s`` marks wall e as tested (a wall listed in several cells is tested once);
    `stamp` holds values below `base` on entry. A point tests such a wall again (cheaper than the mark).
    """
    far2 = radius * radius * (1.0 + 1e-9) + 1e-9 * h * h
    for s0 in range(a.shape[0]):
        s = base + s0
        ax, ay, bx, by = a[s0, 0], a[s0, 1], b[s0, 0], b[s0, 1]
        point = ax == bx and ay == by
        clear = True
        j0 = _cell(min(ay, by) - radius, y0, h, ny)
        j1 = _cell(max(ay, by) + radius, y0, h, ny)
        for j in range(j0, j1 + 1):
            if not clear:
                break
            # the part of the segment within `radius` of this row of cells, grown by the radius
            sy0, sy1 = y0 + j * h - radius, y0 + (j + 1) * h + radius
            if ay == by:
                t0, t1 = 0.0, 1.0
            else:
                ta, tb = (sy0 - ay) / (by - ay), (sy1 - ay) / (by - ay)
                t0, t1 = max(0.0, min(ta, tb)), min(1.0, max(ta, tb))
            if t0 > t1:
                continue
            xa, xb = ax + t0 * (bx - ax), ax + t1 * (bx - ax)
            i0 = _cell(min(xa, xb) - radius, x0, h, nx)
            i1 = _cell(max(xa, xb) + radius, x0, h, nx)
            for i in range(i0, i1 + 1):
                if point:
                    # a cell whose box is farther than the radius holds no wall within it
                    gx = max(x0 + i * h - ax, 0.0, ax - (x0 + (i + 1) * h))
                    gy = max(y0 + j * h - ay, 0.0, ay - (y0 + (j + 1) * h))
                    if gx * gx + gy * gy > far2:
                        continue
                c = i * ny + j
                for q in range(start[c], start[c + 1]):
                    if point:
                        d = _point_segment_distance(ax, ay, cell_walls[q, 0], cell_walls[q, 1], cell_walls[q, 2],
                                                    cell_walls[q, 3])
                    else:
                        e = items[q]
                        if stamp[e] == s:
                            continue
                        stamp[e] = s
                        d = _segment_segment_distance(ax, ay, bx, by, cell_walls[q, 0], cell_walls[q, 1],
                                                      cell_walls[q, 2], cell_walls[q, 3])
                    if d < radius:
                        clear = False
                        break
                if not clear:
                    break
        out[s0] = clear


@_jit
def _nearest(walls: FloatArray, x0: float, y0: float, h: float, nx: int, ny: int, start: IntArray,
             items: IntArray, pts: FloatArray, out: FloatArray) -> None:
    """out[s] = exact distance from point s to the nearest wall (inf without walls), by rings of cells."""
    for s in range(pts.shape[0]):
        px, py = pts[s, 0], pts[s, 1]
        ci = _cell(px, x0, h, nx)
        cj = _cell(py, y0, h, ny)
        best = np.inf
        ring = 0
        while True:
            i0, i1, j0, j1 = ci - ring, ci + ring, cj - ring, cj + ring
            if i0 < 0 and j0 < 0 and i1 >= nx and j1 >= ny:
                break
            for i in range(max(i0, 0), min(i1, nx - 1) + 1):
                on_i = i == i0 or i == i1
                for j in range(max(j0, 0), min(j1, ny - 1) + 1):
                    if not on_i and j != j0 and j != j1:
                        continue
                    c = i * ny + j
                    for q in range(start[c], start[c + 1]):
                        e = items[q]
                        d = _point_segment_distance(px, py, walls[e, 0], walls[e, 1], walls[e, 2], walls[e, 3])
                        if d < best:
                            best = d
            # cells beyond this ring are at least `ring` whole cells from the point's cell (or its
            # projection onto the grid, which is no farther from any cell than the point itself)
            if best <= ring * h:
                break
            ring += 1
        out[s] = best


@dataclass(frozen=True, eq=False)
class EdgeIndex:
    """Walls listed per cell of a uniform grid (compressed rows), with exact compiled queries.

    Build with `edge_index` (cached per walls array) or `EdgeIndex.build`.

    Attributes
    ----------
    walls : (W, 4) float64 ndarray
        The segments [x1, y1, x2, y2] (cm).
    origin : (2,) ndarray
        Lower-left corner of the grid (cm).
    cell : float
        Side of a cell (cm).
    shape : (nx, ny)
        Cells along x and y.
    start, items : int64 ndarrays
        The walls of cell ``i * ny + j`` are ``items[start[c]:start[c + 1]]``.
    empty : int32 ndarray
        Per cell, the chessboard distance (in cells) to the nearest cell that lists a wall (0 there).
    cell_walls : (len(items), 4) float64 ndarray
        ``walls[items]``: each cell's walls side by side in memory.
    """

    walls: FloatArray
    origin: FloatArray
    cell: float
    shape: tuple[int, int]
    start: IntArray
    items: IntArray
    empty: NDArray[np.int32]
    cell_walls: FloatArray
    _scratch: threading.local = field(default_factory=threading.local, repr=False)
    """Per-thread marks of the walls already tested by a query (see `_capsules_clear`)."""

    @classmethod
    def build(cls, walls: FloatArray, cells_per_wall: float = 2.0) -> EdgeIndex:
        """Index `walls` on a grid of about ``cells_per_wall * W`` square cells (at least one)."""
        w = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
        if len(w) == 0:
            lo, hi = np.zeros(2), np.ones(2)
        else:
            lo = np.minimum(w[:, :2].min(axis=0), w[:, 2:].min(axis=0))
            hi = np.maximum(w[:, :2].max(axis=0), w[:, 2:].max(axis=0))
        span = np.maximum(hi - lo, 1e-9)
        pad = 1e-6 * float(span.max()) + 1e-9
        lo, span = lo - pad, span + 2 * pad
        # mean wall length bounds the cell from below: cells much smaller than a wall list it many times
        n_cells = max(cells_per_wall * len(w), 1.0)
        h = math.sqrt(float(span[0] * span[1]) / n_cells)
        if len(w):
            h = max(h, 0.5 * float(np.mean(np.hypot(w[:, 2] - w[:, 0], w[:, 3] - w[:, 1]))))
        h = max(h, float(span.max()) / 4096.0)
        nx, ny = max(1, math.ceil(span[0] / h)), max(1, math.ceil(span[1] / h))
        counts = np.zeros(nx * ny, dtype=np.int64)
        start = np.zeros(nx * ny + 1, dtype=np.int64)
        empty = np.zeros(0, dtype=np.int64)
        _fill_cells(w, float(lo[0]), float(lo[1]), h, nx, ny, counts, empty, start, False)
        np.cumsum(counts, out=start[1:])
        items = np.empty(int(start[-1]), dtype=np.int64)
        counts[:] = 0
        _fill_cells(w, float(lo[0]), float(lo[1]), h, nx, ny, counts, items, start, True)
        w.setflags(write=False)
        occupied = (np.diff(start) > 0).reshape(nx, ny)
        if occupied.any():
            import scipy.ndimage  # here, not at the top: it costs every process half a second at start

            empty = scipy.ndimage.distance_transform_cdt(~occupied, metric="chessboard").astype(np.int32)
        else:
            empty = np.full((nx, ny), max(nx, ny), dtype=np.int32)
        return cls(w, lo, h, (nx, ny), start, items, np.ascontiguousarray(empty.ravel()),
                   np.ascontiguousarray(w[items]))

    def __getstate__(self) -> dict[str, object]:
        """Pickle the index without its per-thread scratch (a new process starts its own)."""
        return {k: v for k, v in self.__dict__.items() if k != "_scratch"}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state, _scratch=threading.local())

    @property
    def nbytes(self) -> int:
        """Memory of the index (bytes), walls included."""
        return int(sum(a.nbytes for a in (self.walls, self.start, self.items, self.empty, self.cell_walls)))

    def cast(self, ox: FloatArray, oy: FloatArray, angles: FloatArray, k: int = 1,
             slack: float = 0.0, max_range: float = math.inf) -> tuple[FloatArray, IntArray]:
        """The first `k` crossings (distances in cm, wall indices) of each ray within `slack` cm of the first.

        Crossings farther than `max_range` cm are not reported (a range-limited sensor; faster).

        Rays start at (ox, oy) along absolute `angles` (rad), all flat arrays of one length. Returns
        (n, k) distances (``inf`` beyond the crossings found) and wall indices (-1 there).
        """
        n = ox.size
        out_t = np.empty((n, k))
        out_w = np.empty((n, k), dtype=np.int64)
        _cast_rays(self.cell_walls, float(self.origin[0]), float(self.origin[1]), self.cell, self.shape[0],
                   self.shape[1], self.start, self.items, self.empty, np.ascontiguousarray(ox, dtype=np.float64),
                   np.ascontiguousarray(oy, dtype=np.float64), np.ascontiguousarray(angles, dtype=np.float64),
                   float(slack), float(max_range), out_t, out_w)
        return out_t, out_w

    def nearest_distance(self, pts: FloatArray) -> FloatArray:
        """Exact distance (cm) from each point of an (n, 2) array to the nearest wall."""
        out = np.empty(len(pts))
        _nearest(self.walls, float(self.origin[0]), float(self.origin[1]), self.cell, self.shape[0], self.shape[1],
                 self.start, self.items, np.ascontiguousarray(pts, dtype=np.float64).reshape(-1, 2), out)
        return out

    def capsules_clear(self, a: FloatArray, b: FloatArray, radius: float) -> NDArray[np.bool_]:
        """Whether no wall comes closer than `radius` cm to each segment a[s] -> b[s] ((n, 2) arrays)."""
        out = np.empty(len(a), dtype=bool)
        scratch = self._scratch.__dict__
        if "stamp" not in scratch:
            scratch["stamp"], scratch["base"] = np.full(len(self.walls), -1, dtype=np.int64), 0
        _capsules_clear(self.cell_walls, float(self.origin[0]), float(self.origin[1]), self.cell, self.shape[0],
                        self.shape[1], self.start, self.items, np.ascontiguousarray(a, dtype=np.float64),
                        np.ascontiguousarray(b, dtype=np.float64), float(radius), out, scratch["stamp"],
                        scratch["base"])
        scratch["base"] += len(a)
        return out


_BY_ID: dict[int, tuple[weakref.ref[np.ndarray], EdgeIndex]] = {}
_BY_CONTENT: dict[bytes, EdgeIndex] = {}
_CACHE_LOCK = threading.Lock()
_CONTENT_ENTRIES = 8


def edge_index(walls: ArrayLike) -> EdgeIndex:
    """The `EdgeIndex` of a walls array, built once per array.

    A read-only (W, 4) float64 array (such as `Map.walls`) is recognised by identity; anything else by
    its contents (the last few are kept), so an array changed in place is indexed again.
    """
    if isinstance(walls, np.ndarray) and walls.dtype == np.float64 and not walls.flags.writeable \
            and walls.ndim == 2 and walls.shape[1] == 4:
        key = id(walls)
        with _CACHE_LOCK:
            hit = _BY_ID.get(key)
            if hit is not None and hit[0]() is walls:
                return hit[1]
        index = EdgeIndex.build(walls)
        with _CACHE_LOCK:
            for k in [k for k, v in _BY_ID.items() if v[0]() is None]:
                del _BY_ID[k]
            _BY_ID[key] = (weakref.ref(walls), index)
        return index
    arr = np.ascontiguousarray(walls, dtype=np.float64).reshape(-1, 4)
    digest = arr.tobytes()
    with _CACHE_LOCK:
        found = _BY_CONTENT.get(digest)
        if found is not None:
            return found
    index = EdgeIndex.build(arr.copy())
    with _CACHE_LOCK:
        while len(_BY_CONTENT) >= _CONTENT_ENTRIES:
            del _BY_CONTENT[next(iter(_BY_CONTENT))]
        _BY_CONTENT[digest] = index
    return index
