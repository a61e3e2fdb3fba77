"""Occupancy grids and their exact polygonisation into a `Map`.

An `OccupancyGrid` holds which cells are free, row 0 at the bottom (``free[j, i]``: column ``i``,
row ``j``, world y growing with ``j``), the cell size and the world position of the grid's
lower-left corner. `grid_to_map` turns it into the polygonal map every other part of the toolkit
uses, exactly: the free space is the union of the free cells (shapely's ``unary_union`` of the
free cells merged into row runs, then collinear vertices dropped by a zero-tolerance simplify).
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
from .maps import GridSpec, Map, Region

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


def polygonise(grid: OccupancyGrid, simplify_cm: float = 0.0) -> list[shapely.Polygon]:
    """The free space of `grid` as polygons with holes, one per 4-connected region, largest first.

    Exteriors are counter-clockwise and holes clockwise; collinear vertices are merged. With
    ``simplify_cm > 0`` the outlines are simplified and clipped to the exact free space, so the
    result is a subset of it (obstacles only grow).
    """
    free = np.asarray(grid.free, dtype=bool)
    if free.ndim != 2:
        raise MapError(f"occupancy grid must be 2-D, got shape {free.shape}")
    c = float(grid.cell_cm)
    x0, y0 = grid.origin
    # free runs of each row as boxes: far fewer than cells, and unary_union merges them exactly
    padded = np.zeros((free.shape[0], free.shape[1] + 2), dtype=np.int8)
    padded[:, 1:-1] = free
    d = np.diff(padded, axis=1)
    rs, cs = np.nonzero(d == 1)
    re, ce = np.nonzero(d == -1)
    if not len(rs):
        return []
    order_s, order_e = np.lexsort((cs, rs)), np.lexsort((ce, re))
    rows, c_start, c_end = rs[order_s], cs[order_s], ce[order_e]
    boxes = shapely.box(x0 + c * c_start, y0 + c * rows, x0 + c * c_end, y0 + c * (rows + 1))
    union = shapely.unary_union(boxes)
    if simplify_cm > 0:
        union = shapely.intersection(shapely.simplify(union, float(simplify_cm)), union)
    parts = [g for g in shapely.get_parts(union) if isinstance(g, shapely.Polygon) and g.area > 0]
    parts = [shapely_polygon.orient(shapely.simplify(p, 0.0), 1.0) for p in parts]
    parts.sort(key=lambda p: -p.area)
    return parts


def grid_to_map(grid: OccupancyGrid, name: str, description: str = "", simplify_cm: float = 0.0,
                start: NDArray[np.float64] | None = None, target: NDArray[np.float64] | None = None) -> Map:
    """A `Map` whose free space is exactly the free cells of `grid` (see the module docstring)."""
    from .maps import map_from_dict

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
