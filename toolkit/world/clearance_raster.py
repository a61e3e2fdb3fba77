"""A raster of certain answers for disc checks: most points and segments decided by a byte lookup.

`CollisionChecker` decides a disc of radius r exactly by visiting the walls near it
(`toolkit.world.edge_index`). On a dense map (a wall every few centimetres) a free disc has many
walls within reach, and each must be tested. This raster answers most queries without any wall:

* the map's bounds are cut into square cells of side ``s`` (an eighth of the radius, coarser on
  huge maps, see `ClearanceRaster.layout`); each cell's centre c gets its exact wall distance class;
* a point p in the cell lies within ``rho = s * sqrt(2) / 2 + eps`` of c (eps covers rounding in
  finding the cell), so its distance to the nearest wall is within rho of c's: when every wall is
  at least ``r + rho`` from c, every disc centred in the cell is clear, and inside or outside the
  free area as c is (no wall lies between them): the cell is ``FREE`` or ``BLOCKED``; when some
  wall is closer than ``r - rho`` to c, every disc centred in the cell touches it: ``BLOCKED``;
  otherwise the cell is in the band: when c lies inside, at least 0.75 r from the walls, the byte
  holds c's wall distance (quantised to 1/126 of rho), and a point query there uses its own
  distance to c instead of rho (the wall distance is 1-Lipschitz), which decides about half of
  the band's points; the rest are ``UNKNOWN``, and the exact test decides;
* a point beyond the raster (which covers the map's bounds) lies outside the free area, and a
  segment with an end there crosses a wall: ``BLOCKED``;
* a segment walks the cells it passes through (a 4-connected staircase from its start cell to
  its end cell): a ``BLOCKED`` cell on the way means a collision, all cells ``FREE`` mean a free
  motion, anything else goes to the exact test. Near a cell corner rounding may pick the
  neighbouring cell, which lies within eps of the segment, so the bounds still hold.

Every answer given here is the exact test's answer (the tests compare both on random queries); the
raster only removes work. Segments treat band cells as ``UNKNOWN``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from .arrays import FloatArray

__all__ = ["BLOCKED", "FREE", "UNKNOWN", "ClearanceRaster"]

BLOCKED, FREE, UNKNOWN = 0, 1, 2
"""Cell states: every disc centred in the cell collides / is free / undecided here."""
_BAND = 3
"""Codes _BAND ... 255 of a cell in the band: inside, its centre's wall distance quantised (see `build`)."""
_LEVELS = 255 - _BAND

_MAX_CELLS = 16_000_000
"""Largest raster (cells, one byte each); a larger map gets coarser cells."""

_jit = numba.njit(cache=True, nogil=True)


@_jit
def _outside(fx: float, fy: float) -> int:
    """State of a point beyond the raster, which covers the map's bounds: outside the free area, so
    BLOCKED (a segment to it crosses a wall); UNKNOWN for a coordinate that is not a number."""
    return BLOCKED if math.isfinite(fx) and math.isfinite(fy) else UNKNOWN


@_jit
def _points_state(state: NDArray[np.uint8], x0: float, y0: float, s: float, nx: int, ny: int,
                  band_lo: float, band_step: float, radius: float, tol: float,
                  pts: FloatArray, out: NDArray[np.uint8]) -> None:
    """out[k] = state of the disc at point k: its cell's, or for a band cell decided from the centre's
    distance and the point's own distance to the centre."""
    for k in range(pts.shape[0]):
        fx, fy = (pts[k, 0] - x0) / s, (pts[k, 1] - y0) / s
        if not (0.0 <= fx < nx and 0.0 <= fy < ny):
            out[k] = _outside(fx, fy)
            continue
        i, j = int(fx), int(fy)
        c = state[i * ny + j]
        if c < _BAND:
            out[k] = c
            continue
        # the wall distance d of the point is within |p - centre| of the centre's
        off = math.hypot(pts[k, 0] - (x0 + (i + 0.5) * s), pts[k, 1] - (y0 + (j + 0.5) * s))
        d_lo = band_lo + (c - _BAND) * band_step
        if d_lo - off - tol >= radius:
            out[k] = FREE
        elif d_lo + band_step + off + tol < radius:
            out[k] = BLOCKED
        else:
            out[k] = UNKNOWN


@_jit
def _segments_state(state: NDArray[np.uint8], x0: float, y0: float, s: float, nx: int, ny: int,
                    a: FloatArray, b: FloatArray, out: NDArray[np.uint8]) -> None:
    """out[k] = BLOCKED if a cell on segment k's staircase is, FREE if all are, else UNKNOWN."""
    for k in range(a.shape[0]):
        ax, ay, bx, by = a[k, 0], a[k, 1], b[k, 0], b[k, 1]
        fax, fay, fbx, fby = (ax - x0) / s, (ay - y0) / s, (bx - x0) / s, (by - y0) / s
        if not (0.0 <= fax < nx and 0.0 <= fay < ny):
            out[k] = _outside(fax, fay)
            continue
        if not (0.0 <= fbx < nx and 0.0 <= fby < ny):
            out[k] = _outside(fbx, fby)
            continue
        i, j = int(fax), int(fay)
        ib, jb = int(fbx), int(fby)
        di, dj = ib - i, jb - j
        si = 1 if di > 0 else -1
        sj = 1 if dj > 0 else -1
        ni, nj = abs(di), abs(dj)
        dx, dy = fbx - fax, fby - fay
        # parameter (0..1 along the segment) of the next vertical / horizontal cell line
        tx = ((i + (1 if si > 0 else 0)) - fax) / dx if ni > 0 else np.inf
        ty = ((j + (1 if sj > 0 else 0)) - fay) / dy if nj > 0 else np.inf
        dtx = 1.0 / abs(dx) if ni > 0 else np.inf
        dty = 1.0 / abs(dy) if nj > 0 else np.inf
        verdict = state[i * ny + j]
        if verdict > FREE:
            verdict = UNKNOWN
        while verdict != BLOCKED and (ni > 0 or nj > 0):
            if nj == 0 or (ni > 0 and tx < ty):
                i += si
                ni -= 1
                tx += dtx
            else:
                j += sj
                nj -= 1
                ty += dty
            c = state[i * ny + j]
            if c == BLOCKED:
                verdict = BLOCKED
            elif c != FREE:
                verdict = UNKNOWN
        out[k] = verdict


@dataclass(frozen=True, eq=False)
class ClearanceRaster:
    """Per cell of a square raster over the map, whether every disc centred there is free or collides.

    Attributes
    ----------
    origin : (2,) ndarray
        Lower-left corner (cm).
    cell : float
        Side of a cell (cm).
    shape : (nx, ny)
        Cells along x and y.
    state : uint8 ndarray
        Cell ``i * ny + j``: `BLOCKED`, `FREE` or `UNKNOWN`.
    """

    origin: FloatArray
    cell: float
    shape: tuple[int, int]
    state: NDArray[np.uint8]
    radius: float = 0.0
    band_lo: float = 0.0
    band_step: float = 0.0

    @classmethod
    def build(cls, bounds: tuple[float, float, float, float], radius: float,
              clear: Callable[[FloatArray, float], NDArray[np.bool_]],
              inside_if_clear: Callable[[FloatArray], NDArray[np.bool_]],
              distance: Callable[[FloatArray], FloatArray] | None = None,
              max_cells: int = _MAX_CELLS) -> ClearanceRaster:
        """The raster of a disc of `radius` cm over `bounds` (xmin, ymin, xmax, ymax).

        `clear(points, d)` tells exactly whether no wall is closer than d cm to each point;
        `inside_if_clear(points)` whether points at least 0.75 `radius` from every wall lie in the
        free area; `distance(points)` their exact distance to the nearest wall. With `distance`,
        the cells of the band (centre within rho of distance r) keep that distance, quantised to
        1/126 of rho, so that a point query there decides with its own distance to the centre
        instead of the cell's half-diagonal (about half of the band's points).
        """
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        w, h = max(xmax - xmin, 1e-9), max(ymax - ymin, 1e-9)
        s, (nx, ny) = cls.layout(bounds, radius, max_cells)
        gx, gy = np.meshgrid(xmin + (np.arange(nx) + 0.5) * s, ymin + (np.arange(ny) + 0.5) * s, indexing="ij")
        centres = np.column_stack([gx.ravel(), gy.ravel()])
        # rounding margin: finding a point's cell may err by far less than this (relative 1e-6)
        rho = s * math.sqrt(0.5) + 1e-6 * (s + abs(xmin) + abs(ymin) + w + h)
        state = np.full(len(centres), UNKNOWN, dtype=np.uint8)
        far = np.flatnonzero(clear(centres, radius + rho))
        state[far] = np.where(inside_if_clear(centres[far]), FREE, BLOCKED)
        if radius - rho > 0:
            rest = np.flatnonzero(state == UNKNOWN)
            state[rest[~clear(centres[rest], radius - rho)]] = BLOCKED
        band_lo, band_step = radius - rho, 2.0 * rho / _LEVELS
        if distance is not None and radius - rho >= 0.75 * radius:
            band = np.flatnonzero(state == UNKNOWN)
            d = distance(centres[band])
            keep = d >= 0.75 * radius  # so that inside_if_clear holds (and the centre is a point's side)
            keep[keep] = inside_if_clear(centres[band[keep]])
            # level k holds distances in [band_lo + k step, band_lo + (k + 1) step) (up to rounding)
            code = np.clip(np.floor((d[keep] - band_lo) / band_step), 0, _LEVELS - 1)
            state[band[keep]] = (_BAND + code).astype(np.uint8)
        return cls(np.array([xmin, ymin]), s, (nx, ny), state, radius, band_lo, band_step)

    @staticmethod
    def layout(bounds: tuple[float, float, float, float], radius: float,
               max_cells: int = _MAX_CELLS) -> tuple[float, tuple[int, int]]:
        """Cell side (cm) and shape of the raster `build` makes: an eighth of the radius, or coarser
        so that it has at most `max_cells` cells."""
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        w, h = max(xmax - xmin, 1e-9), max(ymax - ymin, 1e-9)
        s = max(radius / 8.0, math.sqrt(w * h / max_cells))
        nx, ny = math.ceil(w / s) + 1, math.ceil(h / s) + 1
        while nx * ny > max_cells:
            s *= 1.05
            nx, ny = math.ceil(w / s) + 1, math.ceil(h / s) + 1
        return s, (nx, ny)

    @property
    def nbytes(self) -> int:
        """Memory of the raster (bytes)."""
        return int(self.state.nbytes)

    def points(self, pts: FloatArray) -> NDArray[np.uint8]:
        """State of the disc centred at each point of an (n, 2) array."""
        out = np.empty(len(pts), dtype=np.uint8)
        _points_state(self.state, float(self.origin[0]), float(self.origin[1]), self.cell, self.shape[0],
                      self.shape[1], self.band_lo, self.band_step, self.radius, 1e-9 * (self.radius + self.cell),
                      np.ascontiguousarray(pts, dtype=np.float64), out)
        return out

    def segments(self, a: FloatArray, b: FloatArray) -> NDArray[np.uint8]:
        """State of the disc swept along each segment a[k] -> b[k] ((n, 2) arrays)."""
        out = np.empty(len(a), dtype=np.uint8)
        _segments_state(self.state, float(self.origin[0]), float(self.origin[1]), self.cell, self.shape[0],
                        self.shape[1], np.ascontiguousarray(a, dtype=np.float64),
                        np.ascontiguousarray(b, dtype=np.float64), out)
        return out
