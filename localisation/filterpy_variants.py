"""Localisers built on filterpy 2.0: the paper's particle filter with filterpy's resampling, EKF and UKF.

``pf-systematic``, ``pf-stratified``, ``pf-multinomial``, ``pf-residual``
    `ParticleFilter` (``paper-pf``) with its resampling step replaced by the function of the same
    name in ``filterpy.monte_carlo``. Everything else (lattice start, annealing, modes) is the same,
    so differences come from resampling alone.
``ekf``, ``ukf``
    Pose trackers on filterpy's ``ExtendedKalmanFilter`` and ``UnscentedKalmanFilter``: state
    (x cm, y cm, theta rad), the `MotionModel` for prediction, and a measurement of up to
    `max_beams` selected sonar ranges predicted by exact ray casting. They need a prior.

filterpy's defects and the workarounds here (docs/localisers.md, "filterpy 2.0 defects"; each is tested):

1. ``residual_resample`` is biased: it draws the remainder from ``w - floor(N w)`` instead of
   ``N w - floor(N w)`` (upstream issue 290); the remainder weights can be negative and the draw is
   not proportional to the weights. Workaround (`filterpy_residual`): keep filterpy's deterministic
   copies and draw the remainder with filterpy's ``multinomial_resample`` from the corrected
   ``N w - floor(N w)``.
2. ``systematic_resample`` and ``stratified_resample`` walk a cumulative sum they assume ends at 1:
   unnormalised weights raise IndexError (sum < 1) or bias the draw (sum > 1), and even normalised
   weights whose float cumulative sum ends just below 1 can run off the end. Workaround: normalise,
   and lift the cumulative sum to at least 1 (adding the round-off to the heaviest weight).
3. All four draw from numpy's global random state (``from numpy.random import random``). Workaround
   (`filterpy_rng`): while a filterpy function runs, the module's ``random`` is replaced by our
   Generator's ``random`` (under a lock), so results depend only on the localiser's ``rng``.
4. filterpy returns as many indices as there are weights. Workaround: to draw ``n`` indices, pad the
   weights with zeros to a multiple of ``n`` and, for systematic and stratified, keep every k-th of
   the sorted indices from a random start (exactly a systematic/stratified draw of size ``n``).
5. The UKF takes square roots of P with ``scipy.linalg.cholesky``, which reads only the upper
   triangle: a P made slightly asymmetric by the update ``P - K S K^T`` silently gives a wrong
   factor or fails. Workaround: P is symmetrised after every step and the square root symmetrises
   (and, if needed, adds diagonal jitter) before Cholesky (`symmetric_cholesky`).
6. The UKF's ``update`` uses the sigma points of the last ``predict``; after a reset with no
   predict they are zeros. Workaround: sigma points are regenerated from (x, P) before every update.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from toolkit.world import LocalisationError, Map, Options, Pose, RngLike, Scan, angle_diff, wrap_angle
from toolkit.world.arrays import FloatArray, IntArray

from .base import HeadingPrior, Localiser, Motion, PoseEstimate, Prior, RobotMapping
from .declarations import KALMAN_ROBOT, EkfOptions, KalmanOptions, UkfOptions
from .models import MotionModel, exact_ranges
from .particle_filter import ParticleFilter
from .resampling import normalise_weights

__all__ = [
    "FILTERPY_RESAMPLERS",
    "EkfLocaliser",
    "FilterpyParticleFilter",
    "KalmanLocaliser",
    "MultinomialPF",
    "ResidualPF",
    "StratifiedPF",
    "SystematicPF",
    "UkfLocaliser",
    "filterpy_resample",
    "filterpy_residual",
    "filterpy_rng",
    "symmetric_cholesky",
]

log = logging.getLogger(__name__)


_RNG_LOCK = threading.RLock()


def _filterpy_resampling() -> Any:
    """filterpy's resampling module, imported on first use: filterpy imports scipy.stats, which costs
    every `nxtnav` process over a second at start, and most never use a filterpy variant."""
    from filterpy.monte_carlo import resampling

    return resampling


@contextmanager
def filterpy_rng(rng: np.random.Generator) -> Iterator[None]:
    """Make filterpy's resampling functions draw from `rng` instead of numpy's global state.

    filterpy.monte_carlo.resampling imports ``random`` from ``numpy.random`` at module level; the
    module attribute is swapped for ``rng.random`` for the duration of the block (under a lock, so
    threads do not see each other's generator).
    """
    fp_resampling = _filterpy_resampling()
    with _RNG_LOCK:
        saved = fp_resampling.random
        fp_resampling.random = rng.random
        try:
            yield
        finally:
            fp_resampling.random = saved


def _lift_cumsum(w: FloatArray) -> FloatArray:
    """Normalised weights whose float cumulative sum ends at or above 1 (filterpy defect 2)."""
    w = normalise_weights(w).copy()
    for _ in range(4):
        c = float(np.cumsum(w)[-1])
        if c >= 1.0:
            break
        w[int(np.argmax(w))] += 1.0 - c + 1e-15
    return w


def filterpy_residual(weights: ArrayLike, n: int | None = None, rng: RngLike = None) -> IntArray:
    """Residual resampling through filterpy, with its remainder bias fixed (defect 1).

    The deterministic copies ``floor(n w)`` come from ``filterpy.monte_carlo.residual_resample``;
    the remainder is drawn with ``filterpy.monte_carlo.multinomial_resample`` from the corrected
    residual ``n w - floor(n w)``.
    """
    gen = np.random.default_rng(rng) if not isinstance(rng, np.random.Generator) else rng
    w = normalise_weights(weights)
    m = w.size if n is None else int(n)
    copies = np.floor(m * w).astype(np.int64)
    k = int(copies.sum())
    if m >= w.size:
        wp = np.concatenate([w, np.zeros(m - w.size)])
        with filterpy_rng(gen), np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            det = np.asarray(_filterpy_resampling().residual_resample(wp), dtype=np.int64)[:k]
    else:  # filterpy makes len(weights) draws; with fewer wanted, the same deterministic part by hand
        det = np.repeat(np.arange(w.size, dtype=np.int64), copies)
    rest = m - k
    if rest == 0:
        return np.sort(det)
    residual = m * w - copies
    residual = residual / residual.sum()
    if residual.size < rest:
        residual = np.concatenate([residual, np.zeros(rest - residual.size)])
    with filterpy_rng(gen):
        extra = np.asarray(_filterpy_resampling().multinomial_resample(residual), dtype=np.int64)[:rest]
    return np.sort(np.concatenate([det, np.minimum(extra, w.size - 1)]))


FILTERPY_RESAMPLERS: dict[str, str] = {
    "systematic": "systematic_resample",
    "stratified": "stratified_resample",
    "multinomial": "multinomial_resample",
    "residual": "residual_resample",
}
"""Each scheme's function in ``filterpy.monte_carlo.resampling``, by name."""


def filterpy_resample(scheme: str, weights: ArrayLike, n: int | None = None, rng: RngLike = None) -> IntArray:
    """`n` indices by filterpy's `scheme` resampling, with the workarounds of the module docstring.

    Parameters
    ----------
    scheme : {"systematic", "stratified", "multinomial", "residual"}
    weights : array_like
        Non-negative weights (need not be normalised).
    n : int, optional
        Indices wanted (default: as many as weights).
    rng : None, int or Generator
        The only source of randomness.
    """
    gen = np.random.default_rng(rng) if not isinstance(rng, np.random.Generator) else rng
    if scheme == "residual":
        return filterpy_residual(weights, n, gen)
    if scheme not in FILTERPY_RESAMPLERS:
        raise LocalisationError(f"unknown filterpy resampling {scheme!r}; known: {', '.join(FILTERPY_RESAMPLERS)}")
    w = _lift_cumsum(np.asarray(weights, dtype=float))
    size = w.size
    m = size if n is None else int(n)
    if m < 1:
        raise LocalisationError(f"cannot draw {m} indices")
    stride = 1 if m >= size else math.ceil(size / m)
    length = max(m * stride, size)
    wp = np.concatenate([w, np.zeros(length - size)])
    with filterpy_rng(gen):
        idx = np.asarray(getattr(_filterpy_resampling(), FILTERPY_RESAMPLERS[scheme])(wp), dtype=np.int64)
    if stride > 1:
        if scheme == "multinomial":
            idx = idx[:m]
        else:
            idx = np.sort(idx)[int(gen.integers(stride))::stride][:m]
    return np.minimum(idx, size - 1)


class FilterpyParticleFilter(ParticleFilter):
    """`ParticleFilter` resampling with a filterpy function (subclasses set `scheme`)."""

    scheme: ClassVar[str] = "systematic"

    def resample(self, weights: FloatArray, n: int) -> IntArray:
        return filterpy_resample(self.scheme, weights, n, self.rng)


class SystematicPF(FilterpyParticleFilter):
    """The paper's PF with ``filterpy.monte_carlo.systematic_resample``."""

    name: ClassVar[str] = "pf-systematic"
    scheme: ClassVar[str] = "systematic"


class StratifiedPF(FilterpyParticleFilter):
    """The paper's PF with ``filterpy.monte_carlo.stratified_resample``."""

    name: ClassVar[str] = "pf-stratified"
    scheme: ClassVar[str] = "stratified"


class MultinomialPF(FilterpyParticleFilter):
    """The paper's PF with ``filterpy.monte_carlo.multinomial_resample``."""

    name: ClassVar[str] = "pf-multinomial"
    scheme: ClassVar[str] = "multinomial"


class ResidualPF(FilterpyParticleFilter):
    """The paper's PF with ``filterpy.monte_carlo.residual_resample`` (remainder bias fixed)."""

    name: ClassVar[str] = "pf-residual"
    scheme: ClassVar[str] = "residual"


# -- Kalman trackers --------------------------------------------------------------------------------


def symmetric_cholesky(p: ArrayLike) -> FloatArray:
    """Upper Cholesky factor of the symmetric part of `p`, with diagonal jitter if needed (defect 5)."""
    a = np.asarray(p, dtype=float)
    a = 0.5 * (a + a.T)
    jitter = 0.0
    scale = max(float(np.max(np.abs(np.diag(a)))), 1e-12)
    for _ in range(8):
        try:
            import scipy.linalg  # imported here for the same reason as filterpy

            return np.asarray(scipy.linalg.cholesky(a + jitter * np.eye(a.shape[0])))
        except np.linalg.LinAlgError:
            jitter = scale * 1e-9 if jitter == 0.0 else jitter * 100.0
    raise LocalisationError("covariance is not positive definite even after symmetrising")


def _state_residual(a: ArrayLike, b: ArrayLike) -> FloatArray:
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    d[2] = angle_diff(np.asarray(a, dtype=float)[2], np.asarray(b, dtype=float)[2])
    return d


def _state_mean(sigmas: ArrayLike, wm: ArrayLike) -> FloatArray:
    s = np.asarray(sigmas, dtype=float)
    w = np.asarray(wm, dtype=float)
    return np.array([float(np.dot(w, s[:, 0])), float(np.dot(w, s[:, 1])),
                     float(np.arctan2(np.dot(w, np.sin(s[:, 2])), np.dot(w, np.cos(s[:, 2]))))])


def _state_add(x: ArrayLike, dx: ArrayLike) -> FloatArray:
    out = np.asarray(x, dtype=float) + np.asarray(dx, dtype=float)
    out[2] = wrap_angle(out[2])
    return out


class KalmanLocaliser(Localiser):
    """Shared parts of the EKF and UKF pose trackers.

    Parameters
    ----------
    map : Map
    options : KalmanOptions, optional
        The options of the subclass's model (`localisation.declarations.EkfOptions`, `UkfOptions`; None:
        the defaults): ``sensor.sensor_sigma_cm`` (R), the motion model (Q, linearised), ``sensor.max_beams``
        ranges per update (evenly chosen among the valid readings), ``sensor.gate_cm`` (readings further
        than this from the predicted range are left out: corners, outliers), ``min_process_var`` (the
        floor of Q on every predict: cm^2, cm^2, rad^2) and the convergence thresholds.
    rng : None, int or Generator
        Unused (the filters are deterministic); kept for the common constructor.
    **overrides
        Options on top of `options`, by dotted path or by the name of one field.
    """

    needs_prior: ClassVar[bool] = True
    robot_options: ClassVar[RobotMapping | None] = KALMAN_ROBOT

    def __init__(self, map: Map, options: KalmanOptions | None = None, *, rng: RngLike = None,
                 **overrides: Any) -> None:
        super().__init__(map, rng=rng)
        o: KalmanOptions = self.configure(options, overrides)
        self.options = o
        sensor = o.sensor
        self.sensor_sigma_cm, self.max_beams, self.gate_cm = sensor.sensor_sigma_cm, sensor.max_beams, sensor.gate_cm
        m = o.motion
        self.motion_model = MotionModel(m.noise_model, m.motion_noise, m.turn_noise, m.motion_inflation)
        self.min_process_var = np.asarray(o.min_process_var, dtype=float)
        self.converged_xy_cm = o.convergence.converged_xy_cm
        self.converged_heading_rad = math.radians(o.convergence.converged_heading_deg)
        self.iterations = 0
        self._ready = False

    # subclasses provide the filterpy object and these hooks
    def _get(self) -> tuple[FloatArray, FloatArray]:
        raise NotImplementedError

    def _set(self, x: FloatArray, p: FloatArray) -> None:
        raise NotImplementedError

    def _require(self) -> None:
        if not self._ready:
            raise LocalisationError(f"{self.name} is a pose tracker: reset it with a prior first")

    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        if prior is None:
            raise LocalisationError(f"{self.name} is a pose tracker and needs a prior (reset(prior=Prior(...)))")
        if isinstance(prior, HeadingPrior):
            raise LocalisationError(f"{self.name} is a pose tracker: a heading prior gives it no position to start "
                                    "from (reset(prior=Prior(...)))")
        self.iterations = 0
        cov = np.asarray(prior.cov, dtype=float)
        self._set(prior.mean.as_array(), 0.5 * (cov + cov.T))
        self._ready = True

    def _q(self, x: FloatArray, motion: Motion) -> FloatArray:
        q = self.motion_model.covariance(x, motion)
        return 0.5 * (q + q.T) + np.diag(self.min_process_var)

    def _hx(self, x: ArrayLike, rel: FloatArray) -> FloatArray:
        r = exact_ranges(self.map, np.asarray(x, dtype=float)[None, :], rel)[0]
        return np.where(np.isfinite(r), r, 1e4)

    def _select(self, scan: Scan) -> tuple[FloatArray, FloatArray]:
        """Up to `max_beams` valid readings, evenly spread, gated against the current prediction."""
        ok = scan.valid & np.isfinite(scan.ranges)
        rel = np.asarray(scan.angles[ok], dtype=float)
        z = np.asarray(scan.ranges[ok], dtype=float)
        if z.size > self.max_beams:
            pick = np.linspace(0, z.size - 1, self.max_beams).round().astype(np.int64)
            rel, z = rel[pick], z[pick]
        x, _ = self._get()
        near = np.abs(self._hx(x, rel) - z) <= self.gate_cm
        return rel[near], z[near]

    def estimate(self) -> PoseEstimate:
        self._require()
        x, p = self._get()
        p = 0.5 * (p + p.T)
        conv = bool(math.sqrt(max(p[0, 0] + p[1, 1], 0.0)) < self.converged_xy_cm
                    and math.sqrt(max(p[2, 2], 0.0)) < self.converged_heading_rad)
        return PoseEstimate(Pose(float(x[0]), float(x[1]), float(x[2])), p, conv, self.iterations)


class EkfLocaliser(KalmanLocaliser):
    """Pose tracker on ``filterpy.kalman.ExtendedKalmanFilter`` (see the module docstring).

    The motion is nonlinear, so ``predict_x`` is overridden with `MotionModel.mean` and F is its
    Jacobian; the measurement Jacobian is taken by central differences of the ray-cast ranges.
    """

    name: ClassVar[str] = "ekf"
    options_model: ClassVar[type[Options] | None] = EkfOptions

    def __init__(self, map: Map, options: EkfOptions | None = None, *, rng: RngLike = None,
                 **overrides: Any) -> None:
        super().__init__(map, options, rng=rng, **overrides)
        o: EkfOptions = self.options  # type: ignore[assignment]
        self.jacobian_step = np.asarray(o.jacobian_step, dtype=float)
        self.kf = _motion_ekf_class()(self.motion_model)

    def _get(self) -> tuple[FloatArray, FloatArray]:
        return np.asarray(self.kf.x, dtype=float).ravel(), np.asarray(self.kf.P, dtype=float)

    def _set(self, x: FloatArray, p: FloatArray) -> None:
        self.kf.x = np.asarray(x, dtype=float).reshape(3, 1).copy()
        self.kf.P = np.asarray(p, dtype=float).copy()

    def predict(self, motion: Motion) -> None:
        self._require()
        x, _ = self._get()
        th = x[2] + motion.turn_rad
        d = motion.distance_cm
        self.kf.F = np.array([[1.0, 0.0, -d * math.sin(th)], [0.0, 1.0, d * math.cos(th)], [0.0, 0.0, 1.0]])
        self.kf.Q = self._q(x, motion)
        self.kf.predict(u=motion)
        self.kf.P = 0.5 * (self.kf.P + self.kf.P.T)

    def _jacobian(self, x: ArrayLike, rel: FloatArray) -> FloatArray:
        x0 = np.asarray(x, dtype=float).ravel()
        h = np.zeros((rel.size, 3))
        for i in range(3):
            e = np.zeros(3)
            e[i] = self.jacobian_step[i]
            h[:, i] = (self._hx(x0 + e, rel) - self._hx(x0 - e, rel)) / (2.0 * e[i])
        return h

    def update(self, scan: Scan) -> None:
        self._require()
        rel, z = self._select(scan)
        if z.size == 0:
            log.info("ekf: no reading within the gate; belief unchanged")
            return
        self.kf.dim_z = z.size  # filterpy keeps dim_z fixed; the number of beams changes per scan
        self.kf.update(z.reshape(-1, 1), lambda x: self._jacobian(x, rel),
                       lambda x: self._hx(np.asarray(x).ravel(), rel).reshape(-1, 1),
                       R=np.eye(z.size) * self.sensor_sigma_cm**2)
        self.kf.x[2, 0] = wrap_angle(self.kf.x[2, 0])
        self.kf.P = 0.5 * (self.kf.P + self.kf.P.T)
        self.iterations += 1


@functools.cache
def _motion_ekf_class() -> type:
    """filterpy's EKF with the nonlinear motion of `MotionModel` as ``predict_x`` (a class made on first
    use, so that importing this module does not import filterpy)."""
    from filterpy.kalman import ExtendedKalmanFilter

    class MotionEKF(ExtendedKalmanFilter):
        def __init__(self, model: MotionModel) -> None:
            super().__init__(dim_x=3, dim_z=1)
            self.model = model

        def predict_x(self, u: Any = 0) -> None:
            motion = u if isinstance(u, Motion) else Motion()
            state: Any = self.x  # type: ignore[has-type]  # filterpy assigns x without annotations
            self.x = self.model.mean(np.array(state, dtype=np.float64).ravel(), motion).reshape(3, 1)

    return MotionEKF


class UkfLocaliser(KalmanLocaliser):
    """Pose tracker on ``filterpy.kalman.UnscentedKalmanFilter`` with Merwe scaled sigma points.

    Angle-aware state mean (circular heading), residual and addition; P symmetrised after every
    step and square roots through `symmetric_cholesky`.
    """

    name: ClassVar[str] = "ukf"
    options_model: ClassVar[type[Options] | None] = UkfOptions

    def __init__(self, map: Map, options: UkfOptions | None = None, *, rng: RngLike = None,
                 **overrides: Any) -> None:
        super().__init__(map, options, rng=rng, **overrides)
        sp = self.options.sigma_points  # type: ignore[attr-defined]
        from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

        points = MerweScaledSigmaPoints(3, alpha=sp.alpha, beta=sp.beta, kappa=sp.kappa,
                                        sqrt_method=symmetric_cholesky, subtract=_state_residual)
        self.kf = UnscentedKalmanFilter(dim_x=3, dim_z=1, dt=1.0, hx=None, fx=self._fx, points=points,
                                        sqrt_fn=symmetric_cholesky, x_mean_fn=_state_mean,
                                        residual_x=_state_residual, state_add=_state_add)

    def _fx(self, x: FloatArray, dt: float, motion: Motion | None = None) -> FloatArray:
        return self.motion_model.mean(x, motion or Motion())

    def _get(self) -> tuple[FloatArray, FloatArray]:
        return np.asarray(self.kf.x, dtype=float).ravel(), np.asarray(self.kf.P, dtype=float)

    def _set(self, x: FloatArray, p: FloatArray) -> None:
        self.kf.x = np.asarray(x, dtype=float).ravel().copy()
        self.kf.P = np.asarray(p, dtype=float).copy()

    def predict(self, motion: Motion) -> None:
        self._require()
        x, _ = self._get()
        self.kf.Q = self._q(x, motion)
        self.kf.predict(motion=motion)
        self.kf.P = 0.5 * (self.kf.P + self.kf.P.T)

    def update(self, scan: Scan) -> None:
        self._require()
        rel, z = self._select(scan)
        if z.size == 0:
            log.info("ukf: no reading within the gate; belief unchanged")
            return
        # filterpy's update reuses the sigma points of the last predict: regenerate them (defect 6)
        self.kf.sigmas_f = self.kf.points_fn.sigma_points(self.kf.x, self.kf.P)
        self.kf._dim_z = z.size
        self.kf.update(z, R=np.eye(z.size) * self.sensor_sigma_cm**2, hx=lambda s: self._hx(s, rel))
        self.kf.x[2] = wrap_angle(self.kf.x[2])
        self.kf.P = 0.5 * (self.kf.P + self.kf.P.T)
        self.iterations += 1

