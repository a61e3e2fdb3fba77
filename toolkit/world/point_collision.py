"""Collision checks for a point robot (radius 0), and `make_checker`, the one way to get a checker.

A point robot may touch walls: a position is free when it lies in the closed free space, a straight
motion when the whole segment does and it passes through no pinch point of the map (a corner where
the free space touches itself, such as two blocked grid cells meeting diagonally). This is the rule
of the published grid benchmarks, whose optimal paths run along walls and round obstacle corners.
FCL's contact test cannot express it (touching is contact there), so the point checker decides with
exact predicates instead:

- on a map imported from a grid (``map.grid``), by walking the segment through the cells (a
  compiled kernel, `toolkit.world.grid_kernel`), whose cost does not grow with the number of walls;
- on any other map, with shapely's ``covers`` against the free polygon and a test against the
  pinch points.

The two agree (the tests compare them on random segments of grid maps).

Thin walls (`Map.thin_walls`) are not part of the closed free space: a position on one is not free,
and neither is a motion that crosses or touches one (exact predicates against the thin walls'
segments, `Map.on_thin_wall` and `Map.meets_thin_wall`, after either test above).
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .collision import CollisionChecker, segment_arrays
from .errors import MapError
from .grid_kernel import grid_pinches, grid_points_free, grid_segments_free
from .maps import Map

__all__ = ["CHECKER_BACKENDS", "PointCollisionChecker", "make_checker"]


CHECKER_BACKENDS = ("index", "fcl")


def make_checker(map: Map, robot_radius: float, backend: str = "index") -> CollisionChecker:
    """The checker for a disc of `robot_radius` cm, or the exact point checker for radius 0.

    `backend` picks the disc checker: ``"index"`` (default: exact distances over a uniform grid of
    the walls, compiled) or ``"fcl"`` (python-fcl's BVH, the reference it is tested against). A
    point robot has one checker whatever the backend (FCL cannot express touching a wall); every
    checker's ``backend`` attribute says which one answers.
    """
    if backend not in CHECKER_BACKENDS:
        raise MapError(f"unknown collision backend {backend!r}; known: {', '.join(CHECKER_BACKENDS)}")
    if robot_radius == 0:
        return PointCollisionChecker(map)
    if backend == "fcl":
        from .fcl_collision import FclCollisionChecker

        return FclCollisionChecker(map, robot_radius)
    return CollisionChecker(map, robot_radius)


class PointCollisionChecker(CollisionChecker):
    """Exact checks of a point robot in `map` (radius 0; touching walls is allowed, touching a thin wall is not).

    The interface is `CollisionChecker`'s; ``clearance`` is the distance to the nearest wall.

    Examples
    --------
    >>> from toolkit.world import load_map
    >>> cc = PointCollisionChecker(load_map("map1"))
    >>> cc.point_free([0, 0]), cc.segment_free([0, 0], [60, 0]), cc.segment_free([50, 40], [50, 50])
    (True, True, False)
    """

    backend = "point"

    def __init__(self, map: Map, use_grid: bool = True) -> None:
        self.map = map
        self.robot_radius = 0.0
        self.use_grid = bool(use_grid) and map.grid is not None
        self.point_checks = 0
        self.segment_checks = 0
        if self.use_grid and not self._grid_is_exact():
            self.use_grid = False  # a simplified outline: the cells no longer describe the free space
        if not self.use_grid:
            shapely.prepare(map.polygon)

    def _grid_is_exact(self) -> bool:
        """Whether the free space is exactly the union of the free cells (not so after ``--simplify``)."""
        g = self.map.grid
        assert g is not None
        area = float(self.map.polygon.area)
        return abs(area - float(self.cells.sum()) * g.cell_cm ** 2) <= 1e-9 * max(area, 1.0)

    @cached_property
    def cells(self) -> NDArray[np.bool_]:
        """Free cells of the map's grid, ``[j, i]`` with row 0 at the bottom (from the polygons, exactly)."""
        g = self.map.grid
        assert g is not None
        c = g.centres().reshape(-1, 2)
        return np.asarray(shapely.contains_xy(self.map.polygon, c[:, 0], c[:, 1]), dtype=bool).reshape(g.height,
                                                                                                          g.width)

    @cached_property
    def _pinch_grid(self) -> NDArray[np.bool_]:
        return grid_pinches(self.cells)

    @cached_property
    def _pinch_tree(self) -> shapely.STRtree:
        return shapely.STRtree(shapely.points(self.map.pinch_points))

    def _to_cells(self, p: NDArray[np.float64]) -> NDArray[np.float64]:
        g = self.map.grid
        assert g is not None
        return (p - np.asarray(g.origin)) / g.cell_cm

    def point_free(self, xy: ArrayLike) -> Any:
        """Whether `xy` lies in the closed free space. (2,) -> bool; (n, 2) -> (n,) bool array."""
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        if self.use_grid:
            out = grid_points_free(self.cells, self._to_cells(pts))
        else:
            out = np.asarray(shapely.intersects_xy(self.map.polygon, pts[:, 0], pts[:, 1]), dtype=bool)
        if self.map.thin_walls and out.any():
            out[out] = ~np.asarray(self.map.on_thin_wall(pts[out]), dtype=bool)
        self.point_checks += len(pts)
        return bool(out[0]) if p.ndim == 1 else out

    def segments_free(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        """Whether each segment ``a[k] -> b[k]`` lies in the closed free space, passes no pinch point and
        meets no thin wall."""
        pa, pb = segment_arrays(a, b)
        self.segment_checks += len(pa)
        if not len(pa):
            return np.zeros(0, dtype=bool)
        if self.use_grid:
            out = grid_segments_free(self.cells, self._pinch_grid, self._to_cells(pa), self._to_cells(pb))
        else:
            lines = shapely.linestrings(np.stack([pa, pb], axis=1))
            out = np.asarray(shapely.covers(self.map.polygon, lines), dtype=bool)
            if len(self.map.pinch_points) and out.any():
                seg, pin = self._pinch_tree.query(lines, predicate="intersects")
                pts = self.map.pinch_points[pin]
                at_end = np.all(pts == pa[seg], axis=1) | np.all(pts == pb[seg], axis=1)
                out[seg[~at_end]] = False
        if self.map.thin_walls and out.any():
            out[out] = ~self.map.meets_thin_wall(pa[out], pb[out])
        return out

    def clearance(self, xy: ArrayLike) -> Any:
        """Distance (cm) to the nearest wall for points in the free space, ``-inf`` outside."""
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        inside = np.asarray(self.point_free(pts), dtype=bool)
        out = np.full(len(pts), -np.inf)
        if inside.any():
            out[inside] = self.map.wall_distance(pts[inside])
        return float(out[0]) if p.ndim == 1 else out
