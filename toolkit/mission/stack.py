"""One run of the mission stack: localise, plan, drive, re-localise, correct at the target."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.ops import nearest_points

from localisation.ambiguity import candidate_poses, describe_candidates
from localisation.base import Localiser, Motion, PoseEstimate, Prior
from localisation.procedure import LocaliseProcedure, look
from localisation.scan import sweep_angles
from planners.base import Planner, PlanningProblem, PlanResult

from ..world import (
    CollisionChecker,
    Map,
    MoveOutcome,
    Pose,
    Robot,
    angle_diff,
    make_checker,
)
from .config import _WINDOW_CENTRES, MissionConfig
from .recovery import WIDE_STD_CM, WIDE_STD_DEG, off_course, widened_prior
from .report import Action, Leg, Outcome, TraceStep

FloatArray = NDArray[np.float64]
log = logging.getLogger(__name__)

_TURN_EPS = math.radians(0.5)  # turns smaller than this are not counted as turns


class _MissionEnded(Exception):
    """Internal: the mission stops with `outcome`, `status` saying it in words."""

    def __init__(self, outcome: Outcome, status: str) -> None:
        super().__init__(status)
        self.outcome = outcome
        self.status = status
        self.success = outcome is Outcome.REACHED


class _Mission:
    """The mutable state of one run (counters, trace, current estimate)."""

    def __init__(self, robot: Robot, m: Map, target: FloatArray, planner: Planner,
                 localiser: Callable[[], Localiser], rng: np.random.Generator, config: MissionConfig,
                 procedure: LocaliseProcedure = look,
                 on_plan: Callable[[FloatArray], None] | None = None) -> None:
        self.robot = robot
        self._on_plan = on_plan  # told every path the mission will drive (a recorder, a live view)
        self.map = m
        self.target = target
        self.planner = planner
        self._make_localiser = localiser
        self._localiser: Localiser | None = None
        self.rng = rng
        self.cfg = config
        radius = float(robot.geometry.radius_cm)
        self.radius = radius
        self.candidates: list[Pose] = []  # the belief's candidate poses when it stayed ambiguous
        shared = getattr(robot, "checker", None)
        if (isinstance(shared, CollisionChecker) and shared.map is m and shared.robot_radius == radius
                and shared.backend == config.collision):
            self.checker = shared
        else:
            self.checker = make_checker(m, radius, config.collision)
        margin = config.safety_margin_cm
        # planning checkers with the full margin, then half of it; the bare radius is the last resort
        self.safe_checkers = [make_checker(m, radius + f * margin, config.collision) for f in (1.0, 0.5)
                              if margin > 0]
        lm = config.leg_margin_cm
        self.leg_checker = make_checker(m, radius + lm, config.collision) if lm > 0 else self.checker
        self._margin_checkers: dict[float, CollisionChecker] = {}
        self.trace: list[TraceStep] = []
        self.plans: list[FloatArray] = []
        self.planned_length = 0.0
        self.turns = 0
        self.watchdog_stops = 0
        self.relocalisations = 0
        self.replans = 0
        self.path_length = 0.0
        self.actions = 0
        self.estimate: PoseEstimate | None = None
        self.fresh_fix = False  # the estimate comes from a global fix not yet checked by a drive
        self.since_fix_cm = 0.0  # driven since the last converged fix
        self._localise = procedure
        self.on_sweep_fault: Callable[[str], None] | None = None  # told of sweeps taken again (a faulty sonar)
        self.on_motion_fault: Callable[[str], None] | None = None  # told of fixes far off the prediction
        self.on_watchdog_stop: Callable[[_Mission], str | None] | None = None  # why a stop says the belief is wrong
        self.last_move: MoveOutcome | None = None  # the outcome of the latest move

    @property
    def localiser(self) -> Localiser:
        """The localiser, built at its first use (a target in a wall is reported before any range table
        is computed)."""
        if self._localiser is None:
            self._localiser = self._make_localiser()
        return self._localiser

    # -- recording ------------------------------------------------------------------------------
    def true_pose(self) -> Pose | None:
        p = getattr(self.robot, "true_pose", None)
        return p if isinstance(p, Pose) else None

    def record(self, action: Action | str, **kw: Any) -> None:
        """A trace step: `action` (an `Action`, or its value; another string is a ValueError) and the belief."""
        est = self.estimate.pose if self.estimate is not None else None
        spread = self.estimate.std_xy_cm if self.estimate is not None else None
        self.trace.append(TraceStep(Action(action), est, self.true_pose(), robot_time_s=float(self.robot.robot_time_s),
                                    spread_cm=spread, **kw))

    def _count_action(self) -> None:
        self.actions += 1
        if self.actions > self.cfg.max_actions:
            raise _MissionEnded(Outcome.GAVE_UP, f"gave up after {self.cfg.max_actions} actions")

    # -- localisation ---------------------------------------------------------------------------
    def _sweep_options(self, kind: str) -> dict[str, Any]:
        """How a ``track`` or ``final`` re-localisation sweeps (a global one: `MissionConfig.global_strategy`)."""
        cfg = self.cfg
        if cfg.track_align:
            return {"align": True, "process": True, "scan_angles": None}
        if kind == "final":
            return {"align": False, "process": False,
                    "scan_angles": sweep_angles(cfg.final_scan_step_deg, cfg.final_window_deg)}
        return {"align": False, "process": False,
                "scan_angles": sweep_angles(cfg.track_scan_step_deg, cfg.track_window_deg,
                                            _WINDOW_CENTRES[cfg.track_windows])}

    def _look_options(self) -> dict[str, Any]:
        """Keyword arguments of every look, global or tracking: the config's, and `on_sweep_fault`."""
        options = dict(self.cfg.localise_options)
        if self.on_sweep_fault is not None:
            options["on_sweep_fault"] = self.on_sweep_fault
        return options

    def _call_localise(self, prior: Prior | None, kind: str = "track", **extra: Any) -> PoseEstimate:
        kwargs: dict[str, Any] = {"prior": prior, "rng": self.rng, **self._sweep_options(kind),
                                  **self._look_options(), **extra}
        return self._localise(self.robot, self.localiser, **kwargs).estimate

    def _ok(self, est: PoseEstimate) -> bool:
        return bool(est.converged) and bool(self.map.contains(est.pose.xy))

    def localise_global(self) -> PoseEstimate:
        """Global localisation by the strategy missions and the localiser benchmark share
        (`localisation.global_localisation.GlobalLocalisation`, from `MissionConfig.global_strategy`);
        the mission is its `Driver`, so every move of it is counted, checked and recorded here. Ends the
        mission when the robot stays lost, naming the candidate places when several fit.
        """
        cfg = self.cfg
        result = cfg.global_strategy().run(self.robot, self.localiser, rng=self.rng, driver=self,
                                           procedure=self._localise, look_options=self._look_options(),
                                           map=self.map, checker=self.checker,
                                           margin_checker=self.safe_checkers[-1] if self.safe_checkers else None)
        self.estimate = result.estimate
        if result.converged:
            self.fresh_fix = True
            self.since_fix_cm = 0.0
            return result.estimate
        self.candidates = candidate_poses(self._localiser)
        if self.candidates:  # several places fit the scans equally: say which, not just "lost"
            raise _MissionEnded(Outcome.AMBIGUOUS, f"{describe_candidates(self.candidates)}; global localisation "
                                f"could not tell them apart in {cfg.max_localisation_attempts} attempts")
        raise _MissionEnded(Outcome.LOST, f"robot lost: global localisation did not converge in "
                            f"{cfg.max_localisation_attempts} attempts")

    def note(self, text: str) -> None:
        """A decision of the global strategy, recorded in the trace."""
        self.record(Action.LOCALISE, note=text)

    def relocalise(self, reason: str, kind: str = "track") -> PoseEstimate:
        """Tracking re-localisation from the current belief (`kind` ``track`` or, at the target,
        ``final`` chooses the sweep); falls back to a global one."""
        self.relocalisations += 1
        if self.estimate is None:
            return self.localise_global()
        if self.cfg.tracking == "prior":
            est = self._call_localise(self._prior(self.estimate), kind, reset=True)
        else:
            est = self._call_localise(None, kind, reset=False)
        self.estimate = est
        ok = self._ok(est)
        self.record(Action.RELOCALISE, note=f"{reason}: {'converged' if ok else 'not converged'}, "
                                       f"spread {est.std_xy_cm:.2f} cm")
        if ok:
            self.fresh_fix = False
            self.since_fix_cm = 0.0
            return est
        if self.cfg.tracking != "prior":
            est = self._call_localise(self._prior(self.estimate), kind, reset=True)
            self.estimate = est
            ok = self._ok(est)
            self.record(Action.RELOCALISE,
                        note=f"{reason}, from a wider prior: {'converged' if ok else 'not converged'}")
            if ok:
                self.since_fix_cm = 0.0
                return est
        return self.localise_global()

    def relocalise_from(self, prior: Prior, reason: str) -> PoseEstimate:
        """Re-localise the usual way (`relocalise`) with the belief reset to `prior` first; a short first leg
        follows, as after a global fix."""
        self.localiser.reset(prior)
        self.estimate = self.localiser.estimate()
        est = self.relocalise(reason)
        self.fresh_fix = True
        return est

    def _prior(self, est: PoseEstimate) -> Prior:
        cov = np.array(est.cov, dtype=float, copy=True)
        floor = np.array([self.cfg.tracking_std_cm ** 2, self.cfg.tracking_std_cm ** 2,
                          math.radians(self.cfg.tracking_std_deg) ** 2])
        d = np.maximum(np.diag(cov), floor)
        if not np.all(np.isfinite(cov)):
            cov = np.diag(d)
        else:
            cov[np.diag_indices(3)] = d
        return Prior(est.pose, cov)

    # -- actions --------------------------------------------------------------------------------
    def turn(self, angle: float, action: Action | str = Action.TURN) -> None:
        self._count_action()
        self.robot.turn(angle)
        self.localiser.predict(Motion(turn_rad=angle))
        self.estimate = self.localiser.estimate()
        if abs(angle) > _TURN_EPS:
            self.turns += 1
        self.record(action, turn_rad=angle)

    def move(self, distance: float, action: Action | str = Action.MOVE) -> bool:
        """Move `distance` cm; returns True when the watchdog stopped it."""
        self._count_action()
        out = self.robot.move(distance)
        self.localiser.predict(Motion(distance_cm=out.distance_cm))
        self.estimate = self.localiser.estimate()
        self.path_length += abs(out.distance_cm)
        self.since_fix_cm += abs(out.distance_cm)
        if out.watchdog:
            self.watchdog_stops += 1
        self.last_move = out
        self.record(action, distance_cm=out.distance_cm, watchdog=out.watchdog)
        return bool(out.watchdog)

    def turnback(self) -> None:
        self._count_action()
        out = self.robot.turnback()
        self.localiser.predict(Motion(distance_cm=out.distance_cm))
        self.estimate = self.localiser.estimate()
        self.path_length += abs(out.distance_cm)
        self.since_fix_cm += abs(out.distance_cm)
        self.record(Action.TURNBACK, distance_cm=out.distance_cm)

    def after_watchdog(self) -> None:
        wrong = self.on_watchdog_stop(self) if self.on_watchdog_stop is not None else None
        self.turnback()
        if wrong:  # the sonar saw a wall where the belief sees none, twice: start from a wider belief
            self.record(Action.OFF_COURSE, note=wrong)
            if self.on_motion_fault is not None:
                self.on_motion_fault(wrong)
            assert self.estimate is not None
            self.relocalise_from(widened_prior(self.estimate, WIDE_STD_CM, math.radians(WIDE_STD_DEG)), wrong)
        else:
            self.relocalise("after watchdog stop")
        self.replans += 1
        if self.replans > self.cfg.max_replans:
            raise _MissionEnded(Outcome.GAVE_UP, f"gave up after {self.cfg.max_replans} re-plans")

    def safe_leg(self, xy: FloatArray, heading: float, leg: float) -> float:
        """The part of a `leg` (cm) from `xy` along `heading` (rad) that stays collision-free when the
        heading is off by `heading_tolerance_deg` either way (at least `min_leg_cm`)."""
        tol = math.radians(self.cfg.heading_tolerance_deg)
        if tol <= 0 or leg <= self.cfg.min_leg_cm:
            return leg
        length = leg
        checker = self.leg_checker if self.leg_checker.point_free(xy) else self.checker
        for dev in (-tol, tol):
            end = xy + leg * np.array([math.cos(heading + dev), math.sin(heading + dev)])
            length = min(length, checker.first_contact(xy, end, tol=0.2) * leg)
        return max(length, self.cfg.min_leg_cm)

    def _margin_checker(self, extra_cm: float) -> CollisionChecker:
        """A checker for the robot disc grown by `extra_cm` (rounded up to 0.5 cm; cached)."""
        key = math.ceil(max(extra_cm, 0.0) * 2.0) / 2.0
        if key == 0.0:
            return self.checker
        if key not in self._margin_checkers:
            self._margin_checkers[key] = make_checker(self.map, self.radius + key, self.cfg.collision)
        return self._margin_checkers[key]

    def spread_clear(self, goal: FloatArray) -> bool:
        """Whether the belief, as predicted now, can drive from its mean to `goal` without a fix:
        the segment is free for the robot disc grown by `spread_sigmas` standard deviations of the
        position across the segment plus the heading's over the segment's length."""
        assert self.estimate is not None
        a = self.estimate.pose.xy
        d = np.asarray(goal, dtype=float) - a
        length = float(np.hypot(*d))
        if length < 1e-6:
            return True
        cov = np.asarray(self.estimate.cov, dtype=float)
        if not np.all(np.isfinite(cov)):
            return False
        perp = np.array([-d[1], d[0]]) / length
        var_heading = max(float(cov[2, 2]), math.radians(self.cfg.spread_min_heading_deg) ** 2)
        var_across = max(float(perp @ cov[:2, :2] @ perp), (self.cfg.spread_drift * self.since_fix_cm) ** 2)
        var = var_across + length**2 * var_heading
        extra = self.cfg.spread_sigmas * math.sqrt(max(var, 0.0))
        if extra > 10.0:
            return False
        return bool(self._margin_checker(extra).segment_free(a, goal))

    def drive_to(self, goal: FloatArray, *, final: bool = False, next_goal: FloatArray | None = None) -> Leg:
        """Turn toward `goal` from the estimate and drive there in steps, re-localising on the way.

        Legs longer than `relocalise_every_cm` are split; after each leg the robot re-localises and
        re-aims, until the estimate is within `waypoint_tolerance_cm` of `goal` (for the `final`
        goal the final correction re-localises instead). With ``fix_rule="spread"`` a leg ends
        without a fix when the predicted belief can drive on (`spread_clear`: to `goal`, or on
        reaching it to `next_goal`), and a missed `goal` is skipped when the belief can drive on
        to `next_goal` the same way.

        Returns how the drive ended, a `Leg`: arrived, watchdog (the watchdog stopped a move), blocked (a
        move made almost no progress: a contact) or deviated (the straight line from the estimate to the
        goal is no longer free, or the goal is not reached in a few legs).
        """
        assert self.estimate is not None
        cfg = self.cfg
        spread = cfg.fix_rule == "spread"
        for legs in range(cfg.max_legs):
            pose = self.estimate.pose
            delta = goal - pose.xy
            dist = float(np.hypot(*delta))
            if dist <= cfg.waypoint_tolerance_cm and (legs > 0 or dist < 1e-6):
                return Leg.ARRIVED
            if legs > 0 and spread and next_goal is not None and self.spread_clear(next_goal):
                return Leg.ARRIVED  # missed the waypoint, but the way to the next one is clear for the belief
            if not self.checker.segment_free(pose.xy, goal):
                return Leg.DEVIATED
            turn = float(angle_diff(math.atan2(delta[1], delta[0]), pose.theta))
            if abs(turn) > 1e-9:
                self.turn(turn)
            every = cfg.relocalise_every_cm
            if self.fresh_fix and cfg.first_leg_cm is not None:
                every = cfg.first_leg_cm if every is None else min(every, cfg.first_leg_cm)
            leg = dist if every is None or dist <= 1.25 * every else every
            leg = self.safe_leg(pose.xy, math.atan2(delta[1], delta[0]), leg)
            driven = 0.0
            while leg - driven > 1e-9:
                step = min(cfg.move_step_cm, leg - driven)
                before = self.path_length
                if self.move(step):
                    return Leg.WATCHDOG
                if self.path_length - before < 0.5 * step:
                    return Leg.BLOCKED
                driven += step
            if final and leg >= dist:
                return Leg.ARRIVED
            ahead = goal if leg < dist else next_goal
            if spread and ahead is not None and self.spread_clear(ahead):
                self.record(Action.SKIP_FIX, note=f"belief spread {self.estimate.std_xy_cm:.1f} cm leaves the way "
                                             "ahead clear")
                if leg >= dist:
                    return Leg.ARRIVED
                continue
            predicted = self.estimate
            self.relocalise("at waypoint" if leg >= dist else "along segment")
            if self.off_course(predicted):
                return Leg.DEVIATED  # the robot did not go where its motions should have taken it: plan again
        return Leg.DEVIATED

    def off_course(self, predicted: PoseEstimate | None) -> bool:
        """Whether the fix just taken lies further from the `predicted` belief than motion noise explains
        (`toolkit.mission.recovery.off_course`: a wheel that slipped, a robot pushed); said in the trace
        and to `on_motion_fault`."""
        why = off_course(predicted, self.estimate) if self.estimate is not None and self._ok(self.estimate) else None
        if why is None:
            return False
        self.record(Action.OFF_COURSE, note=why)
        if self.on_motion_fault is not None:
            self.on_motion_fault(why)
        return True

    # -- planning -------------------------------------------------------------------------------
    def plan(self) -> FloatArray:
        """A path from the current estimate to the target; ends the mission when none exists.

        The path is planned with the safety margin when it can be: a start or target closer to a wall
        than the margin is joined by a short straight leg to the nearest point with the margin.
        Without such a path, it is planned with the bare robot radius.
        """
        assert self.estimate is not None
        start = self.estimate.pose.xy
        prefix: list[FloatArray] = []
        if not self.checker.point_free(start):
            escape = self._nearest_free(start, self.checker, self.radius + 0.5)
            if escape is None:
                raise _MissionEnded(Outcome.LOST, f"robot lost: estimate ({start[0]:.1f}, {start[1]:.1f}) is in a wall "
                                    "and no free space is near")
            prefix = [start]
            start = escape
        path: FloatArray | None = None
        result: PlanResult | None = None
        for checker in self.safe_checkers:
            s2 = self._nearest_free(start, checker, checker.robot_radius + 0.1)
            g2 = self._nearest_free(self.target, checker, checker.robot_radius + 0.1)
            if s2 is None or g2 is None:
                continue
            problem = PlanningProblem(self.map, checker, s2, g2, self.cfg.planning_time_s, self.rng)
            result = self.planner.plan(problem)
            if result.success:
                path = np.vstack([start, result.path, self.target])
                break
        if path is None:
            problem = PlanningProblem(self.map, self.checker, start, self.target, self.cfg.planning_time_s, self.rng)
            result = self.planner.plan(problem)
            if result.success:
                path = result.path
        assert result is not None
        if path is None:
            self.record(Action.PLAN, note=f"failed: {result.message}")
            raise _MissionEnded(Outcome.UNREACHABLE, f"target unreachable: planner {self.planner.name} found no "
                                f"path from ({start[0]:.1f}, {start[1]:.1f}) to "
                                f"({self.target[0]:.1f}, {self.target[1]:.1f}) ({result.message})")
        if prefix:
            path = np.vstack([*prefix, path])
        keep = np.ones(len(path), dtype=bool)
        keep[1:] = np.hypot(*np.diff(path, axis=0).T) > 1e-6
        path = path[keep]
        self.plans.append(path)
        if self._on_plan is not None:
            self._on_plan(path)
        length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
        if len(self.plans) == 1:
            self.planned_length = length
        self.record(Action.PLAN, note=f"{len(path) - 2} intermediate point(s), {length:.1f} cm, "
                                 f"{result.time_s * 1e3:.1f} ms")
        return path

    def _nearest_free(self, xy: FloatArray, checker: CollisionChecker, buffer: float) -> FloatArray | None:
        """`xy` when `checker` finds it free, else the nearest point of the c-space of radius `buffer`
        reachable from `xy` in a straight line with the bare radius (None when there is none)."""
        if checker.point_free(xy):
            return xy
        region = self.map.free_space(buffer)
        if region.is_empty:
            return None
        _, near = nearest_points(shapely.Point(xy), region)
        p = np.array([near.x, near.y])
        if not checker.point_free(p):
            return None
        if checker is not self.checker and not self.checker.segment_free(xy, p):
            return None
        return p

    # -- the whole run --------------------------------------------------------------------------
    def run(self) -> tuple[Outcome, str]:
        t = self.target
        if not self.map.contains(t):
            raise _MissionEnded(Outcome.TARGET_OUTSIDE,
                                f"target ({t[0]:.1f}, {t[1]:.1f}) is outside the free area of map {self.map.name}")
        if not self.checker.point_free(t):
            raise _MissionEnded(Outcome.TARGET_IN_WALL,
                                f"target ({t[0]:.1f}, {t[1]:.1f}) is in a wall: closer than the robot radius "
                                f"({self.radius:g} cm) to a wall of map {self.map.name}")
        self.localise_global()
        self.navigate()
        return self.final_correction()

    def navigate(self) -> None:
        """Plan and drive until the estimate is at the target."""
        while True:
            path = self.plan()
            outcome = Leg.ARRIVED
            for i, wp in enumerate(path[1:], start=1):
                nxt = path[i + 1] if i + 1 < len(path) else None
                outcome = self.drive_to(wp, final=i == len(path) - 1, next_goal=nxt)
                if outcome is not Leg.ARRIVED:
                    break
            if outcome is Leg.ARRIVED:
                return
            if outcome in (Leg.WATCHDOG, Leg.BLOCKED):
                self.after_watchdog()
            else:
                self.replans += 1
                if self.replans > self.cfg.max_replans:
                    raise _MissionEnded(Outcome.GAVE_UP, f"gave up after {self.cfg.max_replans} re-plans")

    def final_correction(self) -> tuple[Outcome, str]:
        """Re-localise at the target and correct until the estimate is within the tolerance."""
        cfg = self.cfg
        for k in range(cfg.max_corrections + 1):
            est = self.relocalise("at target", "final")
            for _ in range(cfg.final_scans - 1):
                est = self.relocalise("at target (extra scan)", "final")
            delta = self.target - est.pose.xy
            dist = float(np.hypot(*delta))
            if dist <= cfg.goal_tolerance_cm:
                return Outcome.REACHED, f"reached target (estimate {dist:.2f} cm from it after {k} correction(s))"
            if k == cfg.max_corrections:
                break
            if not self.checker.segment_free(est.pose.xy, self.target):
                self.navigate()
                continue
            turn = float(angle_diff(math.atan2(delta[1], delta[0]), est.pose.theta))
            sense = 1.0
            if dist <= cfg.reverse_cm and abs(turn) > 0.5 * math.pi:  # back up rather than turn around
                turn, sense = float(angle_diff(turn, math.pi)), -1.0
            self.turn(turn, action=Action.CORRECT_TURN)
            if self.move(sense * dist, action=Action.CORRECT_MOVE):
                self.after_watchdog()
                self.navigate()
        dist = float(np.hypot(*(self.target - self.estimate.pose.xy))) if self.estimate else math.inf
        if dist <= cfg.success_radius_cm:
            return Outcome.REACHED, (f"reached target (estimate {dist:.2f} cm from it; tolerance "
                                     f"{cfg.goal_tolerance_cm:g} cm not met in {cfg.max_corrections} corrections)")
        return Outcome.STOPPED_SHORT, f"stopped {dist:.1f} cm from the target after {cfg.max_corrections} corrections"
