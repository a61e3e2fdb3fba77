"""`FixPolicy`: when the robot re-localises on the way, and how a re-localisation starts and sweeps."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from localisation.base import PoseEstimate, Prior
from localisation.scan import sweep_angles

from ..world import Pose
from ..world.arrays import FloatArray
from .checkers import Checkers
from .config import TRACK_WINDOWS, FixConfig, SweepConfig

SPREAD_LIMIT_CM = 10.0
"""A belief whose grown disc would need more than this (cm) is never clear to drive on."""


class FixPolicy:
    """The decisions about fixes on the way (`FixConfig`, `SweepConfig`).

    When: legs end at waypoints, every `relocalise_every_cm`, and after `first_leg_cm` following a global
    fix; where a leg ends, rule ``always`` re-localises, rule ``spread`` only when the predicted belief
    could not drive on (`spread_clear`). How: a tracking look from the predicted belief or from a prior
    around it (`tracking`), with the sweeps of `SweepConfig`.
    """

    def __init__(self, fix: FixConfig, sweeps: SweepConfig, checkers: Checkers) -> None:
        self.cfg = fix
        self.sweeps = sweeps
        self.checkers = checkers

    # -- when -------------------------------------------------------------------------------------
    def leg_length(self, dist_cm: float, fresh_fix: bool) -> float:
        """How much of the `dist_cm` to the waypoint the next leg drives (before the heading check)."""
        every = self.cfg.relocalise_every_cm
        first = self.cfg.first_leg_cm
        if fresh_fix and first is not None:
            every = first if every is None else min(every, first)
        return dist_cm if every is None or dist_cm <= 1.25 * every else every

    def checks_turn(self, turn_rad: float) -> bool:
        """Whether turning by `turn_rad` toward waypoints since the last check calls for a heading check
        before the next leg (`FixConfig.check_turn_deg`; the leg's own safety decides too)."""
        limit = self.cfg.check_turn_deg
        return limit is not None and abs(turn_rad) >= math.radians(limit)

    def passes_missed(self, est: PoseEstimate, since_fix_cm: float, next_goal: FloatArray | None) -> bool:
        """Whether a waypoint missed after a leg can be passed: the belief can drive on to `next_goal`."""
        return (self.cfg.rule == "spread" and next_goal is not None
                and self.spread_clear(est, since_fix_cm, next_goal))

    def skips_fix(self, est: PoseEstimate, since_fix_cm: float, ahead: FloatArray | None) -> bool:
        """Whether the leg just driven ends without a fix: the belief can drive on to `ahead`."""
        return self.cfg.rule == "spread" and ahead is not None and self.spread_clear(est, since_fix_cm, ahead)

    def spread_clear(self, est: PoseEstimate, since_fix_cm: float, goal: FloatArray) -> bool:
        """Whether the belief `est` can drive from its mean to `goal` without a fix: the segment is free
        for the robot disc grown by `spread_sigmas` standard deviations of the position across the
        segment plus the heading's over the segment's length."""
        a = est.pose.xy
        d = np.asarray(goal, dtype=float) - a
        length = float(np.hypot(*d))
        if length < 1e-6:
            return True
        cov = np.asarray(est.cov, dtype=float)
        if not np.all(np.isfinite(cov)):
            return False
        perp = np.array([-d[1], d[0]]) / length
        var_heading = max(float(cov[2, 2]), math.radians(self.cfg.spread_min_heading_deg) ** 2)
        var_across = max(float(perp @ cov[:2, :2] @ perp), (self.cfg.spread_drift * since_fix_cm) ** 2)
        var = var_across + length**2 * var_heading
        extra = self.cfg.spread_sigmas * math.sqrt(max(var, 0.0))
        if extra > SPREAD_LIMIT_CM:
            return False
        return bool(self.checkers.grown(extra).segment_free(a, goal))

    # -- how --------------------------------------------------------------------------------------
    @property
    def from_prior(self) -> bool:
        """Whether a re-localisation starts from a prior around the last estimate (else from the belief)."""
        return self.cfg.tracking == "prior"

    def prior(self, est: PoseEstimate) -> Prior:
        """`est` as a prior, its spreads at least `tracking_std_cm` and `tracking_std_deg`."""
        cov = np.array(est.cov, dtype=float, copy=True)
        floor = np.array([self.cfg.tracking_std_cm ** 2, self.cfg.tracking_std_cm ** 2,
                          math.radians(self.cfg.tracking_std_deg) ** 2])
        d = np.maximum(np.diag(cov), floor)
        if not np.all(np.isfinite(cov)):
            cov = np.diag(d)
        else:
            cov[np.diag_indices(3)] = d
        return Prior(est.pose, cov)

    def turned_prior(self, est: PoseEstimate, offset_rad: float) -> Prior:
        """`prior` of `est` with its heading turned by `offset_rad` (where a heading check found the robot
        pointing)."""
        p = self.prior(est)
        return Prior(Pose(p.mean.x, p.mean.y, p.mean.theta + offset_rad), p.cov)

    def sweep(self, kind: str) -> dict[str, Any]:
        """How a ``track`` or ``final`` re-localisation sweeps (keyword arguments of the look)."""
        s = self.sweeps
        if s.track_align:
            return {"align": True, "process": True, "scan_angles": None}
        if kind == "final":
            return {"align": False, "process": False,
                    "scan_angles": sweep_angles(s.final_scan_step_deg, s.final_window_deg)}
        return {"align": False, "process": False,
                "scan_angles": sweep_angles(s.track_scan_step_deg, s.track_window_deg, TRACK_WINDOWS[s.track_windows])}
