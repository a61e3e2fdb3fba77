"""amcl's particle draws: resample-move of a new fix, KLD-sampling with augmented-MCL injection, and fresh
particles drawn uniformly or from the scan (`localisation.amcl` describes each; `Amcl` mixes them in)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from toolkit.world import angle_diff, circular_mean, wrap_angle

from .adaptive import kld_bound
from .resampling import log_normalise, systematic_resample

if TYPE_CHECKING:
    from .amcl import Amcl

__all__ = ["kld_resample", "refine", "scan_poses", "uniform_poses"]

FloatArray = NDArray[np.float64]


def refine(amcl: Amcl, rel: FloatArray, meas: FloatArray, ll: FloatArray) -> None:
    """Resample-move on a new fix: `refine_particles` draws from the weights, then `refine_steps`
    Metropolis moves targeting this scan's likelihood (times a first fix's heading prior; `ll` is that
    target at the particles), with step sizes shrinking from 2 cm / 2 degrees to 0.1 cm / 0.1 degrees.

    A new fix's particles came from the scan (a global start, or fresh particles that took over), so
    the prior is flat at the scale of the likelihood: the moves then sample the posterior of the fix
    instead of one lucky particle, and its spread tells how well the scan pins the pose.
    """
    w = log_normalise(np.where(amcl._weighed, amcl.log_weights, -np.inf))
    k = min(amcl.refine_particles, amcl.max_particles)
    idx = systematic_resample(w, k, amcl.rng)
    p, cur = amcl.particles[idx].copy(), ll[idx].copy()
    scales = np.geomspace(2.0, 0.1, amcl.refine_steps) if amcl.refine_steps > 1 else np.array([0.5])
    for sc in scales:
        d = np.column_stack([p[:, :2] - p[:, :2].mean(axis=0), angle_diff(p[:, 2], circular_mean(p[:, 2]))])
        cov = (2.38**2 / 3.0) * (d.T @ d) / k + np.diag([sc, sc, math.radians(sc)]) ** 2
        q = p + amcl.rng.standard_normal(p.shape) @ np.linalg.cholesky(cov).T
        q[:, 2] = wrap_angle(q[:, 2])
        new = amcl.log_likelihood(q, rel, meas) + amcl._log_heading_prior(q)
        with np.errstate(invalid="ignore"):
            accept = np.log(amcl.rng.random(k)) < new - cur
        p[accept], cur[accept] = q[accept], new[accept]
    amcl.particles = p
    amcl.log_weights = np.full(k, -math.log(k))
    amcl._weighed = np.ones(k, dtype=bool)


def kld_resample(amcl: Amcl, rel: FloatArray, meas: FloatArray) -> None:
    """KLD-sampling with augmented-MCL injection, vectorised over the `max_particles` candidates."""
    w = log_normalise(amcl.log_weights)
    m = amcl.max_particles
    cdf = np.cumsum(w)
    cdf[-1] = max(cdf[-1], 1.0)
    cand = amcl.particles[np.searchsorted(cdf, amcl.rng.random(m), side="right").clip(0, w.size - 1)]
    p_inject = max(amcl.injection_probability, amcl.ambiguity_injection if amcl._ambiguous_fix else 0.0)
    fresh = amcl.rng.random(m) < p_inject if p_inject > 0 else np.zeros(m, dtype=bool)
    if fresh.any():
        k = int(fresh.sum())
        cand[fresh] = (scan_poses(amcl, k, rel, meas) if amcl.recovery_sampler == "scan"
                       else uniform_poses(amcl, k))
    bins = np.floor(cand / amcl.kld_bin).astype(np.int64)
    _, first = np.unique(bins, axis=0, return_index=True)
    is_new = np.zeros(m, dtype=np.int64)
    is_new[first] = 1
    occupied = np.cumsum(is_new)  # bins occupied by the first n+1 candidates
    count = np.arange(1, m + 1)
    enough = (count >= kld_bound(occupied, amcl.pf_err, amcl.pf_z)) & (count >= amcl.min_particles)
    n = int(np.argmax(enough)) + 1 if enough.any() else m
    amcl.particles = cand[:n]
    amcl._weighed = ~fresh[:n]
    amcl.log_weights = np.full(n, -math.log(n))
    amcl.injected += int(fresh[:n].sum())


def uniform_poses(amcl: Amcl, n: int) -> FloatArray:
    xmin, ymin, xmax, ymax = amcl.map.bounds
    out: list[FloatArray] = []
    have = 0
    while have < n:
        cand = amcl.rng.uniform([xmin, ymin], [xmax, ymax], size=(2 * (n - have) + 64, 2))
        keep = cand[amcl._free(cand, amcl.clearance_cm)]
        out.append(keep)
        have += len(keep)
    xy = np.vstack(out)[:n]
    hp = amcl._heading_prior
    return np.column_stack([xy, amcl.rng.uniform(-math.pi, math.pi, n) if hp is None else hp.sample(n, amcl.rng)])


def scan_poses(amcl: Amcl, n: int, rel: FloatArray, meas: FloatArray) -> FloatArray:
    """`n` poses drawn from the lattice scored against the scan, tempered to about `scan_sample_ess`
    effective candidates, jittered within their lattice cell and direction."""
    ssd = amcl._lattice_costs(rel, meas).ravel()
    top = min(20000, ssd.size)
    cand = np.argpartition(ssd, top - 1)[:top]
    s = ssd[cand] - ssd[cand].min()
    lo, hi = 1e-6, 1.0  # bisection on the temperature: the ESS falls as beta grows
    target = min(amcl.scan_sample_ess, top / 2)
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        w = np.exp(-0.5 * mid * s)
        ess = w.sum() ** 2 / (w * w).sum()
        lo, hi = (mid, hi) if ess >= target else (lo, mid)
    w = np.exp(-0.5 * lo * s)
    idx = cand[systematic_resample(w / w.sum(), n, amcl.rng)]
    cell, head = np.divmod(idx, amcl.table.n_angles)
    half = 0.5 * amcl.lattice.step * amcl.table.resolution_cm
    xy = amcl.lattice.xy[cell] + amcl.rng.uniform(-half, half, size=(n, 2))
    dth = math.pi / amcl.table.n_angles
    theta = wrap_angle(head * (2.0 * math.pi / amcl.table.n_angles) + amcl.rng.uniform(-dth, dth, size=n))
    return np.column_stack([xy, theta])
