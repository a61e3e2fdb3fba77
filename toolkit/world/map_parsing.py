"""A `Map` built and validated from the parsed YAML structure of a map file (`map_from_dict`).

The fields and their rules are those of `toolkit.world.maps` (its docstring lists them).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from .arrays import FloatArray
from .errors import MapError
from .map_model import GridSpec, Map, Region
from .map_rings import check_obstacles, read_number, read_point, read_region_ring, read_ring, read_rings

__all__ = ["MAP_FIELDS", "map_from_dict"]

MAP_FIELDS = ("name", "description", "boundary", "obstacles", "walls", "regions", "grid", "start", "target")


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
        region = Region(read_region_ring(item["boundary"], f"{where}: boundary"),
                        tuple(read_region_ring(h, f"{where}: hole {k}") for k, h in enumerate(holes)))
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
        line = np.array([read_point(v, f"{where} vertex {i}") for i, v in enumerate(item)], dtype=np.float64)
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
    cell = read_number(value["cell_cm"], f"{label}: grid.cell_cm")
    origin = read_point(value["origin"], f"{label}: grid.origin")
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
        boundary = read_ring(data["boundary"], f"{label}: boundary")
        obstacles = read_rings(data.get("obstacles") or [], label, "obstacles")
        check_obstacles(label, boundary, obstacles)
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
        p = read_point(data[key], f"{label}: {key}")
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
