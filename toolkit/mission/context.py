"""What one mission run knows and does to its robot: the belief, the counters, the trace, the actions."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from localisation.base import HeadingPrior, Localiser, Motion, PoseEstimate
from localisation.global_localisation import DriveAction

from ..world import CollisionChecker, Map, MoveOutcome, Pose, Robot, TruthSource
from ..world.arrays import FloatArray
from .config import MissionConfig
from .report import Action, Outcome, TraceStep
from .robot_distances import backoff_cm
from .states import MissionEnded

TURN_EPS = math.radians(0.5)
"""Turns smaller than this (rad) are not counted as turns."""
BACKOFF_MARGIN_CM = 2.0
"""Room (cm) a back-off leaves between the robot and the wall behind it, as the map shows it from the belief."""


@dataclass
class Counts:
    """The mission's own counters."""

    actions: int = 0
    turns: int = 0
    watchdog_stops: int = 0
    relocalisations: int = 0
    replans: int = 0
    path_cm: float = 0.0
    """Distance driven, forward and backward (cm)."""


class MissionContext:
    """The mutable state of one run, and the robot's actions as the mission takes them: each one counted
    (against `LimitsConfig.max_actions`), told to the localiser and recorded in the trace. It is the
    global strategy's `Driver` too, so the strategy's moves are the mission's.

    Attributes
    ----------
    estimate : PoseEstimate or None
        The current belief (after the latest action or look).
    fresh_fix : bool
        The estimate comes from a global fix not yet checked by a drive.
    since_fix_cm : float
        Distance driven since the last converged fix (cm).
    last_move : MoveOutcome or None
        The outcome of the latest move.
    on_sweep_fault, on_motion_fault : callable or None
        Told of sweeps taken again (a faulty sonar) and of fixes far off the prediction.
    on_watchdog_stop : callable or None
        Says why a watchdog stop shows the belief is wrong (None: it does not).
    checker : CollisionChecker or None
        The robot disc against the map (the mission's bare checker): how much room a back-off has.
    start_heading : HeadingPrior or None
        What the robot knows of its heading at the start (its position unknown): the first global
        localisation starts from it, later ones (after a lost belief) do not.
    """

    def __init__(self, robot: Robot, m: Map, target: FloatArray, config: MissionConfig,
                 localiser: Callable[[], Localiser], truth: TruthSource | None = None,
                 start_heading: HeadingPrior | None = None) -> None:
        self.robot = robot
        self.map = m
        self.target = target
        self.cfg = config
        self.radius = float(robot.geometry.radius_cm)
        self.truth = truth
        self._make_localiser = localiser
        self._localiser: Localiser | None = None
        self.counts = Counts()
        self.trace: list[TraceStep] = []
        self.plans: list[FloatArray] = []
        self.candidates: list[Pose] = []  # the belief's candidate poses when it stayed ambiguous
        self.estimate: PoseEstimate | None = None
        self.fresh_fix = False
        self.since_fix_cm = 0.0
        self.last_move: MoveOutcome | None = None
        self.start_heading = start_heading
        self.on_sweep_fault: Callable[[str], None] | None = None
        self.checker: CollisionChecker | None = None
        self.on_motion_fault: Callable[[str], None] | None = None
        self.on_watchdog_stop: Callable[[MissionContext], str | None] | None = None

    @property
    def localiser(self) -> Localiser:
        """The localiser, built at its first use (a target in a wall is reported before any range table
        is computed)."""
        if self._localiser is None:
            self._localiser = self._make_localiser()
        return self._localiser

    def true_pose(self) -> Pose | None:
        """The true pose from the truth source (None without one)."""
        return None if self.truth is None else self.truth.true_pose

    def record(self, action: Action | str, **kw: Any) -> None:
        """A trace step: `action` (an `Action` or its value; another string is a ValueError) and the belief."""
        est = self.estimate.pose if self.estimate is not None else None
        spread = self.estimate.std_xy_cm if self.estimate is not None else None
        self.trace.append(TraceStep(Action(action), est, self.true_pose(), robot_time_s=float(self.robot.robot_time_s),
                                    spread_cm=spread, **kw))

    def _count_action(self) -> None:
        self.counts.actions += 1
        limit = self.cfg.limits.max_actions
        if self.counts.actions > limit:
            raise MissionEnded(Outcome.GAVE_UP, f"gave up after {limit} actions")

    def _predicted(self, motion: Motion, driven_cm: float = 0.0) -> None:
        """Tell the localiser of `motion`; `driven_cm` adds to the distance counters."""
        self.localiser.predict(motion)
        self.estimate = self.localiser.estimate()
        self.counts.path_cm += abs(driven_cm)
        self.since_fix_cm += abs(driven_cm)

    def turn(self, angle: float, action: Action | DriveAction = Action.TURN) -> None:
        """Turn in place by `angle` (rad)."""
        self._count_action()
        self.robot.turn(angle)
        self._predicted(Motion(turn_rad=angle))
        if abs(angle) > TURN_EPS:
            self.counts.turns += 1
        self.record(action, turn_rad=angle)

    def move(self, distance: float, action: Action | DriveAction = Action.MOVE) -> bool:
        """Move `distance` cm; True when the watchdog stopped it."""
        self._count_action()
        out = self.robot.move(distance)
        self._predicted(Motion(distance_cm=out.distance_cm), out.distance_cm)
        if out.watchdog:
            self.counts.watchdog_stops += 1
        self.last_move = out
        self.record(action, distance_cm=out.distance_cm, watchdog=out.watchdog)
        return bool(out.watchdog)

    def turnback(self) -> None:
        """Back off from the wall ahead: the robot's `turnback` when the map behind the belief has room for
        it, a shorter reverse when it has less, none without room (`BACKOFF_MARGIN_CM` kept clear)."""
        self._count_action()
        full = backoff_cm(self.robot)
        room = self.room_behind(full + BACKOFF_MARGIN_CM) - BACKOFF_MARGIN_CM
        if room >= full:
            out = self.robot.turnback()
        elif room >= 0.5:
            out = self.robot.move(-room)
        else:
            self.record(Action.TURNBACK, distance_cm=0.0, note="no room behind to back off")
            return
        self._predicted(Motion(distance_cm=out.distance_cm), out.distance_cm)
        self.record(Action.TURNBACK, distance_cm=out.distance_cm)

    def room_behind(self, length_cm: float) -> float:
        """How far (cm, at most `length_cm`) the robot can reverse from the belief before the map's walls
        (all of it without a belief or a checker, or from a belief already in a wall: nothing to go by)."""
        if self.checker is None or self.estimate is None or not self.checker.point_free(self.estimate.pose.xy):
            return length_cm
        p = self.estimate.pose
        end = p.xy - length_cm * np.array([math.cos(p.theta), math.sin(p.theta)])
        return float(self.checker.first_contact(p.xy, end, tol=0.2)) * length_cm

    def note(self, text: str) -> None:
        """A decision of the global strategy, recorded in the trace."""
        self.record(Action.LOCALISE, note=text)
