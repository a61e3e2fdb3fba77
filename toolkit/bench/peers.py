"""Peers measured beside the toolkit's exact planners in the scenario benchmark (optional extras).

``peer:pyastar2d`` (a C++ grid A*) runs on the map's cells with diagonal moves; ``peer:extremitypathfinder``
(a visibility-graph shortest path) on the polygon of the region holding the start. They are never
runtime dependencies: install them with ``pip install 'nxtnav[peers]'``. Their paths are checked
with the toolkit's point checker, so a peer path through a wall is reported as such, not counted.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from planners import PlanStatus

from ..world import Map, NxtnavError, PointCollisionChecker

__all__ = ["PEERS", "PEER_KIND", "peer_path"]

PEER_KIND = {"peer:pyastar2d": "octile", "peer:extremitypathfinder": "any-angle"}
PEERS = tuple(PEER_KIND)

_CACHE: dict[tuple[Any, ...], Any] = {}


def _import(name: str) -> Any:
    try:
        return __import__(name)
    except ImportError:
        raise NxtnavError(f"peer {name} is not installed: pip install 'nxtnav[peers]'") from None


def _pyastar2d(m: Map, checker: PointCollisionChecker, start: np.ndarray, goal: np.ndarray) -> np.ndarray | None:
    lib = _import("pyastar2d")
    key = ("pyastar2d", id(m))
    if key not in _CACHE:
        _CACHE[key] = np.where(checker.cells, 1.0, np.inf).astype(np.float32)
    weights = _CACHE[key]
    g = m.grid
    assert g is not None
    to_cell = lambda p: (int((p[1] - g.origin[1]) // g.cell_cm), int((p[0] - g.origin[0]) // g.cell_cm))  # noqa: E731
    path = lib.astar_path(weights, to_cell(start), to_cell(goal), allow_diagonal=True)
    if path is None:
        return None
    rc = np.asarray(path, dtype=float)
    return np.column_stack([g.origin[0] + (rc[:, 1] + 0.5) * g.cell_cm, g.origin[1] + (rc[:, 0] + 0.5) * g.cell_cm])


def _extremity(m: Map, checker: PointCollisionChecker, start: np.ndarray, goal: np.ndarray) -> np.ndarray | None:
    lib = _import("extremitypathfinder")
    k = m.region_of(start)
    if k < 0:
        return None
    key = ("extremitypathfinder", id(m), k)
    if key not in _CACHE:
        env = lib.PolygonEnvironment()
        region = m.regions[k]
        env.store(region.boundary, list(region.holes), validate=False)
        _CACHE[key] = env
    path, length = _CACHE[key].find_shortest_path(tuple(start), tuple(goal))
    if not path or length is None or not math.isfinite(length):
        return None
    return np.asarray(path, dtype=float)


def peer_path(name: str, m: Map, checker: PointCollisionChecker, start: np.ndarray,
              goal: np.ndarray) -> tuple[np.ndarray | None, PlanStatus, str]:
    """The peer's path (None when it finds none), a status and its detail; paths through walls are refused."""
    run = {"peer:pyastar2d": _pyastar2d, "peer:extremitypathfinder": _extremity}.get(name)
    if run is None:
        raise NxtnavError(f"unknown peer {name!r}; known: {', '.join(PEERS)}")
    try:
        path = run(m, checker, start, goal)
    except NxtnavError:
        raise
    except Exception as exc:  # a peer's crash is its result
        return None, PlanStatus.ERROR, f"peer error: {type(exc).__name__}: {exc}"
    if path is None:
        return None, PlanStatus.NO_PATH, ""
    if len(path) >= 2 and not checker.path_free(path):
        return None, PlanStatus.INVALID_PATH, "the peer's path leaves the free space"
    return path, PlanStatus.EXACT, ""
