"""Where to drive to break an ambiguous belief, from one scan."""

from __future__ import annotations

import math

import numpy as np

from localisation.procedure import free_travel

from ..world import (
    Scan,
    angle_diff,
    as_rng,
)


def explore_direction(scan: Scan, clearance_cm: float, rng: np.random.Generator | None = None,
                      avoid_rad: float | None = None, max_step_cm: float = 30.0) -> tuple[float, float]:
    """Where to drive to break an ambiguous belief, from one scan alone (no pose needed).

    For every usable reading direction, the free run of a disc of radius `clearance_cm` along it is
    the distance before any scan point comes within the radius of the disc's centre line. The
    direction with the longest run wins (ties within 2 cm broken at random; directions within 45
    degrees of `avoid_rad`, where the robot came from, only when nothing else is open).

    Returns
    -------
    (float, float)
        Turn (rad, relative to the heading) and distance (cm): half the free run, at most
        `max_step_cm`; (0, 0) when no direction is open.
    """
    ok = scan.valid & np.isfinite(scan.ranges)
    if not ok.any():
        return 0.0, 0.0
    a, free = free_travel(scan, clearance_cm, scan.angles[ok])
    if avoid_rad is not None:
        back = np.abs(angle_diff(a, avoid_rad)) < math.radians(45.0)
        if (free[~back] > 2.0).any():
            free = np.where(back, -np.inf, free)
    best = float(free.max())
    if best <= 2.0:
        return 0.0, 0.0
    cand = np.flatnonzero(free >= best - 2.0)
    k = int(as_rng(rng).choice(cand))
    return float(angle_diff(a[k], 0.0)), float(min(max_step_cm, 0.5 * free[k]))
