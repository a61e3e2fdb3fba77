"""Occupancy grids and their exact polygonisation into a `Map`.

An `OccupancyGrid` holds which cells are free, row 0 at the bottom (``free[j, i]``: column ``i``,
row ``j``, world y growing with ``j``), the cell size and the world position of the grid's
lower-left corner. `grid_to_map` turns it into the polygonal map every other part of the toolkit
uses, exactly: the free space is the union of the free cells (faces built by shapely's
``polygonize`` from the free/blocked boundary, collinear vertices dropped by a zero-tolerance
simplify).
Free cells joined only at a corner (two blocked cells meeting diagonally) are not joined: each
4-connected group of free cells is one region, and the shared corner is a pinch point of the map,
which no motion may pass.

``simplify_cm`` trades exactness for fewer edges in one direction only: the simplified free space
is intersected with the exact one, so obstacles may grow by up to that many cm and never shrink.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import polygon as shapely_polygon

from .errors import MapError
from .map_model import GridSpec, Map, Region
from .map_parsing import map_from_dict

__all__ = ["OccupancyGrid", "grid_to_map", "polygonise"]


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """Free cells of a grid map.

    Attributes
    ----------
    free : (height, width) bool ndarray
        ``free[j, i]``: cell in column ``i`` and row ``j``, row 0 at the bottom (smallest y).
    cell_cm : float
        Side of a cell (cm).
    origin : (float, float)
        World position (cm) of the lower-left corner of cell (0, 0).
    """

    free: NDArray[np.bool_]
    cell_cm: float = 1.0
    origin: tuple[float, float] = (0.0, 0.0)

    @property
    def spec(self) -> GridSpec:
        h, w = self.free.shape
        return GridSpec(float(self.cell_cm), (float(self.origin[0]), float(self.origin[1])), int(w), int(h))


def _runs(edges: NDArray[np.bool_], splits: NDArray[np.bool_]) -> tuple[NDArray[np.intp], ...]:
    """Maximal runs of unit edges along each grid line, split at the given lattice points.

    ``edges[l, k]``: the unit edge from lattice point k to k + 1 on line l; ``splits[l, k]``:
    lattice point k of line l ends every run through it. Returns (line, first point, last point).
    """
    pad = np.zeros((edges.shape[0], edges.shape[1] + 2), dtype=np.int8)
    pad[:, 1:-1] = edges
    d = np.diff(pad, axis=1)
    starts, ends = d[:, :-1] == 1, d[:, 1:] == -1
    cut = splits[:, 1:-1] & edges[:, :-1] & edges[:, 1:]  # inner points where a run would pass a pinch
    starts[:, 1:] |= cut
    ends[:, :-1] |= cut
    line, first = np.nonzero(starts)
    _, last = np.nonzero(ends)
    return line, first, last + 1


def polygonise(grid: OccupancyGrid, simplify_cm: float = 0.0) -> list[shapely.Polygon]:
    """The free space of `grid` as polygons with holes, one per 4-connected region, largest first.

    The boundary between free and blocked cells is collected as maximal straight runs along the
    grid lines (split where two blocked cells meet diagonally, so that the lines only meet at their
    ends) and shapely's ``polygonize`` (GEOS) builds the faces they bound; the faces whose interior
    lies in a free cell are the free regions. This is exact, and measured 2-3 times faster than the
    ``unary_union`` of the free cells' row runs on AcrosstheCape and 20 times on a 512 x 512 grid of
    random blocks. Exteriors are counter-clockwise and holes clockwise, with no collinear vertices. With
    ``simplify_cm > 0`` the outlines are simplified and clipped to the exact free space, so the result
    is a subset of it (obstacles only grow).
    """
    free = np.asarray(grid.free, dtype=bool)
    if free.ndim != 2:
        raise MapError(f"occupancy grid must be 2-D, got shape {free.shape}")
    if not free.any():
        return []
    h, w = free.shape
    f = np.zeros((h + 2, w + 2), dtype=bool)
    f[1:-1, 1:-1] = free  # the outside counts as blocked
    sw, se, nw, ne = f[:-1, :-1], f[:-1, 1:], f[1:, :-1], f[1:, 1:]  # cells around lattice point [j, i]
    pinch = (sw & ne & ~se & ~nw) | (se & nw & ~sw & ~ne)
    horizontal = f[:-1, 1:-1] != f[1:, 1:-1]  # [j, i]: edge y = j, x in [i, i + 1]
    vertical = (f[1:-1, :-1] != f[1:-1, 1:]).T  # [i, j]: edge x = i, y in [j, j + 1]
    hy, hx0, hx1 = _runs(horizontal, pinch)
    vx, vy0, vy1 = _runs(vertical, pinch.T)
    ends = np.concatenate([np.stack([np.column_stack([hx0, hy]), np.column_stack([hx1, hy])], axis=1),
                           np.stack([np.column_stack([vx, vy0]), np.column_stack([vx, vy1])], axis=1)])
    c = float(grid.cell_cm)
    lines = shapely.linestrings(np.asarray(grid.origin) + c * ends.astype(np.float64))
    faces = shapely.get_parts(shapely.polygonize(lines))
    inner = (shapely.get_coordinates(shapely.point_on_surface(faces)) - np.asarray(grid.origin)) / c
    is_free = free[np.floor(inner[:, 1]).astype(int), np.floor(inner[:, 0]).astype(int)]
    parts = list(faces[is_free])
    if simplify_cm > 0:
        exact = shapely.union_all(parts)
        clipped = shapely.intersection(shapely.simplify(exact, float(simplify_cm)), exact)
        parts = [g for g in shapely.get_parts(clipped) if isinstance(g, shapely.Polygon) and g.area > 0]
    parts = [shapely_polygon.orient(shapely.simplify(p, 0.0), 1.0) for p in parts]
    parts.sort(key=lambda p: -p.area)
    return parts


def grid_to_map(grid: OccupancyGrid, name: str, description: str = "", simplify_cm: float = 0.0,
                start: NDArray[np.float64] | None = None, target: NDArray[np.float64] | None = None) -> Map:
    """A `Map` whose free space is exactly the free cells of `grid` (see the module docstring)."""
    parts = polygonise(grid, simplify_cm)
    if not parts:
        raise MapError(f"map {name!r}: the grid has no free cell")
    regions = [Region(np.asarray(p.exterior.coords)[:-1], tuple(np.asarray(h.coords)[:-1] for h in p.interiors))
               for p in parts]
    data: dict[str, object] = {"name": name, "description": description, "regions": [r.to_dict() for r in regions],
            "grid": grid.spec.to_dict()}
    if start is not None:
        data["start"] = [float(v) for v in start]
    if target is not None:
        data["target"] = [float(v) for v in target]
    return map_from_dict(data, default_name=name)
