"""The steps of one annealed iteration of the paper's particle filter (`localisation.particle_filter`).

Each iteration on a scan weighs the cloud by a likelihood increment, groups it into modes
(`split_modes`), resamples each mode on its own (`resample_modes`) and moves the copies with a
Metropolis kernel that shrinks with the modes' spread (`metropolis_move`). Positions are in cm,
headings in rad, residuals are summed capped squared normalised residuals per particle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from toolkit.world import wrap_angle
from toolkit.world.arrays import FloatArray, IntArray

from .annealing import GaussianPrior, log_prior
from .clusters import cluster

__all__ = ["ModeSplit", "MoveKernel", "metropolis_move", "resample_modes", "split_modes"]


class ModeSplit(NamedTuple):
    """The cloud grouped into modes after a reweighing.

    Attributes
    ----------
    labels : IntArray
        Each particle's mode.
    log_masses : FloatArray
        Each mode's log weight (before the modes are judged).
    clustered : bool
        Whether the heaviest modes hold enough of the weight to be tracked apart.
    keep : IntArray
        The modes kept (plausible ones once ``beta`` reaches 1); empty when not `clustered`.
    log_mode_w : FloatArray
        The kept modes' log weights (their best fit once ``beta`` reaches 1).
    log_w : FloatArray
        The particles' log weights, the dropped modes' at minus infinity.
    """

    labels: IntArray
    log_masses: FloatArray
    clustered: bool
    keep: IntArray
    log_mode_w: FloatArray
    log_w: FloatArray


def split_modes(p: FloatArray, log_w: FloatArray, s: FloatArray, beta: float, prior: GaussianPrior | None, *,
                radius_cm: float, heading_rad: float, max_modes: int, coverage: float,
                ambiguity_nats: float) -> ModeSplit:
    """Group the particles `p` (n, 3) into modes and, once they hold `coverage` of the weight, keep
    the plausible ones: at ``beta >= 1`` those whose best fit (log-likelihood from the residuals `s`,
    plus the log `prior` when tracking) is within `ambiguity_nats` of the best mode's."""
    labels, log_masses = cluster(p, log_w, radius_cm, heading_rad, max_modes)
    total = math.log(float(np.exp(log_w).sum()))
    clustered = bool(np.exp(log_masses - total).sum() >= coverage)
    keep = np.zeros(0, dtype=np.int64)
    log_mode_w = np.zeros(0)
    if clustered:
        # a mode's fit: its best particle's log-likelihood (plus log prior when tracking,
        # so that a mode far out in the predicted belief's tail does not count as a twin)
        fit = -0.5 * s + log_prior(prior, p)
        best_ll = np.array([float(np.max(fit[labels == k])) for k in range(log_masses.size)])
        ok = np.isfinite(log_masses)
        if beta >= 1.0:
            # judge the modes by their best fit: twins fit alike, and their weights are too
            # noisy to judge by; the plausible ones then get weights from the fit alone.
            ok &= best_ll >= np.max(best_ll[ok]) - ambiguity_nats
        keep = np.flatnonzero(ok)
        log_mode_w = best_ll[keep] if beta >= 1.0 else log_masses[keep]
        inside = np.isin(labels, keep)
        log_w = np.where(inside, log_w, -np.inf)
        for lmk, k in zip(log_mode_w, keep, strict=True):
            mk = labels == k
            log_w[mk] += lmk - log_masses[k]
    return ModeSplit(labels, log_masses, clustered, keep, log_mode_w, log_w)


def resample_modes(w: FloatArray, split: ModeSplit, stds: FloatArray, *, n_particles: int, mode_share: float,
                   resample: Callable[[FloatArray, int], IntArray]) -> tuple[IntArray, FloatArray, FloatArray]:
    """Resample each kept mode on its own, keeping its weight (the mode survives resampling).

    Each kept mode gets an equal part of `mode_share` of the `n_particles` plus a part of the rest in
    proportion to its weight, so a symmetric twin is not lost to resampling noise. Returns the
    indices, the new log weights (mode log weight - log copies) and each new particle's mode spread
    (cm, rad: for the jitter).
    """
    keep = split.keep
    lm = split.log_mode_w - np.max(split.log_mode_w)
    lm = lm - math.log(float(np.exp(lm).sum()))
    floor = max(int(mode_share * n_particles) // keep.size, 10)
    counts = np.maximum(np.rint(np.exp(lm) * n_particles * (1.0 - mode_share)).astype(np.int64), 0)
    counts += floor
    idx_parts: list[IntArray] = []
    lw_parts: list[FloatArray] = []
    std_parts: list[FloatArray] = []
    for i, (k, ck) in enumerate(zip(keep, counts, strict=True)):
        members = np.flatnonzero(split.labels == k)
        wk = w[members]
        sub = wk / wk.sum() if wk.sum() > 0 else np.full(members.size, 1.0 / members.size)
        idx_parts.append(members[resample(sub, int(ck))])
        lw_parts.append(np.full(int(ck), lm[i] - math.log(int(ck))))
        std_parts.append(np.broadcast_to(stds[i], (int(ck), 2)))
    return np.concatenate(idx_parts), np.concatenate(lw_parts), np.concatenate(std_parts)


@dataclass(frozen=True)
class MoveKernel:
    """What bounds the Metropolis jitter on one scan.

    Attributes
    ----------
    sigma_cm : float
        The sensor's standard deviation (cm), widened by ``1 / sqrt(beta)`` at each iteration.
    n_beams : int
        Readings in the scan.
    typical_range_cm : float
        The median reading (cm): a heading step moves the far end of a beam by about this times it.
    cap_xy_cm, cap_heading_rad : float
        Largest steps (after a lattice start: a lattice cell and a table direction; else infinite).
    """

    sigma_cm: float
    n_beams: int
    typical_range_cm: float
    cap_xy_cm: float
    cap_heading_rad: float

    def scale(self, beta: float, j_std: FloatArray) -> FloatArray:
        """The jitter's standard deviations (x, y in cm, heading in rad) per particle for spreads `j_std`."""
        local_xy = 2.0 * (self.sigma_cm / math.sqrt(beta)) / math.sqrt(self.n_beams)
        j_xy = np.maximum(np.minimum(np.minimum(0.5 * j_std[:, 0] / math.sqrt(2.0), local_xy), self.cap_xy_cm), 0.02)
        j_th = np.maximum(np.minimum(np.minimum(0.5 * j_std[:, 1], 2.0 * local_xy / max(self.typical_range_cm, 1.0)),
                                     self.cap_heading_rad), math.radians(0.05))
        return np.column_stack([j_xy, j_xy, j_th])


def metropolis_move(p: FloatArray, s: FloatArray, scale: FloatArray, beta: float, prior: GaussianPrior | None,
                    score: Callable[[FloatArray], FloatArray],
                    rng: np.random.Generator) -> tuple[FloatArray, FloatArray]:
    """One Metropolis step of every particle: propose a Gaussian jitter of `scale`, accept it by the
    tempered likelihood (``beta``) times the `prior`; `score` gives a proposal's residuals (inf where
    it may not stand). Returns the particles and their residuals."""
    q = p + rng.standard_normal(p.shape) * scale
    q[:, 2] = wrap_angle(q[:, 2])
    s_q = score(q)
    with np.errstate(invalid="ignore"):  # inf - inf: both outside, rejected below
        log_ratio = -0.5 * beta * (s_q - s) + (log_prior(prior, q) - log_prior(prior, p))
    accept = np.log(rng.random(p.shape[0])) < log_ratio
    return np.where(accept[:, None], q, p), np.where(accept, s_q, s)
