"""AMCL's adaptive parts: how many particles a belief needs (KLD-sampling, Fox 2003) and the running
averages of the measurement likelihood that decide when to inject random particles (augmented MCL,
Thrun, Burgard and Fox, Probabilistic Robotics, ch. 8), all in log space.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from toolkit.world.arrays import FloatArray

__all__ = ["kld_bound", "log_blend", "log_mean_exp"]


def kld_bound(k: Any, pf_err: float, pf_z: float) -> NDArray[np.int64]:
    """Particles needed for `k` occupied bins (Fox 2003, with nav2's use of `pf_z`; 0 for k <= 1).

    Examples
    --------
    >>> [int(n) for n in kld_bound([1, 2, 10, 100], 0.05, 0.99)]
    [0, 20, 131, 1129]
    """
    kk = np.asarray(k, dtype=float)
    km1 = np.maximum(kk - 1.0, 1.0)
    b = 2.0 / (9.0 * km1)
    x = 1.0 - b + np.sqrt(b) * pf_z
    n = np.ceil(km1 / (2.0 * pf_err) * x**3)
    return np.where(kk <= 1, 0, n).astype(np.int64)


def log_mean_exp(x: FloatArray) -> float:
    """log(mean(exp(x))) without overflow; -inf when every value is -inf.

    >>> round(log_mean_exp(np.log(np.array([1.0, 3.0]))), 12) == round(math.log(2.0), 12)
    True
    """
    top = float(np.max(x))
    if not math.isfinite(top):
        return -math.inf
    return top + math.log(float(np.mean(np.exp(x - top))))


def log_blend(log_a: float, log_b: float, alpha: float) -> float:
    """log((1 - alpha) a + alpha b) from log a and log b."""
    if alpha <= 0:
        return log_a
    terms = [v for v in (math.log1p(-alpha) + log_a if alpha < 1 else -math.inf, math.log(alpha) + log_b)
             if math.isfinite(v)]
    if not terms:
        return -math.inf
    top = max(terms)
    return top + math.log(sum(math.exp(t - top) for t in terms))
