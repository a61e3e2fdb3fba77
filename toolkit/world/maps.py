"""Polygonal maps: loading and validating map files, free space, sampling.

A map file is YAML with the fields (units: cm)::

    name: map1                      # optional, defaults to the file name
    description: BotSim map 1       # optional
    boundary: [[0, 0], [60, 0], ...]            # >= 3 vertices, simple polygon, non-zero area
    obstacles: [[[20, 20], [30, 20], [30, 30]]] # optional: polygons strictly inside, not overlapping
    start: [20, 20]                 # optional preset, must lie in free space
    target: [80, 80]                # optional preset, must lie in free space

Names such as ``map1`` resolve to the files in the repository's ``maps/`` folder, and to files in the
folders listed in the environment variable ``NXTNAV_MAPS`` (separated like ``PATH``).
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
import yaml
from numpy.typing import ArrayLike, NDArray
from shapely.geometry.base import BaseGeometry

from .errors import MapError
from .geometry import RngLike, as_rng

__all__ = ["MAP_FIELDS", "Map", "list_maps", "load_map", "map_from_dict", "map_search_path"]

MAP_FIELDS = ("name", "description", "boundary", "obstacles", "start", "target")
_BUNDLED = Path(__file__).resolve().parents[2] / "maps"

FloatArray = NDArray[np.float64]


def map_search_path() -> list[Path]:
    """Folders searched for map names: ``$NXTNAV_MAPS`` entries first, then the bundled ``maps/``."""
    extra = [Path(p) for p in os.environ.get("NXTNAV_MAPS", "").split(os.pathsep) if p]
    return [*extra, _BUNDLED]


def list_maps() -> dict[str, Path]:
    """Map names that resolve, mapped to their files (earlier search folders win)."""
    found: dict[str, Path] = {}
    for folder in map_search_path():
        if folder.is_dir():
            for f in sorted(folder.glob("*.y*ml")):
                found.setdefault(f.stem, f)
    return dict(sorted(found.items()))


def _resolve(name_or_path: str | os.PathLike[str]) -> Path:
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or p.exists() or os.sep in str(name_or_path):
        if not p.is_file():
            raise MapError(f"map file {str(p)!r} not found")
        return p
    known = list_maps()
    if str(name_or_path) in known:
        return known[str(name_or_path)]
    raise MapError(f"unknown map {str(name_or_path)!r}; known: {', '.join(known) or 'none'} (or give a path)")


def load_map(name_or_path: str | os.PathLike[str]) -> Map:
    """Load and validate a map by name (``map1``) or path (``maps/map1.yaml``).

    Raises
    ------
    MapError
        With the file and the field, vertex or value at fault.
    """
    if isinstance(name_or_path, Map):
        return name_or_path
    path = _resolve(name_or_path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}: cannot read map file: {exc}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise MapError(f"{path}: not valid YAML{where}: {problem}") from None
    return map_from_dict(data, source=path, default_name=path.stem)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MapError(f"{where}: expected a number, got {type(value).__name__} {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise MapError(f"{where}: coordinate must be finite, got {v}")
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
    """Raise when two non-adjacent edges of the ring meet (or adjacent edges overlap)."""
    n = len(ring)
    edges = [shapely.LineString([ring[i], ring[(i + 1) % n]]) for i in range(n)]
    for i in range(n):
        for j in range(i + 1, n):
            adjacent = j == i + 1 or (i == 0 and j == n - 1)
            inter = edges[i].intersection(edges[j])
            if inter.is_empty:
                continue
            if adjacent and inter.geom_type == "Point":
                continue  # the shared vertex
            pt = inter.representative_point()
            raise MapError(
                f"{where}: self-intersecting, edge {i} ({i}->{(i + 1) % n}) meets edge {j} "
                f"({j}->{(j + 1) % n}) at ({pt.x:.6g}, {pt.y:.6g})"
            )


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
    if "boundary" not in data:
        raise MapError(f"{label}: missing field 'boundary'")
    boundary = _ring(data["boundary"], f"{label}: boundary")
    raw_obs = data.get("obstacles") or []
    if not isinstance(raw_obs, list):
        raise MapError(f"{label}: field 'obstacles' must be a list of polygons, got {type(raw_obs).__name__}")
    obstacles = tuple(_ring(o, f"{label}: obstacle {k}") for k, o in enumerate(raw_obs))
    outer = shapely.Polygon(boundary)
    obs_polys = [shapely.Polygon(o) for o in obstacles]
    for k, op in enumerate(obs_polys):
        if not outer.contains(op) or outer.exterior.intersects(op):
            raise MapError(f"{label}: obstacle {k} is not strictly inside the boundary")
        for m in range(k):
            if op.intersects(obs_polys[m]):
                raise MapError(f"{label}: obstacles {m} and {k} overlap or touch")
    presets: dict[str, FloatArray | None] = {}
    free = shapely.Polygon(boundary, [o for o in obstacles])
    for key in ("start", "target"):
        if data.get(key) is None:
            presets[key] = None
            continue
        p = _point(data[key], f"{label}: {key}")
        if not free.contains(shapely.Point(p)):
            raise MapError(f"{label}: {key} {p.tolist()} is outside the free space of the map")
        presets[key] = p
    return Map(
        name=name,
        description=description,
        boundary=boundary,
        obstacles=obstacles,
        start=presets["start"],
        target=presets["target"],
        source=source,
    )


@dataclass(frozen=True, eq=False)
class Map:
    """A validated polygonal map (cm): a boundary, optional obstacles and optional start/target presets.

    Build one with `load_map` or `map_from_dict`; the constructor trusts its arguments.
    """

    name: str
    boundary: FloatArray
    obstacles: tuple[FloatArray, ...] = ()
    start: FloatArray | None = None
    target: FloatArray | None = None
    description: str = ""
    source: Path | None = field(default=None, repr=False)

    @cached_property
    def polygon(self) -> shapely.Polygon:
        """The free area (boundary with obstacles as holes) as a shapely polygon."""
        return shapely.Polygon(self.boundary, [o for o in self.obstacles])

    @cached_property
    def walls(self) -> FloatArray:
        """All wall segments as a (W, 4) array [x1, y1, x2, y2] (boundary first, then obstacles)."""
        segs = []
        for ring in (self.boundary, *self.obstacles):
            nxt = np.roll(ring, -1, axis=0)
            segs.append(np.hstack([ring, nxt]))
        return np.vstack(segs)

    @cached_property
    def wall_lines(self) -> shapely.MultiLineString:
        """The walls as one shapely geometry (for exact distances)."""
        return shapely.MultiLineString([[(a, b), (c, d)] for a, b, c, d in self.walls])

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the boundary (cm)."""
        lo = self.boundary.min(axis=0)
        hi = self.boundary.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @property
    def area(self) -> float:
        """Free area (cm^2)."""
        return float(self.polygon.area)

    def free_space(self, radius: float = 0.0) -> BaseGeometry:
        """The configuration space of a disc of `radius` cm: the free area shrunk by the radius."""
        if radius <= 0:
            return self.polygon
        return self.polygon.buffer(-float(radius), quad_segs=16)

    def contains(self, xy: ArrayLike) -> Any:
        """Whether points lie strictly inside the free area ((2,) -> bool, (n, 2) -> (n,) bool array)."""
        p = np.asarray(xy, dtype=float)
        res = shapely.contains_xy(self.polygon, p[..., 0], p[..., 1])
        return bool(res) if p.ndim == 1 else res

    def wall_distance(self, xy: ArrayLike) -> Any:
        """Exact distance (cm) from points to the nearest wall (shapely), vectorised like `contains`."""
        p = np.asarray(xy, dtype=float)
        d = shapely.distance(shapely.points(p.reshape(-1, 2)), self.wall_lines)
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

    def to_dict(self) -> dict[str, Any]:
        """The map in its file form (JSON/YAML ready)."""
        d: dict[str, Any] = {
            "name": self.name,
            "description": self.description,
            "boundary": self.boundary.tolist(),
        }
        if self.obstacles:
            d["obstacles"] = [o.tolist() for o in self.obstacles]
        if self.start is not None:
            d["start"] = self.start.tolist()
        if self.target is not None:
            d["target"] = self.target.tolist()
        return d
