"""`Mission`: the mission as a state machine, one handler per `State`, the decisions in named policies.

The transitions (`step` runs one state and returns the next)::

    CHECK_TARGET -> LOCALISE_GLOBAL -> PLAN -> DRIVE
    DRIVE -> DRIVE (next leg or waypoint) | RELOCALISE (a leg driven) | CHECK_HEADING (a large turn)
          | FINAL_CORRECTION (path driven)
          | RECOVER_STOP (watchdog stop, blocked move) | REPLAN (deviated, too many legs)
    RELOCALISE -> DRIVE | REPLAN (the fix is off course)
    CHECK_HEADING -> DRIVE (the sweep agrees) | RELOCALISE (the sweep was faulty) | REPLAN (it did not agree)
    RECOVER_STOP -> REPLAN -> PLAN
    FINAL_CORRECTION -> FINAL_CORRECTION (a correction move) | PLAN (no straight way)
          | RECOVER_STOP | DONE | FAILED
    any state -> RECONNECT (the link was lost) -> PLAN;  any state -> FAILED (a limit, a lost robot)

The policies: `FixPolicy` (when and how to re-localise), the exploration policy
(`MissionConfig.global_localisation`, a `GlobalLocalisation`), `FinalCorrectionPolicy`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import numpy as np

from localisation.base import HeadingPrior, Localiser
from localisation.procedure import LocaliseProcedure, look
from planners.base import Planner

from ..world import LinkLostError, Map, Robot, TruthSource
from ..world.arrays import FloatArray
from .checkers import Checkers
from .config import MissionConfig
from .context import MissionContext
from .driving import Driving, Leg
from .final_correction import FinalCorrectionPolicy
from .fix_policy import FixPolicy
from .localising import Fixes
from .planning import PathPlanner
from .recovery import WIDE_STD_CM, WIDE_STD_DEG, Recovery, StopCheck, widened_prior
from .report import Action, Outcome
from .states import MissionEnded, State


class Mission:
    """One run of the mission stack: its parts, where it is (`state`) and how it ended (`outcome`)."""

    def __init__(self, robot: Robot, m: Map, target: FloatArray, planner: Planner,
                 localiser: Callable[[], Localiser], rng: np.random.Generator, config: MissionConfig, *,
                 procedure: LocaliseProcedure = look, truth: TruthSource | None = None,
                 recovery: Recovery | None = None, on_plan: Callable[[FloatArray], None] | None = None,
                 start_heading: HeadingPrior | None = None) -> None:
        self.context = MissionContext(robot, m, target, config, localiser, truth, start_heading)
        self.checkers = Checkers(m, self.context.radius, config)
        self.context.checker = self.checkers.bare
        self.fix_policy = FixPolicy(config.fix, config.sweeps, self.checkers)
        self.final_policy = FinalCorrectionPolicy(config.final, target, self.checkers.bare)
        self.fixes = Fixes(self.context, self.fix_policy, self.checkers, procedure, rng)
        self.driving = Driving(self.context, self.fix_policy, self.checkers)
        self.planner = PathPlanner(self.context, planner, self.checkers, rng, on_plan)
        self.recovery = recovery
        if recovery is not None:  # its hooks: faults noted, watchdog stops watched
            self.context.on_sweep_fault = partial(recovery.sonar_fault, self.context)
            self.context.on_motion_fault = partial(recovery.motion_fault, self.context)
            self.context.on_watchdog_stop = StopCheck()
        self.state = State.CHECK_TARGET
        self.outcome: Outcome | None = None
        self.status = ""
        self._path: FloatArray = np.empty((0, 2))
        self._waypoint = 1  # index in the path of the waypoint driven to
        self._legs = 0  # legs driven toward it
        self._fix_reason = ""  # why the next RELOCALISE re-localises (the trace's note)
        self._corrections = 0  # correction rounds at the target
        self._lost: LinkLostError | None = None

    def run(self) -> tuple[Outcome, str]:
        """Run the states from `CHECK_TARGET` until `DONE` or `FAILED`."""
        while self.state not in (State.DONE, State.FAILED):
            self.state = self.step(self.state)
        assert self.outcome is not None
        return self.outcome, self.status

    def step(self, state: State) -> State:
        """Run `state`; the next state (`FAILED` when a limit or a lost robot ends the mission inside it,
        `RECONNECT` when the link was lost)."""
        try:
            return _HANDLERS[state](self)
        except LinkLostError as exc:
            if self.recovery is None:
                raise
            self._lost = exc
            return State.RECONNECT
        except MissionEnded as end:
            return self._end(end.outcome, end.status)

    def _end(self, outcome: Outcome, status: str) -> State:
        self.outcome, self.status = outcome, status
        return State.DONE if outcome is Outcome.REACHED else State.FAILED

    # -- the states -------------------------------------------------------------------------------
    def _check_target(self) -> State:
        t, m = self.context.target, self.context.map
        if not m.contains(t):
            return self._end(Outcome.TARGET_OUTSIDE,
                             f"target ({t[0]:.1f}, {t[1]:.1f}) is outside the free area of map {m.name}")
        if not self.checkers.bare.point_free(t):
            return self._end(Outcome.TARGET_IN_WALL,
                             f"target ({t[0]:.1f}, {t[1]:.1f}) is in a wall: closer than the robot radius "
                             f"({self.context.radius:g} cm) to a wall of map {m.name}")
        return State.LOCALISE_GLOBAL

    def _localise_global(self) -> State:
        self.fixes.localise_global()
        self.driving.checked()  # a global fix finds the heading afresh
        return State.PLAN

    def _plan(self) -> State:
        self._path = self.planner.plan()
        self._waypoint = 0
        return self._next_waypoint()

    def _next_waypoint(self) -> State:
        self._waypoint += 1
        self._legs = 0
        return State.DRIVE if self._waypoint < len(self._path) else State.FINAL_CORRECTION

    def _drive(self) -> State:
        if self._legs >= self.context.cfg.drive.max_legs:
            return State.REPLAN
        i, path = self._waypoint, self._path
        goal, ahead = path[i], (path[i + 1] if i + 1 < len(path) else None)
        end = self.driving.leg(goal, self._legs, ahead)
        if end.leg in (Leg.ARRIVED, Leg.PASSED):
            return self._next_waypoint()
        if end.leg in (Leg.WATCHDOG, Leg.BLOCKED):
            return State.RECOVER_STOP
        if end.leg is Leg.DEVIATED:
            return State.REPLAN
        if end.leg is Leg.TURNED:
            return State.CHECK_HEADING
        if end.to_goal and ahead is None:
            return self._next_waypoint()  # at the target, the final correction re-localises
        mission = self.context
        assert mission.estimate is not None
        if self.fix_policy.skips_fix(mission.estimate, mission.since_fix_cm, ahead if end.to_goal else goal):
            mission.record(Action.SKIP_FIX, note=f"belief spread {mission.estimate.std_xy_cm:.1f} cm leaves the way "
                                                 "ahead clear")
            if end.to_goal:
                return self._next_waypoint()
            self._legs += 1
            return State.DRIVE
        self._fix_reason = "at waypoint" if end.to_goal else "along segment"
        return State.RELOCALISE

    def _check_heading(self) -> State:
        mission = self.context
        check = self.fixes.heading_check()
        self.driving.checked()
        if check is None:  # the sensor was faulty: a fix instead
            self._fix_reason = "after the turn"
            return State.RELOCALISE
        if not check.off:
            mission.record(Action.CHECK_HEADING, note=f"the heading agrees: {check.describe()}")
            return State.DRIVE
        why = (f"the sweep after the turn fits a heading {math.degrees(check.offset_rad):+.0f} degrees from the "
               f"belief ({check.describe()}; did a wheel slip?); re-localising from there")
        mission.record(Action.OFF_COURSE, note=why)
        if mission.on_motion_fault is not None:
            mission.on_motion_fault(why)
        assert mission.estimate is not None
        self.fixes.relocalise_from(self.fix_policy.turned_prior(mission.estimate, check.offset_rad), why)
        return State.REPLAN

    def _relocalise(self) -> State:
        predicted = self.context.estimate
        est = self.fixes.relocalise(self._fix_reason)
        if self.driving.off_course(predicted, self.fixes.ok(est)):
            return State.REPLAN  # the robot did not go where its motions should have taken it
        self._legs += 1
        return State.DRIVE

    def _recover_stop(self) -> State:
        mission = self.context
        wrong = mission.on_watchdog_stop(mission) if mission.on_watchdog_stop is not None else None
        mission.turnback()
        if wrong:  # the sonar saw a wall where the belief sees none, twice: start from a wider belief
            mission.record(Action.OFF_COURSE, note=wrong)
            if mission.on_motion_fault is not None:
                mission.on_motion_fault(wrong)
            assert mission.estimate is not None
            self.fixes.relocalise_from(widened_prior(mission.estimate, WIDE_STD_CM, math.radians(WIDE_STD_DEG)), wrong)
        else:
            self.fixes.relocalise("after watchdog stop")
        return State.REPLAN

    def _replan(self) -> State:
        counts, limit = self.context.counts, self.context.cfg.limits.max_replans
        counts.replans += 1
        if counts.replans > limit:
            return self._end(Outcome.GAVE_UP, f"gave up after {limit} re-plans")
        return State.PLAN

    def _final_correction(self) -> State:
        est = self.fixes.relocalise("at target", "final")
        decision = self.final_policy.decide(est.pose, self._corrections)
        if decision.outcome is not None:
            return self._end(decision.outcome, decision.status)
        self._corrections += 1
        if decision.replan:
            return State.PLAN
        self.context.turn(decision.turn_rad, action=Action.CORRECT_TURN)
        if self.context.move(decision.distance_cm, action=Action.CORRECT_MOVE):
            return State.RECOVER_STOP
        return State.FINAL_CORRECTION

    def _reconnect(self) -> State:
        assert self.recovery is not None and self._lost is not None
        self.recovery.resume_or_end(self.context, self.fixes, self._lost)
        self._corrections = 0
        return State.PLAN


_HANDLERS: dict[State, Callable[[Mission], State]] = {
    State.CHECK_TARGET: Mission._check_target,
    State.LOCALISE_GLOBAL: Mission._localise_global,
    State.PLAN: Mission._plan,
    State.DRIVE: Mission._drive,
    State.CHECK_HEADING: Mission._check_heading,
    State.RELOCALISE: Mission._relocalise,
    State.RECOVER_STOP: Mission._recover_stop,
    State.REPLAN: Mission._replan,
    State.FINAL_CORRECTION: Mission._final_correction,
    State.RECONNECT: Mission._reconnect,
}
"""The handler of every state but the two ends."""


