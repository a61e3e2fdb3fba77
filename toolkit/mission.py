"""The mission stack: localise, plan, drive with the watchdog, re-localise and re-plan, final correction.

`run_mission` runs any registered localiser and planner on any `toolkit.world.Robot` (the simulator
or a real NXT) from an unknown start pose to a target, the way the paper's system does:

1. **Localise** globally with `localisation.procedure.localise`, one iteration at a time: by default
   one full sweep at 2-degree steps whose readings near the minimum reading's direction and its
   perpendiculars go to the localiser (the paper's processing without the turn and the second
   sweep; `MissionConfig.global_align` restores them). While the belief is ambiguous (the identical
   rooms of map3) the mission drives toward open space along a move that is collision-free from
   every candidate pose the localiser reports, and localises again. A fix is confirmed by a second,
   independent global localisation.
2. **Plan** in the configuration space from the estimate with the chosen planner and the shared FCL
   `CollisionChecker` (with a safety margin on the robot radius when the map allows it).
3. **Drive** the path segment by segment: Turn to the segment heading (from the estimate), then Move in
   steps with the collision watchdog on; the localiser predicts after every action, so the belief
   is tracked through the motion. Legs end at each waypoint, after a short first leg following a
   global fix, where a heading error of a few degrees could bring the robot to a wall, and every
   `relocalise_every_cm` when set. Where a leg ends the robot re-localises (tracking: one sweep of
   the paper's four windows around its axes, from its belief) only when the belief's predicted
   spread would not leave the way ahead clear of the walls (`MissionConfig.fix_rule`); a missed
   waypoint is skipped when the belief can drive on to the next one. A next segment that is no longer free
   from the new estimate is re-planned.
4. On a **watchdog stop** (or a move that makes no progress): Turnback, re-localise, re-plan.
5. At the **target**: re-localise and correct (turn + move toward the target from the estimate, backing
   up for short moves behind the robot) until the estimate is within
   `MissionConfig.goal_tolerance_cm` of the target or the retry limit is hit.

The robot's time (on the simulator, `toolkit.robots.sim.RobotTiming`) goes mostly to sweeps; the
report splits it into sweeping, turning the turret back, driving and turning
(`MissionReport.time_split`), and `toolkit.bench.paper_pareto` measures what each sweep option
costs against what it buys.

Every action is recorded in a trace (action, estimate, and the true pose when the robot exposes one,
as `SimRobot` does). Nothing here raises for an unreachable target, a target in a wall or a lost
robot: the `MissionReport` says so in `status`.

Examples
--------
>>> from toolkit.robots.sim import SimRobot
>>> from toolkit.world import Pose, load_map
>>> m = load_map("map1")
>>> robot = SimRobot(m, Pose(20, 20, 1.0), rng=1)
>>> report = run_mission(robot, m, (80, 80), rng=1)   # doctest: +SKIP
>>> report.success, round(report.final_error_cm, 1)   # doctest: +SKIP
(True, 0.4)
"""

from __future__ import annotations

import inspect
import logging
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.ops import nearest_points

from localisation.ambiguity import candidate_poses, describe_candidates
from localisation.base import LOCALISERS, Localiser, Motion, PoseEstimate, Prior, make_localiser
from localisation.procedure import free_travel
from localisation.scan import ScanProcessing
from planners.base import Planner, PlanningProblem, PlanResult, make_planner

from .world import (
    CollisionChecker,
    ConfigError,
    Map,
    NxtnavError,
    Pose,
    RngLike,
    Robot,
    RobotGeometry,
    Scan,
    angle_diff,
    as_rng,
    load_map,
    make_sonar,
    ray_cast,
)

if TYPE_CHECKING:
    from .recording import Recorder

__all__ = [
    "MissionConfig",
    "MissionReport",
    "RobotTimeSplit",
    "TraceStep",
    "explore_direction",
    "matched_localiser_options",
    "mission_seeds",
    "random_start",
    "run_mission",
    "run_sim_mission",
    "sweep_angles",
]

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

_TURN_EPS = math.radians(0.5)  # turns smaller than this are not counted as turns

NXT_SONAR_SIGMA_CM = 3.0
"""Range standard deviation (cm) a localiser is told for the `nxt` sonar model: the sensor's +-3 cm,
which also absorbs the lobe and rounding the range model does not represent (1 cm made paper-pf
overconfident and wrong in half the map1 missions; 3 cm made them all succeed)."""


_WINDOW_CENTRES: dict[str, tuple[float, ...]] = {"axes": (0.0, 90.0, 180.0, 270.0), "sides": (-90.0, 0.0, 90.0)}


@dataclass(frozen=True)
class MissionConfig:
    """How a mission is run (all lengths in cm, angles in rad, times in s).

    Parameters
    ----------
    planning_time_s : float
        Time budget of each planner query.
    planner_options, localiser_options : mapping
        Keyword arguments for `make_planner` / `make_localiser` when the stack is given by name.
    localise_options : mapping
        Extra keyword arguments for `localisation.procedure.localise` (those it does not accept are
        dropped with a debug log line).
    safety_margin_cm : float
        Extra clearance added to the robot radius when planning; the mission tries half the margin and
        then the bare radius when no path exists with it (narrow passages). Starts and targets closer
        to a wall than the margin are joined to the path by a short straight leg.
    move_step_cm : float
        Longest single Move command; a segment is driven as several Moves, the localiser predicting
        after each one (the watchdog runs inside every Move).
    relocalise_every_cm : float or None
        Re-localise (tracking) after driving this far along one segment, then re-aim at the waypoint;
        None re-localises at the waypoints only.
    first_leg_cm : float or None
        After a global fix, the first leg is at most this long before re-localising: a heading error
        of the fix shows as a sideways offset after a short drive, before it can bring the robot to
        a wall (None: no special first leg).
    waypoint_tolerance_cm : float
        A waypoint counts as reached when the estimate is this close to it (after re-localising there).
    max_legs : int
        Legs (re-aimed after each re-localisation) toward one waypoint before re-planning.
    heading_tolerance_deg, min_leg_cm : float
        A leg ends (and the robot re-localises) where the straight drive would touch a wall if the
        estimated heading were off by this much either way; legs are never shorter than
        `min_leg_cm`. Bounds the damage of a heading error, the error a sonar localiser makes most.
    leg_margin_cm : float
        Extra clearance (cm) for that check (position error of the estimate); used from estimates
        that have it.
    goal_tolerance_cm : float
        The final correction stops when the estimate is this close to the target.
    max_corrections : int
        Correction moves at the target before giving up on the tolerance (the mission still counts
        as a success when the estimate ends within `success_radius_cm`).
    success_radius_cm : float
        The estimate must end within this distance of the target for the mission to succeed.
    final_scans : int
        Scans fused at the target before each correction decision (more scans, tighter estimate).
    reverse_cm : float
        A correction move at the target up to this long whose direction is more than 90 degrees off
        the heading backs up instead of turning around (0: always turn toward the target).
    max_replans : int
        Re-plans (after watchdog stops or deviations) before the mission gives up.
    max_localisation_attempts : int
        Global localisation attempts before the robot is declared lost.
    max_explore_moves, explore_step_cm : int, float
        While a global belief stays ambiguous, up to this many moves of at most this length toward
        open space (chosen from the scan with room for the robot disc and the margin).
    explore_heading_tolerance_deg : float
        An exploration move planned from the localiser's modes must stay free when the modes'
        headings are off by this much either way.
    confirm_global : bool
        Confirm a global fix that rests on scans from one place with a second, independent one
        (guards against a localiser that collapses on one of several identical places); fixes further apart than
        `confirm_tolerance_cm` count as ambiguous.
    confirm_tolerance_cm : float
    confirm_all : bool
        Confirm every global fix, also those reached by exploring (a short exploration can leave the
        localiser collapsed on a twin place; on map3 without it about 1 mission in 100 ended in the
        wrong room). False confirms single-place fixes only.
    tracking : {"continue", "prior"}
        How a re-localisation starts: from the localiser's current (predicted) belief, or reset to a
        Gaussian prior around the last estimate (`tracking_std_cm`, `tracking_std_deg`). Either falls
        back to the other, then to a global localisation, when it does not converge.
    tracking_std_cm, tracking_std_deg : float
        Minimum standard deviations of the prior handed to a tracking re-localisation.
    max_actions : int
        Hard limit on Turn/Move commands (guards against endless loops).
    global_scan_step_deg : float
        Turret step (deg) of the sweeps of a global localisation (1: the paper's 360 readings).
    global_align : bool
        Global localisation the paper's way: sweep, turn toward the minimum reading, sweep again and
        keep the windows around the axes. False: one sweep, keeping the windows around the minimum
        reading's direction of that sweep (the same near-perpendicular readings, half the sweeps).
    track_window_deg : float
        Sweeps of a tracking re-localisation (from a belief, no alignment) read only the four windows
        of +-this many degrees around the robot's axes (15: the 124 readings the paper's processing
        keeps); 180 sweeps the full turn.
    track_scan_step_deg : float
        Turret step (deg) inside those windows.
    track_windows : {"axes", "sides"}
        ``axes``: the four windows around 0, 90, 180 and 270 degrees; ``sides``: only the three
        ahead and to the sides (-90, 0, 90), a shorter turret travel.
    track_align : bool
        Re-localise along the way the paper's way (full sweep, align, full sweep) instead of one
        window sweep; the window settings are then ignored.
    final_window_deg, final_scan_step_deg : float
        The same for the re-localisations at the target (the final correction loop).
    fix_rule : {"habit", "spread"}
        When a leg ends (at a waypoint, after `relocalise_every_cm`, or where `heading_tolerance_deg`
        cuts it), ``habit`` re-localises every time; ``spread`` only when the belief as predicted
        through the motion could not drive on: the position spread across the next stretch plus
        the heading spread over its length, times `spread_sigmas`, must leave the robot disc clear
        of the walls along it. A waypoint the robot missed is skipped when the belief can drive on
        to the next one by the same rule.
    spread_sigmas : float
        Standard deviations of the belief the ``spread`` rule keeps clear of the walls.
    spread_min_heading_deg : float
        The ``spread`` rule never takes the heading spread as smaller than this (deg): a sonar
        localiser's belief can be narrower than its heading error.
    spread_drift : float
        Nor the position spread as smaller than this fraction of the distance driven since the
        last fix (a localiser whose belief does not grow with the motion is not trusted blindly).
    """

    planning_time_s: float = 1.0
    planner_options: Mapping[str, Any] = field(default_factory=dict)
    localiser_options: Mapping[str, Any] = field(default_factory=dict)
    localise_options: Mapping[str, Any] = field(default_factory=dict)
    safety_margin_cm: float = 2.0
    move_step_cm: float = 10.0
    relocalise_every_cm: float | None = None
    first_leg_cm: float | None = 6.0
    waypoint_tolerance_cm: float = 1.0
    max_legs: int = 12
    heading_tolerance_deg: float = 8.0
    leg_margin_cm: float = 0.0
    min_leg_cm: float = 4.0
    goal_tolerance_cm: float = 0.5
    max_corrections: int = 6
    success_radius_cm: float = 3.0
    final_scans: int = 1
    reverse_cm: float = 10.0
    max_replans: int = 12
    max_localisation_attempts: int = 3
    max_explore_moves: int = 6
    explore_step_cm: float = 30.0
    explore_heading_tolerance_deg: float = 12.0
    tracking: str = "continue"
    confirm_global: bool = True
    confirm_tolerance_cm: float = 5.0
    confirm_all: bool = True
    tracking_std_cm: float = 4.0
    tracking_std_deg: float = 8.0
    max_actions: int = 400
    global_scan_step_deg: float = 2.0
    global_align: bool = False
    track_window_deg: float = 15.0
    track_scan_step_deg: float = 2.0
    track_windows: str = "axes"
    track_align: bool = False
    final_window_deg: float = 15.0
    final_scan_step_deg: float = 1.0
    fix_rule: str = "spread"
    spread_sigmas: float = 3.0
    spread_min_heading_deg: float = 1.0
    spread_drift: float = 0.05

    def __post_init__(self) -> None:
        positive = ("planning_time_s", "move_step_cm", "waypoint_tolerance_cm", "goal_tolerance_cm",
                    "success_radius_cm", "tracking_std_cm", "tracking_std_deg")
        for name in positive:
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"MissionConfig.{name} must be a positive number, got {v!r}")
        if not (math.isfinite(self.safety_margin_cm) and self.safety_margin_cm >= 0):
            raise ValueError(f"MissionConfig.safety_margin_cm must be >= 0, got {self.safety_margin_cm!r}")
        for name in ("global_scan_step_deg", "track_scan_step_deg", "final_scan_step_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 < v <= 90):
                raise ValueError(f"MissionConfig.{name} must be in (0, 90] degrees, got {v!r}")
        for name in ("track_window_deg", "final_window_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0 <= v <= 180):
                raise ValueError(f"MissionConfig.{name} must be in [0, 180] degrees, got {v!r}")
        if self.track_windows not in _WINDOW_CENTRES:
            raise ValueError(f"MissionConfig.track_windows must be one of {', '.join(_WINDOW_CENTRES)}, "
                             f"got {self.track_windows!r}")
        if self.fix_rule not in ("habit", "spread"):
            raise ValueError(f"MissionConfig.fix_rule must be 'habit' or 'spread', got {self.fix_rule!r}")
        for name in ("spread_sigmas", "spread_min_heading_deg", "spread_drift"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"MissionConfig.{name} must be >= 0, got {v!r}")
        if self.tracking not in ("continue", "prior"):
            raise ValueError(f"MissionConfig.tracking must be 'continue' or 'prior', got {self.tracking!r}")
        if self.relocalise_every_cm is not None and not self.relocalise_every_cm > 0:
            raise ValueError(f"MissionConfig.relocalise_every_cm must be > 0 or None, got {self.relocalise_every_cm!r}")
        for name in ("max_corrections", "max_replans", "max_localisation_attempts", "max_actions", "final_scans",
                     "max_legs", "max_explore_moves"):
            v = getattr(self, name)
            lowest = 0 if name in ("max_corrections", "max_replans", "max_explore_moves") else 1
            if not (isinstance(v, int) and v >= lowest):
                raise ValueError(f"MissionConfig.{name} must be a non-negative integer, got {v!r}")

    def to_dict(self) -> dict[str, Any]:
        return {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in self.__dict__.items()}

    @classmethod
    def for_sonar(cls, sonar: str, **overrides: Any) -> MissionConfig:
        """Defaults for a sonar model: the ``nxt`` sensor (and a real NXT) gets a wider heading
        tolerance and a position margin for each leg (its localisation errs by up to ~10 degrees in
        heading and ~2 cm in position near slanted walls while reporting a narrow belief)."""
        base: dict[str, Any] = {}
        if sonar == "nxt":
            base = {"heading_tolerance_deg": 15.0, "leg_margin_cm": 2.0, "spread_min_heading_deg": 4.0}
        return cls(**{**base, **overrides})


@dataclass(frozen=True)
class TraceStep:
    """One recorded step of a mission.

    Attributes
    ----------
    action : str
        ``localise``, ``relocalise``, ``plan``, ``turn``, ``move``, ``turnback``, ``explore-turn``,
        ``explore-move``, ``correct-turn`` or ``correct-move``.
    estimate : Pose or None
        The localiser's mean pose after the action.
    true_pose : Pose or None
        The robot's true pose after the action, when the robot knows it (simulator).
    turn_rad : float
        Commanded turn (rad), for turns.
    distance_cm : float
        Distance the robot reported driving (cm), for moves.
    watchdog : bool
        Whether the watchdog stopped this move.
    robot_time_s : float
        The robot's clock after the action (s).
    note : str
        Free text (planner status, localisation result, ...).
    spread_cm : float or None
        The estimate's position spread (root of the summed x and y variances, cm).
    """

    action: str
    estimate: Pose | None = None
    true_pose: Pose | None = None
    turn_rad: float = 0.0
    distance_cm: float = 0.0
    watchdog: bool = False
    robot_time_s: float = 0.0
    note: str = ""
    spread_cm: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "action": self.action,
            "spread_cm": self.spread_cm,
            "estimate": None if self.estimate is None else self.estimate.to_list_deg(),
            "true_pose": None if self.true_pose is None else self.true_pose.to_list_deg(),
            "turn_deg": math.degrees(self.turn_rad),
            "distance_cm": self.distance_cm,
            "watchdog": self.watchdog,
            "robot_time_s": self.robot_time_s,
            "note": self.note,
        }


@dataclass(frozen=True)
class RobotTimeSplit:
    """Where a mission's robot time went (s), from the robot's own counters.

    Attributes
    ----------
    sweep_s : float
        Sonar sweeps: the readings and the turret's travel through them.
    turret_return_s : float
        Turning the turret back to the front after each sweep.
    drive_s, turn_s : float
        Driving (forward and backward) and spinning in place.
    readings : int
        Sonar readings taken by the sweeps (the watchdog's forward readings are not counted).
    other_s : float
        Robot time outside these (link overheads on a real NXT; 0 on the simulator).
    """

    sweep_s: float
    turret_return_s: float
    drive_s: float
    turn_s: float
    readings: int
    other_s: float = 0.0

    def to_dict(self) -> dict[str, float | int]:
        return dict(self.__dict__)

    def describe(self) -> str:
        """One line: ``sweeping 40.1 s (1612 readings), turret back 9.0 s, driving 12.0 s, turning 7.1 s``."""
        text = (f"sweeping {self.sweep_s:.1f} s ({self.readings} readings), turret back {self.turret_return_s:.1f} s, "
                f"driving {self.drive_s:.1f} s, turning {self.turn_s:.1f} s")
        return text + (f", other {self.other_s:.1f} s" if abs(self.other_s) >= 0.05 else "")


_SPLIT_COUNTERS = ("sweep_s", "turret_return_s", "drive_s", "turn_s", "readings")


def _time_split(delta: Mapping[str, float], robot_time_s: float) -> RobotTimeSplit | None:
    """The split from the robot's counter increments, when the robot keeps them all."""
    if not all(k in delta for k in _SPLIT_COUNTERS):
        return None
    sweep, back, drive, turn = (float(delta[k]) for k in _SPLIT_COUNTERS[:4])
    return RobotTimeSplit(sweep, back, drive, turn, int(delta["readings"]),
                          robot_time_s - (sweep + back + drive + turn))


@dataclass(frozen=True, eq=False)
class MissionReport:
    """What a mission did and how well.

    Attributes
    ----------
    success : bool
        The mission ended with the estimate within the success radius of the target.
    status : str
        One line: ``reached target`` or why the mission ended early.
    final_error_cm : float or None
        TRUE distance from the robot to the target at the end (cm), when the robot knows its pose;
        otherwise None.
    estimate_error_cm : float or None
        Distance between the final estimate and the target (cm).
    completion_s : float
        Wall-clock time of the whole run (s).
    robot_time_s : float
        Time the robot spent acting (modelled on the simulator) (s).
    path_length_cm : float
        Distance driven, from odometry (forward and backward moves) (cm).
    planned_length_cm : float
        Length of the first successful plan (cm); 0 when nothing was planned.
    turns : int
        Turn commands of the mission (above half a degree; those of the localisation procedure excluded).
    collisions : int or None
        True contacts with walls (simulator), None when unknown.
    watchdog_stops, relocalisations, replans : int
        Counters of the run (relocalisations exclude the first global localisation).
    map, planner, localiser : str
    seed : int or None
    start : Pose or None
        True start pose when known.
    target : (2,) ndarray
    final_pose, final_estimate : Pose or None
    plans : list of (k, 2) ndarray
        Every planned path, in order.
    trace : list of TraceStep
    """

    success: bool
    status: str
    final_error_cm: float | None
    estimate_error_cm: float | None
    completion_s: float
    robot_time_s: float
    path_length_cm: float
    planned_length_cm: float
    turns: int
    collisions: int | None
    watchdog_stops: int
    relocalisations: int
    replans: int
    map: str
    planner: str
    localiser: str
    seed: int | None
    start: Pose | None
    target: FloatArray
    final_pose: Pose | None
    final_estimate: Pose | None
    plans: list[FloatArray] = field(default_factory=list)
    trace: list[TraceStep] = field(default_factory=list)
    candidates: list[Pose] = field(default_factory=list)
    time_split: RobotTimeSplit | None = None

    def to_dict(self, trace: bool = True) -> dict[str, Any]:
        """JSON-ready dict (poses as [x, y, heading_deg]); `trace=False` leaves out the trace and plans."""
        d: dict[str, Any] = {
            "success": self.success,
            "status": self.status,
            "final_error_cm": self.final_error_cm,
            "estimate_error_cm": self.estimate_error_cm,
            "completion_s": self.completion_s,
            "robot_time_s": self.robot_time_s,
            "robot_time_split": None if self.time_split is None else self.time_split.to_dict(),
            "path_length_cm": self.path_length_cm,
            "planned_length_cm": self.planned_length_cm,
            "turns": self.turns,
            "collisions": self.collisions,
            "watchdog_stops": self.watchdog_stops,
            "relocalisations": self.relocalisations,
            "replans": self.replans,
            "map": self.map,
            "planner": self.planner,
            "localiser": self.localiser,
            "seed": self.seed,
            "start": None if self.start is None else self.start.to_list_deg(),
            "target": [float(v) for v in self.target],
            "final_pose": None if self.final_pose is None else self.final_pose.to_list_deg(),
            "final_estimate": None if self.final_estimate is None else self.final_estimate.to_list_deg(),
            "ambiguous": len(self.candidates) > 1,
            "candidates": [p.to_list_deg() for p in self.candidates],
        }
        if trace:
            d["plans"] = [p.tolist() for p in self.plans]
            d["trace"] = [s.to_dict() for s in self.trace]
        return d

    @property
    def true_trajectory(self) -> FloatArray:
        """(n, 2) true positions along the trace (cm); empty when the robot does not know its pose."""
        pts = [s.true_pose.xy for s in self.trace if s.true_pose is not None]
        if self.start is not None:
            pts.insert(0, self.start.xy)
        return np.array(pts).reshape(-1, 2)

    @property
    def estimates(self) -> FloatArray:
        """(n, 3) estimated poses [x, y, theta] recorded along the trace."""
        pts = [s.estimate.as_array() for s in self.trace if s.estimate is not None]
        return np.array(pts).reshape(-1, 3)

    def confident_estimates(self, max_spread_cm: float = 5.0) -> FloatArray:
        """(n, 3) estimated poses whose position spread is under `max_spread_cm` (ambiguous global
        beliefs left out: their mean lies between the candidate places)."""
        pts = [s.estimate.as_array() for s in self.trace if s.estimate is not None
               and (s.spread_cm is None or s.spread_cm <= max_spread_cm)]
        return np.array(pts).reshape(-1, 3)

    def summary(self) -> str:
        """A few human-readable lines."""
        err = "unknown" if self.final_error_cm is None else f"{self.final_error_cm:.2f} cm"
        coll = "unknown" if self.collisions is None else str(self.collisions)
        lines = [
            f"{'SUCCESS' if self.success else 'FAILED'}: {self.status}",
            f"map {self.map}, planner {self.planner}, localiser {self.localiser}, seed {self.seed}",
            f"final error {err} (estimate {_fmt(self.estimate_error_cm)} cm from target), "
            f"collisions {coll}",
            f"completion {self.completion_s:.3f} s wall-clock, robot time {self.robot_time_s:.1f} s"
            + ("" if self.time_split is None else f": {self.time_split.describe()}"),
            f"driven {self.path_length_cm:.1f} cm (planned {self.planned_length_cm:.1f} cm), turns {self.turns}, "
            f"watchdog stops {self.watchdog_stops}, re-localisations {self.relocalisations}, "
            f"re-plans {self.replans}",
        ]
        return "\n".join(lines)


def _fmt(v: float | None) -> str:
    return "?" if v is None else f"{v:.2f}"


class _MissionEnded(Exception):
    """Internal: the mission stops with `status` (success or not)."""

    def __init__(self, status: str, success: bool = False) -> None:
        super().__init__(status)
        self.status = status
        self.success = success


def _raw_scan_of(result: Any) -> Scan | None:
    """The last raw scan of a localisation result (`LocalisationResult.trace[-1].scan.raw`), if any."""
    trace = getattr(result, "trace", None)
    if not trace:
        return None
    scan = getattr(getattr(trace[-1], "scan", None), "raw", None)
    return scan if isinstance(scan, Scan) else None


def explore_direction(scan: Scan, clearance_cm: float, rng: np.random.Generator | None = None,
                      avoid_rad: float | None = None, max_step_cm: float = 30.0) -> tuple[float, float]:
    """Where to drive to break an ambiguous belief, from one scan alone (no pose needed).

    For every usable reading direction, the free run of a disc of radius `clearance_cm` along it is
    the distance before any scan point comes within the radius of the disc's centre line. The
    direction with the longest run wins (ties within 2 cm broken at random; directions within 45
    degrees of `avoid_rad`, where the robot came from, only when nothing else is open).

    Returns
    -------
    (float, float)
        Turn (rad, relative to the heading) and distance (cm): half the free run, at most
        `max_step_cm`; (0, 0) when no direction is open.
    """
    ok = scan.valid & np.isfinite(scan.ranges)
    if not ok.any():
        return 0.0, 0.0
    a, free = free_travel(scan, clearance_cm, scan.angles[ok])
    if avoid_rad is not None:
        back = np.abs(angle_diff(a, avoid_rad)) < math.radians(45.0)
        if (free[~back] > 2.0).any():
            free = np.where(back, -np.inf, free)
    best = float(free.max())
    if best <= 2.0:
        return 0.0, 0.0
    cand = np.flatnonzero(free >= best - 2.0)
    k = int(as_rng(rng).choice(cand))
    return float(angle_diff(a[k], 0.0)), float(min(max_step_cm, 0.5 * free[k]))


def sweep_angles(step_deg: float = 1.0, window_deg: float = 180.0,
                 centres_deg: tuple[float, ...] = (0.0, 90.0, 180.0, 270.0)) -> FloatArray:
    """Turret angles (rad, relative to the heading) of one sweep, in the order the turret visits them.

    ``window_deg >= 180`` is the full turn from straight ahead at `step_deg` steps (360 readings at
    1 degree); smaller windows read only the windows of +-`window_deg` around `centres_deg`
    (degrees from the heading, visited in the order given). Around the four axes that is what the
    paper's scan processing keeps: 124 readings for 15-degree windows at 1 degree, and 600 degrees
    of turret travel (out and back) instead of 720; the three windows ahead and to the sides
    (-90, 0, 90) take 420.

    >>> sweep_angles(1.0, 15.0).size, sweep_angles(2.0).size, sweep_angles(2.0, 15.0, (-90, 0, 90)).size
    (124, 180, 48)
    """
    if window_deg >= 180.0:
        return np.radians(np.arange(0.0, 360.0 - 1e-9, step_deg))
    half = np.arange(0.0, window_deg + 1e-9, step_deg)
    off = np.concatenate([-half[:0:-1], half])
    return np.radians(np.concatenate([c + off for c in centres_deg]))


def _localise_procedure() -> Callable[..., Any]:
    from localisation.procedure import localise

    return localise


def _estimate_of(result: Any, localiser: Localiser) -> PoseEstimate:
    est = getattr(result, "estimate", None)
    return est if isinstance(est, PoseEstimate) else localiser.estimate()


class _Mission:
    """The mutable state of one run (counters, trace, current estimate)."""

    def __init__(self, robot: Robot, m: Map, target: FloatArray, planner: Planner,
                 localiser: Callable[[], Localiser], rng: np.random.Generator, config: MissionConfig) -> None:
        self.robot = robot
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
        if isinstance(shared, CollisionChecker) and shared.map is m and shared.robot_radius == radius:
            self.checker = shared
        else:
            self.checker = CollisionChecker(m, radius)
        margin = config.safety_margin_cm
        # planning checkers with the full margin, then half of it; the bare radius is the last resort
        self.safe_checkers = [CollisionChecker(m, radius + f * margin) for f in (1.0, 0.5) if margin > 0]
        lm = config.leg_margin_cm
        self.leg_checker = CollisionChecker(m, radius + lm) if lm > 0 else self.checker
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
        self._last_raw_scan: Scan | None = None
        self.fresh_fix = False  # the estimate comes from a global fix not yet checked by a drive
        self.since_fix_cm = 0.0  # driven since the last converged fix
        self._localise = _localise_procedure()
        params = inspect.signature(self._localise).parameters
        self._localise_kw = set(params) if not any(p.kind is p.VAR_KEYWORD for p in params.values()) else None

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

    def record(self, action: str, **kw: Any) -> None:
        est = self.estimate.pose if self.estimate is not None else None
        spread = self.estimate.std_xy_cm if self.estimate is not None else None
        self.trace.append(TraceStep(action, est, self.true_pose(), robot_time_s=float(self.robot.robot_time_s),
                                    spread_cm=spread, **kw))

    def _count_action(self) -> None:
        self.actions += 1
        if self.actions > self.cfg.max_actions:
            raise _MissionEnded(f"gave up after {self.cfg.max_actions} actions")

    # -- localisation ---------------------------------------------------------------------------
    def _sweep_options(self, kind: str) -> dict[str, Any]:
        """How the localisation procedure sweeps for a ``global``, ``track`` or ``final`` localisation."""
        cfg = self.cfg
        if kind == "global":
            # without the turn, the windows are taken around the minimum reading's direction: the
            # near-perpendicular readings a sonar model gets right, from one sweep
            return {"align": cfg.global_align, "scan_angles": sweep_angles(cfg.global_scan_step_deg),
                    "processing": None if cfg.global_align else ScanProcessing(reference="min")}
        if cfg.track_align:
            return {"align": True, "process": True, "scan_angles": None}
        if kind == "final":
            return {"align": False, "process": False,
                    "scan_angles": sweep_angles(cfg.final_scan_step_deg, cfg.final_window_deg)}
        return {"align": False, "process": False,
                "scan_angles": sweep_angles(cfg.track_scan_step_deg, cfg.track_window_deg,
                                            _WINDOW_CENTRES[cfg.track_windows])}

    def _call_localise(self, prior: Prior | None, kind: str = "global", **extra: Any) -> PoseEstimate:
        kwargs: dict[str, Any] = {"prior": prior, "rng": self.rng, **self._sweep_options(kind),
                                  **dict(self.cfg.localise_options), **extra}
        if self._localise_kw is not None:
            dropped = [k for k in kwargs if k not in self._localise_kw]
            if dropped:
                log.debug("localise() does not take %s; dropped", ", ".join(dropped))
            kwargs = {k: v for k, v in kwargs.items() if k in self._localise_kw}
        result = self._localise(self.robot, self.localiser, **kwargs)
        self._last_raw_scan = _raw_scan_of(result)
        return _estimate_of(result, self.localiser)

    def _ok(self, est: PoseEstimate) -> bool:
        return bool(est.converged) and bool(self.map.contains(est.pose.xy))

    def localise_global(self) -> PoseEstimate:
        """Global localisation with retries; ends the mission when the robot stays lost.

        Each attempt runs one iteration of the localisation procedure at a time. A converged fix is
        confirmed by a second, independent global localisation on a fresh scan (`confirm_global`):
        two fixes that disagree reveal a symmetric place the localiser collapsed on too early. While
        the belief is ambiguous the mission drives toward open space along a direction where the scan
        shows room for the whole robot disc, and localises again from there.
        """
        cfg = self.cfg
        for attempt in range(1, cfg.max_localisation_attempts + 1):
            est = self._call_localise(None, reset=True, max_iterations=1)
            self.estimate = est
            explores = 0
            fresh = False
            from_one_place = True  # the fix rests on scans from one place only
            while True:
                if self._ok(est):
                    if not (cfg.confirm_global and (from_one_place or cfg.confirm_all)):
                        break
                    est2 = self._call_localise(None, reset=True, max_iterations=1)
                    self.estimate = est2
                    if self._ok(est2) and est2.pose.distance_to(est.pose) <= cfg.confirm_tolerance_cm:
                        est = est2
                        break
                    self.record("localise", note=f"global attempt {attempt}: two fixes disagree "
                                                 f"({est.pose.x:.0f}, {est.pose.y:.0f}) vs "
                                                 f"({est2.pose.x:.0f}, {est2.pose.y:.0f})")
                    est = est2
                    fresh = True
                if explores >= cfg.max_explore_moves:
                    break
                direction, distance = self.explore_move(math.pi if explores else None)
                if distance < 1.0:
                    break
                self.record("localise", note=f"global attempt {attempt}: ambiguous (spread "
                                             f"{est.std_xy_cm:.1f} cm), exploring")
                self.turn(direction, action="explore-turn")
                if self.move(distance, action="explore-move"):
                    self.turnback()
                explores += 1
                est = self._call_localise(None, reset=fresh, max_iterations=1)
                self.estimate = est
                from_one_place = fresh
                fresh = False
            ok = self._ok(est)
            self.record("localise", note=f"global attempt {attempt}: {'converged' if ok else 'not converged'}, "
                                         f"spread {est.std_xy_cm:.2f} cm")
            if ok:
                self.fresh_fix = True
                self.since_fix_cm = 0.0
                return est
        self.candidates = candidate_poses(self._localiser)
        if self.candidates:  # several places fit the scans equally: say which, not just "lost"
            raise _MissionEnded(f"{describe_candidates(self.candidates)}; global localisation could not tell "
                                f"them apart in {cfg.max_localisation_attempts} attempts")
        raise _MissionEnded(f"robot lost: global localisation did not converge in "
                            f"{cfg.max_localisation_attempts} attempts")

    def explore_move(self, avoid_rad: float | None) -> tuple[float, float]:
        """A turn (rad) and distance (cm) toward open space while the belief is ambiguous.

        With a localiser that reports its modes (candidate poses, as paper-pf does), the move must be
        collision-free with the safety margin from every mode and heads where the nearest wall
        (over the modes) is farthest: safe whichever candidate is the truth. Otherwise the move comes
        from the last scan alone (`explore_direction`), which trusts the sonar's free space.
        """
        cfg = self.cfg
        modes = getattr(self.localiser, "modes", None)
        poses: list[Pose] = []
        try:
            listed = modes() if callable(modes) else modes
            poses = [md.pose for md in (listed or []) if isinstance(getattr(md, "pose", None), Pose)]
        except Exception:  # a localiser without usable modes: fall back to the scan
            poses = []
        poses = [p for p in poses if self.checker.point_free(p.xy)]
        if poses:
            rel = np.radians(np.arange(0.0, 360.0, 5.0))
            if avoid_rad is not None:
                rel = rel[np.abs(angle_diff(rel, avoid_rad)) >= math.radians(45.0)]
            checker = self.safe_checkers[-1] if self.safe_checkers else self.checker
            tol = math.radians(cfg.explore_heading_tolerance_deg)
            for length in (cfg.explore_step_cm, 0.5 * cfg.explore_step_cm, 0.25 * cfg.explore_step_cm):
                ok = np.ones(rel.size, dtype=bool)
                room = np.full(rel.size, np.inf)
                for p in poses:
                    for dev in (-tol, 0.0, tol):  # the modes' headings may be off by the tolerance
                        ang = p.theta + rel + dev
                        ends = p.xy[None, :] + length * np.column_stack([np.cos(ang), np.sin(ang)])
                        ok &= checker.segments_free(np.repeat(p.xy[None, :], rel.size, axis=0), ends)
                        room = np.minimum(room, ray_cast(self.map.walls, p.xy, ang))
                if ok.any():
                    k = int(np.argmax(np.where(ok, room, -np.inf)))
                    return float(angle_diff(rel[k], 0.0)), float(length)
            return 0.0, 0.0
        scan = self._last_raw_scan if self._last_raw_scan is not None else self.robot.ultrascan()
        return explore_direction(scan, self.radius + 0.5 * cfg.safety_margin_cm + 0.5, self.rng, avoid_rad,
                                 cfg.explore_step_cm)

    def relocalise(self, reason: str, kind: str = "track") -> PoseEstimate:
        """Tracking re-localisation from the current belief (`kind` ``track`` or, at the target,
        ``final`` chooses the sweep); falls back to a global one."""
        self.relocalisations += 1
        if self.estimate is None:
            return self.localise_global()
        if self.cfg.tracking == "prior":
            est = self._call_localise(self._prior(self.estimate), kind, reset=True, max_iterations=1)
        else:
            est = self._call_localise(None, kind, reset=False, max_iterations=1)
        self.estimate = est
        ok = self._ok(est)
        self.record("relocalise", note=f"{reason}: {'converged' if ok else 'not converged'}, "
                                       f"spread {est.std_xy_cm:.2f} cm")
        if ok:
            self.fresh_fix = False
            self.since_fix_cm = 0.0
            return est
        if self.cfg.tracking != "prior":
            est = self._call_localise(self._prior(self.estimate), kind, reset=True, max_iterations=1)
            self.estimate = est
            ok = self._ok(est)
            self.record("relocalise", note=f"{reason}, from a wider prior: {'converged' if ok else 'not converged'}")
            if ok:
                self.since_fix_cm = 0.0
                return est
        return self.localise_global()

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
    def turn(self, angle: float, action: str = "turn") -> None:
        self._count_action()
        self.robot.turn(angle)
        self.localiser.predict(Motion(turn_rad=angle))
        self.estimate = self.localiser.estimate()
        if abs(angle) > _TURN_EPS:
            self.turns += 1
        self.record(action, turn_rad=angle)

    def move(self, distance: float, action: str = "move") -> bool:
        """Move `distance` cm; returns True when the watchdog stopped it."""
        self._count_action()
        out = self.robot.move(distance)
        self.localiser.predict(Motion(distance_cm=out.distance_cm))
        self.estimate = self.localiser.estimate()
        self.path_length += abs(out.distance_cm)
        self.since_fix_cm += abs(out.distance_cm)
        if out.watchdog:
            self.watchdog_stops += 1
        self.record(action, distance_cm=out.distance_cm, watchdog=out.watchdog)
        return bool(out.watchdog)

    def turnback(self) -> None:
        self._count_action()
        out = self.robot.turnback()
        self.localiser.predict(Motion(distance_cm=out.distance_cm))
        self.estimate = self.localiser.estimate()
        self.path_length += abs(out.distance_cm)
        self.since_fix_cm += abs(out.distance_cm)
        self.record("turnback", distance_cm=out.distance_cm)

    def after_watchdog(self) -> None:
        self.turnback()
        self.relocalise("after watchdog stop")
        self.replans += 1
        if self.replans > self.cfg.max_replans:
            raise _MissionEnded(f"gave up after {self.cfg.max_replans} re-plans")

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
            self._margin_checkers[key] = CollisionChecker(self.map, self.radius + key)
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

    def drive_to(self, goal: FloatArray, *, final: bool = False, next_goal: FloatArray | None = None) -> str:
        """Turn toward `goal` from the estimate and drive there in steps, re-localising on the way.

        Legs longer than `relocalise_every_cm` are split; after each leg the robot re-localises and
        re-aims, until the estimate is within `waypoint_tolerance_cm` of `goal` (for the `final`
        goal the final correction re-localises instead). With ``fix_rule="spread"`` a leg ends
        without a fix when the predicted belief can drive on (`spread_clear`: to `goal`, or on
        reaching it to `next_goal`), and a missed `goal` is skipped when the belief can drive on
        to `next_goal` the same way.

        Returns ``arrived``, ``watchdog`` (the watchdog stopped a move), ``blocked`` (a move made
        almost no progress: a contact) or ``deviated`` (the straight line from the estimate to the
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
                return "arrived"
            if legs > 0 and spread and next_goal is not None and self.spread_clear(next_goal):
                return "arrived"  # missed the waypoint, but the way to the next one is clear for the belief
            if not self.checker.segment_free(pose.xy, goal):
                return "deviated"
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
                    return "watchdog"
                if self.path_length - before < 0.5 * step:
                    return "blocked"
                driven += step
            if final and leg >= dist:
                return "arrived"
            ahead = goal if leg < dist else next_goal
            if spread and ahead is not None and self.spread_clear(ahead):
                self.record("skip-fix", note=f"belief spread {self.estimate.std_xy_cm:.1f} cm leaves the way "
                                             "ahead clear")
                if leg >= dist:
                    return "arrived"
                continue
            self.relocalise("at waypoint" if leg >= dist else "along segment")
        return "deviated"

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
                raise _MissionEnded(f"robot lost: estimate ({start[0]:.1f}, {start[1]:.1f}) is in a wall "
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
            self.record("plan", note=f"failed: {result.status}")
            raise _MissionEnded(f"target unreachable: planner {self.planner.name} found no path from "
                                f"({start[0]:.1f}, {start[1]:.1f}) to ({self.target[0]:.1f}, {self.target[1]:.1f}) "
                                f"({result.status})")
        if prefix:
            path = np.vstack([*prefix, path])
        keep = np.ones(len(path), dtype=bool)
        keep[1:] = np.hypot(*np.diff(path, axis=0).T) > 1e-6
        path = path[keep]
        self.plans.append(path)
        length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
        if len(self.plans) == 1:
            self.planned_length = length
        self.record("plan", note=f"{len(path) - 2} intermediate point(s), {length:.1f} cm, "
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
    def run(self) -> tuple[str, bool]:
        t = self.target
        if not self.map.contains(t):
            raise _MissionEnded(f"target ({t[0]:.1f}, {t[1]:.1f}) is outside the free area of map {self.map.name}")
        if not self.checker.point_free(t):
            raise _MissionEnded(f"target ({t[0]:.1f}, {t[1]:.1f}) is in a wall: closer than the robot radius "
                                f"({self.radius:g} cm) to a wall of map {self.map.name}")
        self.localise_global()
        self.navigate()
        return self.final_correction()

    def navigate(self) -> None:
        """Plan and drive until the estimate is at the target."""
        while True:
            path = self.plan()
            outcome = "arrived"
            for i, wp in enumerate(path[1:], start=1):
                nxt = path[i + 1] if i + 1 < len(path) else None
                outcome = self.drive_to(wp, final=i == len(path) - 1, next_goal=nxt)
                if outcome != "arrived":
                    break
            if outcome == "arrived":
                return
            if outcome in ("watchdog", "blocked"):
                self.after_watchdog()
            else:
                self.replans += 1
                if self.replans > self.cfg.max_replans:
                    raise _MissionEnded(f"gave up after {self.cfg.max_replans} re-plans")

    def final_correction(self) -> tuple[str, bool]:
        """Re-localise at the target and correct until the estimate is within the tolerance."""
        cfg = self.cfg
        for k in range(cfg.max_corrections + 1):
            est = self.relocalise("at target", "final")
            for _ in range(cfg.final_scans - 1):
                est = self.relocalise("at target (extra scan)", "final")
            delta = self.target - est.pose.xy
            dist = float(np.hypot(*delta))
            if dist <= cfg.goal_tolerance_cm:
                return f"reached target (estimate {dist:.2f} cm from it after {k} correction(s))", True
            if k == cfg.max_corrections:
                break
            if not self.checker.segment_free(est.pose.xy, self.target):
                self.navigate()
                continue
            turn = float(angle_diff(math.atan2(delta[1], delta[0]), est.pose.theta))
            sense = 1.0
            if dist <= cfg.reverse_cm and abs(turn) > 0.5 * math.pi:  # back up rather than turn around
                turn, sense = float(angle_diff(turn, math.pi)), -1.0
            self.turn(turn, action="correct-turn")
            if self.move(sense * dist, action="correct-move"):
                self.after_watchdog()
                self.navigate()
        dist = float(np.hypot(*(self.target - self.estimate.pose.xy))) if self.estimate else math.inf
        if dist <= cfg.success_radius_cm:
            return (f"reached target (estimate {dist:.2f} cm from it; tolerance {cfg.goal_tolerance_cm:g} cm "
                    f"not met in {cfg.max_corrections} corrections)"), True
        return f"stopped {dist:.1f} cm from the target after {cfg.max_corrections} corrections", False


def _robot_counters(robot: Robot) -> dict[str, float]:
    """The robot's own counters (simulator: collisions, watchdog stops, odometry), where it has them."""
    out: dict[str, float] = {}
    for name in ("collisions", "watchdog_stops", "odometry_cm", *_SPLIT_COUNTERS):
        v = getattr(robot, name, None)
        if isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool):
            out[name] = float(v)
    return out


def run_mission(
    robot: Robot,
    map: Map | str,
    target: ArrayLike,
    *,
    planner: str | Planner = "min-turn",
    localiser: str | Localiser = "paper-pf",
    rng: RngLike = None,
    config: MissionConfig | None = None,
    recorder: Recorder | None = None,
) -> MissionReport:
    """Run the stack on `robot` from its unknown pose to `target`.

    Parameters
    ----------
    robot : Robot
        A `SimRobot`, an NXT robot, or anything implementing the protocol. A robot with a
        ``true_pose`` (the simulator) gets the true final error and true trajectory in the report;
        one with a ``collisions`` counter gets the true collision count.
    map : Map or str
        The map the robot is in (or its name/path).
    target : (2,) array_like
        Target position (cm).
    planner : str or Planner
        Registry name (``min-turn``, ``rrtstar``, ``ompl:BITstar``, ...) or a configured planner.
    localiser : str or Localiser
        Registry name (``paper-pf``, ...) or a localiser built for `map`.
    rng : None, int or Generator
        Seeds the planner's and the localiser's draws (the simulator has its own `rng`).
    config : MissionConfig or None
        Tolerances and limits; the defaults are tuned for the paper's setting.
    recorder : toolkit.recording.Recorder, optional
        Records every robot command, scan and localiser call (`toolkit.recording`); the caller closes it.

    Returns
    -------
    MissionReport
        Never raises for an unreachable target, a target in a wall or a lost robot: ``status`` says
        what happened and ``success`` is False. Malformed arguments (unknown planner name, a target
        that is not two finite numbers) raise `NxtnavError`/`ValueError`.
    """
    t0 = time.perf_counter()
    cfg = config or MissionConfig()
    m = map if isinstance(map, Map) else load_map(map)
    tgt = np.asarray(target, dtype=float).ravel()
    if tgt.shape != (2,) or not np.all(np.isfinite(tgt)):
        raise NxtnavError(f"target must be two finite numbers (x, y) in cm, got {np.asarray(target).tolist()!r}")
    seed = int(rng) if isinstance(rng, int | np.integer) else None
    gen = as_rng(rng)
    plan_rng, loc_rng = gen.spawn(2)
    plan_obj = planner if isinstance(planner, Planner) else make_planner(planner, **dict(cfg.planner_options))
    if isinstance(localiser, Localiser):
        loc_name, build_localiser = localiser.name, lambda: localiser
    else:  # built at first use; an unknown name fails here, before anything runs
        loc_name = LOCALISERS.get(localiser).name
        build_localiser = partial(make_localiser, localiser, m, rng=loc_rng, **dict(cfg.localiser_options))
    if recorder is not None:
        robot, build_localiser = _recorded(recorder, robot, build_localiser, localiser, cfg, loc_rng)
    start_pose = getattr(robot, "true_pose", None)
    start = start_pose if isinstance(start_pose, Pose) else None
    time0 = float(robot.robot_time_s)
    counters0 = _robot_counters(robot)
    mission = _Mission(robot, m, tgt, plan_obj, build_localiser, plan_rng, cfg)
    try:
        status, success = mission.run()
    except _MissionEnded as end:
        status, success = end.status, end.success
    except ConfigError:
        raise  # options that cannot work (a range model over its budget): bad input, not a mission result
    except NxtnavError as exc:
        status, success = f"aborted: {exc}", False
    log.info("mission on %s: %s", m.name, status)
    final = mission.true_pose()
    est = mission.estimate.pose if mission.estimate is not None else None
    counters1 = _robot_counters(robot)
    delta = {k: counters1[k] - counters0[k] for k in counters0 if k in counters1}
    collisions = delta.get("collisions")
    path_length = float(delta.get("odometry_cm", mission.path_length))
    robot_time = float(robot.robot_time_s) - time0
    return MissionReport(
        success=success,
        status=status,
        final_error_cm=None if final is None else final.distance_to(tgt),
        estimate_error_cm=None if est is None else est.distance_to(tgt),
        completion_s=time.perf_counter() - t0,
        robot_time_s=robot_time,
        path_length_cm=path_length,
        planned_length_cm=mission.planned_length,
        turns=mission.turns,
        collisions=None if collisions is None else int(collisions),
        watchdog_stops=int(delta.get("watchdog_stops", mission.watchdog_stops)),
        relocalisations=mission.relocalisations,
        replans=mission.replans,
        map=m.name,
        planner=plan_obj.name,
        localiser=loc_name,
        seed=seed,
        start=start,
        target=tgt,
        final_pose=final,
        final_estimate=est,
        plans=mission.plans,
        trace=mission.trace,
        candidates=mission.candidates,
        time_split=_time_split(delta, robot_time),
    )


def _recorded(recorder: Recorder, robot: Robot, build: Callable[[], Localiser], localiser: str | Localiser,
              cfg: MissionConfig, loc_rng: np.random.Generator) -> tuple[Any, Callable[[], Localiser]]:
    """The robot and the localiser factory with their calls written to `recorder`."""
    by_name = not isinstance(localiser, Localiser)
    options = dict(cfg.localiser_options) if by_name else {}
    return recorder.wrap_robot(robot), lambda: recorder.wrap_localiser(
        build(), options=options, rng=loc_rng if by_name else None)


def mission_seeds(seed: int) -> tuple[int, int, int]:
    """The three seeds one mission seed expands to: (start heading/pose, simulator, stack)."""
    a, b, c = np.random.SeedSequence(int(seed)).generate_state(3)
    return int(a), int(b), int(c)


def random_start(m: Map, rng: RngLike = None, clearance_cm: float = 10.0) -> Pose:
    """A random pose: position uniform over the free area at least `clearance_cm` from every wall
    (robot centre), heading uniform."""
    gen = as_rng(rng)
    xy = m.sample_free(1, clearance=clearance_cm, rng=gen)[0]
    return Pose(float(xy[0]), float(xy[1]), float(gen.uniform(-math.pi, math.pi)))


def lobe_options(localiser: str, sonar: str, sensor_noise: float = 1.0) -> dict[str, Any]:
    """The sonar model's lobe as constructor options of `localiser`, when it can model one.

    A localiser whose constructor takes ``beam_width_deg`` (and ``critical_incidence_deg``), such as
    the particle filters' range tables, gets the sonar model's values: for ``nxt`` (and a real NXT) a
    20-degree lobe with specular loss beyond 40 degrees of incidence and its 255 cm range limit
    (``max_range_cm``, when the localiser takes it); nothing for the thin-ray ``ideal`` sonar or for
    localisers without the options.
    """
    model = make_sonar(sonar, noise_sd=sensor_noise)
    width = float(getattr(model, "beam_width_deg", 0.0))
    if width <= 0.0:
        return {}
    lobe = {"beam_width_deg": width}
    if hasattr(model, "critical_incidence_deg"):
        lobe["critical_incidence_deg"] = float(model.critical_incidence_deg)
    if hasattr(model, "max_range_cm"):
        lobe["max_range_cm"] = float(model.max_range_cm)
    return _accepted(localiser, lobe)


def _accepted(localiser: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """The `options` that the constructor of the localiser registered as `localiser` takes."""
    params = inspect.signature(LOCALISERS.get(localiser).__init__).parameters
    return {k: v for k, v in options.items() if k in params}


def matched_localiser_options(localiser: str, *, sonar: str = "ideal", noise_model: str = "botsim",
                              motion_noise: float = 0.1, turn_noise: float = 0.005,
                              sensor_noise: float = 1.0) -> dict[str, Any]:
    """Options that tell a localiser (by registry name) the robot's motion and sensor model.

    Only the options its constructor accepts are returned (``noise_model``, ``motion_noise``,
    ``turn_noise``, ``sensor_sigma_cm``, the lobe of `lobe_options`): the ideal sonar's noise, or
    `NXT_SONAR_SIGMA_CM` and the sensor's lobe for the ``nxt`` sonar (and a real NXT). Without the
    lobe, paper-pf settles on headings 5-10 degrees off near the slanted walls of map2 with the
    ``nxt`` sonar while reporting a narrow belief (23 of 100 Table I missions on map2 with absolute
    noise ended 3-5 cm from the target; with it, none of the 600 Table I missions failed).
    """
    known: dict[str, Any] = {"noise_model": noise_model, "motion_noise": motion_noise, "turn_noise": turn_noise}
    if sonar == "ideal" and sensor_noise > 0:
        known["sensor_sigma_cm"] = sensor_noise
    elif sonar == "nxt":
        known["sensor_sigma_cm"] = NXT_SONAR_SIGMA_CM
    return {**_accepted(localiser, known), **lobe_options(localiser, sonar, sensor_noise)}


def run_sim_mission(
    map: Map | str,
    *,
    seed: int = 0,
    start: Pose | ArrayLike | None = None,
    random_start_pose: bool = False,
    target: ArrayLike | None = None,
    planner: str | Planner = "min-turn",
    localiser: str | Localiser = "paper-pf",
    noise_model: str = "botsim",
    sensor_noise: float = 1.0,
    motion_noise: float = 0.1,
    turn_noise: float = 0.005,
    sonar: str = "ideal",
    config: MissionConfig | None = None,
    recorder: Recorder | None = None,
    robot_radius_cm: float | None = None,
) -> MissionReport:
    """One seeded mission on the simulator, as `nxtnav run` and `nxtnav paper` run it.

    Parameters
    ----------
    map : Map or str
    seed : int
        Expands (`mission_seeds`) into the start heading (or random start), the simulator's noise and
        the stack's draws: the same seed gives the same mission.
    start : Pose, (x, y) or None
        True start pose; (x, y) gets a seeded random heading; None is the map's preset start with a
        seeded random heading.
    random_start_pose : bool
        Ignore `start` and draw a free pose at least 10 cm from every wall.
    target : (2,) array_like or None
        Target (cm); None is the map's preset.
    planner, localiser : str or plug-in
    noise_model : {"botsim", "absolute"}
    sensor_noise, motion_noise, turn_noise : float
        Sonar noise (cm), motion noise (fraction or cm) and turn noise (fraction or rad); the paper's by default.
    sonar : {"ideal", "nxt"}
    config : MissionConfig or None
        None: `MissionConfig.for_sonar(sonar)`.
    recorder : toolkit.recording.Recorder, optional
        Passed to `run_mission`.
    robot_radius_cm : float, optional
        Radius of the robot disc (cm; default `RobotGeometry`'s 8 cm): a robot scaled to the map. The
        random start keeps it plus 2 cm from the walls, and localisers that take ``clearance_cm``
        get it.
    """
    from .robots.sim import MotionNoise, SimRobot

    geometry = RobotGeometry() if robot_radius_cm is None else RobotGeometry(radius_cm=float(robot_radius_cm))

    m = map if isinstance(map, Map) else load_map(map)
    s_start, s_sim, s_stack = mission_seeds(seed)
    start_rng = np.random.default_rng(s_start)
    if random_start_pose:
        pose = random_start(m, start_rng) if robot_radius_cm is None else \
            random_start(m, start_rng, geometry.radius_cm + 2.0)
    elif isinstance(start, Pose):
        pose = start
    else:
        xy = m.start if start is None else np.asarray(start, dtype=float).ravel()
        if xy is None:
            raise NxtnavError(f"map {m.name} has no preset start: give one")
        if xy.shape != (2,) or not np.all(np.isfinite(xy)):
            raise NxtnavError(f"start must be (x, y) or a Pose, got {np.asarray(start).tolist()!r}")
        pose = Pose(float(xy[0]), float(xy[1]), float(start_rng.uniform(-math.pi, math.pi)))
    if target is None:
        if m.target is None:
            raise NxtnavError(f"map {m.name} has no preset target: give one")
        target = m.target
    noise = MotionNoise(noise_model, motion_noise, turn_noise)  # type: ignore[arg-type]
    cfg = config or MissionConfig.for_sonar(sonar)
    if isinstance(localiser, str):
        opts = matched_localiser_options(localiser, sonar=sonar, noise_model=noise_model, motion_noise=motion_noise,
                                         turn_noise=turn_noise, sensor_noise=sensor_noise)
        if robot_radius_cm is not None:
            opts.update(_accepted(localiser, {"clearance_cm": geometry.radius_cm}))
        cfg = replace(cfg, localiser_options={**opts, **dict(cfg.localiser_options)})
    robot = SimRobot(m, pose, geometry=geometry, noise=noise, sonar=sonar, sensor_noise=sensor_noise, rng=s_sim)
    report = run_mission(robot, m, target, planner=planner, localiser=localiser, rng=s_stack, config=cfg,
                         recorder=recorder)
    return replace(report, seed=int(seed))
