"""Ambiguous beliefs said plainly: the candidate poses of a localiser whose belief has several modes.

A global localiser in a symmetric place (a point-symmetric room, map3's identical rooms) may hold
several equally good hypotheses. Its mean pose then lies between them and means nothing; the honest
answer is "ambiguous: N candidate poses" with the poses. Localisers that track modes (the particle
filters' ``modes``) report them; the others never call themselves ambiguous.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from toolkit.world import Pose, angle_diff, wrap_angle

from .base import Localiser, Mode
from .clusters import in_mode

__all__ = ["CANDIDATE_RADIUS_CM", "candidate_poses", "confidently_wrong", "describe_candidates", "lattice_candidates",
           "mass_near", "other_candidates", "truth_among"]

CANDIDATE_RADIUS_CM = 20.0
"""A candidate (or estimate) this close (cm) to the true position finds it."""


def candidate_poses(localiser: Localiser | None) -> list[Pose]:
    """The mean poses of the belief's plausible modes, heaviest first, when there are two or more.

    Parameters
    ----------
    localiser : Localiser
        Any localiser (None: not built yet); one that tracks no modes (or has a single mode) gives ``[]``.

    Returns
    -------
    list of Pose
        Candidate poses (cm, cm, rad); empty when the belief is not ambiguous.
    """
    found = [] if localiser is None else localiser.modes
    return [m.pose for m in found] if len(found) > 1 else []


def describe_candidates(poses: list[Pose], shown: int = 4) -> str:
    """``ambiguous: N candidate poses (x, y, h deg), ...`` (at most `shown` listed); empty for none."""
    if not poses:
        return ""
    listed = ", ".join(f"({p.x:.1f}, {p.y:.1f}, {p.heading_deg:.0f} deg)" for p in poses[:shown])
    more = f" and {len(poses) - shown} more" if len(poses) > shown else ""
    return f"ambiguous: {len(poses)} candidate poses {listed}{more}"


def truth_among(poses: list[Pose], x_cm: float, y_cm: float, radius_cm: float = CANDIDATE_RADIUS_CM) -> bool:
    """Whether a candidate of `poses` lies within `radius_cm` (cm) of the true position (`x_cm`, `y_cm`);
    positions only (the truth's heading may be unknown)."""
    return any(math.hypot(p.x - x_cm, p.y - y_cm) <= radius_cm for p in poses)


def confidently_wrong(converged: bool, ambiguous: bool, error_cm: float,
                      radius_cm: float = CANDIDATE_RADIUS_CM) -> bool:
    """A converged, unambiguous estimate more than `radius_cm` (cm) from the true position."""
    return converged and not ambiguous and error_cm > radius_cm


def lattice_candidates(xy: Any, n_angles: int, costs: Any, *, within_nats: float, radius_cm: float,
                       heading_rad: float, max_candidates: int = 8, pool: int = 5000) -> list[tuple[Pose, float]]:
    """Distinct good poses of a scored lattice: the best pose, then the best of those further than
    `radius_cm` or `heading_rad` from every pose already taken, while within `within_nats` of the best.

    Parameters
    ----------
    xy : (P, 2) array
        Lattice cell centres (cm).
    n_angles : int
        Directions per cell (heading ``k * 2 pi / n_angles``).
    costs : (P, n_angles) array
        ``-2 log-likelihood`` of each pose (`localisation.beam_model.lattice_costs`).

    Returns
    -------
    list of (Pose, float)
        The candidates with their log-likelihood relative to the best (0 for the first), best first.
    """
    c = np.asarray(costs, dtype=float).ravel()
    k = min(pool, c.size)
    top = np.argpartition(c, k - 1)[:k]
    top = top[np.argsort(c[top], kind="stable")]
    best = c[top[0]]
    cell, head = np.divmod(top, n_angles)
    pts = np.asarray(xy, dtype=float)[cell]
    theta = head * (2.0 * math.pi / n_angles)
    taken: list[int] = []
    for i in range(top.size):
        ll = -0.5 * (c[top[i]] - best)
        if -ll > within_nats or len(taken) >= max_candidates:
            break
        if taken:
            t = np.asarray(taken)
            near = (np.hypot(pts[t, 0] - pts[i, 0], pts[t, 1] - pts[i, 1]) <= radius_cm) & \
                (np.abs(angle_diff(theta[t], theta[i])) <= heading_rad)
            if near.any():
                continue
        taken.append(i)
    return [(Pose(float(pts[i, 0]), float(pts[i, 1]), float(wrap_angle(theta[i]))), -0.5 * (c[top[i]] - best))
            for i in taken]


def mass_near(particles: Any, weights: Any, pose: Pose, radius_cm: float, heading_rad: float) -> float:
    """The share of the weight of a cloud (`particles` (N, 3), normalised `weights` (N,)) within
    `radius_cm` (cm) and `heading_rad` of `pose`: one mode's worth of belief around it (`in_mode`).

    >>> round(mass_near(np.array([[0.0, 0.0, 0.0], [5.0, 0.0, 0.1], [50.0, 0.0, 0.0]]), np.array([0.5, 0.3, 0.2]),
    ...                 Pose(0.0, 0.0, 0.0), 10.0, 0.35), 6)
    0.8
    """
    p, w = np.asarray(particles, dtype=float), np.asarray(weights, dtype=float)
    return float(w[in_mode(p, pose.as_array(), radius_cm, heading_rad)].sum())


def other_candidates(xy: Any, n_angles: int, costs: Any, pose: Pose, *, within_nats: float, radius_cm: float,
                     heading_rad: float, max_candidates: int = 8) -> list[Mode]:
    """The distinct good poses of a scored lattice (`lattice_candidates`) further than `radius_cm` or
    `heading_rad` from `pose` (outside its mode, `in_mode`), as modes of no weight with their
    log-likelihood on the lattice."""
    c_best = float(np.min(costs))
    found = lattice_candidates(xy, n_angles, costs, within_nats=within_nats, radius_cm=radius_cm,
                               heading_rad=heading_rad, max_candidates=max_candidates)
    if not found:
        return []
    outside = ~in_mode(np.array([p.as_array() for p, _ in found]), pose.as_array(), radius_cm, heading_rad)
    return [Mode(p, 0.0, ll - 0.5 * c_best, 0) for (p, ll), out in zip(found, outside, strict=True) if out]
