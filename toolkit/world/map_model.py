"""The map types (cm): `Region`, `GridSpec` and the validated polygonal `Map` with its geometry.

Build a `Map` with `toolkit.world.load_map` or `toolkit.world.map_from_dict`; the constructor trusts
its arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry.base import BaseGeometry

from .arrays import FloatArray
from .edge_index import edge_index
from .errors import MapError
from .geometry import Pose, RngLike, as_rng
from .map_rings import check_obstacles

__all__ = ["THIN_WALL_SLIT_CM", "GridSpec", "Map", "Region"]


@dataclass(frozen=True, eq=False)
class Region:
    """One connected piece of free space (cm): an outer boundary and holes (obstacles) inside it."""

    boundary: FloatArray
    holes: tuple[FloatArray, ...] = ()

    @cached_property
    def polygon(self) -> shapely.Polygon:
        return shapely.Polygon(self.boundary, [h for h in self.holes])

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"boundary": self.boundary.tolist()}
        if self.holes:
            d["holes"] = [h.tolist() for h in self.holes]
        return d


@dataclass(frozen=True)
class GridSpec:
    """The cell grid an imported map was polygonised from.

    Cell ``(i, j)`` (column ``i`` from the left, row ``j`` from the bottom) is the square
    ``[x0 + i c, x0 + (i + 1) c] x [y0 + j c, y0 + (j + 1) c]`` with ``(x0, y0) = origin`` and
    ``c = cell_cm``; ``width`` columns and ``height`` rows.
    """

    cell_cm: float
    origin: tuple[float, float]
    width: int
    height: int

    def centres(self) -> FloatArray:
        """Cell centres (cm), shape (height, width, 2), indexed ``[j, i]``."""
        x0, y0 = self.origin
        c = self.cell_cm
        xs = x0 + c * (np.arange(self.width) + 0.5)
        ys = y0 + c * (np.arange(self.height) + 0.5)
        gx, gy = np.meshgrid(xs, ys)
        return np.stack([gx, gy], axis=-1)

    def to_dict(self) -> dict[str, Any]:
        return {"cell_cm": self.cell_cm, "origin": list(self.origin), "width": self.width, "height": self.height}


THIN_WALL_SLIT_CM = 1e-6
"""Width (cm) of the slit `Map.free_space` cuts along a thin wall for radius 0: shapely cannot take a
segment out of an area (the difference of an area and a line is the area again). Only that geometry
is widened: `Map.contains` and the checkers test the segments themselves, exactly."""


@dataclass(frozen=True, eq=False)
class Map:
    """A validated polygonal map (cm): free regions (boundaries with holes), optional thin walls and
    optional start/target presets.

    Most maps have one region (`boundary` with `obstacles` inside); an imported grid map may have
    several disjoint ones. `thin_walls` are polylines ((k, 2) arrays, k >= 2) of zero thickness in the
    closed free area. Build one with `load_map` or `map_from_dict`; the constructor trusts its
    arguments.
    """

    name: str
    regions: tuple[Region, ...]
    start: FloatArray | None = None
    target: FloatArray | None = None
    description: str = ""
    grid: GridSpec | None = None
    thin_walls: tuple[FloatArray, ...] = ()
    source: Path | None = field(default=None, repr=False)

    @property
    def boundary(self) -> FloatArray:
        """The outer boundary of the first (largest, for imported maps) region."""
        return self.regions[0].boundary

    @property
    def obstacles(self) -> tuple[FloatArray, ...]:
        """The holes of the first region."""
        return self.regions[0].holes

    @cached_property
    def polygon(self) -> shapely.Polygon | shapely.MultiPolygon:
        """The free area as one shapely geometry (a MultiPolygon when there are several regions)."""
        if len(self.regions) == 1:
            return self.regions[0].polygon
        return shapely.MultiPolygon([r.polygon for r in self.regions])

    @cached_property
    def walls(self) -> FloatArray:
        """All wall segments as a (W, 4) array [x1, y1, x2, y2]: each region's boundary, then its holes,
        then the thin walls' segments (`thin_segments`, the last rows)."""
        segs = []
        for region in self.regions:
            for ring in (region.boundary, *region.holes):
                nxt = np.roll(ring, -1, axis=0)
                segs.append(np.hstack([ring, nxt]))
        walls = np.vstack([*segs, self.thin_segments])
        walls.setflags(write=False)  # read-only: ray casting and collision checks index it once
        return walls

    @cached_property
    def thin_segments(self) -> FloatArray:
        """The thin walls' segments as a (T, 4) array [x1, y1, x2, y2] (cm; T = 0 without thin walls)."""
        segs = [np.hstack([w[:-1], w[1:]]) for w in self.thin_walls]
        out = np.vstack(segs) if segs else np.empty((0, 4))
        out.setflags(write=False)
        return out

    @cached_property
    def thin_lines(self) -> shapely.MultiLineString:
        """The thin walls as one shapely geometry (empty without thin walls)."""
        return shapely.multilinestrings(self.thin_segments.reshape(-1, 2, 2))

    @cached_property
    def _thin_tree(self) -> shapely.STRtree:
        return shapely.STRtree(shapely.linestrings(self.thin_segments.reshape(-1, 2, 2)))

    def _thin_hits(self, a: FloatArray, b: FloatArray, points: bool) -> NDArray[np.bool_]:
        """Whether each point a[k] (`points`) or segment a[k] -> b[k] meets a thin wall: exact shapely
        predicates, asked only for those the thin walls' grid index finds within a hair of one."""
        out = np.zeros(len(a), dtype=bool)
        if not self.thin_walls or not len(a):
            return out
        near = np.flatnonzero(~edge_index(self.thin_segments).capsules_clear(a, b, THIN_WALL_SLIT_CM))
        if len(near):
            geoms = shapely.points(a[near]) if points else shapely.linestrings(np.stack([a[near], b[near]], axis=1))
            hit, _ = self._thin_tree.query(geoms, predicate="intersects")
            out[near[hit]] = True
        return out

    def on_thin_wall(self, xy: ArrayLike) -> Any:
        """Whether points lie on a thin wall (exact; (2,) -> bool, (..., 2) -> bool array)."""
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        out = self._thin_hits(pts, pts, points=True)
        return bool(out[0]) if p.ndim == 1 else out.reshape(p.shape[:-1])

    def meets_thin_wall(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        """Whether each segment ``a[k] -> b[k]`` ((n, 2) arrays, cm) crosses or touches a thin wall (exact)."""
        pa = np.asarray(a, dtype=float).reshape(-1, 2)
        pb = np.asarray(b, dtype=float).reshape(-1, 2)
        return self._thin_hits(pa, pb, points=False)

    @cached_property
    def wall_lines(self) -> shapely.MultiLineString:
        """The walls as one shapely geometry (for exact distances)."""
        return shapely.multilinestrings(np.asarray(self.walls).reshape(-1, 2, 2))

    @cached_property
    def pinch_points(self) -> FloatArray:
        """Points where the boundary of the free space touches itself, shape (k, 2).

        A hole touching the boundary or another hole at one point, or two regions meeting at a
        corner (in a grid map: two blocked cells meeting only diagonally). They close the passage:
        no motion may pass through one.
        """
        verts = [ring for region in self.regions for ring in (region.boundary, *region.holes)]
        allv = np.vstack(verts)
        uniq, counts = np.unique(allv, axis=0, return_counts=True)
        return np.asarray(uniq[counts > 1], dtype=np.float64)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the boundaries (cm)."""
        allv = np.vstack([r.boundary for r in self.regions])
        lo = allv.min(axis=0)
        hi = allv.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def area(self) -> float:
        """Free area (cm^2)."""
        return float(self.polygon.area)

    def free_space(self, radius: float = 0.0) -> BaseGeometry:
        """The configuration space of a disc of `radius` cm: the free area shrunk by the radius, minus
        every thin wall grown by the radius.

        Arcs are drawn as chords (16 per quarter circle). For radius 0 the thin walls are cut out as
        slits `THIN_WALL_SLIT_CM` wide (and no longer than the walls), so a point on one is not in
        the result.
        """
        r = float(radius)
        space = self.polygon if r <= 0 else self.polygon.buffer(-r, quad_segs=16)
        if not self.thin_walls:
            return space
        if r > 0:
            grown = shapely.buffer(self.thin_lines, r, quad_segs=16)
        else:  # square ends: the slit ends at the wall's ends
            grown = shapely.buffer(self.thin_lines, THIN_WALL_SLIT_CM, quad_segs=1, cap_style="flat")
        return shapely.difference(space, grown)

    def contains(self, xy: ArrayLike) -> Any:
        """Whether points lie strictly inside the free area and on no thin wall.

        (2,) -> bool; (..., 2) -> bool array.
        """
        p = np.asarray(xy, dtype=float)
        res = shapely.contains_xy(self.polygon, p[..., 0], p[..., 1])
        if self.thin_walls:
            res = res & ~np.asarray(self.on_thin_wall(p), dtype=bool)
        return bool(res) if p.ndim == 1 else res

    @cached_property
    def _region_tree(self) -> shapely.STRtree:
        return shapely.STRtree([r.polygon for r in self.regions])

    def region_of(self, xy: ArrayLike) -> Any:
        """Index of the region whose closure holds each point, -1 for none ((2,) -> int, (n, 2) -> array)."""
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        out = np.full(len(pts), -1, dtype=np.intp)
        if len(self.regions) == 1:
            out[shapely.intersects_xy(self.regions[0].polygon, pts[:, 0], pts[:, 1])] = 0
        else:
            idx = self._region_tree.query(shapely.points(pts), predicate="intersects")
            out[idx[0][::-1]] = idx[1][::-1]  # the first region listed wins
        return int(out[0]) if p.ndim == 1 else out

    def wall_distance(self, xy: ArrayLike) -> Any:
        """Exact distance (cm) from points to the nearest wall, vectorised like `contains`.

        Computed over the walls' grid index (`toolkit.world.edge_index`): shapely's formula, but only
        the walls near each point are visited.
        """
        p = np.asarray(xy, dtype=float)
        d = edge_index(self.walls).nearest_distance(p.reshape(-1, 2))
        return float(d[0]) if p.ndim == 1 else d

    def is_free(self, xy: ArrayLike, clearance: float = 0.0) -> Any:
        """Inside the free area and at least `clearance` cm from every wall."""
        p = np.asarray(xy, dtype=float)
        ok = np.asarray(self.contains(p)) & (np.asarray(self.wall_distance(p)) >= clearance)
        return bool(ok) if p.ndim == 1 else ok

    def sample_free(self, n: int, clearance: float = 0.0, rng: RngLike = None) -> FloatArray:
        """`n` points uniform over the free area at least `clearance` cm from every wall, shape (n, 2)."""
        gen = as_rng(rng)
        xmin, ymin, xmax, ymax = self.bounds
        region = self.free_space(clearance)
        if region.is_empty:
            raise MapError(f"map {self.name!r}: no free space with clearance {clearance} cm")
        out: list[FloatArray] = []
        have = 0
        frac = max(region.area / ((xmax - xmin) * (ymax - ymin)), 1e-3)
        while have < n:
            m = int((n - have) / frac * 1.2) + 16
            cand = gen.uniform([xmin, ymin], [xmax, ymax], size=(m, 2))
            keep = cand[self.is_free(cand, clearance)]
            out.append(keep)
            have += len(keep)
        return np.vstack(out)[:n]

    def random_pose(self, rng: RngLike = None, clearance: float = 10.0) -> Pose:
        """A pose uniform over the free area at least `clearance` cm from every wall, heading uniform (rad)."""
        gen = as_rng(rng)
        xy = self.sample_free(1, clearance=clearance, rng=gen)[0]
        return Pose(float(xy[0]), float(xy[1]), float(gen.uniform(-math.pi, math.pi)))

    def to_dict(self) -> dict[str, Any]:
        """The map in its file form (JSON/YAML ready): ``boundary``/``obstacles`` when that form holds it."""
        d: dict[str, Any] = {"name": self.name, "description": self.description}
        simple = self.grid is None and len(self.regions) == 1 and _apart(self.regions[0])
        if simple:
            d["boundary"] = self.boundary.tolist()
            if self.obstacles:
                d["obstacles"] = [o.tolist() for o in self.obstacles]
        else:
            d["regions"] = [r.to_dict() for r in self.regions]
        if self.thin_walls:
            d["walls"] = [w.tolist() for w in self.thin_walls]
        if self.grid is not None:
            d["grid"] = self.grid.to_dict()
        if self.start is not None:
            d["start"] = self.start.tolist()
        if self.target is not None:
            d["target"] = self.target.tolist()
        return d


def _apart(region: Region) -> bool:
    """Whether the region's holes keep clear of its boundary and of each other (the simple file form)."""
    try:
        check_obstacles("", region.boundary, region.holes)
    except MapError:
        return False
    return True
