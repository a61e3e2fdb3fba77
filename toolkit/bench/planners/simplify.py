"""Simplifying a planned path before it is driven, the same way for every planner.

Two methods, both validated by the shared `CollisionChecker` only:

- ``shortcut``: greedy waypoint shortcutting. From the first waypoint, jump to the farthest later
  waypoint joined to it by a free straight segment, and repeat from there. Deterministic; the result
  keeps a subset of the waypoints (so never longer than the input, by the triangle inequality).
- ``ompl``: OMPL's `PathSimplifier` (``simplifyMax``: vertex reduction, random shortcuts between
  points on the segments, collapsing close vertices, until nothing improves), seeded, for the path
  of any planner (`planners.ompl_planners.ompl_simplify`).

``none`` leaves the path as it is.
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from planners.ompl_planners import ompl_simplify

from ...world import CollisionChecker, ConfigError
from ...world.arrays import FloatArray

__all__ = ["SIMPLIFY_METHODS", "SimplifyMethod", "check_simplify", "shortcut_path", "simplify_path"]

SimplifyMethod = Literal["none", "shortcut", "ompl"]
SIMPLIFY_METHODS: tuple[SimplifyMethod, ...] = ("none", "shortcut", "ompl")


def check_simplify(method: str) -> SimplifyMethod:
    """`method` when it is one of `SIMPLIFY_METHODS`, else a `ConfigError` listing them."""
    if method not in SIMPLIFY_METHODS:
        raise ConfigError(f"simplify must be one of {', '.join(SIMPLIFY_METHODS)}, got {method!r}")
    return method


def shortcut_path(path: ArrayLike, checker: CollisionChecker) -> FloatArray:
    """Greedy waypoint shortcutting of a free path (see the module notes).

    Each step checks the segments from the current waypoint to all later ones in one batch.

    >>> from toolkit.world import load_map, make_checker
    >>> m = load_map("map1")
    >>> shortcut_path([[10, 50], [20, 50], [30, 50], [40, 50]], make_checker(m, 8.0)).tolist()
    [[10.0, 50.0], [30.0, 50.0], [40.0, 50.0]]
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 3:
        return p.copy()
    keep = [0]
    i = 0
    while i < len(p) - 1:
        later = p[i + 1:]
        free = np.asarray(checker.segments_free(np.repeat(p[i:i + 1], len(later), axis=0), later), dtype=bool)
        reach = np.flatnonzero(free)
        # the next waypoint is always reachable on a free path; guard against a path that is not
        i = i + 1 + (int(reach[-1]) if len(reach) else 0)
        keep.append(i)
    return p[keep].copy()


def simplify_path(method: SimplifyMethod, path: ArrayLike, checker: CollisionChecker,
                  bounds: tuple[float, float, float, float], seed: int) -> tuple[FloatArray, float]:
    """The path simplified by `method` and the time it took (s).

    Parameters
    ----------
    method : {"none", "shortcut", "ompl"}
    path : (k, 2) array_like
        A free path (cm).
    checker : CollisionChecker
        The shared checker (the only judge of free segments).
    bounds : (xmin, ymin, xmax, ymax)
        The map's bounds (OMPL's state space).
    seed : int
        Seed of OMPL's random shortcuts (``ompl`` only).
    """
    check_simplify(method)
    t0 = time.perf_counter()
    if method == "shortcut":
        out = shortcut_path(path, checker)
    elif method == "ompl":
        out = ompl_simplify(path, checker, bounds, seed)
    else:
        out = np.asarray(path, dtype=float).reshape(-1, 2).copy()
    return out, time.perf_counter() - t0
