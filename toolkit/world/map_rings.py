"""The raw values of a map file read and checked (cm): numbers, points, polygon rings, obstacles.

Each function takes what the YAML parser gave and either returns it as an array or raises a one-line
`MapError` naming `where` (the file and field) and the value at fault. `toolkit.world.map_parsing`
builds a `Map` from them; `toolkit.world.map_model` asks `check_obstacles` whether a map keeps the
simple file form.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import shapely

from .arrays import FloatArray
from .errors import MapError

__all__ = ["COORDINATE_LIMIT_CM", "check_obstacles", "check_simple", "read_number", "read_point",
           "read_region_ring", "read_ring", "read_rings"]

COORDINATE_LIMIT_CM = 1.0e6
"""Largest absolute map coordinate (cm, 10 km): far beyond any room, and far below where the
geometry's predicates lose their precision (shapely's break down near 1e154)."""


def read_number(value: Any, where: str) -> float:
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


def read_point(value: Any, where: str) -> FloatArray:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise MapError(f"{where}: expected a point [x, y], got {value!r}")
    return np.array([read_number(value[0], f"{where}[0]"), read_number(value[1], f"{where}[1]")])


def read_ring(value: Any, where: str) -> FloatArray:
    if not isinstance(value, list | tuple):
        raise MapError(f"{where}: expected a list of [x, y] vertices, got {type(value).__name__}")
    pts = [read_point(v, f"{where} vertex {i}") for i, v in enumerate(value)]
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
    check_simple(ring, where)
    if not shapely.Polygon(ring).area > 0.0:
        raise MapError(f"{where}: polygon has zero area")
    return ring


def check_simple(ring: FloatArray, where: str) -> None:
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


def read_rings(value: Any, where: str, what: str) -> tuple[FloatArray, ...]:
    if value is None:
        return ()
    if not isinstance(value, list):
        raise MapError(f"{where}: field '{what}' must be a list of polygons, got {type(value).__name__}")
    return tuple(read_ring(o, f"{where}: {what[:-1]} {k}") for k, o in enumerate(value))


def check_obstacles(label: str, boundary: FloatArray, obstacles: tuple[FloatArray, ...]) -> None:
    """The simple form's rule: obstacles strictly inside the boundary and apart from each other."""
    outer = shapely.Polygon(boundary)
    obs_polys = [shapely.Polygon(o) for o in obstacles]
    for k, op in enumerate(obs_polys):
        if not outer.contains(op) or outer.exterior.intersects(op):
            raise MapError(f"{label}: obstacle {k} is not strictly inside the boundary")
        for m in range(k):
            if op.intersects(obs_polys[m]):
                raise MapError(f"{label}: obstacles {m} and {k} overlap or touch")


def read_region_ring(value: Any, where: str) -> FloatArray:
    """A ring of the ``regions`` form: vectorised checks (the polygon's validity test does the rest).

    Anything unusual goes through `read_ring`, whose messages name the vertex at fault.
    """
    try:
        ring = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return read_ring(value, where)
    if ring.ndim != 2 or ring.shape[1] != 2 or not np.isfinite(ring).all() or isinstance(value, np.ndarray):
        return read_ring(value, where)
    if len(ring) >= 2 and np.array_equal(ring[0], ring[-1]):
        ring = ring[:-1]
    if len(ring) < 3 or (ring == np.roll(ring, -1, axis=0)).all(axis=1).any():
        return read_ring(value, where)
    if any(isinstance(c, bool) for v in value for c in v):
        return read_ring(value, where)
    return ring
