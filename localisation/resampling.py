"""Resampling functions (indices out, explicit ``rng``) and log-weight helpers.

Every function takes normalised or unnormalised non-negative weights (they are normalised here) and
returns ``n`` indices into them; randomness comes only from ``rng``. ``E[copies of i] = n * w_i`` for
all four schemes (checked statistically in the tests).

>>> systematic_resample([0.5, 0.5], n=4, rng=0).tolist()
[0, 0, 1, 1]
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from toolkit.world import LocalisationError, RngLike, as_rng
from toolkit.world.arrays import FloatArray, IntArray

__all__ = [
    "RESAMPLERS",
    "Resampler",
    "effective_sample_size",
    "log_normalise",
    "multinomial_resample",
    "normalise_weights",
    "residual_resample",
    "stratified_resample",
    "systematic_resample",
]

Resampler = Callable[[FloatArray, int, np.random.Generator], IntArray]


def normalise_weights(weights: ArrayLike) -> FloatArray:
    """Weights scaled to sum to one; raises `LocalisationError` when they are all zero or not finite."""
    w = np.asarray(weights, dtype=float).ravel()
    if w.size == 0:
        raise LocalisationError("cannot resample an empty set of weights")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise LocalisationError("weights must be finite and non-negative")
    total = w.sum()
    if not total > 0:
        raise LocalisationError("all weights are zero")
    return w / total


def log_normalise(log_weights: ArrayLike) -> FloatArray:
    """Normalised weights from log weights (log-sum-exp; -inf entries get weight 0).

    Raises `LocalisationError` when every log weight is -inf (or nan).
    """
    lw = np.asarray(log_weights, dtype=float).ravel()
    top = np.max(lw) if lw.size else -np.inf
    if not np.isfinite(top):
        raise LocalisationError("every particle has zero likelihood")
    w = np.exp(lw - top)
    return w / w.sum()


def effective_sample_size(weights: ArrayLike) -> float:
    """Kish's effective sample size 1 / sum(w^2) of normalised `weights`."""
    w = np.asarray(weights, dtype=float)
    return float(1.0 / np.sum(w * w))


def _n(w: FloatArray, n: int | None) -> int:
    return w.size if n is None else int(n)


def _search(cdf: FloatArray, u: FloatArray) -> IntArray:
    idx = np.searchsorted(cdf, u, side="right")
    return np.minimum(idx, cdf.size - 1).astype(np.int64)


def systematic_resample(weights: ArrayLike, n: int | None = None, rng: RngLike = None) -> IntArray:
    """Systematic (low-variance) resampling: one uniform offset, `n` evenly spaced pointers."""
    w = normalise_weights(weights)
    m = _n(w, n)
    u = (as_rng(rng).random() + np.arange(m)) / m
    return _search(np.cumsum(w), u)


def stratified_resample(weights: ArrayLike, n: int | None = None, rng: RngLike = None) -> IntArray:
    """Stratified resampling: one uniform pointer in each of `n` equal strata."""
    w = normalise_weights(weights)
    m = _n(w, n)
    u = (as_rng(rng).random(m) + np.arange(m)) / m
    return _search(np.cumsum(w), u)


def multinomial_resample(weights: ArrayLike, n: int | None = None, rng: RngLike = None) -> IntArray:
    """Multinomial resampling: `n` independent draws (sorted, so the output is ordered like the others)."""
    w = normalise_weights(weights)
    m = _n(w, n)
    u = np.sort(as_rng(rng).random(m))
    return _search(np.cumsum(w), u)


def residual_resample(weights: ArrayLike, n: int | None = None, rng: RngLike = None) -> IntArray:
    """Residual resampling: floor(n w_i) copies of each, the rest multinomially from n w_i - floor(n w_i)."""
    w = normalise_weights(weights)
    m = _n(w, n)
    copies = np.floor(m * w).astype(np.int64)
    det = np.repeat(np.arange(w.size, dtype=np.int64), copies)
    rest = m - det.size
    if rest == 0:
        return det
    residual = m * w - copies
    residual /= residual.sum()
    extra = _search(np.cumsum(residual), as_rng(rng).random(rest))
    return np.sort(np.concatenate([det, extra]))


RESAMPLERS: dict[str, Callable[..., IntArray]] = {
    "systematic": systematic_resample,
    "stratified": stratified_resample,
    "multinomial": multinomial_resample,
    "residual": residual_resample,
}
