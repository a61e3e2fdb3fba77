"""The paper's particle filter (``paper-pf``), made fast.

The paper fills the map with random particles, weighs each by a Gaussian likelihood of the difference
between the ranges it would read and the robot's readings, reallocates particles around the heavy ones
and iterates until the cloud narrows. This implementation keeps that loop and makes it quick and
robust:

* weights live in log space (`RangeLikelihood`), so hundreds of beams never underflow;
* expected ranges come from a precomputed `RangeTable` (1 cm cells x 360 directions per map, built
  once and cached), vectorised over particles and beams;
* the iterations on one scan are an annealing schedule: iteration ``m`` weighs the particles by the
  likelihood raised to ``beta_m`` (chosen so that the effective sample size stays near a target),
  resamples (systematic by default) and jitters the copies with a kernel that shrinks with the cloud.
  ``beta`` reaches 1 (the true sensor noise) before the filter may declare convergence;
* distinct modes (symmetric places, such as the identical rooms of map3) are kept apart: each mode is
  resampled on its own and the filter reports ``converged = False`` while more than one mode is
  plausible, so the localisation procedure moves and rescans.

Beyond the paper: a kidnapped robot is detected when no particle explains the scan (mean squared
normalised residual above a threshold) and the filter restarts globally.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from toolkit.world import LocalisationError, Map, Pose, RngLike, Scan, angle_diff, circular_mean, wrap_angle

from .base import Localiser, Motion, PoseEstimate, Prior
from .models import MotionModel, RangeLikelihood, RangeTable, exact_ranges, range_table
from .resampling import effective_sample_size, log_normalise, systematic_resample

__all__ = ["Mode", "ParticleFilter", "Snapshot"]

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The cloud after one filter iteration (for plots and traces).

    Attributes
    ----------
    particles : (n, 3) ndarray
        x cm, y cm, theta rad (a subsample of at most the requested size).
    weights : (n,) ndarray
        Normalised weights of those particles.
    beta : float
        Tempering exponent of the iteration (1 = the full likelihood).
    estimate : PoseEstimate
    """

    particles: FloatArray
    weights: FloatArray
    beta: float
    estimate: PoseEstimate

    def to_dict(self) -> dict[str, Any]:
        return {
            "particles": np.column_stack([self.particles[:, :2], np.degrees(self.particles[:, 2])]).tolist(),
            "weights": self.weights.tolist(),
            "beta": self.beta,
            "estimate": self.estimate.to_dict(),
        }


@dataclass(frozen=True)
class Mode:
    """One cluster of the particle cloud: its mean pose, total weight and best log-likelihood."""

    pose: Pose
    weight: float
    best_log_likelihood: float
    count: int

    def to_dict(self) -> dict[str, Any]:
        return {"pose": self.pose.to_list_deg(), "weight": self.weight,
                "best_log_likelihood": self.best_log_likelihood, "count": self.count}


def _cloud_stats(p: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Weighted mean pose (3,) and covariance (3, 3) with a circular heading."""
    mx = float(np.dot(w, p[:, 0]))
    my = float(np.dot(w, p[:, 1]))
    mt = float(circular_mean(p[:, 2], w))
    d = np.column_stack([p[:, 0] - mx, p[:, 1] - my, angle_diff(p[:, 2], mt)])
    dw = d * w[:, None]
    # einsum rather than a BLAS matmul: a (3, N) x (N, 3) product is dominated by thread start-up
    cov = np.einsum("ni,nj->ij", dw, d)
    return np.array([mx, my, mt]), 0.5 * (cov + cov.T)


class ParticleFilter(Localiser):
    """The paper's particle filter with annealed iterations on each scan (see the module docstring).

    Parameters
    ----------
    map : Map
    rng : None, int or Generator
    n_particles : int
        Particles kept between scans and in the refining iterations.
    n_global : int
        Particles drawn uniformly over the free space for a global start.
    clearance_cm : float
        Particles are drawn at least this far from every wall (the robot radius).
    sensor_sigma_cm : float
        Standard deviation of a range reading (cm); the paper's simulations use 1 cm.
    residual_cap : float
        Largest residual one beam may contribute, in standard deviations (robustness to outliers).
    noise_model, motion_noise, turn_noise : str, float, float
        Motion noise as the robot's (`MotionModel`): ``botsim`` (proportional, the paper's 0.1 and
        0.005) or ``absolute``.
    motion_inflation : float
        Factor on the motion noise when predicting (> 1 tolerates unmodelled slip).
    ess_target : float
        Fraction of the particles the effective sample size is kept at when choosing ``beta``.
    max_iterations : int
        Iterations per scan at most.
    converged_xy_cm, converged_heading_deg : float
        The cloud counts as converged when sqrt(var x + var y) and the heading standard deviation
        are below these (and only one mode is left).
    global_beams : int
        Beams (evenly chosen) used in the first iteration of a global start, where the cloud is
        widest and the tempered likelihood is coarse.
    max_modes : int
        Modes tracked at most.
    mode_radius_cm, mode_heading_deg : float
        Particles within both of a mode's best particle belong to that mode.
    ambiguity_nats : float
        A mode stays plausible while its best log-likelihood (at beta 1) is within this of the best
        mode's; below it, it is dropped.
    recovery_threshold : float or None
        When the best particle's mean squared normalised residual exceeds this, the filter restarts
        globally (kidnapped robot); None disables it.
    use_table : bool
        Expected ranges from the precomputed `RangeTable` (fast) or exact ray casting (slow).
    table_resolution_cm, table_angles : float, int
        Cell size and directions of the table.
    refine_exact : bool
        Run the last iterations with exact ray casting (removes the table's quantisation).
    cache_dir : path, optional
        Disk cache for the table (see `range_table`).
    snapshot_size : int
        Particles kept per iteration in `snapshots` (0 disables snapshots).
    """

    name: ClassVar[str] = "paper-pf"
    resampler_name: ClassVar[str] = "systematic"

    def __init__(
        self,
        map: Map,
        *,
        rng: RngLike = None,
        n_particles: int = 1000,
        n_global: int = 20000,
        clearance_cm: float = 8.0,
        sensor_sigma_cm: float = 1.0,
        residual_cap: float = 5.0,
        noise_model: str = "botsim",
        motion_noise: float = 0.1,
        turn_noise: float = 0.005,
        motion_inflation: float = 1.5,
        ess_target: float = 0.5,
        max_iterations: int = 40,
        converged_xy_cm: float = 1.5,
        converged_heading_deg: float = 2.0,
        global_beams: int = 48,
        max_modes: int = 6,
        mode_radius_cm: float = 10.0,
        mode_heading_deg: float = 20.0,
        ambiguity_nats: float = 30.0,
        recovery_threshold: float | None = 9.0,
        use_table: bool = True,
        table_resolution_cm: float = 1.0,
        table_angles: int = 360,
        refine_exact: bool = False,
        cache_dir: str | None = None,
        snapshot_size: int = 300,
    ) -> None:
        super().__init__(map, rng=rng)
        if n_particles < 10 or n_global < n_particles:
            raise ValueError(f"need 10 <= n_particles <= n_global, got {n_particles}, {n_global}")
        if not 0.0 < ess_target < 1.0:
            raise ValueError(f"ess_target must be in (0, 1), got {ess_target}")
        if max_iterations < 1:
            raise ValueError(f"max_iterations must be >= 1, got {max_iterations}")
        self.n_particles = int(n_particles)
        self.n_global = int(n_global)
        self.clearance_cm = float(clearance_cm)
        self.likelihood = RangeLikelihood(sensor_sigma_cm, residual_cap)
        self.motion_model = MotionModel(noise_model, motion_noise, turn_noise, motion_inflation)
        self.ess_target = float(ess_target)
        self.max_iterations = int(max_iterations)
        self.converged_xy_cm = float(converged_xy_cm)
        self.converged_heading_rad = math.radians(converged_heading_deg)
        self.global_beams = int(global_beams)
        self.max_modes = int(max_modes)
        self.mode_radius_cm = float(mode_radius_cm)
        self.mode_heading_rad = math.radians(mode_heading_deg)
        self.ambiguity_nats = float(ambiguity_nats)
        self.recovery_threshold = recovery_threshold
        self.use_table = bool(use_table)
        self.refine_exact = bool(refine_exact)
        self.snapshot_size = int(snapshot_size)
        self.table: RangeTable | None = (
            range_table(map, table_resolution_cm, table_angles, cache_dir) if use_table else None
        )
        self.particles: FloatArray = np.zeros((0, 3))
        self.log_weights: FloatArray = np.zeros(0)
        self.labels: IntArray = np.zeros(0, dtype=np.int64)
        self.snapshots: list[Snapshot] = []
        self.iterations = 0
        self.restarts = 0
        self._global = True
        self._converged = False
        self._modes: list[Mode] = []
        self._estimate: PoseEstimate | None = None
        self.reset()

    # -- the resampling scheme (filterpy variants override this) ---------------------------------
    def resample(self, weights: FloatArray, n: int) -> IntArray:
        """`n` indices drawn according to normalised `weights` (systematic resampling)."""
        return systematic_resample(weights, n, self.rng)

    # -- Localiser interface ------------------------------------------------------------------------
    def reset(self, prior: Prior | None = None) -> None:
        self.snapshots = []
        self.iterations = 0
        self._converged = False
        self._modes = []
        if prior is None:
            self._reset_global()
        else:
            cov = np.asarray(prior.cov, dtype=float)
            p = self.rng.multivariate_normal(prior.mean.as_array(), 0.5 * (cov + cov.T), self.n_particles)
            p[:, 2] = wrap_angle(p[:, 2])
            self.particles = p
            self.log_weights = np.full(self.n_particles, -math.log(self.n_particles))
            self.labels = np.zeros(self.n_particles, dtype=np.int64)
            self._global = False
        self._estimate = self._make_estimate()

    def _reset_global(self) -> None:
        xy = self._sample_free(self.n_global)
        theta = self.rng.uniform(-math.pi, math.pi, self.n_global)
        self.particles = np.column_stack([xy, theta])
        self.log_weights = np.full(self.n_global, -math.log(self.n_global))
        self.labels = np.zeros(self.n_global, dtype=np.int64)
        self._global = True

    def _sample_free(self, n: int) -> FloatArray:
        if self.table is None:
            return self.map.sample_free(n, self.clearance_cm, self.rng)
        xmin, ymin, xmax, ymax = self.map.bounds
        frac = max(self.map.free_space(0).area / ((xmax - xmin) * (ymax - ymin)), 1e-3)
        out: list[FloatArray] = []
        have = 0
        while have < n:
            m = int((n - have) / frac * 1.5) + 64
            cand = self.rng.uniform([xmin, ymin], [xmax, ymax], size=(m, 2))
            keep = cand[self.table.free(cand, self.clearance_cm)]
            out.append(keep)
            have += len(keep)
        return np.vstack(out)[:n]

    def predict(self, motion: Motion) -> None:
        if motion.turn_rad == 0.0 and motion.distance_cm == 0.0:
            return
        self.particles = self.motion_model.sample(self.particles, motion, self.rng)
        self._global = False
        self._converged = False
        self._estimate = self._make_estimate()

    def update(self, scan: Scan) -> None:
        ok = scan.valid & np.isfinite(scan.ranges)
        rel = np.asarray(scan.angles[ok], dtype=float)
        meas = np.asarray(scan.ranges[ok], dtype=float)
        if meas.size == 0:
            log.warning("scan without usable readings: belief unchanged")
            return
        if not self._global and self.recovery_threshold is not None and self._lost(rel, meas):
            log.info("no particle explains the scan: restarting global localisation")
            self.restarts += 1
            self._reset_global()
        self._iterate(rel, meas)

    def estimate(self) -> PoseEstimate:
        if self._estimate is None:
            self._estimate = self._make_estimate()
        return self._estimate

    # -- extras -------------------------------------------------------------------------------------
    @property
    def modes(self) -> list[Mode]:
        """The plausible modes after the last update (more than one: the belief is ambiguous)."""
        return list(self._modes)

    @property
    def ambiguous(self) -> bool:
        return len(self._modes) > 1

    @property
    def weights(self) -> FloatArray:
        return log_normalise(self.log_weights)

    # -- internals ----------------------------------------------------------------------------------
    def _sq_residuals(self, poses: FloatArray, rel: FloatArray, meas: FloatArray, exact: bool = False) -> FloatArray:
        """Summed capped squared normalised residuals per pose; inf for poses outside the free space."""
        if self.table is None or exact:
            expected = exact_ranges(self.map, poses, rel)
            s = self.likelihood.sq_residuals(expected, meas)
            inside = np.asarray(self.map.contains(poses[:, :2]), dtype=bool)
        else:
            expected32, inside = self.table.lookup(poses, rel)
            s = self.likelihood.sq_residuals(expected32, meas)
        return np.where(inside, s, np.inf)

    def _lost(self, rel: FloatArray, meas: FloatArray) -> bool:
        s = self._sq_residuals(self.particles, rel, meas)
        best = float(np.min(s)) / meas.size
        return not best <= float(self.recovery_threshold or np.inf)

    def _next_beta(self, log_w: FloatArray, s: FloatArray, beta: float) -> float:
        """Largest beta' in (beta, 1] whose incremental weights keep the ESS at or above the target."""
        finite = np.isfinite(s) & np.isfinite(log_w)
        n_target = self.ess_target * np.count_nonzero(finite)
        s0 = np.where(finite, s, np.inf)

        def ess(b: float) -> float:
            return effective_sample_size(log_normalise(log_w - 0.5 * (b - beta) * s0))

        if ess(1.0) >= n_target:
            return 1.0
        a, b = beta, 1.0
        for _ in range(40):
            mid = math.sqrt(max(a, 1e-12) * b) if a > 0 else (1e-9 if b > 1e-8 else 0.5 * b)
            if ess(mid) >= n_target:
                a = mid
            else:
                b = mid
            if b - a <= 1e-3 * b:
                break
        return max(a, beta + 1e-9)

    def _iterate(self, rel: FloatArray, meas: FloatArray) -> None:
        """Annealed SMC on one scan: reweigh by a likelihood increment, resample, move (Metropolis)."""
        p = self.particles
        log_w = self.log_weights
        n_beams = meas.size
        typical_range = float(np.median(meas))
        clear = max(self.clearance_cm - 1.0, 0.0)
        if self._global and n_beams > self.global_beams:
            sub = np.linspace(0, n_beams - 1, self.global_beams).round().astype(np.int64)
            s = self._sq_residuals(p, rel[sub], meas[sub]) * (n_beams / sub.size)
            subset = True
        else:
            s = self._sq_residuals(p, rel, meas)
            subset = False
        if not np.isfinite(s).any():
            raise LocalisationError("every particle lies outside the free space of the map")
        beta = 0.0
        self._converged = False
        self._modes = []
        for _ in range(self.max_iterations):
            new_beta = self._next_beta(log_w, s, beta)
            log_w = log_w - 0.5 * (new_beta - beta) * s
            beta = new_beta
            w = log_normalise(log_w)
            self.iterations += 1
            self.particles, self.log_weights = p, np.log(np.maximum(w, 1e-300))
            mean, cov = _cloud_stats(p, w)
            if beta >= 1.0:
                self._modes = self._find_modes(p, w, s)
                narrow = (math.sqrt(cov[0, 0] + cov[1, 1]) < self.converged_xy_cm
                          and math.sqrt(cov[2, 2]) < self.converged_heading_rad)
                self._converged = narrow and len(self._modes) <= 1
            self._record(p, w, beta, mean, cov)
            if self._converged:
                break
            # resample
            n = self.n_particles
            idx = self.resample(w, n)
            p, s = p[idx], s[idx]
            log_w = np.full(n, -math.log(n))
            if subset:
                s = self._sq_residuals(p, rel, meas)
                subset = False
            # Metropolis move with a jitter kernel that shrinks with the cloud and the tempered likelihood
            std_xy = math.sqrt(max(cov[0, 0] + cov[1, 1], 0.0) / 2.0)
            std_th = math.sqrt(max(cov[2, 2], 0.0))
            sigma_b = self.likelihood.sigma_cm / math.sqrt(beta)
            local_xy = 2.0 * sigma_b / math.sqrt(n_beams)
            j_xy = max(min(0.5 * std_xy, local_xy), 0.02)
            j_th = max(min(0.5 * std_th, 2.0 * local_xy / max(typical_range, 1.0)), math.radians(0.05))
            q = p + self.rng.standard_normal(p.shape) * np.array([j_xy, j_xy, j_th])
            q[:, 2] = wrap_angle(q[:, 2])
            s_q = self._sq_residuals(q, rel, meas)
            if self.table is not None and clear > 0:
                s_q = np.where(self.table.free(q[:, :2], clear), s_q, np.inf)
            accept = np.log(self.rng.random(n)) < -0.5 * beta * (s_q - s)
            p = np.where(accept[:, None], q, p)
            s = np.where(accept, s_q, s)
        self._global = False
        self._estimate = self._make_estimate()

    def _find_modes(self, p: FloatArray, w: FloatArray, s: FloatArray) -> list[Mode]:
        return []

    def _record(self, p: FloatArray, w: FloatArray, beta: float, mean: FloatArray, cov: FloatArray) -> None:
        if self.snapshot_size <= 0:
            return
        est = PoseEstimate(Pose.from_array(mean), cov, self._converged, self.iterations)
        if p.shape[0] > self.snapshot_size:
            pick = np.linspace(0, p.shape[0] - 1, self.snapshot_size).round().astype(np.int64)
            sp, sw = p[pick], w[pick] / max(w[pick].sum(), 1e-300)
        else:
            sp, sw = p, w
        self.snapshots.append(Snapshot(sp.copy(), sw.copy(), float(beta), est))

    def _estimate_from(self, p: FloatArray, w: FloatArray) -> PoseEstimate:
        mean, cov = _cloud_stats(p, w)
        return PoseEstimate(Pose.from_array(mean), cov, self._converged, self.iterations)

    def _make_estimate(self) -> PoseEstimate:
        return self._estimate_from(self.particles, log_normalise(self.log_weights))
