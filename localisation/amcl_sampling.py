"""amcl's particle draws: resample-move of a new fix, KLD-sampling with augmented-MCL injection, and fresh
particles drawn uniformly or from the scan (`localisation.amcl` describes each): `ParticleDraws`, which `Amcl`
mixes in."""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from toolkit.world import Map, angle_diff, circular_mean, wrap_angle
from toolkit.world.arrays import FloatArray

from .adaptive import kld_bound
from .base import HeadingPrior
from .declarations import AmclOptions
from .models import RangeLattice, RangeTable
from .resampling import log_normalise, systematic_resample

__all__ = ["ParticleDraws"]


class ParticleDraws:
    """The particle draws of `localisation.amcl.Amcl`, a mixin: the annotations and abstract properties below
    are what the draws read and write of the filter (its options, its belief, its measurement model's helpers)."""

    map: Map
    options: AmclOptions
    rng: np.random.Generator
    particles: FloatArray
    log_weights: FloatArray
    _weighed: NDArray[np.bool_]
    injected: int
    kld_bin: FloatArray
    _ambiguous_fix: bool
    _heading_prior: HeadingPrior | None
    log_likelihood: Callable[[FloatArray, FloatArray, FloatArray], FloatArray]
    _log_heading_prior: Callable[[FloatArray], FloatArray | float]
    _free: Callable[[FloatArray, float], NDArray[np.bool_]]
    _lattice_costs: Callable[[FloatArray, FloatArray], FloatArray]

    @property
    @abstractmethod
    def table(self) -> RangeTable:
        """The range table (`localisation.models.RangeTable`) of the filter's map."""

    @property
    @abstractmethod
    def lattice(self) -> RangeLattice:
        """The lattice of poses the scan draws score."""

    @property
    @abstractmethod
    def injection_probability(self) -> float:
        """The probability that augmented MCL replaces a resampled particle by a fresh one."""

    def refine(self, rel: FloatArray, meas: FloatArray, ll: FloatArray) -> None:
        """Resample-move on a new fix: `refine_particles` draws from the weights, then `refine_steps`
        Metropolis moves targeting this scan's likelihood (times a first fix's heading prior; `ll` is that
        target at the particles), with step sizes shrinking from 2 cm / 2 degrees to 0.1 cm / 0.1 degrees.

        A new fix's particles came from the scan (a global start, or fresh particles that took over), so
        the prior is flat at the scale of the likelihood: the moves then sample the posterior of the fix
        instead of one lucky particle, and its spread tells how well the scan pins the pose.
        """
        w = log_normalise(np.where(self._weighed, self.log_weights, -np.inf))
        k = min(self.options.global_start.refine_particles, self.options.max_particles)
        idx = systematic_resample(w, k, self.rng)
        p, cur = self.particles[idx].copy(), ll[idx].copy()
        steps = self.options.global_start.refine_steps
        scales = np.geomspace(2.0, 0.1, steps) if steps > 1 else np.array([0.5])
        for sc in scales:
            d = np.column_stack([p[:, :2] - p[:, :2].mean(axis=0), angle_diff(p[:, 2], circular_mean(p[:, 2]))])
            cov = (2.38**2 / 3.0) * (d.T @ d) / k + np.diag([sc, sc, math.radians(sc)]) ** 2
            q = p + self.rng.standard_normal(p.shape) @ np.linalg.cholesky(cov).T
            q[:, 2] = wrap_angle(q[:, 2])
            new = self.log_likelihood(q, rel, meas) + self._log_heading_prior(q)
            with np.errstate(invalid="ignore"):
                accept = np.log(self.rng.random(k)) < new - cur
            p[accept], cur[accept] = q[accept], new[accept]
        self.particles = p
        self.log_weights = np.full(k, -math.log(k))
        self._weighed = np.ones(k, dtype=bool)


    def kld_resample(self, rel: FloatArray, meas: FloatArray) -> None:
        """KLD-sampling with augmented-MCL injection, vectorised over the `max_particles` candidates."""
        w = log_normalise(self.log_weights)
        o = self.options
        m = o.max_particles
        cdf = np.cumsum(w)
        cdf[-1] = max(cdf[-1], 1.0)
        cand = self.particles[np.searchsorted(cdf, self.rng.random(m), side="right").clip(0, w.size - 1)]
        p_inject = max(self.injection_probability, o.recovery.ambiguity_injection if self._ambiguous_fix else 0.0)
        fresh = self.rng.random(m) < p_inject if p_inject > 0 else np.zeros(m, dtype=bool)
        if fresh.any():
            k = int(fresh.sum())
            cand[fresh] = (self.scan_draws(k, rel, meas)[0] if o.recovery.recovery_sampler == "scan"
                           else self.uniform_poses(k))
        bins = np.floor(cand / self.kld_bin).astype(np.int64)
        _, first = np.unique(bins, axis=0, return_index=True)
        is_new = np.zeros(m, dtype=np.int64)
        is_new[first] = 1
        occupied = np.cumsum(is_new)  # bins occupied by the first n+1 candidates
        count = np.arange(1, m + 1)
        enough = (count >= kld_bound(occupied, o.kld.pf_err, o.kld.pf_z)) & (count >= o.min_particles)
        n = int(np.argmax(enough)) + 1 if enough.any() else m
        self.particles = cand[:n]
        self._weighed = ~fresh[:n]
        self.log_weights = np.full(n, -math.log(n))
        self.injected += int(fresh[:n].sum())


    def uniform_poses(self, n: int) -> FloatArray:
        xmin, ymin, xmax, ymax = self.map.bounds
        out: list[FloatArray] = []
        have = 0
        while have < n:
            cand = self.rng.uniform([xmin, ymin], [xmax, ymax], size=(2 * (n - have) + 64, 2))
            keep = cand[self._free(cand, self.options.global_start.clearance_cm)]
            out.append(keep)
            have += len(keep)
        xy = np.vstack(out)[:n]
        hp = self._heading_prior
        return np.column_stack([xy, self.rng.uniform(-math.pi, math.pi, n) if hp is None else hp.sample(n, self.rng)])


    def scan_draws(self, n: int, rel: FloatArray, meas: FloatArray) -> tuple[FloatArray, FloatArray]:
        """`n` poses drawn from the lattice scored against the scan, tempered to about `scan_sample_ess`
        effective candidates, jittered within their lattice cell and direction; and the log probability of
        each one's lattice pose under that draw (an importance weight divides by it)."""
        ssd = self._lattice_costs(rel, meas).ravel()
        top = min(20000, ssd.size)
        cand = np.argpartition(ssd, top - 1)[:top]
        s = ssd[cand] - ssd[cand].min()
        lo, hi = 1e-6, 1.0  # bisection on the temperature: the ESS falls as beta grows
        target = min(self.options.global_start.scan_sample_ess, top / 2)
        for _ in range(40):
            mid = math.sqrt(lo * hi)
            w = np.exp(-0.5 * mid * s)
            ess = w.sum() ** 2 / (w * w).sum()
            lo, hi = (mid, hi) if ess >= target else (lo, mid)
        w = np.exp(-0.5 * lo * s)
        drawn = systematic_resample(w / w.sum(), n, self.rng)
        log_q = -0.5 * lo * s[drawn] - math.log(float(w.sum()))
        cell, head = np.divmod(cand[drawn], self.table.n_angles)
        half = 0.5 * self.lattice.step * self.table.resolution_cm
        xy = self.lattice.xy[cell] + self.rng.uniform(-half, half, size=(n, 2))
        dth = math.pi / self.table.n_angles
        theta = wrap_angle(head * (2.0 * math.pi / self.table.n_angles) + self.rng.uniform(-dth, dth, size=n))
        return np.column_stack([xy, theta]), log_q
