"""Array type aliases and small array helpers shared by every layer (one definition each).

`toolkit.world` is the bottom layer: planners, localisers, robots, the mission and the benchmarks
import these from here rather than writing them again.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

__all__ = ["FloatArray", "IntArray", "finite_median", "normal_cdf"]

FloatArray = NDArray[np.float64]
"""An array of float64 values (cm, rad, s, ... as the name of the variable says)."""

IntArray = NDArray[np.int64]
"""An array of int64 values (indices, counts, tacho degrees)."""


def finite_median(values: Iterable[float | None]) -> float:
    """Median of the finite values (None, NaN and infinities are left out); NaN when there are none.

    Parameters
    ----------
    values : iterable of float or None, or array
        The values, in whatever unit they carry (the median keeps it); None or NaN marks a failed run.

    Returns
    -------
    float
        The median of the finite values, or NaN.

    >>> finite_median([3.0, None, float("nan"), 1.0, 2.0]), math.isnan(finite_median([]))
    (2.0, True)
    """
    if isinstance(values, np.ndarray):
        a = values.astype(float).ravel()
    else:
        a = np.array([math.nan if v is None else v for v in values], dtype=float)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if a.size else math.nan


def normal_cdf(x: FloatArray) -> FloatArray:
    """The standard normal distribution's CDF at each of `x` (``scipy.special.ndtr``; scipy.special is
    imported on the first call, not with `toolkit.world`: it costs every process a third of a second)."""
    from scipy.special import ndtr

    return np.asarray(ndtr(x), dtype=np.float64)
