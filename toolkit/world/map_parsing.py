"""A `Map` built and validated from the parsed YAML structure of a map file (`map_from_dict`), through
its typed model `MapFile`.

The fields and their rules are those of `toolkit.world.maps` (its docstring lists them). Each field's
value is read and checked by `toolkit.world.map_rings` (the messages name the file, the field, the
vertex and the value); the geometric rules that tie fields together (obstacles inside the boundary
and apart, regions valid and disjoint, thin walls and presets in the free space) are `MapFile`'s
validator, which keeps the geometry it built for `map_from_dict`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import shapely
from pydantic import BeforeValidator, ConfigDict, Field, PrivateAttr, ValidationError, ValidationInfo, model_validator
from shapely.geometry.base import BaseGeometry

from .arrays import FloatArray
from .errors import MapError
from .map_model import GridSpec, Map, Region
from .map_rings import check_obstacles, read_number, read_point, read_region_ring, read_ring, read_rings
from .typed import Typed, worded

__all__ = ["MAP_FIELDS", "MapFile", "map_from_dict"]

MAP_FIELDS = ("name", "description", "boundary", "obstacles", "walls", "regions", "grid", "start", "target")


def _label(info: ValidationInfo) -> str:
    return str((info.context or {}).get("label", "map"))


def _checked(read: Any, *args: Any) -> Any:
    """`read(*args)` (a `toolkit.world.map_rings` reader), its `MapError` as a worded validation error."""
    try:
        return read(*args)
    except MapError as exc:
        raise worded(str(exc)) from None


def _name(value: Any, info: ValidationInfo) -> Any:
    if not isinstance(value, str) or not value:
        raise worded(f"{_label(info)}: field 'name' must be a non-empty string, got {value!r}")
    return value


def _description(value: Any, info: ValidationInfo) -> Any:
    if value is None:
        return ""
    if not isinstance(value, str):
        raise worded(f"{_label(info)}: field 'description' must be a string, got {type(value).__name__}")
    return value


def _boundary(value: Any, info: ValidationInfo) -> Any:
    return _checked(read_ring, value, f"{_label(info)}: boundary").tolist()


def _obstacles(value: Any, info: ValidationInfo) -> Any:
    return [o.tolist() for o in _checked(read_rings, value or [], _label(info), "obstacles")]


def _regions(value: Any, info: ValidationInfo) -> Any:
    """The ``regions`` form's rings read (their polygons are checked with the rest of the geometry)."""
    label = _label(info)
    if not isinstance(value, list) or not value:
        raise worded(f"{label}: field 'regions' must be a non-empty list of {{boundary, holes}} mappings")
    out: list[dict[str, Any]] = []
    for k, item in enumerate(value):
        where = f"{label}: region {k}"
        if not isinstance(item, dict):
            raise worded(f"{where}: expected a mapping with 'boundary' and optional 'holes', got {item!r}")
        extra = sorted(str(x) for x in item if x not in ("boundary", "holes"))
        if extra:
            raise worded(f"{where}: unknown field(s) {', '.join(extra)}; allowed: boundary, holes")
        if "boundary" not in item:
            raise worded(f"{where}: missing field 'boundary'")
        holes = item.get("holes") or []
        if not isinstance(holes, list):
            raise worded(f"{where}: field 'holes' must be a list of polygons, got {type(holes).__name__}")
        out.append({"boundary": _checked(read_region_ring, item["boundary"], f"{where}: boundary").tolist(),
                     "holes": [_checked(read_region_ring, h, f"{where}: hole {j}").tolist()
                               for j, h in enumerate(holes)]})
    return out


def _walls(value: Any, info: ValidationInfo) -> Any:
    """The ``walls`` field's polylines read: >= 2 points, no zero-length segment (their place in the free
    space is checked with the rest of the geometry)."""
    if value is None:
        return None
    label = _label(info)
    if not isinstance(value, list):
        raise worded(f"{label}: field 'walls' must be a list of polylines [[x, y], [x, y], ...], "
                     f"got {type(value).__name__}")
    out: list[Any] = []
    for k, item in enumerate(value):
        where = f"{label}: wall {k}"
        if not isinstance(item, list | tuple):
            raise worded(f"{where}: expected a list of [x, y] points, got {type(item).__name__} {item!r}")
        line = np.array([_checked(read_point, v, f"{where} vertex {i}") for i, v in enumerate(item)],
                        dtype=np.float64).reshape(-1, 2)
        if len(line) < 2:
            raise worded(f"{where}: a wall needs at least 2 points, got {len(line)}")
        same = np.flatnonzero((line[1:] == line[:-1]).all(axis=1))
        if len(same):
            i = int(same[0])
            raise worded(f"{where} vertex {i + 1}: zero-length segment, the same point {line[i].tolist()} "
                         f"as vertex {i}")
        out.append(line.tolist())
    return out


def _grid(value: Any, info: ValidationInfo) -> Any:
    if value is None:
        return None
    label = _label(info)
    if not isinstance(value, dict) or set(value) != {"cell_cm", "origin", "width", "height"}:
        raise worded(f"{label}: field 'grid' must be a mapping with cell_cm, origin, width and height, got {value!r}")
    cell = _checked(read_number, value["cell_cm"], f"{label}: grid.cell_cm")
    origin = _checked(read_point, value["origin"], f"{label}: grid.origin")
    for key in ("width", "height"):
        if isinstance(value[key], bool) or not isinstance(value[key], int) or value[key] <= 0:
            raise worded(f"{label}: grid.{key} must be a positive integer, got {value[key]!r}")
    if cell <= 0:
        raise worded(f"{label}: grid.cell_cm must be positive, got {cell}")
    return {"cell_cm": cell, "origin": origin.tolist(), "width": value["width"], "height": value["height"]}


def _preset(value: Any, info: ValidationInfo) -> Any:
    return None if value is None else _checked(read_point, value, f"{_label(info)}: {info.field_name}").tolist()


Point = Annotated[tuple[float, float], Field(description="[x, y] (cm)")]
Ring = Annotated[list[Point], Field(min_length=3, description="a simple polygon's vertices (cm)")]


class RegionFile(Typed):
    """One free region of the ``regions`` form: a polygon with holes (OGC-valid: holes may touch at points)."""

    boundary: Ring
    holes: list[Ring] = Field(default_factory=list)


class GridFile(Typed):
    """The cell grid an imported map was polygonised from (`toolkit.world.map_model.GridSpec`)."""

    cell_cm: float = Field(gt=0)
    origin: Point
    width: int = Field(gt=0)
    height: int = Field(gt=0)


class MapFile(Typed):
    """A map file (`toolkit.world.maps`): ``boundary`` with ``obstacles``, or ``regions``; optional thin
    ``walls``, ``grid`` and ``start``/``target`` presets. Validated with ``{"label": file}`` as its
    context (the messages' prefix); `map_from_dict` builds the `Map` from it."""

    model_config = ConfigDict(validate_default=False)

    name: Annotated[str, Field(min_length=1, description="defaults to the file's name"), BeforeValidator(_name)]
    description: Annotated[str, BeforeValidator(_description)] = ""
    regions: Annotated[list[RegionFile] | None, Field(description="disjoint free regions (instead of boundary)"),
                       BeforeValidator(_regions)] = None
    boundary: Annotated[Ring | None, Field(description="the outer wall: simple polygon, non-zero area"),
                        BeforeValidator(_boundary)] = None
    obstacles: Annotated[list[Ring], Field(default_factory=list, description="polygons strictly inside the "
                                           "boundary, apart"), BeforeValidator(_obstacles)]
    grid: Annotated[GridFile | None, BeforeValidator(_grid)] = None
    walls: Annotated[list[Annotated[list[Point], Field(min_length=2)]] | None,
                     Field(description="thin walls: polylines of >= 2 points in the free space"),
                     BeforeValidator(_walls)] = None
    start: Annotated[Point | None, Field(description="preset start, in the free space"),
                     BeforeValidator(_preset)] = None
    target: Annotated[Point | None, Field(description="preset target, in the free space"),
                      BeforeValidator(_preset)] = None

    _regions: tuple[Region, ...] = PrivateAttr(())
    _thin: tuple[FloatArray, ...] = PrivateAttr(())

    @model_validator(mode="before")
    @classmethod
    def _form(cls, data: Any, info: ValidationInfo) -> Any:
        label = _label(info)
        if not isinstance(data, dict):
            raise worded(f"{label}: expected a mapping with fields {', '.join(MAP_FIELDS)}, got {type(data).__name__}")
        unknown = sorted(str(k) for k in data if k not in MAP_FIELDS)
        if unknown:
            raise worded(f"{label}: unknown field(s) {', '.join(unknown)}; allowed: {', '.join(MAP_FIELDS)}")
        if "regions" in data and ("boundary" in data or "obstacles" in data):
            raise worded(f"{label}: give either 'regions' or 'boundary' (with 'obstacles'), not both")
        if "regions" not in data and "boundary" not in data:
            raise worded(f"{label}: missing field 'boundary'")
        return data if "name" in data else {**data, "name": (info.context or {}).get("default_name", "map")}

    @model_validator(mode="after")
    def _geometry(self, info: ValidationInfo) -> MapFile:
        """The geometric rules: obstacles inside the boundary and apart, regions valid and disjoint,
        thin walls and presets in the free space (the `Map`'s geometry kept for `map_from_dict`)."""
        label = _label(info)
        if self.regions is not None:
            regions = _checked(_valid_regions, self.regions, label)
        else:
            boundary = np.asarray(self.boundary, dtype=np.float64)
            obstacles = tuple(np.asarray(o, dtype=np.float64) for o in self.obstacles)
            _checked(check_obstacles, label, boundary, obstacles)
            regions = (Region(boundary, obstacles),)
        free = regions[0].polygon if len(regions) == 1 else shapely.MultiPolygon([r.polygon for r in regions])
        shapely.prepare(free)
        thin = _checked(_thin_walls, self.walls, label, free)
        for key in ("start", "target"):
            p = getattr(self, key)
            if p is None:
                continue
            if not free.contains(shapely.Point(p)):
                raise worded(f"{label}: {key} {list(p)} is outside the free space of the map")
            on = [k for k, w in enumerate(thin) if shapely.intersects_xy(shapely.LineString(w), *p)]
            if on:
                raise worded(f"{label}: {key} {list(p)} lies on wall {on[0]}")
        self._regions, self._thin = regions, thin
        return self


def _valid_regions(items: list[RegionFile], label: str) -> tuple[Region, ...]:
    """The regions as `Region`s: each a valid polygon of non-zero area, no two overlapping or sharing an edge."""
    out: list[Region] = []
    for k, item in enumerate(items):
        region = Region(np.asarray(item.boundary, dtype=np.float64),
                        tuple(np.asarray(h, dtype=np.float64) for h in item.holes))
        reason = shapely.is_valid_reason(region.polygon)
        if reason != "Valid Geometry":
            raise MapError(f"{label}: region {k}: invalid polygon: {reason}")
        if not region.polygon.area > 0:
            raise MapError(f"{label}: region {k}: polygon has zero area")
        out.append(region)
    polys = [r.polygon for r in out]
    pairs = shapely.STRtree(polys).query(polys, predicate="intersects")
    for i, j in zip(pairs[0].tolist(), pairs[1].tolist(), strict=True):
        if i < j and shapely.get_dimensions(shapely.intersection(polys[i], polys[j])) > 0:
            raise MapError(f"{label}: regions {i} and {j} overlap or share an edge")
    return tuple(out)


def _thin_walls(walls: list[Any] | None, label: str, free: BaseGeometry) -> tuple[FloatArray, ...]:
    """The thin walls as arrays, each segment in the closed free area (`MapError` naming the wall)."""
    out: list[FloatArray] = []
    for k, points in enumerate(walls or []):
        where = f"{label}: wall {k}"
        line = np.asarray(points, dtype=np.float64)
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


def map_from_dict(
    data: Any, *, source: Path | None = None, default_name: str = "map"
) -> Map:
    """Build and validate a `Map` from the parsed YAML structure (see the module docstring)."""
    label = str(source) if source is not None else "map"
    try:
        f = MapFile.model_validate(data, context={"label": label, "default_name": default_name})
    except ValidationError as exc:
        err = exc.errors()[0]
        text = (err.get("ctx") or {}).get("text") if err.get("type") == "worded" else None
        raise MapError(str(text) if text else f"{label}: {' '.join(str(exc).split())}") from None
    grid = None if f.grid is None else GridSpec(f.grid.cell_cm, f.grid.origin, f.grid.width, f.grid.height)
    return Map(
        name=f.name,
        description=f.description,
        regions=f._regions,
        start=None if f.start is None else np.array(f.start, dtype=np.float64),
        target=None if f.target is None else np.array(f.target, dtype=np.float64),
        grid=grid,
        thin_walls=f._thin,
        source=source,
    )
