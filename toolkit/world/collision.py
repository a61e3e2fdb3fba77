"""The one collision checker every planner shares: a disc robot against the walls, exact and indexed.

A disc of radius r at a point is free when the point lies inside the free area and no wall is closer
than r; a straight motion from a to b is free when a is inside and no wall is closer than r to the
segment ab (the disc swept along the segment: exact, no discretisation, no tunnelling; a segment
that keeps r > 0 from every wall cannot cross one, so the whole motion stays inside). The
distances are exact planar point-segment and segment-segment distances, computed by a compiled
kernel that visits only the walls listed in the grid cells near the query
(`toolkit.world.edge_index`), so a check costs about the same on a room of 8 walls and on a
building of 100,000. The walls are `Map.walls`: the edges of the free area's polygons and the
segments of its thin walls (zero thickness, `Map.thin_walls`) alike, so a disc keeps r from a thin
wall and a motion that crosses one is never free.

Most checks never reach the walls: a byte raster of cells an eighth of the radius wide
(`toolkit.world.clearance_raster`, built once the checker has been asked enough to pay for it)
knows for most cells that every disc centred there is free, or that every one collides; a
segment walks its cells. The rest (discs within a cell's reach of touching a wall) take the exact
test, and the raster's own answers are exact too, so the checker's answers are unchanged.

Inside-ness of a disc already clear of every wall is read from a raster of sample points spaced
at most the radius apart, each classified once by shapely: the disc holds no wall, so it lies
wholly inside or wholly outside, and the sample nearest its centre (closer than 0.71 radius) lies
in it. So the raster answer is exact, not an approximation. (Maps too large for a raster of 16
million samples fall back to shapely's point-in-polygon test, as do the other queries.)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray

from .clearance_raster import FREE, UNKNOWN, ClearanceRaster
from .edge_index import EdgeIndex, edge_index
from .errors import ConfigError, MapError
from .maps import Map

__all__ = ["CollisionChecker"]

_MAX_SAMPLES = 16_000_000


def segment_arrays(a: ArrayLike, b: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Segment starts and ends as (n, 2) float arrays of the same shape (every checker's batch input)."""
    pa = np.asarray(a, dtype=float).reshape(-1, 2)
    pb = np.asarray(b, dtype=float).reshape(-1, 2)
    if pa.shape != pb.shape:
        raise ConfigError(f"segment starts {pa.shape} and ends {pb.shape} differ in shape")
    return pa, pb


class CollisionChecker:
    """Exact collision checks of a disc robot of `robot_radius` cm in `map` (see the module docstring).

    Parameters
    ----------
    map : Map
        The map; its walls (boundary, obstacles and thin walls) are the obstacles.
    robot_radius : float
        Radius of the robot disc in cm (> 0). A disc at distance < radius from a wall collides.

    Attributes
    ----------
    point_checks, segment_checks : int
        Number of single point / segment checks made (batch calls count each element).
    backend : str
        How the checks are made: ``"index"`` here (``"fcl"``, ``"point"`` for the other checkers);
        result files record it.

    Examples
    --------
    >>> from toolkit.world import load_map
    >>> cc = CollisionChecker(load_map("map1"), 8.0)
    >>> cc.point_free([20, 20]), cc.point_free([3, 3])
    (True, False)
    """

    backend = "index"

    def __init__(self, map: Map, robot_radius: float) -> None:
        r = float(robot_radius)
        if not math.isfinite(r) or r <= 0:
            raise MapError(f"robot_radius must be a positive finite number of cm, got {robot_radius!r}")
        self.map = map
        self.robot_radius = r
        self.index: EdgeIndex = edge_index(map.walls)
        shapely.prepare(map.polygon)
        xmin, ymin, xmax, ymax = map.bounds
        self._lo = np.array([xmin, ymin])
        self._hi = np.array([xmax, ymax])
        self._step = r
        shape = (int((xmax - xmin) / r) + 2, int((ymax - ymin) / r) + 2)
        self._raster: NDArray[np.bool_] | None = None
        if shape[0] * shape[1] <= _MAX_SAMPLES:
            gx, gy = np.meshgrid(xmin + r * np.arange(shape[0]), ymin + r * np.arange(shape[1]), indexing="ij")
            self._raster = np.asarray(shapely.contains_xy(map.polygon, gx, gy), dtype=bool)
        self.point_checks = 0
        self.segment_checks = 0
        self._regions: list[shapely.Polygon] | None = None
        self._clearance: ClearanceRaster | None = None

    @property
    def clearance_raster(self) -> ClearanceRaster:
        """The raster of certain answers (`toolkit.world.clearance_raster`), built on first access."""
        if self._clearance is None:
            self._clearance = ClearanceRaster.build(
                self.map.bounds, self.robot_radius, lambda p, d: self.index.capsules_clear(p, p, d),
                self._clear_inside, self.index.nearest_distance)
        return self._clearance

    def _decided(self, n: int) -> ClearanceRaster | None:
        """The raster once the checks made (with `n` more) pay for building it: about one check per
        eight of its cells (building costs about two exact checks per cell, a check it decides far
        less than one); None before, so a checker asked a few questions stays cheap."""
        if self._clearance is None:
            cells = np.prod(ClearanceRaster.layout(self.map.bounds, self.robot_radius)[1])
            if 8 * (self.checks + n) < cells:
                return None
        return self.clearance_raster

    # -- counters -------------------------------------------------------------------------------
    @property
    def checks(self) -> int:
        """Total checks made (points + segments)."""
        return self.point_checks + self.segment_checks

    def reset_counters(self) -> None:
        """Set the check counters to zero."""
        self.point_checks = 0
        self.segment_checks = 0

    # -- connectivity ---------------------------------------------------------------------------
    def free_regions(self) -> list[shapely.Polygon]:
        """The connected pieces of the configuration space (the free area shrunk by the robot radius).

        Computed once per checker. The arcs of the shrunk area are drawn as chords that lie slightly
        outside the exact arcs, so each piece holds every free position of its exact piece; pieces
        that are apart here are apart in truth.
        """
        regions: list[shapely.Polygon] | None = getattr(self, "_regions", None)  # subclasses may skip __init__
        if regions is None:
            space = self.map.free_space(self.robot_radius)
            regions = [g for g in getattr(space, "geoms", [space]) if not g.is_empty]
            self._regions = regions
        return regions

    def connected(self, a: ArrayLike, b: ArrayLike) -> bool:
        """False when free positions `a` and `b` (cm) lie in different pieces of the configuration space,
        so that no collision-free path can join them; True otherwise (also when undecided)."""
        if self.robot_radius <= 0:  # a point robot: the map's own regions decide (`Map.region_of`)
            return True
        regions = self.free_regions()
        if len(regions) < 2:
            return True

        def region(xy: ArrayLike) -> int | None:
            p = shapely.Point(np.asarray(xy, dtype=float).reshape(2))
            return next((i for i, g in enumerate(regions) if shapely.dwithin(g, p, 1e-6)), None)

        ra, rb = region(a), region(b)
        return ra is None or rb is None or ra == rb

    # -- single checks --------------------------------------------------------------------------
    def _inside(self, pts: NDArray[np.float64]) -> NDArray[np.bool_]:
        return np.asarray(shapely.contains_xy(self.map.polygon, pts[:, 0], pts[:, 1]), dtype=bool)

    def _clear_inside(self, pts: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Inside-ness of points at least the radius from every wall (the raster; see the module docstring)."""
        if self._raster is None:
            return self._inside(pts)
        within = np.all((pts >= self._lo) & (pts <= self._hi), axis=1)
        k = np.rint((np.where(within[:, None], pts, self._lo) - self._lo) / self._step).astype(np.int64)
        return within & self._raster[k[:, 0], k[:, 1]]

    def point_free(self, xy: ArrayLike) -> Any:
        """Whether the robot disc centred at `xy` is collision-free.

        (2,) -> bool; (n, 2) -> (n,) bool array.
        """
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        raster = self._decided(len(pts))
        state = raster.points(pts) if raster is not None else np.full(len(pts), UNKNOWN, dtype=np.uint8)
        out = state == FREE
        rest = np.flatnonzero(state == UNKNOWN)  # undecided by the raster: the exact test
        if len(rest):
            q = pts[rest]
            clear = self.index.capsules_clear(q, q, self.robot_radius)
            clear[clear] = self._clear_inside(q[clear])
            out[rest] = clear
        self.point_checks += len(pts)
        return bool(out[0]) if p.ndim == 1 else out

    def nearest_free(self, xy: ArrayLike, reach_cm: float) -> NDArray[np.float64] | None:
        """`xy` itself when free, else the nearest free point at most `reach_cm` away, searched on rings
        1 cm apart, 24 points each; None when none is free.

        >>> from toolkit.world import load_map
        >>> c = CollisionChecker(load_map("co333-arena"), 8.0)  # the wall y = 0: free from y = 8
        >>> c.nearest_free([60.0, 6.0], 0.0), c.nearest_free([60.0, 6.0], 5.0).round(2).tolist()
        (None, [60.0, 8.0])
        """
        p = np.asarray(xy, dtype=float)
        if self.point_free(p):
            return p
        angles = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
        for r in np.arange(1.0, reach_cm + 0.5, 1.0):
            ring = p + r * np.column_stack([np.cos(angles), np.sin(angles)])
            free = np.flatnonzero(self.point_free(ring))
            if len(free):
                return np.asarray(ring[free[0]], dtype=float)
        return None

    def segment_free(self, a: ArrayLike, b: ArrayLike) -> bool:
        """Whether the disc swept straight from `a` to `b` touches no wall (and stays inside)."""
        return bool(self.segments_free(np.asarray(a, float)[None], np.asarray(b, float)[None])[0])

    def segments_free(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        """Batch form of `segment_free` for (n, 2) start and end arrays; returns (n,) bools."""
        pa, pb = segment_arrays(a, b)
        raster = self._decided(len(pa))
        state = raster.segments(pa, pb) if raster is not None else np.full(len(pa), UNKNOWN, dtype=np.uint8)
        out = state == FREE
        rest = np.flatnonzero(state == UNKNOWN)  # undecided by the raster: the exact test
        if len(rest):
            # a swept disc clear of every wall never crosses one: the start decides inside-ness
            clear = self.index.capsules_clear(pa[rest], pb[rest], self.robot_radius)
            clear[clear] = self._clear_inside(pa[rest][clear])
            out[rest] = clear
        self.segment_checks += len(pa)
        return out

    def path_free(self, path: ArrayLike) -> bool:
        """Whether every segment of a (k, 2) polyline is free (a single point: its point check)."""
        p = np.asarray(path, dtype=float).reshape(-1, 2)
        if len(p) == 1:
            return bool(self.point_free(p[0]))
        return bool(np.all(self.segments_free(p[:-1], p[1:])))

    def clearance(self, xy: ArrayLike) -> Any:
        """Distance (cm) from the robot disc's edge to the nearest wall: negative when it collides.

        Exact planar distance minus the radius; points outside the free area get ``-inf``.
        (2,) -> float; (n, 2) -> (n,) array.
        """
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        inside = self._inside(pts)
        out = np.full(len(pts), -np.inf)
        idx = np.flatnonzero(inside)
        out[idx] = self.index.nearest_distance(pts[idx]) - self.robot_radius
        self.point_checks += len(pts)
        return float(out[0]) if p.ndim == 1 else out

    def first_contact(self, a: ArrayLike, b: ArrayLike, tol: float = 1e-3) -> float:
        """Fraction in [0, 1] of the way from `a` to `b` the disc can travel before touching a wall.

        1.0 when the whole segment is free; found by bisection on `segment_free` to `tol` cm.
        """
        pa, pb = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        if self.segment_free(pa, pb):
            return 1.0
        if not self.point_free(pa):
            return 0.0
        length = float(np.hypot(*(pb - pa)))
        lo, hi = 0.0, 1.0
        while (hi - lo) * length > tol:
            mid = (lo + hi) / 2.0
            if self.segment_free(pa, pa + mid * (pb - pa)):
                lo = mid
            else:
                hi = mid
        return lo
