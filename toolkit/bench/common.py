"""Helpers the benchmarks share: the median of the finite values and a per-process map cache."""

from __future__ import annotations

import math
from collections.abc import Iterable
from functools import lru_cache

import numpy as np

from ..world import Map, load_map

__all__ = ["cached_map", "finite_median"]


def finite_median(values: Iterable[float | None]) -> float:
    """Median of the finite values (None and NaN mark a failed run); NaN when there are none.

    >>> finite_median([3.0, None, float("nan"), 1.0, 2.0]), math.isnan(finite_median([]))
    (2.0, True)
    """
    a = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    return float(np.median(a)) if a.size else math.nan


@lru_cache(maxsize=32)
def cached_map(name: str) -> Map:
    """`load_map(name)`, loaded once per process (benchmark tasks run many times on the same maps)."""
    return load_map(name)
