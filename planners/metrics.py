"""Path metrics: length, turns, turning angle, clearance and ratios to reference paths.

All lengths in cm, angles in rad. A path is a (k, 2) polyline of waypoints. A *turn* is an interior
waypoint where the heading changes by more than a small threshold (1 degree by default); waypoints
that repeat the previous one (zero-length segments) are ignored, so they never count as turns.

Examples
--------
>>> import numpy as np
>>> p = np.array([[0, 0], [10, 0], [10, 10], [20, 10]])
>>> path_length(p), count_turns(p), round(turn_angle(p), 6)
(30.0, 2, 3.141593)
"""

from __future__ import annotations

import itertools
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from toolkit.world import CollisionChecker, segment_turns
from toolkit.world.arrays import FloatArray

__all__ = ["PathMetrics", "count_turns", "drop_straight", "heading_changes", "path_length", "path_metrics",
           "turn_angle"]


_DEFAULT_TURN_THRESHOLD = math.radians(1.0)


def _as_path(path: ArrayLike) -> FloatArray:
    return np.asarray(path, dtype=float).reshape(-1, 2)


def path_length(path: ArrayLike) -> float:
    """Length of a (k, 2) polyline in cm (0 for fewer than two points)."""
    p = _as_path(path)
    if len(p) < 2:
        return 0.0
    return float(np.sum(np.hypot(*np.diff(p, axis=0).T)))


def heading_changes(path: ArrayLike) -> FloatArray:
    """Signed heading change (rad, in [-pi, pi)) at each interior vertex, zero-length segments skipped
    (`toolkit.world.segment_turns`, the one the robot's cost counts)."""
    return segment_turns(path)


def turn_angle(path: ArrayLike) -> float:
    """Total absolute heading change along the path (rad)."""
    return float(np.sum(np.abs(heading_changes(path))))


def count_turns(path: ArrayLike, threshold_rad: float = _DEFAULT_TURN_THRESHOLD) -> int:
    """Number of interior vertices where the heading changes by more than `threshold_rad` (rad)."""
    return int(np.count_nonzero(np.abs(heading_changes(path)) > threshold_rad))


def _sample_along(path: FloatArray, step_cm: float = 1.0) -> FloatArray:
    """Points along the polyline about every `step_cm`, including every waypoint."""
    if len(path) < 2:
        return path.copy()
    pts = [path[:1]]
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / step_cm))
        t = np.arange(1, n + 1)[:, None] / n
        pts.append(a + t * (b - a))
    return np.vstack(pts)


def _ratio(value: float, reference: float | None) -> float:
    if reference is None or not math.isfinite(reference):
        return math.nan
    if reference == 0:
        return 1.0 if value == 0 else math.inf
    return value / reference


@dataclass(frozen=True)
class PathMetrics:
    """Quality figures of one path.

    Attributes
    ----------
    length_cm : float
        Polyline length (cm).
    turns : int
        Interior waypoints with a heading change above the threshold.
    turn_angle_rad : float
        Total absolute heading change (rad).
    min_clearance_cm, mean_clearance_cm : float
        Distance from the robot disc's edge to the nearest wall, sampled about every 1 cm along the
        path (cm); negative means a collision. NaN for an empty path.
    length_ratio : float
        ``length_cm / reference_length`` (NaN when no reference was given).
    turn_ratio : float
        ``turns / reference_turns`` (NaN when no reference was given; 0 / 0 is 1).
    """

    length_cm: float
    turns: int
    turn_angle_rad: float
    min_clearance_cm: float
    mean_clearance_cm: float
    length_ratio: float
    turn_ratio: float

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def path_metrics(
    path: ArrayLike,
    checker: CollisionChecker,
    *,
    reference_length: float | None = None,
    reference_turns: int | None = None,
    turn_threshold_rad: float = _DEFAULT_TURN_THRESHOLD,
) -> PathMetrics:
    """Metrics of `path` (cm) for the robot of `checker`.

    Parameters
    ----------
    path : (k, 2) array_like
        Waypoints in cm.
    checker : CollisionChecker
        Gives the clearance (its counters grow by the number of sampled points).
    reference_length : float, optional
        Length of the reference path (normally the `shortest` planner's), cm.
    reference_turns : int, optional
        Turns of the reference path (normally the `min-link` planner's).
    turn_threshold_rad : float
        Heading changes above this count as turns (rad).
    """
    p = _as_path(path)
    length = path_length(p)
    turns = count_turns(p, turn_threshold_rad)
    if len(p) == 0:
        cmin = cmean = math.nan
    else:
        c = np.atleast_1d(np.asarray(checker.clearance(_sample_along(p)), dtype=float))
        cmin, cmean = float(np.min(c)), float(np.mean(c))
    return PathMetrics(
        length_cm=length,
        turns=turns,
        turn_angle_rad=turn_angle(p),
        min_clearance_cm=cmin,
        mean_clearance_cm=cmean,
        length_ratio=_ratio(length, reference_length),
        turn_ratio=_ratio(float(turns), None if reference_turns is None else float(reference_turns)),
    )


def drop_straight(path: FloatArray) -> FloatArray:
    """`path` (k, 2) without its repeated waypoints and the waypoints where it goes straight on (no turn
    there): the same line, so the same length, no turn, and no new segment to check.

    >>> drop_straight(np.array([[0, 0], [1, 0], [2, 0], [2, 1]], dtype=float)).tolist()
    [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]]
    """
    keep = [0]
    for k in range(1, len(path) - 1):
        a, b, c = path[keep[-1]], path[k], path[k + 1]
        if np.allclose(b, a):
            continue
        u, v = b - a, c - b
        if abs(u[0] * v[1] - u[1] * v[0]) > 1e-9 * (np.hypot(*u) * np.hypot(*v) + 1e-300) or np.dot(u, v) < 0:
            keep.append(k)
    keep.append(len(path) - 1)
    out = path[keep]
    return out[np.r_[True, np.any(np.diff(out, axis=0) != 0, axis=1)]] if len(out) > 2 else out
