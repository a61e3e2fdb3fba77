"""Steps of paper-pf's annealed iterations that need no filter state: the next temperature, the
predicted belief as Gaussians, and the best lattice poses of a global start.

`ParticleFilter` (``paper-pf``) calls them; they are functions of arrays so that they can be read,
tested and reused on their own.
"""

from __future__ import annotations

import math

import numpy as np

from toolkit.world import angle_diff, wrap_angle
from toolkit.world.arrays import FloatArray, IntArray

from .base import HeadingPrior
from .clusters import cloud_stats, cluster
from .models import RangeLattice, RangeTable
from .resampling import effective_sample_size, log_normalise

__all__ = ["GaussianPrior", "best_lattice_poses", "heading_gaussian", "log_prior", "next_beta", "predicted_prior"]


GaussianPrior = list[tuple[FloatArray, FloatArray, float]]
"""A mixture of Gaussians over poses: (mean, inverse covariance, log coefficient) per component."""


def next_beta(log_w: FloatArray, s: FloatArray, beta: float, ess_target: float,
              groups: IntArray | None = None) -> float:
    """Largest beta' in (beta, 1] whose incremental weights keep the ESS at or above the target.

    `s` holds each particle's summed squared normalised residuals, so that the increment from beta
    to beta' multiplies its weight by exp(-(beta' - beta) s / 2); `ess_target` is a fraction of the
    particles. With `groups` (the mode of each particle), the ESS of every mode must stay at the
    target, so that a light twin mode is refined as carefully as the heavy one.

    >>> s = np.array([0.0, 10.0, 20.0, 30.0])
    >>> b = next_beta(np.zeros(4), s, 0.0, 0.5)
    >>> 0.0 < b < 1.0, next_beta(np.zeros(4), np.zeros(4), 0.0, 0.5)
    (True, 1.0)
    """
    finite = np.isfinite(s) & np.isfinite(log_w)
    s0 = np.where(finite, s, np.inf)
    if groups is None:
        parts = [np.arange(s.size)]
    else:
        parts = [np.flatnonzero(groups == g) for g in np.unique(groups)]
    parts = [ix for ix in parts if np.isfinite(s0[ix]).any()]
    targets = [ess_target * np.count_nonzero(finite[ix]) for ix in parts]

    def ok(b: float) -> bool:
        return all(
            effective_sample_size(log_normalise(log_w[ix] - 0.5 * (b - beta) * s0[ix])) >= t
            for ix, t in zip(parts, targets, strict=True)
        )

    if ok(1.0):
        return 1.0
    a, b = beta, 1.0
    for _ in range(40):
        mid = math.sqrt(max(a, 1e-12) * b) if a > 0 else (1e-9 if b > 1e-8 else 0.5 * b)
        if ok(mid):
            a = mid
        else:
            b = mid
        if b - a <= 1e-3 * b:
            break
    return max(a, beta + 1e-9)


def heading_gaussian(prior: HeadingPrior) -> tuple[FloatArray, FloatArray, float]:
    """A `HeadingPrior` as one component of a `GaussianPrior`: no information on the position (a zero
    inverse variance), the heading's Gaussian.

    >>> hp = HeadingPrior(0.5, 0.1)
    >>> float(log_prior([heading_gaussian(hp)], np.array([[30.0, -7.0, 0.6]]))[0])  # doctest: +ELLIPSIS
    -0.5...
    """
    inv = np.diag([0.0, 0.0, 1.0 / prior.sd_rad**2])
    return np.array([0.0, 0.0, prior.heading_rad]), inv, 0.0


def predicted_prior(particles: FloatArray, log_weights: FloatArray, per_mode: bool, mode_radius_cm: float,
                    mode_heading_rad: float, max_modes: int) -> GaussianPrior:
    """Gaussians fitted to a (predicted) cloud.

    One for the whole cloud, or with `per_mode` one per cluster of the cloud (`cluster`, the modes'
    radius and heading), each with the log of its weight over the square root of its covariance's
    determinant, so that their mixture is the predicted belief. Each covariance gets a floor of
    (0.05 cm)^2 and (0.05 degree)^2, so that a cloud collapsed to nearly one pose still leaves the
    moves room.
    """
    floor = np.diag([0.05**2, 0.05**2, math.radians(0.05) ** 2])
    w = log_normalise(log_weights)
    if not per_mode:
        mean, cov = cloud_stats(particles, w)
        return [(mean, np.asarray(np.linalg.inv(cov + floor), dtype=np.float64), 0.0)]
    labels, log_masses = cluster(particles, log_weights, mode_radius_cm, mode_heading_rad, max_modes)
    out = []
    for k, lm in enumerate(log_masses):
        members = labels == k
        wk = w[members]
        if not np.isfinite(lm) or wk.sum() <= 0:
            continue
        mean, cov = cloud_stats(particles[members], wk / wk.sum())
        cov = cov + floor
        out.append((mean, np.asarray(np.linalg.inv(cov), dtype=np.float64),
                    float(lm) - 0.5 * float(np.linalg.slogdet(cov)[1])))
    return out


def log_prior(prior: GaussianPrior | None, x: FloatArray) -> FloatArray | float:
    """Log density (up to a constant) of the mixture `prior` at poses `x` (n, 3); 0 without a prior.

    >>> prior = [(np.zeros(3), np.eye(3), 0.0)]
    >>> log_prior(prior, np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])).tolist(), log_prior(None, np.zeros((1, 3)))
    ([0.0, -0.5], 0.0)
    """
    if prior is None:
        return 0.0
    terms = []
    for mean, inv, coef in prior:
        d = np.column_stack([x[:, 0] - mean[0], x[:, 1] - mean[1], angle_diff(x[:, 2], mean[2])])
        terms.append(coef - 0.5 * np.einsum("ni,ij,nj->n", d, inv, d))
    if len(terms) == 1:
        return terms[0]
    t = np.vstack(terms)
    top = t.max(axis=0)
    return top + np.log(np.exp(t - top).sum(axis=0))


def best_lattice_poses(lattice: RangeLattice, table: RangeTable, costs: FloatArray, k: int,
                       mode_radius_cm: float, mode_heading_rad: float,
                       rng: np.random.Generator) -> tuple[FloatArray, tuple[float, float]]:
    """The `k` lattice poses that fit a scan best (lowest `costs`, (cells, directions) from
    `localisation.beam_model.lattice_costs`), each jittered within its lattice cell and direction.

    At most ``max(4, k // 100)`` come from each coarse bin of `mode_radius_cm` x `mode_heading_rad`,
    so that a twin slightly worse on the lattice is not crowded out by the best mode's neighbours.
    Returns the (k', 3) poses (k' <= k) and the half cell and direction step (cm, rad) that bound
    the first moves (narrow optima must not be diffused away).
    """
    ssd = np.asarray(costs).ravel()
    n_ang = table.n_angles
    k = min(k, ssd.size)
    m = min(20 * k, ssd.size)
    cand = np.argpartition(ssd, m - 1)[:m]
    cand = cand[np.argsort(ssd[cand], kind="stable")]
    c_cell, c_head = np.divmod(cand, n_ang)
    xy = lattice.xy[c_cell]
    bx = np.floor(xy[:, 0] / mode_radius_cm).astype(np.int64)
    by = np.floor(xy[:, 1] / mode_radius_cm).astype(np.int64)
    bh = (c_head * (360 // n_ang if n_ang <= 360 else 1)) // max(int(math.degrees(mode_heading_rad)), 1)
    bins = (bx * 100_003 + by) * 1009 + bh
    order = np.argsort(bins, kind="stable")
    sb = bins[order]
    start = np.r_[0, np.flatnonzero(np.diff(sb)) + 1]
    rank = np.arange(sb.size) - np.repeat(start, np.diff(np.r_[start, sb.size]))
    keep = np.zeros(cand.size, dtype=bool)
    keep[order[rank < max(4, k // 100)]] = True
    best = cand[keep][:k]
    k = best.size
    cell, head = np.divmod(best, n_ang)
    half = 0.5 * lattice.step * table.resolution_cm
    xy = lattice.xy[cell] + rng.uniform(-half, half, size=(k, 2))
    dth = math.pi / n_ang
    theta = wrap_angle(head * (2.0 * math.pi / n_ang) + rng.uniform(-dth, dth, size=k))
    return np.column_stack([xy, theta]), (half, 2.0 * dth)
