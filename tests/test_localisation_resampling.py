"""Resampling: unbiasedness (E[copies] = N w), filterpy's known defects and the workarounds."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
import scipy.linalg
from filterpy.kalman import MerweScaledSigmaPoints
from filterpy.monte_carlo import resampling as fp

from localisation.filterpy_variants import filterpy_resample, filterpy_rng, symmetric_cholesky
from localisation.resampling import RESAMPLERS
from toolkit.world import LocalisationError

SCHEMES = ("systematic", "stratified", "multinomial", "residual")
WEIGHTS = np.array([0.31, 0.02, 0.17, 0.0, 0.123, 0.077, 0.2, 0.1])


def _mean_copies(draw: Callable[[], np.ndarray], n: int, reps: int) -> np.ndarray:
    total = np.zeros(WEIGHTS.size)
    for _ in range(reps):
        idx = draw()
        assert idx.shape == (n,)
        assert idx.min() >= 0 and idx.max() < WEIGHTS.size
        total += np.bincount(idx, minlength=WEIGHTS.size)
    return total / reps


def _assert_unbiased(mean: np.ndarray, n: int, reps: int) -> None:
    expected = n * WEIGHTS / WEIGHTS.sum()
    # multinomial variance bounds every scheme's; 5 standard errors
    tol = 5.0 * np.sqrt(n * (WEIGHTS / WEIGHTS.sum()) * (1 - WEIGHTS / WEIGHTS.sum()) / reps) + 1e-9
    assert np.all(np.abs(mean - expected) <= tol), (mean, expected, tol)


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("n", [8, 5, 13])
def test_own_resamplers_unbiased(scheme: str, n: int) -> None:
    rng = np.random.default_rng(7)
    reps = 3000
    mean = _mean_copies(lambda: RESAMPLERS[scheme](WEIGHTS, n, rng), n, reps)
    _assert_unbiased(mean, n, reps)


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("n", [8, 5, 13])
def test_filterpy_resamplers_with_workarounds_unbiased(scheme: str, n: int) -> None:
    """filterpy's functions through our wrapper: unnormalised weights, any n, our Generator."""
    rng = np.random.default_rng(11)
    reps = 3000
    mean = _mean_copies(lambda: filterpy_resample(scheme, 3.7 * WEIGHTS, n, rng), n, reps)
    _assert_unbiased(mean, n, reps)


def test_filterpy_residual_resample_is_biased_and_workaround_is_not() -> None:
    """Upstream issue 290: the remainder is drawn from w - floor(N w) instead of N w - floor(N w)."""
    w = np.array([0.35, 0.35, 0.3])  # N w = 1.05, 1.05, 0.9: one copy each of 0 and 1, the third draw
    reps = 2000                      # should be particle 2 with probability 0.9
    np.random.seed(0)  # noqa: NPY002 - filterpy draws from the global state (defect 3)
    raw = np.mean([np.bincount(fp.residual_resample(w), minlength=3) for _ in range(reps)], axis=0)
    fixed = np.mean([np.bincount(filterpy_resample("residual", w, rng=np.random.default_rng(k)), minlength=3)
                     for k in range(reps)], axis=0)
    expected = 3 * w
    assert abs(raw[2] - expected[2]) > 0.5  # filterpy almost never picks particle 2 for the remainder
    assert np.all(np.abs(fixed - expected) < 0.05)


def test_filterpy_systematic_needs_normalised_weights() -> None:
    w = np.array([0.2, 0.2, 0.2])  # sums to 0.6
    with filterpy_rng(np.random.default_rng(0)), pytest.raises(IndexError):
        for _ in range(50):  # the pointer runs past the cumulative sum whenever it exceeds 0.6
            fp.systematic_resample(w)
    idx = filterpy_resample("systematic", w, rng=0)
    assert sorted(np.bincount(idx, minlength=3).tolist()) == [1, 1, 1]


@pytest.mark.parametrize("scheme", SCHEMES)
def test_filterpy_global_rng_is_replaced_by_ours(scheme: str) -> None:
    w = np.random.default_rng(3).random(50)
    w /= w.sum()
    # the defect: filterpy's output follows numpy's global state
    outs = []
    for seed in (1, 1, 2, 3, 4, 5):
        np.random.seed(seed)  # noqa: NPY002 - the defect under test
        outs.append(np.asarray(FP[scheme](w)))
    assert np.array_equal(outs[0], outs[1])
    assert any(not np.array_equal(outs[0], o) for o in outs[2:])
    # the workaround: the global state is neither used nor advanced; our seed decides
    state: Any = np.random.get_state()  # noqa: NPY002
    a = filterpy_resample(scheme, w, rng=5)
    b = filterpy_resample(scheme, w, rng=5)
    after: Any = np.random.get_state()  # noqa: NPY002
    assert np.array_equal(a, b)
    assert np.array_equal(state[1], after[1]) and state[2] == after[2]
    assert fp.random is np.random.random  # the module is restored


FP = {
    "systematic": fp.systematic_resample,
    "stratified": fp.stratified_resample,
    "multinomial": fp.multinomial_resample,
    "residual": fp.residual_resample,
}


def test_unknown_scheme_and_zero_weights() -> None:
    with pytest.raises(LocalisationError, match="unknown filterpy resampling"):
        filterpy_resample("roulette", WEIGHTS)
    with pytest.raises(LocalisationError, match="zero"):
        filterpy_resample("systematic", np.zeros(4))


def test_ukf_cholesky_on_asymmetric_covariance() -> None:
    """scipy's Cholesky reads the upper triangle: an asymmetric P fails (or is silently wrong)."""
    p = np.array([[1.0, 1.5, 0.0], [-1.3, 1.0, 0.0], [0.0, 0.0, 1.0]])  # symmetric part is positive definite
    default = MerweScaledSigmaPoints(3, alpha=0.3, beta=2.0, kappa=0.0)
    with pytest.raises(np.linalg.LinAlgError):
        default.sigma_points(np.zeros(3), p)
    fixed = MerweScaledSigmaPoints(3, alpha=0.3, beta=2.0, kappa=0.0, sqrt_method=symmetric_cholesky)
    sig = fixed.sigma_points(np.zeros(3), p)
    assert np.all(np.isfinite(sig))
    u = symmetric_cholesky(p)
    assert np.allclose(u.T @ u, 0.5 * (p + p.T))
    assert np.allclose(u, scipy.linalg.cholesky(0.5 * (p + p.T)))
