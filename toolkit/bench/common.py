"""Helpers the benchmarks share: a per-process map cache, and the median of the finite values
(`toolkit.world.arrays.finite_median`, re-exported here)."""

from __future__ import annotations

from functools import lru_cache

from ..world import Map, load_map
from ..world.arrays import finite_median

__all__ = ["cached_map", "finite_median"]


@lru_cache(maxsize=32)
def cached_map(name: str) -> Map:
    """`load_map(name)`, loaded once per process (benchmark tasks run many times on the same maps)."""
    return load_map(name)
