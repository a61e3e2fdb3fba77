"""`FinalCorrectionPolicy`: what the mission does at the target after each fix there."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..world import CollisionChecker, Pose, angle_diff
from ..world.arrays import FloatArray
from .config import FinalConfig
from .report import Outcome


@dataclass(frozen=True)
class Correction:
    """The decision after a fix at the target: end (`outcome` and `status` set), plan again (`replan`),
    or turn by `turn_rad` and move `distance_cm` (negative: back up)."""

    outcome: Outcome | None = None
    status: str = ""
    replan: bool = False
    turn_rad: float = 0.0
    distance_cm: float = 0.0


class FinalCorrectionPolicy:
    """Corrects toward `target` until the estimate is within `goal_tolerance_cm`, at most
    `max_corrections` times (`FinalConfig`); then the mission succeeds when the estimate is within
    `success_radius_cm`. A target the straight line from the estimate cannot reach is planned for again.
    """

    def __init__(self, cfg: FinalConfig, target: FloatArray, checker: CollisionChecker) -> None:
        self.cfg = cfg
        self.target = target
        self.checker = checker

    def decide(self, estimate: Pose, done: int) -> Correction:
        """The decision after a fix at `estimate`, `done` corrections made so far."""
        cfg = self.cfg
        delta = self.target - estimate.xy
        dist = float(np.hypot(*delta))
        if dist <= cfg.goal_tolerance_cm:
            return Correction(Outcome.REACHED,
                              f"reached target (estimate {dist:.2f} cm from it after {done} correction(s))")
        if done == cfg.max_corrections:
            return self.verdict(dist)
        if not self.checker.segment_free(estimate.xy, self.target):
            return Correction(replan=True)
        turn = float(angle_diff(math.atan2(delta[1], delta[0]), estimate.theta))
        sense = 1.0
        if dist <= cfg.reverse_cm and abs(turn) > 0.5 * math.pi:  # back up rather than turn around
            turn, sense = float(angle_diff(turn, math.pi)), -1.0
        return Correction(turn_rad=turn, distance_cm=sense * dist)

    def verdict(self, dist: float) -> Correction:
        """The end when the corrections ran out with the estimate `dist` cm from the target."""
        cfg = self.cfg
        if dist <= cfg.success_radius_cm:
            return Correction(Outcome.REACHED, f"reached target (estimate {dist:.2f} cm from it; tolerance "
                                               f"{cfg.goal_tolerance_cm:g} cm not met in {cfg.max_corrections} "
                                               "corrections)")
        return Correction(Outcome.STOPPED_SHORT,
                          f"stopped {dist:.1f} cm from the target after {cfg.max_corrections} corrections")
