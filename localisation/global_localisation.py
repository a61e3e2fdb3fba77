"""One global localisation for every caller: sweep, decide, explore, sweep again.

`GlobalLocalisation` is the strategy a mission runs to find the robot and the one the localiser
benchmark measures (`localise` runs it with the defaults). An attempt:

1. **Sweep**: one look (`localisation.procedure.look`): by default one full sweep at 2-degree steps
   whose readings near the minimum reading's direction and its perpendiculars go to the localiser
   (the paper's windows without the turn and the second sweep; ``align=True`` restores them).
2. **Decide**: a fix is converged and inside the map. A fix is confirmed by a second, independent
   look from a fresh reset at the same place (`confirm`): two fixes that disagree reveal a symmetric
   place the localiser collapsed on too early; a second belief at the same place whose heading is
   still loose confirms the place (the belief is then the first fix's again).
3. **Explore** while the belief is ambiguous or wide: drive toward open space (`exploration`, see
   `localisation.exploration`), then
4. **sweep again**, continuing the belief (or from a fresh reset when two fixes disagreed), and
   decide again; at most `max_explore_moves` moves. Where no move is safe but the belief knows the
   place, the robot settles its heading on the spot (turn toward the minimum reading, sweep the
   windows around the axes) up to `align_sweeps` times.

An attempt that ends without a fix is followed by a fresh one, `attempts` in all. The robot moves
through a `Driver`: the mission's own (it counts, records and checks every action), or
`RobotDriver`, which drives a `toolkit.world.Robot` and tells the localiser each motion.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Mapping
from dataclasses import replace
from enum import StrEnum
from typing import Annotated, Any, Protocol

import numpy as np
from pydantic import Field, field_validator

from toolkit.world import CollisionChecker, Map, RngLike, Robot, Scan, angle_diff, as_rng, make_checker
from toolkit.world.typed import Choices, Count, NonNegative, Real, Whole, typed_dataclass, with_unit, worded

from .base import HeadingPrior, Localiser, Motion, PoseEstimate, Prior
from .exploration import explore_direction, explore_from_modes, scan_explore_move
from .procedure import LocalisationResult, LocaliseProcedure, TraceStep, look
from .scan import ScanProcessing, min_reading, sweep_angles

__all__ = ["EXPLORATIONS", "DriveAction", "Driver", "GlobalLocalisation", "RobotDriver", "localise"]

log = logging.getLogger(__name__)

EXPLORATIONS = ("modes", "scan")
"""The exploration rules (`localisation.exploration`): ``modes`` (safe from every candidate pose),
``scan`` (the paper procedure's, from the last sweep alone)."""



class DriveAction(StrEnum):
    """Why the strategy turns or moves the robot (a mission's trace names its steps by these values)."""

    EXPLORE_TURN = "explore-turn"
    EXPLORE_MOVE = "explore-move"
    ALIGN_TURN = "align-turn"


class Driver(Protocol):
    """How the strategy moves the robot: each call acts and tells the localiser (``predict``).

    `estimate` is the strategy's current belief, set after every look (a mission records it with its
    actions).
    """

    estimate: PoseEstimate | None

    def turn(self, angle_rad: float, action: DriveAction) -> None:
        """Turn in place and predict."""
        ...

    def move(self, distance_cm: float, action: DriveAction) -> bool:
        """Drive straight and predict; True when the watchdog stopped the move."""
        ...

    def turnback(self) -> None:
        """Back off from the wall ahead and predict."""
        ...

    def note(self, text: str) -> None:
        """What the strategy decided, in words."""
        ...


class RobotDriver:
    """A `Driver` for a bare `Robot`: acts, then predicts the commanded turn or the distance reported.

    Attributes
    ----------
    compute_time_s : float
        Wall-clock time spent in the localiser's ``predict`` calls (s).
    notes : list of str
        What the strategy said (also logged at debug level).
    """

    def __init__(self, robot: Robot, localiser: Localiser) -> None:
        self.robot = robot
        self.localiser = localiser
        self.estimate: PoseEstimate | None = None
        self.compute_time_s = 0.0
        self.notes: list[str] = []

    def _predict(self, motion: Motion) -> None:
        t0 = time.perf_counter()
        self.localiser.predict(motion)
        self.compute_time_s += time.perf_counter() - t0

    def turn(self, angle_rad: float, action: DriveAction | None = None) -> None:
        self.robot.turn(angle_rad)
        self._predict(Motion(turn_rad=angle_rad))

    def move(self, distance_cm: float, action: DriveAction | None = None) -> bool:
        out = self.robot.move(distance_cm)
        self._predict(Motion(distance_cm=out.distance_cm))
        return bool(out.watchdog)

    def turnback(self) -> None:
        out = self.robot.turnback()
        self._predict(Motion(distance_cm=out.distance_cm))

    def note(self, text: str) -> None:
        self.notes.append(text)
        log.debug("%s", text)


@typed_dataclass()
class GlobalLocalisation:
    """The global-localisation strategy and its settings (lengths in cm, angles in degrees).

    The defaults are a mission's (`toolkit.mission.MissionConfig.global_localisation` is one, the
    mission's exploration policy), so the localiser benchmark measures what missions do.
    """

    scan_step_deg: Real = Field(default=2.0, gt=0, le=90, json_schema_extra=with_unit("deg"),
                                description="Turret step of the global sweeps (1: the paper's 360 readings).")
    align: bool = Field(default=False, description=(
        "Look the paper's way (sweep, turn toward the minimum reading, sweep again, windows around the axes); "
        "false: one sweep, windows around its minimum reading's direction."))
    process: bool = Field(default=True, description=(
        "false gives the localiser every usable reading (the raw baseline) instead of the windows."))
    attempts: Whole = Field(default=3, ge=1, description="Attempts (each from a fresh reset) before giving up.")
    confirm: bool = Field(default=True,
                          description="Confirm a fix with a second, independent look from the same place.")
    confirm_all: bool = Field(default=True, description=(
        "Confirm every fix, also those reached by exploring; false confirms single-place fixes only."))
    confirm_tolerance_cm: NonNegative = Field(default=5.0, json_schema_extra=with_unit("cm"),
                                              description="Two fixes further apart than this disagree.")
    max_explore_moves: Count = Field(default=6, description="Exploration moves per attempt.")
    explore_step_cm: NonNegative = Field(default=30.0, json_schema_extra=with_unit("cm"),
                                         description="Longest exploration move.")
    explore_heading_tolerance_deg: NonNegative = Field(default=12.0, json_schema_extra=with_unit("deg"), description=(
        "modes rule: a move must stay free with the candidates' headings off by this much either way (three "
        "standard deviations of a belief that knows the place but not its heading, when more)."))
    align_sweeps: Count = Field(default=2, description=(
        "Turn-and-sweep-again on the spot, per attempt, when no move is safe but the place is known."))
    place_cm: NonNegative = Field(default=4.0, json_schema_extra=with_unit("cm"), description=(
        "A belief knows the place when its position spread and all its modes are within this of its mean."))
    margin_cm: NonNegative = Field(default=2.0, json_schema_extra=with_unit("cm"), description=(
        "Clearance of exploration moves beyond the robot radius: half of it (modes rule)."))
    exploration: Annotated[str, Choices(lambda: EXPLORATIONS)] = Field(
        default="modes", description="The exploration rule (localisation.exploration).")

    @field_validator("exploration")
    @classmethod
    def _known_rule(cls, value: str) -> str:
        if value not in EXPLORATIONS:
            raise worded(f"exploration must be one of {', '.join(EXPLORATIONS)}, got {value!r}")
        return value

    def look_options(self) -> dict[str, Any]:
        """Keyword arguments of the look of a global sweep (`localisation.procedure.look`)."""
        # without the turn, the windows are taken around the minimum reading's direction: the
        # near-perpendicular readings a sonar model gets right, from one sweep
        return {"align": self.align, "scan_angles": sweep_angles(self.scan_step_deg),
                "processing": None if self.align else ScanProcessing(reference="min"), "process": self.process}

    def run(self, robot: Robot, localiser: Localiser, *, prior: Prior | HeadingPrior | None = None, rng: RngLike = None,
            reset: bool = True, driver: Driver | None = None, procedure: LocaliseProcedure = look,
            look_options: Mapping[str, Any] | None = None, map: Map | None = None,
            checker: CollisionChecker | None = None,
            margin_checker: CollisionChecker | None = None) -> LocalisationResult:
        """Localise `robot` with `localiser` (see the module docstring).

        Parameters
        ----------
        robot : Robot
            Swept by the looks (its ``geometry.radius_cm`` sizes the exploration moves).
        localiser : Localiser
        prior : Prior or HeadingPrior, optional
            The belief every reset starts from (None: global; trackers need one). A `HeadingPrior` turns
            with every turn the strategy makes, so each fresh reset knows the heading as it is then.
        rng : None, int or Generator
            The strategy's own draws (the ``modes`` fallback and the ``scan`` rule pick among equally
            open directions).
        reset : bool
            False: the first look continues the localiser's belief (later attempts and confirmations
            still reset it).
        driver : Driver, optional
            Moves the robot (default `RobotDriver`).
        procedure : callable
            The look (`localisation.procedure.look`; tests pass stand-ins).
        look_options : mapping, optional
            Extra keyword arguments of every look.
        map : Map, optional
            The map (default the localiser's).
        checker : CollisionChecker, optional
            Checks of the robot disc on `map` (built when needed, with the robot's checker's backend).
        margin_checker : CollisionChecker, optional
            Checks of the disc grown by half `margin_cm`, for exploration moves (built when needed, with
            `checker`'s backend).

        Returns
        -------
        LocalisationResult
            ``converged`` when the final belief is a fix inside the map; ``moves`` counts exploration
            moves; the trace holds every look, an exploration move on the look before it.
        """
        run = _Run(self, robot, localiser, prior=prior, rng=as_rng(rng), driver=driver or RobotDriver(robot, localiser),
                   procedure=procedure, look_options=dict(look_options or {}), map=map or localiser.map,
                   checker=checker, margin_checker=margin_checker)
        return run.result(run.localise(reset))


class _Run:
    """The state of one `GlobalLocalisation.run`: counters, trace, the last sweep."""

    def __init__(self, strategy: GlobalLocalisation, robot: Robot, localiser: Localiser, *,
                 prior: Prior | HeadingPrior | None,
                 rng: np.random.Generator, driver: Driver, procedure: LocaliseProcedure,
                 look_options: dict[str, Any], map: Map, checker: CollisionChecker | None,
                 margin_checker: CollisionChecker | None) -> None:
        self.s = strategy
        self.robot = robot
        self.localiser = localiser
        self.prior = prior
        self.rng = rng
        self.driver = driver
        self.procedure = procedure
        self.look_options = look_options
        self.map = map
        self.radius = float(robot.geometry.radius_cm)
        self._checker = checker
        self._margin_checker = margin_checker
        self.trace: list[TraceStep] = []
        self.scans = 0
        self.moves = 0
        self.compute_s = 0.0
        self.last_scan: Scan | None = None
        self.behind: float | None = None  # where the robot came from (rad, relative), after a move
        self.t_robot0 = float(robot.robot_time_s)

    # -- looks and judgements ---------------------------------------------------------------------
    def look(self, reset: bool, **overrides: Any) -> PoseEstimate:
        kwargs = {"prior": self.prior, "rng": self.rng, **self.s.look_options(), **self.look_options,
                  "reset": reset, **overrides}
        res = self.procedure(self.robot, self.localiser, **kwargs)
        self.scans += res.scans
        self.compute_s += res.compute_time_s
        for step in res.trace:
            self.trace.append(replace(step, iteration=len(self.trace) + 1))
            self.turned(step.aligned_turn_rad)
        self.last_scan = res.trace[-1].scan.raw if res.trace else None
        self.driver.estimate = res.estimate
        return res.estimate

    def turned(self, angle: float) -> None:
        """Keep `behind` relative to the heading, and a heading prior on the robot, after the robot turned
        by `angle`."""
        if self.behind is not None and abs(angle) > 1e-9:
            self.behind = float(angle_diff(self.behind, angle))
        if isinstance(self.prior, HeadingPrior):
            self.prior = self.prior.turned(angle)

    def ok(self, est: PoseEstimate) -> bool:
        return bool(est.converged) and bool(self.map.contains(est.pose.xy))

    def place_known(self, est: PoseEstimate) -> bool:
        """Whether a belief knows the place whatever its heading: position spread and every mode within
        `place_cm` of the mean, the mean inside the map."""
        near = self.s.place_cm
        return (bool(np.all(np.isfinite(est.cov))) and est.std_xy_cm <= near
                and all(md.pose.distance_to(est.pose) <= near for md in self.localiser.modes)
                and bool(self.map.contains(est.pose.xy)))

    @property
    def checker(self) -> CollisionChecker:
        """The robot disc's checks: the caller's, the robot's own when it is for this map and radius, or new."""
        if self._checker is None:
            own = getattr(self.robot, "checker", None)
            if isinstance(own, CollisionChecker) and own.map is self.map and own.robot_radius == self.radius:
                self._checker = own
            else:
                self._checker = make_checker(self.map, self.radius)
        return self._checker

    @property
    def margin_checker(self) -> CollisionChecker:
        """The robot disc grown by half the margin: exploration moves keep that clearance."""
        if self.s.margin_cm <= 0:
            return self.checker
        if self._margin_checker is None:
            self._margin_checker = make_checker(self.map, self.radius + 0.5 * self.s.margin_cm,
                                                self.checker.backend)
        return self._margin_checker

    # -- the strategy ---------------------------------------------------------------------------------
    def localise(self, reset: bool) -> PoseEstimate:
        est = self.look(reset)
        for attempt in range(1, self.s.attempts + 1):
            if attempt > 1:
                est = self.look(True)
            est = self.attempt(attempt, est)
            ok = self.ok(est)
            self.driver.note(f"global attempt {attempt}: {'converged' if ok else 'not converged'}, "
                             f"spread {est.std_xy_cm:.2f} cm")
            if ok:
                break
        return est

    def attempt(self, attempt: int, est: PoseEstimate) -> PoseEstimate:
        """Decide, explore and sweep again from the first look's `est` until a (confirmed) fix or the limits."""
        s = self.s
        explores = aligns = 0
        fresh = False  # the next look starts from a reset (two fixes disagreed)
        from_one_place = True  # the fix rests on scans from one place only
        while True:
            if self.ok(est):
                if not (s.confirm and (from_one_place or s.confirm_all)):
                    return est
                est2 = self.look(True)
                if est2.pose.distance_to(est.pose) <= s.confirm_tolerance_cm:
                    if self.ok(est2):
                        return est2
                    if self.place_known(est2):
                        # the same place again, only its heading still loose (no twin place): the first
                        # fix stands, and the belief is the first fix's again
                        t0 = time.perf_counter()
                        self.localiser.reset(Prior(est.pose, est.cov))
                        self.compute_s += time.perf_counter() - t0
                        self.driver.estimate = est
                        return est
                self.driver.note(f"global attempt {attempt}: {_second_fix_verdict(est, est2, s.confirm_tolerance_cm)}")
                est = est2
                fresh = True
            if explores >= s.max_explore_moves:
                return est
            direction, distance = self.explore_move(est, self.behind if explores else None)
            if distance < 1.0:  # no move is safe from this belief: settle its heading on the spot
                if aligns < s.align_sweeps and self.place_known(est):
                    est = self.align_sweep()
                    aligns += 1
                    continue
                return est
            self.driver.note(f"global attempt {attempt}: ambiguous (spread {est.std_xy_cm:.1f} cm), exploring")
            self.driver.turn(direction, DriveAction.EXPLORE_TURN)
            self.turned(direction)
            if self.driver.move(distance, DriveAction.EXPLORE_MOVE):
                self.driver.turnback()
            explores += 1
            self.moves += 1
            if self.trace:
                self.trace[-1] = replace(self.trace[-1], explore=Motion(turn_rad=direction, distance_cm=distance))
            self.behind = math.pi
            est = self.look(fresh)
            from_one_place = fresh
            fresh = False

    def explore_move(self, est: PoseEstimate, avoid_rad: float | None) -> tuple[float, float]:
        """A turn (rad) and distance (cm) toward open space while `est` is ambiguous (`exploration`)."""
        s = self.s
        scan = self.last_scan
        if s.exploration == "scan":
            return scan_explore_move(scan if scan is not None else self.robot.ultrascan(), self.radius, self.rng,
                                     avoid_rad, max_move_cm=s.explore_step_cm)
        tol = math.radians(s.explore_heading_tolerance_deg)
        poses = [md.pose for md in self.localiser.modes if self.checker.point_free(md.pose.xy)]
        if self.place_known(est):
            # one place, loose heading (the modes differ in heading only): allow for the belief's spread
            poses = poses or [est.pose]
            tol = max(tol, 3.0 * math.sqrt(max(float(est.cov[2][2]), 0.0)))
        if poses:
            return explore_from_modes(poses, self.map.walls, self.margin_checker, s.explore_step_cm, tol, avoid_rad)
        return explore_direction(scan if scan is not None else self.robot.ultrascan(),
                                 self.radius + 0.5 * s.margin_cm + 0.5, self.rng, avoid_rad, s.explore_step_cm)

    def align_sweep(self) -> PoseEstimate:
        """The paper's turn-and-sweep-again, on the spot: turn toward the minimum reading of the last
        sweep, sweep the windows around the axes and update the same belief."""
        scan = self.last_scan if self.last_scan is not None else self.robot.ultrascan()
        turn, _ = min_reading(scan)
        self.driver.turn(turn, DriveAction.ALIGN_TURN)
        self.turned(turn)
        est = self.look(False, align=False, processing=None, scan_angles=sweep_angles(self.s.scan_step_deg, 15.0))
        heading_sd = math.degrees(math.sqrt(max(float(est.cov[2][2]), 0.0)))
        self.driver.note(f"no safe exploration move: turned toward the nearest wall, swept again: "
                         f"{'converged' if self.ok(est) else 'not converged'}, heading spread {heading_sd:.1f} deg")
        return est

    def result(self, est: PoseEstimate) -> LocalisationResult:
        extra = self.driver.compute_time_s if isinstance(self.driver, RobotDriver) else 0.0
        return LocalisationResult(
            estimate=est,
            scans=self.scans,
            iterations=len(self.trace),
            converged=self.ok(est),
            trace=tuple(self.trace),
            moves=self.moves,
            robot_time_s=float(self.robot.robot_time_s) - self.t_robot0,
            compute_time_s=self.compute_s + extra,
            localiser=getattr(self.localiser, "name", type(self.localiser).__name__),
        )


def localise(robot: Robot, localiser: Localiser, *, prior: Prior | None = None, rng: RngLike = None,
             reset: bool = True, strategy: GlobalLocalisation | None = None, **look_options: Any) -> LocalisationResult:
    """Localise `robot` with `localiser` by the global strategy (default `GlobalLocalisation()`, a mission's).

    >>> from toolkit.robots.sim import SimRobot             # doctest: +SKIP
    >>> from toolkit.world import Pose, load_map            # doctest: +SKIP
    >>> from localisation import make_localiser             # doctest: +SKIP
    >>> m = load_map("map1")                                # doctest: +SKIP
    >>> robot = SimRobot(m, Pose(20, 20, 0.3), rng=1)       # doctest: +SKIP
    >>> localise(robot, make_localiser("paper-pf", m, rng=1), rng=1).converged  # doctest: +SKIP
    True
    """
    return (strategy or GlobalLocalisation()).run(robot, localiser, prior=prior, rng=rng, reset=reset,
                                                  look_options=look_options)


def _second_fix_verdict(first: PoseEstimate, second: PoseEstimate, tolerance_cm: float) -> str:
    """Why a second look did not confirm the first fix, in words: another place, or the same place
    without a confident estimate (its heading, or its spread)."""
    def pose(e: PoseEstimate) -> str:
        return f"({e.pose.x:.0f}, {e.pose.y:.0f}, {math.degrees(e.pose.theta):.0f} deg)"

    if second.pose.distance_to(first.pose) > tolerance_cm:
        return f"two fixes disagree: {pose(first)} vs {pose(second)}"
    return (f"the second fix, at the same place, is not confident: {pose(first)} vs {pose(second)}, "
            f"spread {second.std_xy_cm:.1f} cm, {math.degrees(second.std_heading_rad):.1f} deg")
