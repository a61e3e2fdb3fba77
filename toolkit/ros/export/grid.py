"""A map rasterised as an occupancy grid (the cells of ``nav_msgs/OccupancyGrid``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from ...world import ConfigError, Map

__all__ = ["FREE", "OCCUPIED", "UNKNOWN", "OccupancyGrid", "rasterise"]

FREE, OCCUPIED, UNKNOWN = 0, 100, -1
MAX_CELLS = 50_000_000


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """Cells (height, width) of int8, row 0 at the bottom (y grows with the row, as ROS stores it).

    Attributes
    ----------
    cells : (height, width) int8 ndarray
        `OCCUPIED` (100) where a wall crosses the cell, `FREE` (0) where the cell's centre is in the
        free area, `UNKNOWN` (-1) elsewhere (outside the boundary, inside obstacles).
    resolution_cm : float
        Side of a cell (cm).
    origin_cm : (x, y)
        Map coordinates of the lower-left corner of cell (0, 0) (cm).
    """

    cells: NDArray[np.int8]
    resolution_cm: float
    origin_cm: tuple[float, float]

    def centres(self) -> NDArray[np.float64]:
        """(height, width, 2) map coordinates of the cells' centres (cm)."""
        h, w = self.cells.shape
        x = self.origin_cm[0] + (np.arange(w) + 0.5) * self.resolution_cm
        y = self.origin_cm[1] + (np.arange(h) + 0.5) * self.resolution_cm
        return np.stack(np.meshgrid(x, y), axis=-1)


def rasterise(m: Map, resolution_cm: float) -> OccupancyGrid:
    """`m` as an `OccupancyGrid` of `resolution_cm` cells, one cell of margin around the boundary.

    A cell is occupied when a wall segment meets its square (exactly, by shapely); a cell no wall
    meets is free when its centre lies in the free area (`Map.contains`), unknown otherwise.
    """
    res = float(resolution_cm)
    if not (math.isfinite(res) and res > 0):
        raise ConfigError(f"grid cell size must be a positive number of cm, got {resolution_cm!r}")
    xmin, ymin, xmax, ymax = m.bounds
    x0, y0 = xmin - res, ymin - res
    w = math.ceil((xmax - xmin) / res) + 2
    h = math.ceil((ymax - ymin) / res) + 2
    if w * h > MAX_CELLS:
        raise ConfigError(f"a {res:g} cm grid of map {m.name} would have {w * h:,} cells (more than "
                          f"{MAX_CELLS:,}); choose larger cells")
    grid = OccupancyGrid(np.full((h, w), UNKNOWN, dtype=np.int8), res, (x0, y0))
    c = grid.centres().reshape(-1, 2)
    near = np.flatnonzero(np.asarray(m.wall_distance(c)) <= res * math.sqrt(0.5) + 1e-9)
    lo = c[near] - 0.5 * res
    boxes = shapely.box(lo[:, 0], lo[:, 1], lo[:, 0] + res, lo[:, 1] + res)
    walls = shapely.multilinestrings(np.asarray(m.walls).reshape(-1, 2, 2))
    hit = near[shapely.intersects(boxes, walls)]
    flat = grid.cells.reshape(-1)
    flat[np.asarray(m.contains(c), dtype=bool)] = FREE
    flat[hit] = OCCUPIED
    return grid
