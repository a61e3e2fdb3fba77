"""Where to drive while a global belief is ambiguous: the exploration moves of the global strategy.

Two rules, both choosing a turn (rad, relative to the heading) and a distance (cm):

``modes`` (`explore_from_modes`)
    From the localiser's candidate poses and the map: the move must be collision-free with a margin
    from every candidate, with its heading off by a tolerance either way, and heads where the nearest
    wall (over the candidates) is farthest: safe whichever candidate is the truth. Without candidates
    it falls back to the scan (`explore_direction`), which trusts the sonar's free space.
``scan`` (`scan_explore_move`)
    From the last sweep alone, as the paper's procedure drove: toward the longest free run of the
    robot's disc among the readings (`open_direction`), most of the way.

Only `toolkit.world` is used (collision checks, ray casting), no robot.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from toolkit.world import CollisionChecker, Pose, RngLike, Scan, angle_diff, as_rng, ray_cast

__all__ = ["EXPLORE_OVERSHOOT", "explore_direction", "explore_from_modes", "free_travel", "open_direction",
           "scan_explore_move"]


def free_travel(scan: Scan, radius_cm: float, directions: Any = None) -> tuple[Any, Any]:
    """How far a disc of `radius_cm` can drive along each direction before touching a scanned point.

    Every usable reading is a wall point in the robot frame; along direction ``phi`` the disc meets
    point ``p`` at ``t = p.u - sqrt(R^2 - (p x u)^2)`` when it passes within R of it. Directions
    default to the scan's own angles. Returns (directions, free distance in cm; ``inf`` when no
    reading limits it).
    """
    ok = scan.valid & np.isfinite(scan.ranges)
    phi = np.asarray(scan.angles if directions is None else directions, dtype=float)
    if not ok.any():
        return phi, np.full(phi.shape, np.inf)
    px = scan.ranges[ok] * np.cos(scan.angles[ok])
    py = scan.ranges[ok] * np.sin(scan.angles[ok])
    ux, uy = np.cos(phi)[:, None], np.sin(phi)[:, None]
    along = px[None, :] * ux + py[None, :] * uy
    across = np.abs(px[None, :] * uy - py[None, :] * ux)
    hit = (across < radius_cm) & (along > 0.0)
    t = along - np.sqrt(np.maximum(radius_cm**2 - across**2, 0.0))
    free = np.where(hit, np.maximum(t, 0.0), np.inf).min(axis=1)
    return phi, free


def open_direction(scan: Scan, clearance_cm: float, rng: RngLike = None, avoid_rad: float | None = None, *,
                   avoid_deg: float = 60.0, open_cm: float | None = None, clip_to_readings: bool = True,
                   need_open: bool = False) -> tuple[float, float]:
    """Where to drive to break an ambiguous belief, from one scan alone (no pose needed).

    For every usable reading direction, the free run of a disc of radius `clearance_cm` along it
    (`free_travel`; with `clip_to_readings`, never beyond the reading itself: a missing echo is as
    likely a wall seen at a glancing angle as open space). Among the directions within 2 cm of the
    longest run one is picked at random; directions within `avoid_deg` of `avoid_rad` (where the robot
    came from) only when no other one runs beyond `open_cm` (default `clearance_cm`).

    Returns
    -------
    (float, float)
        The direction (rad, relative to the heading) and its free run (cm); (0, 0) when no reading is
        usable, or, with `need_open`, when no run is longer than `open_cm` (then nothing is drawn).
    """
    ok = scan.valid & np.isfinite(scan.ranges)
    if not ok.any():
        return 0.0, 0.0
    enough = clearance_cm if open_cm is None else open_cm
    phi, free = free_travel(scan, clearance_cm, scan.angles[ok])
    if clip_to_readings:
        free = np.minimum(free, scan.ranges[ok])
    score = free.copy()
    if avoid_rad is not None:
        back = np.abs(angle_diff(phi, avoid_rad)) < math.radians(avoid_deg)
        if (score[~back] > enough).any():
            score = np.where(back, -np.inf, score)
    best = float(np.max(score))
    if need_open and best <= enough:
        return 0.0, 0.0
    cand = np.flatnonzero(score >= best - 2.0)
    k = int(as_rng(rng).choice(cand))
    return float(angle_diff(phi[k], 0.0)), float(free[k])


EXPLORE_OVERSHOOT = 0.2
"""An exploration move is checked for this fraction more than it drives: a single move of up to 30 cm
is driven at once, and the paper's motion noise (10 % of the distance) takes it up to 20 % further
at two standard deviations."""


def explore_direction(scan: Scan, clearance_cm: float, rng: RngLike = None,
                      avoid_rad: float | None = None, max_step_cm: float = 30.0) -> tuple[float, float]:
    """The ``modes`` rule's fallback from one scan: `open_direction` with a 45-degree cone behind, any
    run over 2 cm counting as open and the free run not clipped to the readings, then half the run, at
    most `max_step_cm`.

    Returns
    -------
    (float, float)
        Turn (rad, relative to the heading) and distance (cm); (0, 0) when no direction is open.
    """
    turn, free = open_direction(scan, clearance_cm, rng, avoid_rad, avoid_deg=45.0, open_cm=2.0,
                                clip_to_readings=False, need_open=True)
    return turn, float(min(max_step_cm, 0.5 * free))


def scan_explore_move(scan: Scan, radius_cm: float, rng: RngLike = None, avoid_rad: float | None = None, *,
                      max_move_cm: float = 40.0, move_fraction: float = 0.7,
                      safety_cm: float | None = None) -> tuple[float, float]:
    """The ``scan`` rule: toward the longest free run of the robot's disc (`open_direction`, 60 degrees
    behind avoided) and ``min(max_move_cm, move_fraction * (run - (safety - radius)))`` along it, where
    `safety_cm` (default the radius + 5 cm) is the distance kept from the wall ahead, centre to wall.

    Returns
    -------
    (float, float)
        Turn (rad, relative to the heading) and distance (cm, 0 when there is no room).
    """
    safety = radius_cm + 5.0 if safety_cm is None else float(safety_cm)
    direction, travel = open_direction(scan, radius_cm, rng, avoid_rad)
    return direction, max(0.0, min(max_move_cm, move_fraction * (travel - safety + radius_cm)))


def explore_from_modes(poses: Sequence[Pose], walls: Any, checker: CollisionChecker, step_cm: float,
                       heading_tolerance_rad: float, avoid_rad: float | None = None,
                       overshoot: float = EXPLORE_OVERSHOOT) -> tuple[float, float]:
    """The ``modes`` rule: a move that is safe from every candidate pose.

    Directions every 5 degrees (those within 45 degrees of `avoid_rad`, where the robot came from,
    left out) are tried for `step_cm`, then half and a quarter of it; a direction qualifies when the
    straight move, `overshoot` (a fraction) longer than it is meant to drive, is free for `checker`'s
    disc from every pose in `poses`, with the pose's heading as it is and off by
    `heading_tolerance_rad` either way. Among those, the one whose nearest wall (ray cast along it
    from every pose and deviation, `walls` as a (W, 4) array) is farthest.

    Returns
    -------
    (float, float)
        Turn (rad, relative to the heading) and distance (cm); (0, 0) when no length is safe.
    """
    rel = np.radians(np.arange(0.0, 360.0, 5.0))
    if avoid_rad is not None:
        rel = rel[np.abs(angle_diff(rel, avoid_rad)) >= math.radians(45.0)]
    tol = heading_tolerance_rad
    for length in (step_cm, 0.5 * step_cm, 0.25 * step_cm):
        ok = np.ones(rel.size, dtype=bool)
        room = np.full(rel.size, np.inf)
        for p in poses:
            for dev in (-tol, 0.0, tol):  # the poses' headings may be off by the tolerance
                ang = p.theta + rel + dev
                ends = p.xy[None, :] + (1.0 + overshoot) * length * np.column_stack([np.cos(ang), np.sin(ang)])
                ok &= checker.segments_free(np.repeat(p.xy[None, :], rel.size, axis=0), ends)
                room = np.minimum(room, ray_cast(walls, p.xy, ang))
        if ok.any():
            k = int(np.argmax(np.where(ok, room, -np.inf)))
            return float(angle_diff(rel[k], 0.0)), float(length)
    return 0.0, 0.0
