"""Fitting sweeps to places the robot knows: which place and heading a sweep fits best (`rank_places`,
`fit_pose`), from one sweep or from the sweeps of one stop (`joined`), and what they say of the heading with
what the robot already believed (`heading_belief`). The challenge's fixes (`toolkit.mission.challenge`) are
made of these."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..real_sonar.sweeps import ALIGN_STEP_DEG, heading_lattice_deg, thin_ray_misfits
from ..world import Map, Pose, Scan, angle_diff, wrap_angle
from ..world.arrays import FloatArray

__all__ = ["Sweeps", "Turned", "fit_pose", "heading_belief", "joined", "misfits", "rank_places"]

XY = tuple[float, float]


Turned = tuple[Scan, float]
"""A sweep and the turn (rad) the robot made after the first sweep of its stop before taking it."""

Sweeps = Scan | Sequence[Turned]
"""What a fit scores: one sweep, or the sweeps of one stop, each with its turn from the first."""


def joined(first: Scan, second: Scan, turn_rad: float) -> list[Turned]:
    """Two sweeps taken at one place, the robot turned by `turn_rad` between them, fitted together from
    the heading of the `first` (`rank_places` scores each at its own heading and averages the scores).

    >>> a = Scan(np.array([0.0]), np.array([50.0]), np.array([True]))
    >>> [round(math.degrees(turn)) for _, turn in joined(a, a, math.pi / 2)]
    [0, 90]
    """
    return [(first, 0.0), (second, turn_rad)]


def _turned_at(place: XY, headings: FloatArray) -> FloatArray:
    """The (n, 3) poses at `place` (cm) facing each of the `headings` (rad)."""
    return np.column_stack([np.full(headings.size, place[0]), np.full(headings.size, place[1]), headings])


def misfits(m: Map, sweeps: Sweeps, poses: FloatArray) -> FloatArray:
    """The fit's score at each of the (n, 3) `poses` (x, y in cm, heading in rad; lower is better): the median
    distance (cm) between a sweep's echoes and exact (thin-ray) ray casting
    (`toolkit.real_sonar.sweeps.thin_ray_misfits`), averaged over the `sweeps` of one stop, each at the pose
    turned by its turn. Each sweep's own median, not the median of their echoes pooled: a sweep with a
    heavy tail of wrong readings flattens a pooled median until any heading in 15 degrees fits it."""
    parts = [(sweeps, 0.0)] if isinstance(sweeps, Scan) else list(sweeps)
    each = np.array([thin_ray_misfits(m, scan, poses + np.array([0.0, 0.0, turn])) for scan, turn in parts])
    heard = np.isfinite(each).sum(axis=0)  # a sweep without an echo (nan) does not count
    return np.where(heard > 0, np.nansum(each, axis=0) / np.maximum(heard, 1), math.nan)


def heading_belief(m: Map, scan: Sweeps, waypoint: XY, around: float, span_deg: float, temperature_cm: float,
                   prior_sd: float | None = None) -> tuple[float, float]:
    """What a sweep (or a stop's sweeps) at `waypoint` says of the heading, with what the robot already
    believed: the most likely heading (rad) on the alignment's lattice within `span_deg` of `around` (rad),
    and the spread (rad) of that belief.

    Each heading's likelihood is exp(-misfit / `temperature_cm`) (`misfits`, relative to the best), and with
    `prior_sd` (rad) it is weighed by a Gaussian prior round `around`. A sweep whose misfit is sharp in
    heading decides; one that is flat over 15 degrees (many real sweeps: a median moves little with the
    heading) leaves the heading to the prior instead of to wherever on the flat its least value fell. No echo
    at all: `around`, with the prior's spread (half a turn without one)."""
    headings = np.radians(heading_lattice_deg(math.degrees(around), span_deg))
    score = misfits(m, scan, _turned_at(waypoint, headings))
    if np.isnan(score).all():
        return around, math.pi if prior_sd is None else prior_sd
    offset = np.asarray(angle_diff(headings, around), dtype=float)
    log_p = -(score - np.nanmin(score)) / temperature_cm
    if prior_sd is not None:
        log_p = log_p - 0.5 * (offset / prior_sd) ** 2
    log_p = np.where(np.isnan(log_p), -np.inf, log_p)
    best = int(np.argmax(log_p))
    weight = np.exp(log_p - log_p[best])
    spread = np.asarray(angle_diff(headings, headings[best]), dtype=float)
    floor = math.radians(ALIGN_STEP_DEG) / 2  # the lattice pins a heading to half its step at best
    return float(wrap_angle(headings[best])), max(floor, float(np.sqrt(weight @ spread ** 2 / weight.sum())))


def fit_pose(m: Map, scan: Sweeps, places: list[XY], *, heading: float | None = None, span_deg: float = 180.0,
             step_deg: float = ALIGN_STEP_DEG) -> Pose:
    """The pose, among the `places` (cm) and the headings of the lattice `step_deg` apart (within `span_deg` of
    `heading`; None: every heading), that the sweep `scan` fits best (`rank_places`)."""
    return rank_places(m, scan, places, heading=heading, span_deg=span_deg, step_deg=step_deg)[0][1]


def rank_places(m: Map, scan: Sweeps, places: list[XY], *, heading: float | None = None, span_deg: float = 180.0,
                step_deg: float = ALIGN_STEP_DEG) -> list[tuple[float, Pose]]:
    """Each of the `places` (cm) at the heading that the sweep `scan` (or a stop's sweeps, `joined`) fits
    best there, with the fit's score, best place first. The headings tried are the multiples of `step_deg`
    (those within `span_deg` of `heading`; None: all): the lattice a sweep set's ``heading_deg`` is aligned
    on (`toolkit.real_sonar.sweeps.heading_lattice_deg`), not one centred on `heading`. The median is flat over
    a few degrees of heading on many real sweeps, and a lattice half a step off lands elsewhere on the
    flat than the alignment did (at a degree apart, 6 degrees off on one of the development set's sweeps).
    The score is minus the median distance (cm) between the sweep's echoes and exact (thin-ray) ray casting
    (`misfits`): the fit that aligned the sweep sets' ``heading_deg`` with the map, so on a real sweep it finds
    the heading the sweep set calls true.

    The course's robot knows its waypoints: at the start it tells which one it stands on (and at what
    heading) by trying them all, the way the course's own place recognition compares a sweep with the
    signature of every waypoint. A thin ray and a robust score: the NXT's 40-degree lobe blurs the
    heading (its beam model leaves 10-20 degrees of heading error on these sweeps), while the walls'
    corners, read by the lobe's axis, pin it (a robust median, since a real sweep has a heavy tail of
    wrong readings)."""
    headings = np.radians(heading_lattice_deg(None if heading is None else math.degrees(heading), span_deg, step_deg))
    ranked: list[tuple[float, Pose]] = []
    for x, y in places:
        median = misfits(m, scan, _turned_at((x, y), headings))
        best = int(np.argmin(median))
        ranked.append((-float(median[best]), Pose(x, y, float(wrap_angle(headings[best])))))
    return sorted(ranked, key=lambda item: -item[0])
