"""Driving one leg toward a waypoint: aim from the estimate, cut the leg where a heading error could
reach a wall, move in steps with the watchdog on."""

from __future__ import annotations

import math
from enum import Enum
from typing import NamedTuple

import numpy as np

from localisation.base import PoseEstimate

from ..world import angle_diff
from ..world.arrays import FloatArray
from .checkers import Checkers
from .context import MissionContext
from .fix_policy import FixPolicy
from .recovery import off_course
from .report import Action

SLIP_SHARE = 0.5
"""The largest part of a turn a slip is taken to lose (wheels that skid on a smooth floor). The turns
toward waypoints since the last heading check add up; a leg whose whole way to its waypoint stays
clear of the walls with its heading off by this share of their sum either way needs no check (the
error stays in the belief over the legs after it: the fixes between them settle near it)."""


class Leg(Enum):
    """How one leg toward a waypoint ended."""

    ARRIVED = "arrived"
    """The estimate is at the waypoint (or, for the last one, the leg drove the whole way to it)."""
    PASSED = "passed"
    """The waypoint was missed, and the belief can drive on to the next one: it is left behind."""
    DRIVEN = "driven"
    """The leg was driven; the fix policy decides whether to re-localise before the next one."""
    WATCHDOG = "watchdog"
    """The watchdog stopped a move."""
    BLOCKED = "blocked"
    """A move made almost no progress: a contact."""
    DEVIATED = "deviated"
    """The straight line from the estimate to the waypoint is no longer free."""
    TURNED = "turned"
    """The robot turned toward the waypoint by enough that its heading is checked before the leg
    (`FixPolicy.checks_turn`)."""


class LegEnd(NamedTuple):
    """A leg's end: how, and whether the leg was long enough to reach the waypoint."""

    leg: Leg
    to_goal: bool = False


class Driving:
    """Drives the legs of `mission` (`DriveConfig`), their lengths as `policy` says."""

    def __init__(self, mission: MissionContext, policy: FixPolicy, checkers: Checkers) -> None:
        self.mission = mission
        self.policy = policy
        self.checkers = checkers
        self.cfg = mission.cfg.drive
        self.turned_rad = 0.0
        """Turning toward waypoints since the heading was last checked (or found globally), rad: a slip
        in any of those turns may still be in the belief."""

    def leg(self, goal: FloatArray, legs: int, next_goal: FloatArray | None) -> LegEnd:
        """Leg number `legs` (from 0) toward `goal`; `next_goal` is the waypoint after it (None: `goal` is
        the last)."""
        mission = self.mission
        assert mission.estimate is not None
        pose = mission.estimate.pose
        delta = goal - pose.xy
        dist = float(np.hypot(*delta))
        if dist <= self.cfg.waypoint_tolerance_cm and (legs > 0 or dist < 1e-6):
            return LegEnd(Leg.ARRIVED)
        if legs > 0 and self.policy.passes_missed(mission.estimate, mission.since_fix_cm, next_goal):
            return LegEnd(Leg.PASSED)
        if not self._clear(pose.xy, goal, dist):
            return LegEnd(Leg.DEVIATED)
        heading = math.atan2(delta[1], delta[0])
        turn = self.turn_toward(goal)
        if abs(turn) > 1e-9:
            mission.turn(turn)
            self.turned_rad += abs(turn)
        length = self.safe_length(pose.xy, heading, self.policy.leg_length(dist, mission.fresh_fix))
        if (dist > self.checkers.radius and self.policy.checks_turn(self.turned_rad)
                and not self.slip_safe(pose.xy, heading, dist, SLIP_SHARE * self.turned_rad)):
            return LegEnd(Leg.TURNED)
        moved = self._steps(length)
        return LegEnd(moved, length >= dist)

    def _clear(self, xy: FloatArray, goal: FloatArray, dist: float) -> bool:
        """Whether the straight leg from `xy` to `goal` (`dist` cm) is free for the robot. From an estimate
        inside the c-space (the robot touching a wall), the leg out to a free point at most a radius
        away is: the plan's escape (`PathPlanner.plan`)."""
        bare = self.checkers.bare
        if bare.point_free(xy):
            return bool(bare.segment_free(xy, goal))
        return dist <= self.checkers.radius + 1.0 and bool(bare.point_free(goal))

    def turn_toward(self, goal: FloatArray) -> float:
        """The turn (rad) that points the estimate at `goal`."""
        assert self.mission.estimate is not None
        pose = self.mission.estimate.pose
        return float(angle_diff(math.atan2(goal[1] - pose.y, goal[0] - pose.x), pose.theta))

    def _steps(self, length: float) -> Leg:
        """Move `length` cm in steps of at most `move_step_cm`: DRIVEN, or how a step ended early."""
        driven = 0.0
        while length - driven > 1e-9:
            step = min(self.cfg.move_step_cm, length - driven)
            before = self.mission.counts.path_cm
            if self.mission.move(step):
                return Leg.WATCHDOG
            if self.mission.counts.path_cm - before < 0.5 * step:
                return Leg.BLOCKED
            driven += step
        return Leg.DRIVEN

    def safe_length(self, xy: FloatArray, heading: float, leg: float) -> float:
        """The part of a `leg` (cm) from `xy` along `heading` (rad) that stays collision-free when the
        heading is off by `heading_tolerance_deg` either way (at least `min_leg_cm`)."""
        tol = math.radians(self.cfg.heading_tolerance_deg)
        if tol <= 0 or leg <= self.cfg.min_leg_cm:
            return leg
        length = leg
        checker = self.checkers.leg if self.checkers.leg.point_free(xy) else self.checkers.bare
        for dev in (-tol, tol):
            end = xy + leg * np.array([math.cos(heading + dev), math.sin(heading + dev)])
            length = min(length, checker.first_contact(xy, end, tol=0.2) * leg)
        return max(length, self.cfg.min_leg_cm)

    def checked(self) -> None:
        """The heading was just checked or found: no slip of the turns before is left in the belief."""
        self.turned_rad = 0.0

    def slip_safe(self, xy: FloatArray, heading: float, length: float, slip: float) -> bool:
        """Whether the leg of `length` cm from `xy` along `heading` (rad) stays free for the robot with its
        heading off by up to `slip` (rad) either way: then no heading check is needed."""
        devs = np.linspace(-slip, slip, 2 * math.ceil(math.degrees(slip) / 5.0) + 1)
        ends = xy + length * np.column_stack([np.cos(heading + devs), np.sin(heading + devs)])
        return bool(np.all(self.checkers.bare.segments_free(np.repeat(xy[None, :], devs.size, axis=0), ends)))

    def off_course(self, predicted: PoseEstimate | None, fixed: bool) -> bool:
        """Whether the fix just taken (`fixed`: it converged inside the map) lies further from the
        `predicted` belief than motion noise explains (`toolkit.mission.recovery.off_course`: a wheel
        that slipped, a robot pushed); said in the trace and to `on_motion_fault`."""
        mission = self.mission
        why = off_course(predicted, mission.estimate) if mission.estimate is not None and fixed else None
        if why is None:
            return False
        mission.record(Action.OFF_COURSE, note=why)
        if mission.on_motion_fault is not None:
            mission.on_motion_fault(why)
        return True
