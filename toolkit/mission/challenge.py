"""The course's challenge: visit waypoints in order, sweeping only at them.

The robot is put down at one of the course's waypoints, at an unknown heading; it knows the course's
waypoints but not which one it stands on. It then visits the others in the course's order (starting
after its own, round the list), sweeping at each and nowhere else. This is the mission a robot runs
when its sonar only answers at waypoints (`toolkit.real_sonar.sweep_sonar`: real sweeps), and
`WaypointSweeps` is its policy:

1. **Start.** One full sweep. The robot knows it stands on a waypoint, so it tells which one and its
   heading by trying them all (`fit_pose`: every waypoint, every heading half a degree apart), as the
   course's own place recognition does; the belief is reset to a narrow Gaussian there
   (`ChallengeConfig.prior_std_cm`, `prior_std_deg`). With `ChallengeConfig.facing_sweep` (the
   default) the robot then turns toward its first leg and sweeps again, and the two sweeps, one turned
   by the odometry's turn, are fitted together (`joined`): which waypoint, and the heading. The next
   best places (`ChallengeConfig.start_retries` of them) are kept until the first leg's sweep says which:
   that leg is planned free wherever they would put the robot, when such a path exists
   (`toolkit.world.ConformantChecker`).
2. **Drive.** A path from the estimate to the next waypoint (the planner, with the robot radius plus
   `ChallengeConfig.margin_cm`; the bare radius when no path has the margin; after a change of start
   that rests on a refused sweep alone (step 3), only a path free at every start still open; from the
   nearest free point, at most `ChallengeRecovery.escape_cm` away, when drift left the belief too near a
   wall; when no path is free the mission ends there, undriven), driven leg by leg: turn toward the
   leg's end from the estimate, then moves of at most `ChallengeConfig.move_step_cm` (under BotSim's
   noise, of the length that leaves the leg's end least uncertain, `toolkit.world.MotionNoise.move_cm`),
   the localiser predicting after each. No sweep on the way.
3. **At the waypoint.** A full sweep and the localiser's update. A real sweep, as taken, says which
   waypoint the robot is at, not where near it, so by default (`ChallengeFix.position_from`
   ``prediction``) the belief is reset around the predicted position, at the heading the sweep fits
   best at the waypoint weighed against the predicted heading (`ChallengeFix.heading_from` ``fused``:
   each heading's fit as a likelihood times the prediction's Gaussian, `heading_belief`; ``sweep``: the
   fit alone). With
   ``localiser`` it is reset around the localiser's pose when that pose is one the odometry could have
   reached (`plausible_update`: within `ChallengeFix.gate_sigmas` standard deviations of the
   prediction, its heading within `ChallengeConfig.heading_span_deg`), else as by default; and with
   `ChallengeFix.max_corrections` > 0, while a trusted estimate is more than
   `ChallengeFix.correction_cm` from the waypoint, a correction (turn and move toward it) and another
   sweep (worth it with the hybrid sonar, `ChallengeSonar.offset_correction`, whose sweeps show the
   robot's offset). `ChallengeFix.oracle` gives the belief the truth's heading or pose after each sweep
   instead: not a policy, a ceiling to measure the policy against (simulated robots only). At the end
   of the first leg a sweep the sonar refuses (the robot is too far from the waypoint for any real
   sweep), or one that fits another start better (`WaypointSweeps.better_start`), moves the belief to
   that start: the next best of those the drive leaves possible (`WaypointSweeps.possible_starts`: a
   start that would have put the robot outside the arena by now was not its start); later, a refused
   sweep ends the mission there.
   With `ChallengeConfig.facing_sweep`, before the next leg the robot turns toward it and sweeps again:
   the heading is then fitted on both sweeps of the waypoint together and weighed against the
   prediction made before the first (`WaypointSweeps.face_next_leg`), so the heading the open-loop leg
   starts from rests on twice the readings, taken from two headings.

A move that makes no headway ends the leg (driving on would push against the wall again): the wheels
stalled against a wall the sonar did not hear, or the watchdog stopped it at once. A lone such stop
(the move before ran its length, and the map at the belief has no wall within twice
`ChallengeConfig.reach_cm` ahead) is tried once more: the real sensor's short readings stop a move now
and then, and under BotSim's noise, whose moves are short, most of those stops come before a move has
begun; a wall approached stops the moves before it too.

The report scores the truth: a waypoint is reached when the robot's true position ends within
`ChallengeConfig.reach_cm` (10 cm) of it; the mission when every waypoint is.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import shapely

from localisation.base import Localiser, Motion, PoseEstimate, Prior
from planners.base import Planner, PlanningProblem

from ..world import (
    ConformantChecker,
    Map,
    MotionNoise,
    Pose,
    RigidMove,
    RobotError,
    Scan,
    angle_diff,
    make_checker,
    wrap_angle,
)
from ..world.arrays import FloatArray
from .challenge_config import ChallengeConfig, ChallengeFix, ChallengeRecovery, ChallengeSonar
from .sweep_fit import Sweeps, fit_pose, heading_belief, joined, rank_places

__all__ = ["ChallengeConfig", "ChallengeFix", "ChallengeRecovery", "ChallengeReport", "ChallengeSonar",
           "WaypointSweeps", "WaypointVisit", "course_from", "fit_pose", "heading_belief", "joined",
           "plausible_update", "run_challenge"]

XY = tuple[float, float]

@dataclass(frozen=True)
class WaypointVisit:
    """One waypoint of the route: where it is, how far the robot truly ended from it and believed it
    ended (cm), the sweeps taken there, and what happened (empty: nothing to say)."""

    waypoint: XY
    error_cm: float
    estimate_error_cm: float
    sweeps: int
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"waypoint": list(self.waypoint), "error_cm": self.error_cm,
                "estimate_error_cm": self.estimate_error_cm, "sweeps": self.sweeps, "note": self.note}


@dataclass
class ChallengeReport:
    """The outcome of `run_challenge`: the visits (the start first), the truth's collisions, the sweeps taken
    (`sweeps_taken`: the facing sweeps too), the robot time, and how far the belief's heading was from the
    truth's as each leg started (`leg_heading_errors_deg`, degrees: what the stop's sweeps left for the
    open-loop leg)."""

    start: XY
    start_pose: Pose
    route: list[XY]
    localiser: str
    planner: str
    visits: list[WaypointVisit] = field(default_factory=list)
    start_match: XY | None = None
    notes: list[str] = field(default_factory=list)
    collisions: int = 0
    robot_time_s: float = 0.0
    sweeps_taken: int = 0
    leg_heading_errors_deg: list[float] = field(default_factory=list)
    status: str = ""
    reach_cm: float = 10.0
    trajectory: list[Pose] = field(default_factory=list)

    @property
    def reached(self) -> bool:
        """Every waypoint of the route visited, in its order, and truly reached within `reach_cm`."""
        return [v.waypoint for v in self.visits] == list(self.route) and \
            all(v.error_cm <= self.reach_cm for v in self.visits)

    @property
    def leg_heading_error_deg(self) -> float:
        """The median of `leg_heading_errors_deg` (NaN before any leg)."""
        return float(np.median(self.leg_heading_errors_deg)) if self.leg_heading_errors_deg else math.nan

    @property
    def worst_error_cm(self) -> float:
        """The largest true distance (cm) from a waypoint where the robot ended its visit."""
        return max((v.error_cm for v in self.visits), default=math.nan)

    def summary(self) -> str:
        lines = [f"challenge: start ({self.start[0]:g}, {self.start[1]:g}), route "
                 + " -> ".join(f"({x:g}, {y:g})" for x, y in self.route) + f"; {self.localiser}, {self.planner}"]
        for v in self.visits:
            lines.append(f"  ({v.waypoint[0]:g}, {v.waypoint[1]:g}): ended {v.error_cm:.1f} cm from it "
                         f"(believed {v.estimate_error_cm:.1f} cm), {v.sweeps} sweep(s)"
                         + (f"; {v.note}" if v.note else ""))
        lines += [f"  {note}" for note in self.notes]
        lines.append(f"{'reached every waypoint' if self.reached else 'NOT reached'} within {self.reach_cm:g} cm: "
                     f"worst {self.worst_error_cm:.1f} cm, {self.collisions} collision(s), "
                     f"{self.sweeps_taken} sweep(s), heading {self.leg_heading_error_deg:.1f} deg off at a "
                     f"leg's start (median), robot time "
                     f"{self.robot_time_s:.1f} s; {self.status}")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return {"start": list(self.start), "start_pose": self.start_pose.to_list_deg(),
                "route": [list(p) for p in self.route], "localiser": self.localiser, "planner": self.planner,
                "start_match": None if self.start_match is None else list(self.start_match),
                "visits": [v.to_dict() for v in self.visits], "notes": list(self.notes), "reached": self.reached,
                "worst_error_cm": self.worst_error_cm, "collisions": self.collisions, "sweeps_taken": self.sweeps_taken,
                "leg_heading_errors_deg": list(self.leg_heading_errors_deg),
                "robot_time_s": self.robot_time_s, "status": self.status, "reach_cm": self.reach_cm}


def course_from(course: list[XY], start: int) -> list[XY]:
    """The route of a challenge from waypoint `start` of `course`: the start, then the others in the
    course's order, round the list.

    >>> course_from([(1, 1), (2, 2), (3, 3)], 1)
    [(2, 2), (3, 3), (1, 1)]
    """
    return [*course[start:], *course[:start]]


def _distance(pose: Pose, xy: XY) -> float:
    return math.hypot(pose.x - xy[0], pose.y - xy[1])


class WaypointSweeps:
    """The challenge's policy: sweep at the waypoints only, drive between them on predictions (module
    docstring). `robot` is a simulated robot with a truth (`true_pose`, `collisions`)."""

    def __init__(self, robot: Any, m: Map, localiser: Localiser, planner: Planner, rng: np.random.Generator,
                 config: ChallengeConfig, motion: MotionNoise | None = None) -> None:
        self.robot = robot
        self.motion = motion
        self.map = m
        self.localiser = localiser
        self.planner = planner
        self.rng = rng
        self.cfg = config
        radius = float(robot.geometry.radius_cm)
        self.checkers = [make_checker(m, radius + config.margin_cm), make_checker(m, radius)]
        self.estimate: PoseEstimate | None = None
        self.trajectory: list[Pose] = [robot.true_pose]
        self.sweeps_taken = 0
        self.unresolved: list[RigidMove] = []
        """Until the first leg's sweep says which start was right: the rigid moves from the believed start to
        each other start the mission may fall back to (`localise_start`); the first leg is planned to be
        free at all of them (`ConformantChecker`)."""
        self.switched = False
        """Whether the mission gave up its believed start for another on a refused sweep alone
        (`restart_from`): until a sweep answers, its legs are driven only where they are free at every
        start still open."""
        self.ran_clean = True
        """Whether the last move ran its length without a watchdog stop (`_act`)."""
        self.last_fix: tuple[Scan, PoseEstimate, XY] | None = None
        """The sweep of the last waypoint, the prediction it corrected and the waypoint, while the
        heading fix may still take a facing sweep (`face_next_leg`)."""

    # -- the start ------------------------------------------------------------------------------------
    def localise_start(self, course: list[XY]) -> list[Pose]:
        """Which waypoint the robot stands on, and at which heading (`rank_places` over every waypoint
        and heading); the belief is reset around the best. Returns every waypoint's pose, best first."""
        scan = self.sweep()
        ranked = [pose for _, pose in rank_places(self.map, scan, course)]
        self._settle(ranked[0])
        if self.cfg.facing_sweep:
            best = ranked[0]
            turn, more = self._face_and_sweep(course_from(course, course.index((best.x, best.y)))[1])
            if more is not None:
                ranked = [pose for _, pose in rank_places(self.map, joined(scan, more, turn), course)]
                best = ranked[0]
                self._settle(Pose(best.x, best.y, float(wrap_angle(best.theta + turn))))
        self.unresolved = [RigidMove(ranked[0], other) for other in ranked[1:1 + self.cfg.start_retries]]
        return ranked

    def restart_from(self, believed: Pose, instead: Pose, others: list[Pose], *, answered: bool) -> None:
        """The robot started at `instead`, not at `believed`: the belief is moved as the robot's own
        motion since then moves it (the estimate seen from `believed`, put at `instead`; the prediction
        before a pending fix, which took the wrong waypoint). The `others` stay unresolved (`unresolved`);
        when no sweep `answered` (the switch rests on a refusal alone), legs are driven only where they are
        free at each of them (`switched`)."""
        pose = self._since_start()
        self.last_fix = None
        self._settle(RigidMove(believed, instead).pose(pose))
        self.unresolved = [RigidMove(instead, other) for other in others]
        self.switched = not answered

    def possible_starts(self, believed: Pose, starts: list[Pose]) -> list[Pose]:
        """The `starts` that could be the robot's, given its motion since the start: where each would have
        put the robot now (the belief seen from `believed`, moved rigidly; the prediction before a pending
        fix) lies within `ChallengeRecovery.start_slack_cm` of the free space. A start that would have driven
        the robot out of the arena, or into a wall, was not its start."""
        pose = self._since_start()
        regions = self.checkers[1].free_regions()  # the bare radius's free space, made once per checker
        return [s for s in starts if min(r.distance(shapely.Point(*RigidMove(believed, s).pose(pose).xy))
                                         for r in regions) <= self.cfg.recovery.start_slack_cm]

    def _since_start(self) -> Pose:
        """The belief as the robot's own motion since the start left it: the prediction before a pending
        fix (which took the waypoint the believed start implies), else the estimate."""
        assert self.estimate is not None
        return self.last_fix[1].pose if self.last_fix is not None else self.estimate.pose

    def start_after_first_leg(self, starts: list[Pose], *, answered: bool) -> Pose | None:
        """The start the end of the first leg says the robot had, when not the believed one (`starts[0]`;
        the others as `possible_starts` leaves them): a refused sweep gives up the believed start for the
        next, an answered one takes the start it fits best (`better_start`). None: the believed start holds
        (or no other is possible)."""
        if len(starts) < 2:
            return None
        best = starts[self.better_start(starts)] if answered else starts[1]
        return None if best is starts[0] else best

    def better_start(self, starts: list[Pose]) -> int:
        """Which of the `starts` (the believed one first, as ranked at the start) the sweep just taken at the
        end of the first leg fits best where that start would have put the robot (the prediction before the
        fix, moved rigidly; `rank_places` there, the heading within `ChallengeConfig.heading_span_deg` of
        the moved prediction's): its index, 0 when the believed start holds or no sweep is pending."""
        if self.last_fix is None:
            return 0
        scan, predicted = self.last_fix[0], self.last_fix[1].pose
        scores = []
        for start in starts:
            here = RigidMove(starts[0], start).pose(predicted)
            scores.append(rank_places(self.map, scan, [(here.x, here.y)], heading=here.theta,
                                      span_deg=self.cfg.heading_span_deg)[0][0])
        return int(np.argmax(scores))

    def _settle(self, pose: Pose, heading_std_rad: float | None = None) -> None:
        """Reset the belief to a narrow Gaussian around `pose` (`ChallengeConfig.prior_std_cm`; the heading's
        spread `heading_std_rad`, default `ChallengeConfig.prior_std_deg`)."""
        heading_sd = math.radians(self.cfg.prior_std_deg) if heading_std_rad is None else heading_std_rad
        cov = np.diag([self.cfg.prior_std_cm ** 2] * 2 + [heading_sd ** 2])
        self.localiser.reset(Prior(pose, cov))
        self.estimate = self.localiser.estimate()

    def sweep(self) -> Scan:
        """A full sweep of the robot's sonar, counted in `sweeps_taken` when the sonar answers."""
        scan = self.robot.ultrascan()
        self.sweeps_taken += 1
        return scan

    def heading_error_deg(self) -> float:
        """How far (degrees, absolute) the belief's heading is from the truth's (scoring only)."""
        assert self.estimate is not None
        return round(abs(math.degrees(float(angle_diff(self.estimate.pose.theta, self.robot.true_pose.theta)))), 3)

    def _face_and_sweep(self, goal: XY) -> tuple[float, Scan | None]:
        """Turn toward the first corner of the path to `goal` and sweep: the turn (rad, as commanded and
        predicted) and the sweep (None when the sonar refuses it)."""
        path = self._plan(goal)
        corner = goal if path is None else path[1]
        turn = self._turn_toward((float(corner[0]), float(corner[1])))
        self._act(turn, 0.0)
        try:
            return turn, self.sweep()
        except RobotError:
            return turn, None

    def face_next_leg(self, goal: XY) -> None:
        """With `ChallengeConfig.facing_sweep`, turn toward the leg to `goal` and sweep again at the
        waypoint just fixed: the heading is fitted on both of its sweeps together (`joined`) and
        weighed against the prediction made before the first (`fixed_heading`), then turned by the
        turn. Nothing to do without a pending fix (the start took its own, or the fix trusted the
        localiser)."""
        pending, self.last_fix = self.last_fix, None
        if not self.cfg.facing_sweep or pending is None:
            return
        first, predicted, waypoint = pending
        turn, more = self._face_and_sweep(goal)
        if more is None:
            return
        heading, spread = self.fixed_heading(joined(first, more, turn), predicted, waypoint)
        assert self.estimate is not None
        here = self.estimate.pose
        self._settle(Pose(here.x, here.y, float(wrap_angle(heading + turn))), spread)
        self._apply_oracle()

    # -- driving ----------------------------------------------------------------------------------------
    def _plan(self, goal: XY) -> FloatArray | None:
        """A path (cm, from the estimate) to `goal`, free with the margin, else with the bare radius; while
        other starts are open (`unresolved`) free at each of them first, and after a switch of start
        (`switched`) only that. None when no path is free: a leg driven where no check holds is a leg
        into a wall, whichever belief is wrong."""
        assert self.estimate is not None
        here = self.estimate.pose.xy
        conformant = [ConformantChecker(c, self.unresolved) for c in self.checkers] if self.unresolved else []
        checkers = conformant if conformant and self.switched else [*conformant, *self.checkers]
        for reach_cm, checker in itertools.product((0.0, self.cfg.recovery.escape_cm), checkers):
            start = checker.nearest_free(here, reach_cm)
            if start is None or not checker.point_free(np.array(goal)):
                continue
            result = self.planner.plan(PlanningProblem(self.map, checker, start, np.array(goal), self.cfg.plan_time_s,
                                                       self.rng))
            if result.success:
                path = np.asarray(result.path, dtype=float)
                return path if np.array_equal(start, here) else np.vstack([here, path])  # the move out first
        return None

    def _act(self, turn_rad: float, distance_cm: float) -> None:
        """Turn, then drive `distance_cm` in moves (`MotionNoise.move_cm`), the localiser predicting after each."""
        move_cm = self.cfg.move_step_cm if self.motion is None else self.motion.move_cm(distance_cm,
                                                                                          self.cfg.move_step_cm)
        if turn_rad:
            self.robot.turn(turn_rad)
            self.localiser.predict(Motion(turn_rad, 0.0))
        left = distance_cm
        while left > 1e-6:
            step = min(move_cm, left)
            outcome = self.robot.move(step)
            self.localiser.predict(Motion(0.0, outcome.distance_cm))
            self.trajectory.append(self.robot.true_pose)
            was_clean, self.ran_clean = self.ran_clean, not outcome.watchdog
            if abs(outcome.distance_cm) < 0.5:  # stopped at once: by the watchdog, or against a wall
                if outcome.watchdog and was_clean and self._clear_ahead(2.0 * self.cfg.reach_cm):
                    continue  # a lone stop where the map has no wall: the sonar may have misread
                break
            if outcome.watchdog:  # a wall ahead, or the sensor's short reading twice: move on
                left -= abs(outcome.distance_cm)
                continue
            if abs(outcome.distance_cm) < step - 0.5:  # the wheels stalled part way: the body met a wall
                break
            left -= step
        self.estimate = self.localiser.estimate()

    def _clear_ahead(self, distance_cm: float) -> bool:
        """Whether the map, at the localiser's pose, leaves the robot `distance_cm` of straight driving."""
        p = self.localiser.estimate().pose
        ahead = p.xy + distance_cm * np.array([math.cos(p.theta), math.sin(p.theta)])
        return bool(self.checkers[1].segment_free(p.xy, ahead))

    def _turn_toward(self, xy: XY) -> float:
        """The turn (rad) that faces the estimate toward `xy`."""
        assert self.estimate is not None
        p = self.estimate.pose
        return float(angle_diff(math.atan2(xy[1] - p.y, xy[0] - p.x), p.theta))

    def go_to(self, xy: XY) -> None:
        """Turn toward `xy` from the estimate and drive there (no sweep)."""
        assert self.estimate is not None
        p = self.estimate.pose
        self._act(self._turn_toward(xy), math.hypot(xy[0] - p.x, xy[1] - p.y))

    def drive_to(self, goal: XY) -> bool:
        """Plan from the estimate to `goal` and drive the path leg by leg; False (nothing driven) when no
        path is free (`_plan`)."""
        path = self._plan(goal)
        for corner in [] if path is None else path[1:]:
            self.go_to((float(corner[0]), float(corner[1])))
        return path is not None

    # -- at a waypoint ------------------------------------------------------------------------------
    def fixed_heading(self, scan: Sweeps, predicted: PoseEstimate, waypoint: XY) -> tuple[float, float]:
        """The belief's heading (rad) after a waypoint's sweep and its spread (rad): ``heading_from`` ``fused``,
        the most likely heading given the sweep's fit at each heading and the `predicted` heading with the
        localiser's spread (`heading_belief`, `ChallengeFix.fit_temperature_cm`); ``sweep``, the fit alone (the
        same without the prior: its least misfit) with the spread `ChallengeConfig.prior_std_deg`. The fit
        holds the position at the waypoint, where the real sweep was taken (a position 2 cm off can move a
        72-reading sweep's minimum by 20 degrees), and tries the headings within
        `ChallengeConfig.heading_span_deg` of the prediction, not of the localiser's update (its 40-degree
        lobe can turn the heading by 10-30 degrees on a real sweep).

        A sweep as taken pins the heading only to a few degrees: turned by whole bins (up to 2.5 degrees off
        for 5-degree bins) and fitted at the waypoint while the robot stands up to 10 cm from it, and on many
        real sweeps the fit is flat over 10-16 degrees. Over a leg the odometry keeps the heading about as
        well, so the two are weighed: a sharp fit decides, a flat one leaves the heading to the prediction
        (a Kalman update of the fit's least misfit by a fixed spread took a flat sweep's arbitrary minimum
        at full weight: a leg 13 degrees off, 24 cm from its waypoint)."""
        alone = self.cfg.fix.heading_from == "sweep"
        prior_sd = None if alone else math.sqrt(float(np.asarray(predicted.cov, dtype=float)[2, 2]))
        heading, spread = heading_belief(self.map, scan, waypoint, predicted.pose.theta, self.cfg.heading_span_deg,
                                         self.cfg.fix.fit_temperature_cm, prior_sd)
        return heading, math.radians(self.cfg.prior_std_deg) if alone else spread

    def _apply_oracle(self) -> None:
        """With `ChallengeFix.oracle`, give the belief the truth's heading or pose (a ceiling, for study)."""
        if self.cfg.fix.oracle == "none":
            return
        assert self.estimate is not None
        truth, pose = self.robot.true_pose, self.estimate.pose
        self._settle(truth if self.cfg.fix.oracle == "pose" else Pose(pose.x, pose.y, truth.theta))

    def sweep_and_correct(self, waypoint: XY) -> WaypointVisit:
        """Sweep, update, fit the heading and correct toward `waypoint` (module docstring); a refused
        sweep ends the visit."""
        sweeps, note = 0, ""
        for attempt in range(self.cfg.fix.max_corrections + 1):
            try:
                scan = self.sweep()
            except RobotError as exc:
                note = f"sweep refused: {exc}"
                break
            sweeps += 1
            assert self.estimate is not None
            predicted = self.estimate
            self.localiser.update(scan)
            updated = self.localiser.estimate().pose
            trusted = self.cfg.fix.position_from == "localiser" and plausible_update(predicted, updated, self.cfg)
            if trusted:
                self._settle(updated)
            else:
                heading, spread = self.fixed_heading(scan, predicted, waypoint)
                self._settle(Pose(predicted.pose.x, predicted.pose.y, heading), spread)
            self.last_fix = None if trusted else (scan, predicted, waypoint)
            self._apply_oracle()
            if not trusted or _distance(self.estimate.pose, waypoint) <= self.cfg.fix.correction_cm or \
                    attempt == self.cfg.fix.max_corrections:
                break
            self.go_to(waypoint)
        assert self.estimate is not None
        return WaypointVisit(waypoint, round(_distance(self.robot.true_pose, waypoint), 3),
                             round(_distance(self.estimate.pose, waypoint), 3), sweeps, note)


def plausible_update(predicted: PoseEstimate, updated: Pose, config: ChallengeConfig) -> bool:
    """Whether the localiser's pose after a sweep (`updated`) is one the odometry could have reached:
    within `ChallengeFix.gate_sigmas` standard deviations of the `predicted` belief (its position
    covariance widened by `ChallengeConfig.prior_std_cm`, how well one sweep pins a position) and its
    heading within `ChallengeConfig.heading_span_deg` of the prediction's. An update that jumps
    farther took a place the sweep fits, not one the robot can have driven to: the mission keeps the
    prediction (a real sweep's fit can jump to a twin of the waypoint; a correction toward the
    waypoint from there drove a robot into the walls)."""
    if abs(math.degrees(float(angle_diff(updated.theta, predicted.pose.theta)))) > config.heading_span_deg:
        return False
    cov = np.asarray(predicted.cov, dtype=float)[:2, :2] + np.eye(2) * config.prior_std_cm ** 2
    v = np.array([updated.x - predicted.pose.x, updated.y - predicted.pose.y])
    return bool(v @ np.linalg.solve(cov, v) <= config.fix.gate_sigmas ** 2)


def run_challenge(robot: Any, m: Map, course: list[XY], start: int, localiser: Localiser, planner: Planner,
                  rng: np.random.Generator, config: ChallengeConfig | None = None,
                  motion: MotionNoise | None = None) -> ChallengeReport:
    """Run the challenge on a simulated `robot` standing on waypoint `start` of `course` (module
    docstring; the robot is not told `start`, the report scores against it); never raises for a refused
    sweep or a lost robot: the report says so."""
    cfg = config or ChallengeConfig()
    truth_route = course_from(course, start)
    policy = WaypointSweeps(robot, m, localiser, planner, rng, cfg, motion)
    report = ChallengeReport(truth_route[0], robot.true_pose, truth_route, localiser.name, planner.name,
                             reach_cm=cfg.reach_cm)
    t0 = float(robot.robot_time_s)
    hypotheses = policy.localise_start(course)
    believed = hypotheses[0]
    report.start_match = (believed.x, believed.y)
    report.visits.append(WaypointVisit(truth_route[0], round(_distance(robot.true_pose, truth_route[0]), 3),
                                       round(_distance(believed, truth_route[0]), 3), 1))
    route, k, restarted = course_from(course, course.index(report.start_match)), 1, False
    report.status = "done"
    while k < len(route):
        policy.face_next_leg(route[k])
        report.leg_heading_errors_deg.append(policy.heading_error_deg())
        if not policy.drive_to(route[k]):
            report.status = (f"ended before ({route[k][0]:g}, {route[k][1]:g}): no path to it is free"
                             + (" at every start still open" if policy.switched and policy.unresolved else ""))
            break
        visit = policy.sweep_and_correct(route[k])
        if k == 1 and not restarted:
            open_starts = [hypotheses[0], *policy.possible_starts(hypotheses[0], hypotheses[1:])[:cfg.start_retries]]
            answer = policy.start_after_first_leg(open_starts, answered=visit.sweeps > 0)
            if answer is not None:  # the first leg did not end where the believed start puts it
                report.notes.append(
                    f"{'no sweep' if visit.sweeps == 0 else 'the sweep fits another start better'} at "
                    f"({route[k][0]:g}, {route[k][1]:g}); started at ({answer.x:g}, {answer.y:g}) instead, the "
                    "next best fit that the drive leaves possible")
                policy.restart_from(hypotheses[0], answer, [h for h in open_starts if h is not answer],
                                    answered=visit.sweeps > 0)  # the others stay possible
                restarted = True
                route = course_from(course, course.index((answer.x, answer.y)))
                continue
        policy.unresolved = []  # the sweep answered where the believed start puts the robot
        report.visits.append(visit)
        if visit.sweeps == 0:
            report.status = f"ended at ({route[k][0]:g}, {route[k][1]:g}): {visit.note}"
            break
        k += 1
    report.collisions = int(robot.collisions)
    report.robot_time_s = float(robot.robot_time_s) - t0
    report.sweeps_taken = policy.sweeps_taken
    report.trajectory = policy.trajectory
    return report
