"""The modes of a weighted particle cloud: its mean and covariance, greedy clusters and their spreads."""

from __future__ import annotations

import math

import numpy as np

from toolkit.world import Pose, angle_diff, circular_mean
from toolkit.world.arrays import FloatArray, IntArray

from .base import Mode

__all__ = ["cloud_stats", "cluster", "describe_modes", "in_mode", "mode_stds", "spread"]


def cloud_stats(p: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Weighted mean pose (3,) and covariance (3, 3) with a circular heading."""
    mx = float(np.dot(w, p[:, 0]))
    my = float(np.dot(w, p[:, 1]))
    mt = float(circular_mean(p[:, 2], w))
    d = np.column_stack([p[:, 0] - mx, p[:, 1] - my, angle_diff(p[:, 2], mt)])
    dw = d * w[:, None]
    # einsum rather than a BLAS matmul: a (3, N) x (N, 3) product is dominated by thread start-up
    cov = np.einsum("ni,nj->ij", dw, d)
    return np.array([mx, my, mt]), 0.5 * (cov + cov.T)


def spread(cov: FloatArray) -> tuple[float, float]:
    """The spread of a pose covariance (3, 3): sqrt(var x + var y) (cm) and the heading's standard deviation
    (rad), each at least 0."""
    return math.sqrt(max(cov[0, 0] + cov[1, 1], 0.0)), math.sqrt(max(cov[2, 2], 0.0))


def mode_stds(p: FloatArray, w: FloatArray, labels: IntArray, keep: IntArray) -> FloatArray:
    """(K, 2) spread of each kept mode: sqrt(var x + var y) (cm) and heading std (rad)."""
    out = np.zeros((keep.size, 2))
    for i, k in enumerate(keep):
        members = labels == k
        wk = w[members]
        wk = wk / wk.sum() if wk.sum() > 0 else np.full(wk.size, 1.0 / wk.size)
        _, c = cloud_stats(p[members], wk)
        out[i] = spread(c)
    return out


def in_mode(p: FloatArray, centre: FloatArray, radius_cm: float, heading_rad: float) -> np.ndarray:
    """Which poses of `p` (N, 3) lie in one mode around `centre` (x, y, theta): within `radius_cm` (cm) and
    `heading_rad` of it."""
    near = (p[:, 0] - centre[0]) ** 2 + (p[:, 1] - centre[1]) ** 2 <= radius_cm**2
    return near & (np.abs(angle_diff(p[:, 2], centre[2])) <= heading_rad)


def cluster(p: FloatArray, log_w: FloatArray, radius_cm: float, heading_rad: float,
            max_modes: int) -> tuple[IntArray, FloatArray]:
    """Greedy clustering: the heaviest unassigned particle seeds a mode of its neighbours.

    Returns a label per particle (-1: in none of the `max_modes` clusters) and the clusters' log
    weights (log-sum-exp of their members' log weights, so a twin of negligible weight is still
    seen).
    """
    labels = np.full(p.shape[0], -1, dtype=np.int64)
    log_masses: list[float] = []
    order = np.argsort(-log_w, kind="stable")
    free = np.isfinite(log_w)
    pos = 0
    for k in range(max_modes):
        while pos < order.size and not free[order[pos]]:
            pos += 1
        if pos >= order.size:
            break
        member = free & in_mode(p, p[order[pos]], radius_cm, heading_rad)
        labels[member] = k
        free &= ~member
        lw = log_w[member]
        top = float(lw.max())
        log_masses.append(top + math.log(float(np.exp(lw - top).sum())))
    return labels, np.asarray(log_masses, dtype=float)


def describe_modes(p: FloatArray, w: FloatArray, s: FloatArray, labels: IntArray, keep: IntArray) -> list[Mode]:
    modes = []
    total = sum(float(w[labels == k].sum()) for k in keep)
    for k in keep:
        members = labels == k
        wk = w[members]
        mass = float(wk.sum())
        wk = wk / mass if mass > 0 else np.full(wk.size, 1.0 / wk.size)
        mean, _ = cloud_stats(p[members], wk)
        modes.append(Mode(Pose.from_array(mean), mass / total,
                          float(-0.5 * np.min(s[members])), int(members.sum())))
    return sorted(modes, key=lambda md: -md.weight)
