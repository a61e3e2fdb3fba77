"""The likelihood field's distance transform: distance from any point to the nearest wall, at a cost
independent of the number of walls (used by `amcl`'s ``model=field``)."""

from __future__ import annotations

import math

import numpy as np

from toolkit.world import ConfigError, Map
from toolkit.world.arrays import FloatArray

__all__ = ["DistanceField"]


class DistanceField:
    """Distance (cm) from any point to the nearest wall: exact at the nodes of a square grid, bilinear between.

    Built once per map from the exact wall distance of every node (`Map.wall_distance`, indexed);
    a lookup is four array reads per point, independent of the number of walls. Distances are capped
    at `max_dist_cm`.

    Parameters
    ----------
    map : Map
    resolution_cm : float
        Node spacing (cm).
    max_dist_cm : float
        Cap on the distance (nav2's ``laser_likelihood_max_dist``, here in cm).
    """

    def __init__(self, map: Map, resolution_cm: float = 0.5, max_dist_cm: float = 20.0) -> None:
        if not (resolution_cm > 0 and math.isfinite(resolution_cm)):
            raise ConfigError(f"field resolution must be a positive number of cm, got {resolution_cm!r}")
        xmin, ymin, xmax, ymax = map.bounds
        self.resolution_cm = float(resolution_cm)
        self.max_dist_cm = float(max_dist_cm)
        self.origin = np.array([xmin, ymin], dtype=float)
        nx = math.ceil((xmax - xmin) / resolution_cm) + 1
        ny = math.ceil((ymax - ymin) / resolution_cm) + 1
        gx, gy = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
        nodes = self.origin + np.column_stack([gx.ravel(), gy.ravel()]) * resolution_cm
        dist = np.asarray(map.wall_distance(nodes), dtype=float)  # exact, over the walls' grid index
        self.grid = np.minimum(dist, self.max_dist_cm).reshape(nx, ny)

    def __call__(self, xy: FloatArray) -> FloatArray:
        """Distances (cm) of points `xy` (..., 2) to the nearest wall, capped at `max_dist_cm`; a point
        outside the grid reads the nearest grid point's distance plus its distance to the grid."""
        g = (np.asarray(xy, dtype=float) - self.origin) / self.resolution_cm
        nx, ny = self.grid.shape
        gx = np.clip(g[..., 0], 0.0, nx - 1.000001)
        gy = np.clip(g[..., 1], 0.0, ny - 1.000001)
        outside = np.hypot(g[..., 0] - gx, g[..., 1] - gy) * self.resolution_cm
        ix, iy = gx.astype(np.int64), gy.astype(np.int64)
        fx, fy = gx - ix, gy - iy
        d = self.grid
        val = ((d[ix, iy] * (1 - fx) + d[ix + 1, iy] * fx) * (1 - fy)
               + (d[ix, iy + 1] * (1 - fx) + d[ix + 1, iy + 1] * fx) * fy)
        return np.minimum(val + outside, self.max_dist_cm)
