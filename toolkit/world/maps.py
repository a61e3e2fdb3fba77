"""Polygonal maps: loading and validating map files, free space, sampling.

A map file is YAML with the fields (units: cm)::

    name: map1                      # optional, defaults to the file name
    description: BotSim map 1       # optional
    boundary: [[0, 0], [60, 0], ...]            # >= 3 vertices, simple polygon, non-zero area
    obstacles: [[[20, 20], [30, 20], [30, 30]]] # optional: polygons strictly inside, not overlapping
    walls: [[[40, 0], [40, 30]]]    # optional: thin walls (zero thickness), each a polyline of >= 2 points
    start: [20, 20]                 # optional preset, must lie in free space
    target: [80, 80]                # optional preset, must lie in free space

A map with several disjoint free regions (an imported grid map, say) lists them instead of
``boundary`` and ``obstacles``::

    regions:                        # each a polygon with holes; holes may touch the boundary or each
      - boundary: [[0, 0], ...]     # other at single points (as in a grid map's double corners)
        holes: [[[2, 2], ...], ...]
      - boundary: [[50, 0], ...]
    grid: {cell_cm: 1.0, origin: [0, 0], width: 281, height: 209}   # optional: the cells it came from

A thin wall (a free-standing stub of cardboard or plywood) is a polyline ``[[x, y], [x, y], ...]``
whose consecutive points are its segments (``[[x1, y1], [x2, y2]]`` for one segment). Each segment
has non-zero length and lies in the closure of the free area (it may touch the boundary or run along
it, never leave it or enter an obstacle). Thin walls are walls like any other (`Map.walls` lists them
after the polygons' edges, so rays stop at them and the disc checkers keep clear of them), and a point
on one is not free: `Map.contains` and every checker refuse it, even for a point robot, so no motion
crosses or touches one. Both forms (``boundary`` and ``regions``) may have ``walls``.

Points where the free space's boundary touches itself (``Map.pinch_points``) close the passage:
no motion may pass through one.

Names such as ``map1`` resolve to the files in the shipped data's ``maps/``, ``maps/external/``,
``maps/real-nxt/`` and ``maps/jarvis/`` folders (`toolkit.world.bundled`: the repository's ``maps/``, installed as the
package ``toolkit.data``), and to files in the folders listed in the environment variable
``NXTNAV_MAPS`` (separated like ``PATH``). A file's name is its stem, except that the map of a sweep
set (`toolkit.sweeps`), which is always called ``arena.yaml``, goes by its ``name`` field
(``co333-arena`` for ``maps/real-nxt/arena.yaml``). Besides the YAML files above, a name may be a
Moving AI ``.map`` file or a ROS map_server YAML, which are imported (`toolkit.world.importers`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry.base import BaseGeometry

from .arrays import FloatArray
from .bundled import data_path, data_root
from .edge_index import edge_index
from .errors import MapError
from .geometry import Pose, RngLike, as_rng
from .yaml_text import YAMLError, load_yaml

__all__ = ["COORDINATE_LIMIT_CM", "MAP_FIELDS", "THIN_WALL_SLIT_CM", "GridSpec", "Map", "Region", "list_maps",
           "load_map", "map_from_dict", "map_search_path"]

MAP_FIELDS = ("name", "description", "boundary", "obstacles", "walls", "regions", "grid", "start", "target")
_BUNDLED_FOLDERS = (".", "external", "real-nxt", "jarvis")
"""The folders of the shipped data that hold maps, relative to `toolkit.world.bundled.data_root`."""
_MAP_GLOBS = ("*.yaml", "*.yml", "*.map")
_SWEEP_SET_MAP = "arena.yaml"
"""File name of a sweep set's map: such a file is listed under its ``name`` field, not its stem."""


def map_search_path() -> list[Path]:
    """Folders searched for map names: ``$NXTNAV_MAPS`` entries first, then the shipped ``maps/``,
    ``maps/external/``, ``maps/real-nxt/`` and ``maps/jarvis/`` (wherever nxtnav is installed)."""
    extra = [Path(p) for p in os.environ.get("NXTNAV_MAPS", "").split(os.pathsep) if p]
    root = data_root()
    return [*extra, *(root / f for f in _BUNDLED_FOLDERS)]


def list_maps() -> dict[str, Path]:
    """Map names that resolve, mapped to their files (earlier search folders win)."""
    found: dict[str, Path] = {}
    for folder in map_search_path():
        if folder.is_dir():
            for f in sorted(f for pattern in _MAP_GLOBS for f in folder.glob(pattern)):
                found.setdefault(_listed_name(f), f)
    return dict(sorted(found.items()))


def _listed_name(path: Path) -> str:
    """The name a map file resolves by: its stem, or a sweep set's map's own ``name`` field (the stem
    when that field is missing or the file unreadable, so that `load_map` reports the problem)."""
    if path.name != _SWEEP_SET_MAP:
        return path.stem
    try:
        data = _read_yaml(path)
    except MapError:
        return path.stem
    name = data.get("name") if isinstance(data, dict) else None
    return name if isinstance(name, str) and name else path.stem


def _resolve(name_or_path: str | os.PathLike[str]) -> Path:
    p = data_path(name_or_path)
    if p.suffix in (".yaml", ".yml", ".map") or p.is_file() or os.sep in str(name_or_path):
        if not p.is_file():
            raise MapError(f"map file {str(p)!r} not found")
        return p
    known = list_maps()
    if str(name_or_path) in known:
        return known[str(name_or_path)]
    raise MapError(f"unknown map {str(name_or_path)!r}; known: {', '.join(known) or 'none'} (or give a path)")


def load_map(name_or_path: str | os.PathLike[str] | Map) -> Map:
    """Load and validate a map by name (``map1``) or path (``maps/map1.yaml``).

    A Moving AI ``.map`` file or a ROS map_server YAML (one with an ``image`` field) is imported with
    the defaults of `toolkit.world.importers.import_map` (1 cm per Moving AI cell; unknown ROS cells
    are obstacles); call that function for other options.

    Raises
    ------
    MapError
        With the file and the field, vertex or value at fault.
    """
    if isinstance(name_or_path, Map):
        return name_or_path
    path = _resolve(name_or_path)
    if path.suffix == ".map":
        from .importers import import_map

        return import_map(path)
    data = _read_yaml(path)
    if isinstance(data, dict) and "image" in data and "boundary" not in data and "regions" not in data:
        from .importers import import_map

        return import_map(path)
    return map_from_dict(data, source=path, default_name=path.stem)


def _read_yaml(path: Path) -> Any:
    """Parse a YAML file (the C parser when PyYAML has it) or raise a one-line `MapError`."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}: cannot read map file: {exc}") from None
    try:
        return load_yaml(text)
    except YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise MapError(f"{path}: not valid YAML{where}: {problem}") from None


COORDINATE_LIMIT_CM = 1.0e6
"""Largest absolute map coordinate (cm, 10 km): far beyond any room, and far below where the
geometry's predicates lose their precision (shapely's break down near 1e154)."""


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MapError(f"{where}: expected a number, got {type(value).__name__} {value!r}")
    try:
        v = float(value)
    except OverflowError:  # an integer too large for a float
        v = math.inf
    if not math.isfinite(v):
        raise MapError(f"{where}: coordinate must be finite, got {value}")
    if abs(v) > COORDINATE_LIMIT_CM:
        raise MapError(f"{where}: coordinate {v:g} is outside the supported range +-{COORDINATE_LIMIT_CM:g} cm")
    return v


def _point(value: Any, where: str) -> FloatArray:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise MapError(f"{where}: expected a point [x, y], got {value!r}")
    return np.array([_number(value[0], f"{where}[0]"), _number(value[1], f"{where}[1]")])


def _ring(value: Any, where: str) -> FloatArray:
    if not isinstance(value, list | tuple):
        raise MapError(f"{where}: expected a list of [x, y] vertices, got {type(value).__name__}")
    pts = [_point(v, f"{where} vertex {i}") for i, v in enumerate(value)]
    if len(pts) >= 2 and np.array_equal(pts[0], pts[-1]):
        pts = pts[:-1]  # a closed ring written with its first vertex repeated
    if len(pts) < 3:
        raise MapError(f"{where}: a polygon needs at least 3 vertices, got {len(pts)}")
    ring = np.array(pts)
    for i in range(len(ring)):
        j = (i + 1) % len(ring)
        if np.array_equal(ring[i], ring[j]):
            raise MapError(f"{where}: vertices {i} and {j} are the same point {ring[i].tolist()}")
    if np.linalg.matrix_rank(ring - ring.mean(axis=0), tol=1e-9) < 2:
        raise MapError(f"{where}: polygon has zero area (all vertices on one line)")
    _check_simple(ring, where)
    if not shapely.Polygon(ring).area > 0.0:
        raise MapError(f"{where}: polygon has zero area")
    return ring


def _check_simple(ring: FloatArray, where: str) -> None:
    """Raise when two non-adjacent edges of the ring meet (or adjacent edges overlap).

    Candidate edge pairs come from a shapely STRtree, so a ring of many thousand vertices (an imported
    grid map) is checked in about n log n time.
    """
    n = len(ring)
    nxt = np.roll(ring, -1, axis=0)
    edges = shapely.linestrings(np.stack([ring, nxt], axis=1))
    pairs = shapely.STRtree(edges).query(edges, predicate="intersects")
    pairs = pairs[:, pairs[0] < pairs[1]]
    for i, j in sorted(zip(pairs[0].tolist(), pairs[1].tolist(), strict=True)):
        adjacent = j == i + 1 or (i == 0 and j == n - 1)
        inter = edges[i].intersection(edges[j])
        if adjacent and inter.geom_type == "Point":
            continue  # the shared vertex
        pt = inter.representative_point()
        raise MapError(
            f"{where}: self-intersecting, edge {i} ({i}->{(i + 1) % n}) meets edge {j} "
            f"({j}->{(j + 1) % n}) at ({pt.x:.6g}, {pt.y:.6g})"
        )


def _rings(value: Any, where: str, what: str) -> tuple[FloatArray, ...]:
    if value is None:
        return ()
    if not isinstance(value, list):
        raise MapError(f"{where}: field '{what}' must be a list of polygons, got {type(value).__name__}")
    return tuple(_ring(o, f"{where}: {what[:-1]} {k}") for k, o in enumerate(value))


def _check_obstacles(label: str, boundary: FloatArray, obstacles: tuple[FloatArray, ...]) -> None:
    """The simple form's rule: obstacles strictly inside the boundary and apart from each other."""
    outer = shapely.Polygon(boundary)
    obs_polys = [shapely.Polygon(o) for o in obstacles]
    for k, op in enumerate(obs_polys):
        if not outer.contains(op) or outer.exterior.intersects(op):
            raise MapError(f"{label}: obstacle {k} is not strictly inside the boundary")
        for m in range(k):
            if op.intersects(obs_polys[m]):
                raise MapError(f"{label}: obstacles {m} and {k} overlap or touch")


def _region_ring(value: Any, where: str) -> FloatArray:
    """A ring of the ``regions`` form: vectorised checks (the polygon's validity test does the rest).

    Anything unusual goes through `_ring`, whose messages name the vertex at fault.
    """
    try:
        ring = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return _ring(value, where)
    if ring.ndim != 2 or ring.shape[1] != 2 or not np.isfinite(ring).all() or isinstance(value, np.ndarray):
        return _ring(value, where)
    if len(ring) >= 2 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    if len(ring) < 3 or (ring == np.roll(ring, -1, axis=0)).all(axis=1).any():
        return _ring(value, where)
    if any(isinstance(c, bool) for v in value for c in v):
        return _ring(value, where)
    return ring


def _regions(value: Any, label: str) -> tuple[Region, ...]:
    """The ``regions`` form: polygons with holes (OGC-valid: holes may touch at points), disjoint."""
    if not isinstance(value, list) or not value:
        raise MapError(f"{label}: field 'regions' must be a non-empty list of {{boundary, holes}} mappings")
    out: list[Region] = []
    for k, item in enumerate(value):
        where = f"{label}: region {k}"
        if not isinstance(item, dict):
            raise MapError(f"{where}: expected a mapping with 'boundary' and optional 'holes', got {item!r}")
        extra = sorted(str(x) for x in item if x not in ("boundary", "holes"))
        if extra:
            raise MapError(f"{where}: unknown field(s) {', '.join(extra)}; allowed: boundary, holes")
        if "boundary" not in item:
            raise MapError(f"{where}: missing field 'boundary'")
        holes = item.get("holes") or []
        if not isinstance(holes, list):
            raise MapError(f"{where}: field 'holes' must be a list of polygons, got {type(holes).__name__}")
        region = Region(_region_ring(item["boundary"], f"{where}: boundary"),
                        tuple(_region_ring(h, f"{where}: hole {k}") for k, h in enumerate(holes)))
        reason = shapely.is_valid_reason(region.polygon)
        if reason != "Valid Geometry":
            raise MapError(f"{where}: invalid polygon: {reason}")
        if not region.polygon.area > 0:
            raise MapError(f"{where}: polygon has zero area")
        out.append(region)
    polys = [r.polygon for r in out]
    pairs = shapely.STRtree(polys).query(polys, predicate="intersects")
    for i, j in zip(pairs[0].tolist(), pairs[1].tolist(), strict=True):
        if i < j and shapely.get_dimensions(shapely.intersection(polys[i], polys[j])) > 0:
            raise MapError(f"{label}: regions {i} and {j} overlap or share an edge")
    return tuple(out)


def _thin_walls(value: Any, label: str, free: BaseGeometry) -> tuple[FloatArray, ...]:
    """The ``walls`` field: polylines of >= 2 points, segments of non-zero length in the closed free area."""
    if value is None:
        return ()
    if not isinstance(value, list):
        raise MapError(f"{label}: field 'walls' must be a list of polylines [[x, y], [x, y], ...], "
                       f"got {type(value).__name__}")
    out: list[FloatArray] = []
    for k, item in enumerate(value):
        where = f"{label}: wall {k}"
        if not isinstance(item, list | tuple):
            raise MapError(f"{where}: expected a list of [x, y] points, got {type(item).__name__} {item!r}")
        line = np.array([_point(v, f"{where} vertex {i}") for i, v in enumerate(item)], dtype=np.float64)
        if len(line) < 2:
            raise MapError(f"{where}: a wall needs at least 2 points, got {len(line)}")
        same = np.flatnonzero((line[1:] == line[:-1]).all(axis=1))
        if len(same):
            i = int(same[0])
            raise MapError(f"{where} vertex {i + 1}: zero-length segment, the same point {line[i].tolist()} "
                           f"as vertex {i}")
        inside = shapely.intersects_xy(free, line[:, 0], line[:, 1])
        if not inside.all():
            i = int(np.flatnonzero(~inside)[0])
            raise MapError(f"{where} vertex {i}: {line[i].tolist()} is outside the free space of the map")
        segs = shapely.linestrings(np.stack([line[:-1], line[1:]], axis=1))
        covered = shapely.covers(free, segs)
        if not covered.all():
            i = int(np.flatnonzero(~covered)[0])
            outside = shapely.get_parts(shapely.difference(segs[i], free))[0]
            pt = shapely.line_interpolate_point(outside, 0.5, normalized=True)
            raise MapError(f"{where}: segment vertex {i} -> {i + 1} leaves the free space of the map at "
                           f"({pt.x:.6g}, {pt.y:.6g})")
        out.append(line)
    return tuple(out)


def _grid(value: Any, label: str) -> GridSpec | None:
    if value is None:
        return None
    if not isinstance(value, dict) or set(value) != {"cell_cm", "origin", "width", "height"}:
        raise MapError(f"{label}: field 'grid' must be a mapping with cell_cm, origin, width and height, got {value!r}")
    cell = _number(value["cell_cm"], f"{label}: grid.cell_cm")
    origin = _point(value["origin"], f"{label}: grid.origin")
    for key in ("width", "height"):
        if isinstance(value[key], bool) or not isinstance(value[key], int) or value[key] <= 0:
            raise MapError(f"{label}: grid.{key} must be a positive integer, got {value[key]!r}")
    if cell <= 0:
        raise MapError(f"{label}: grid.cell_cm must be positive, got {cell}")
    return GridSpec(cell, (float(origin[0]), float(origin[1])), int(value["width"]), int(value["height"]))


def map_from_dict(
    data: Any, *, source: Path | None = None, default_name: str = "map"
) -> Map:
    """Build and validate a `Map` from the parsed YAML structure (see the module docstring)."""
    label = str(source) if source is not None else "map"
    if not isinstance(data, dict):
        raise MapError(f"{label}: expected a mapping with fields {', '.join(MAP_FIELDS)}, "
                       f"got {type(data).__name__}")
    unknown = sorted(str(k) for k in data if k not in MAP_FIELDS)
    if unknown:
        raise MapError(f"{label}: unknown field(s) {', '.join(unknown)}; allowed: {', '.join(MAP_FIELDS)}")
    name = data.get("name", default_name)
    if not isinstance(name, str) or not name:
        raise MapError(f"{label}: field 'name' must be a non-empty string, got {name!r}")
    description = data.get("description", "")
    if description is None:
        description = ""
    if not isinstance(description, str):
        raise MapError(f"{label}: field 'description' must be a string, got {type(description).__name__}")
    if "regions" in data:
        if "boundary" in data or "obstacles" in data:
            raise MapError(f"{label}: give either 'regions' or 'boundary' (with 'obstacles'), not both")
        regions = _regions(data["regions"], label)
    else:
        if "boundary" not in data:
            raise MapError(f"{label}: missing field 'boundary'")
        boundary = _ring(data["boundary"], f"{label}: boundary")
        obstacles = _rings(data.get("obstacles") or [], label, "obstacles")
        _check_obstacles(label, boundary, obstacles)
        regions = (Region(boundary, obstacles),)
    grid = _grid(data.get("grid"), label)
    free = regions[0].polygon if len(regions) == 1 else shapely.MultiPolygon([r.polygon for r in regions])
    shapely.prepare(free)
    thin = _thin_walls(data.get("walls"), label, free)
    presets: dict[str, FloatArray | None] = {}
    for key in ("start", "target"):
        if data.get(key) is None:
            presets[key] = None
            continue
        p = _point(data[key], f"{label}: {key}")
        if not free.contains(shapely.Point(p)):
            raise MapError(f"{label}: {key} {p.tolist()} is outside the free space of the map")
        on = [k for k, w in enumerate(thin) if shapely.intersects_xy(shapely.LineString(w), *p)]
        if on:
            raise MapError(f"{label}: {key} {p.tolist()} lies on wall {on[0]}")
        presets[key] = p
    return Map(
        name=name,
        description=description,
        regions=regions,
        start=presets["start"],
        target=presets["target"],
        grid=grid,
        thin_walls=thin,
        source=source,
    )


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
        _check_obstacles("", region.boundary, region.holes)
    except MapError:
        return False
    return True
