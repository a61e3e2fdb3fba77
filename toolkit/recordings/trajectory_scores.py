"""Trajectory errors with `evo` (Grupp, *evo: Python package for the evaluation of odometry and SLAM*).

`score_trajectory` compares an estimated planar trajectory with the true one, pose for pose:

``ape_rmse_cm``, ``ape_heading_rmse_deg``
    evo's absolute pose error (translation part, and rotation angle) after the best rigid alignment of
    the estimate onto the truth (Umeyama, without scale): a fixed offset between the truth's frame and
    the map's does not count. The poses lie in the plane z = 0, so the SE(3) alignment is an SE(2) one.
``rpe_per_m_cm``
    evo's relative pose error (translation part) over every pair of poses 1 m apart along the true
    path (``delta`` 1 m, all pairs, pairs chosen on the truth): the error one metre of driving adds,
    whatever the frames. RMSE over the pairs; NaN when no two true poses lie a metre apart along the
    path (within evo's tolerance of a tenth of it): a path shorter than a metre, or poses too sparse.

All three are NaN for fewer than three poses, or true positions all on one line (no unique alignment).
Whenever a score is NaN, ``ape_note`` or ``rpe_note`` says why, in words a table can print.

Positions are in cm and headings in rad on the way in; evo works in metres.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["TrajectoryScores", "relative_pose_error", "score_trajectory"]

CM_PER_M = 100.0
RPE_DELTA_M = 1.0
"""Path length between the two poses of each RPE pair (m)."""
RPE_TOLERANCE = 0.1
"""evo's relative tolerance on that length when it picks the pairs (its default ``rel_tol``)."""


@dataclass(frozen=True)
class TrajectoryScores:
    """evo's errors of one trajectory (module docstring); NaN where they cannot be computed, and then
    the reason in ``ape_note`` (both APE values) or ``rpe_note``."""

    ape_rmse_cm: float
    ape_heading_rmse_deg: float
    rpe_per_m_cm: float
    poses: int
    ape_note: str | None = None
    rpe_note: str | None = None

    @classmethod
    def unscored(cls, poses: int, why: str) -> TrajectoryScores:
        """No score at all (every value NaN), for the reason `why`."""
        return cls(math.nan, math.nan, math.nan, poses, why, why)

    def to_dict(self) -> dict[str, Any]:
        return {k: (v if not isinstance(v, float) or math.isfinite(v) else None) for k, v in self.__dict__.items()}


def _trajectory(poses: np.ndarray, stamps: np.ndarray) -> Any:
    from evo.core.trajectory import PoseTrajectory3D

    half = poses[:, 2] / 2.0
    quat = np.column_stack([np.cos(half), np.zeros_like(half), np.zeros_like(half), np.sin(half)])  # w x y z
    xyz = np.column_stack([poses[:, 0] / CM_PER_M, poses[:, 1] / CM_PER_M, np.zeros(len(poses))])
    return PoseTrajectory3D(positions_xyz=xyz, orientations_quat_wxyz=quat, timestamps=stamps)


def _trajectories(truth: ArrayLike, estimate: ArrayLike, stamps: ArrayLike | None) -> tuple[Any, Any, int]:
    """evo trajectories of `truth` and `estimate` (checked to match pose for pose), and their length."""
    t = np.asarray(truth, dtype=float).reshape(-1, 3)
    e = np.asarray(estimate, dtype=float).reshape(-1, 3)
    if t.shape != e.shape:
        raise ValueError(f"truth has {len(t)} poses, the estimate {len(e)}")
    s = np.arange(len(t), dtype=float) if stamps is None else np.asarray(stamps, dtype=float).ravel()
    return _trajectory(t, s), _trajectory(e, s), len(t)


def _rpe(ref: Any, est: Any, delta_m: float, rotation: bool = False) -> tuple[float, str | None]:
    """evo's RPE RMSE over all pairs `delta_m` metres apart on `ref`: translation (cm), or with `rotation`
    the rotation angle (degrees); NaN when no such pair exists, with the reason."""
    from evo.core import metrics
    from evo.core.filters import FilterException
    from evo.core.units import Unit

    if len(ref.positions_xyz) < 2:
        return math.nan, f"fewer than two true poses; the RPE compares poses {delta_m:g} m apart"
    if ref.path_length < delta_m:
        return math.nan, f"the true path is {ref.path_length:.2f} m long, shorter than the {delta_m:g} m the RPE spans"
    relation = metrics.PoseRelation.rotation_angle_deg if rotation else metrics.PoseRelation.translation_part
    metric = metrics.RPE(relation, delta=delta_m, delta_unit=Unit.meters, rel_delta_tol=RPE_TOLERANCE, all_pairs=True,
                         pairs_from_reference=True)
    try:
        metric.process_data((ref, est))
    except (FilterException, metrics.MetricsException):  # no pair delta_m apart within evo's tolerance
        return math.nan, (f"no two of the {len(ref.positions_xyz)} true poses lie {delta_m:g} m apart along the "
                          f"{ref.path_length:.2f} m path (within evo's tolerance of {RPE_TOLERANCE:.0%})")
    return float(metric.get_statistic(metrics.StatisticsType.rmse)) * (1.0 if rotation else CM_PER_M), None


def score_trajectory(truth: ArrayLike, estimate: ArrayLike, stamps: ArrayLike | None = None) -> TrajectoryScores:
    """evo's APE (after rigid alignment) and RPE per metre of `estimate` against `truth`.

    Parameters
    ----------
    truth, estimate : (n, 3) array_like
        Poses x cm, y cm, heading rad, matched one to one.
    stamps : (n,) array_like, optional
        Times of the poses (s); default 0, 1, 2, ...
    """
    from evo.core import metrics
    from evo.core.geometry import GeometryException

    ref, est, n = _trajectories(truth, estimate, stamps)
    if n < 3:
        return TrajectoryScores.unscored(n, f"{n} true pose{'s' if n != 1 else ''}; the scores need three or more")
    aligned = copy.deepcopy(est)
    try:
        aligned.align(ref, correct_scale=False)
    except GeometryException:  # every position on one line: no unique alignment
        xy = np.asarray(truth, dtype=float).reshape(-1, 3)[:, :2]
        where = "are one point" if np.ptp(xy, axis=0).max() < 1e-6 else "lie on one line"
        return TrajectoryScores.unscored(n, f"the true positions {where}: no unique alignment")
    rpe, rpe_note = _rpe(ref, est, RPE_DELTA_M)
    ape_t = metrics.APE(metrics.PoseRelation.translation_part)
    ape_t.process_data((ref, aligned))
    ape_r = metrics.APE(metrics.PoseRelation.rotation_angle_deg)
    ape_r.process_data((ref, aligned))
    return TrajectoryScores(float(ape_t.get_statistic(metrics.StatisticsType.rmse)) * CM_PER_M,
                            float(ape_r.get_statistic(metrics.StatisticsType.rmse)), rpe, n, rpe_note=rpe_note)


def relative_pose_error(truth: ArrayLike, estimate: ArrayLike, delta_m: float = RPE_DELTA_M,
                        stamps: ArrayLike | None = None) -> tuple[float, float]:
    """evo's relative pose error over every pair of poses `delta_m` metres apart along the true path:
    RMSE of the translation part (cm) and of the rotation angle (degrees); NaN when the truth never
    covers `delta_m`. Poses as in `score_trajectory`."""
    ref, est, _ = _trajectories(truth, estimate, stamps)
    return _rpe(ref, est, delta_m)[0], _rpe(ref, est, delta_m, rotation=True)[0]


def similarity_scale(truth: ArrayLike, estimate: ArrayLike) -> float:
    """The scale of evo's best similarity alignment (Umeyama with scale) of `estimate` onto `truth`: above
    1 when the estimate's path is the shorter. Poses as in `score_trajectory`."""
    ref, est, _ = _trajectories(truth, estimate, None)
    return float(copy.deepcopy(est).align(ref, correct_scale=True)[2])
