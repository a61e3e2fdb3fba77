"""What a mission did: `MissionReport`, its trace steps and the split of its robot time."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum, StrEnum
from typing import TYPE_CHECKING, Any

import numpy as np

from ..world import (
    Pose,
)
from ..world.arrays import FloatArray

if TYPE_CHECKING:
    from .fault_log import FaultNote


class Outcome(Enum):
    """How a mission ended (`MissionReport.outcome`); `MissionReport.status` says it in words."""

    REACHED = "reached"
    """The estimate ended within the success radius of the target."""
    STOPPED_SHORT = "stopped-short"
    """The corrections at the target ran out outside the success radius."""
    TARGET_OUTSIDE = "target-outside"
    """The target lies outside the map's free area."""
    TARGET_IN_WALL = "target-in-wall"
    """The target is closer than the robot radius to a wall."""
    UNREACHABLE = "unreachable"
    """The planner found no path from the estimate to the target."""
    LOST = "lost"
    """Global localisation did not converge, or the estimate lies in a wall with no free space near."""
    AMBIGUOUS = "ambiguous"
    """Several places fit the scans equally and exploring could not tell them apart."""
    GAVE_UP = "gave-up"
    """The action or re-plan limit was hit."""
    ABORTED = "aborted"
    """The robot or a plug-in raised an error (the status carries its message)."""
    LINK_LOST = "link-lost"
    """The link to the robot was lost and did not come back within the reconnect timeout."""


class Action(StrEnum):
    """What one trace step did; its value is the name the JSON and the plots use."""

    LOCALISE = "localise"
    """A global localisation's look (the note says what it decided)."""
    RELOCALISE = "relocalise"
    """A fix on the way (tracking, a wider prior, or global)."""
    PLAN = "plan"
    TURN = "turn"
    MOVE = "move"
    TURNBACK = "turnback"
    """Backing off from the wall ahead after a watchdog stop."""
    EXPLORE_TURN = "explore-turn"
    EXPLORE_MOVE = "explore-move"
    ALIGN_TURN = "align-turn"
    """A turn on the spot to sweep again from another heading (no safe exploration move)."""
    CORRECT_TURN = "correct-turn"
    CORRECT_MOVE = "correct-move"
    """The final correction toward the target."""
    SKIP_FIX = "skip-fix"
    """A fix left out: the belief is narrow enough for the way ahead."""
    LINK_LOST = "link-lost"
    LINK_RESTORED = "link-restored"
    SONAR_FAULT = "sonar-fault"
    """A sweep taken again: the sensor was stuck or gave garbage."""
    OFF_COURSE = "off-course"
    """A fix far from the prediction, watchdog stops the map does not explain, or a heading check
    that found the robot pointing elsewhere."""
    CHECK_HEADING = "check-heading"
    """A sweep after a large turn that agreed with the believed heading (`FixConfig.check_turn_deg`)."""


@dataclass(frozen=True)
class TraceStep:
    """One recorded step of a mission.

    Attributes
    ----------
    action : Action
        What the step did (a string enum: ``localise``, ``plan``, ``explore-move``, ...).
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

    action: Action
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
            "action": self.action.value,
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


@dataclass(frozen=True)
class MissionTimes:
    """How long a mission took.

    Attributes
    ----------
    completion_s : float
        Wall-clock time of the whole run (s).
    cpu_s : float
        CPU time the process spent on the run (s, `time.process_time`: every thread of the process,
        so on a shared machine the cost of the computation where the wall clock also counts waiting).
    robot_time_s : float
        Time the robot spent acting (modelled on the simulator) (s).
    split : RobotTimeSplit or None
        Where the robot time went, when the robot keeps the counters.
    """

    completion_s: float
    robot_time_s: float
    cpu_s: float = math.nan
    split: RobotTimeSplit | None = None


@dataclass(frozen=True)
class MissionCounts:
    """The counters of a mission's commands.

    Attributes
    ----------
    turns : int
        Turn commands of the mission (above half a degree; those of the localisation procedure excluded).
    watchdog_stops, relocalisations, replans : int
        Counters of the run (relocalisations exclude the first global localisation).
    """

    turns: int
    watchdog_stops: int
    relocalisations: int
    replans: int


@dataclass(frozen=True, eq=False)
class MissionPoses:
    """Where a mission began, aimed and ended.

    Attributes
    ----------
    start : Pose or None
        True start pose when known.
    target : (2,) ndarray
        The target (cm).
    final_pose, final_estimate : Pose or None
        The true pose (when known) and the estimate at the end.
    candidates : list of Pose
        The places that fit the scans equally when the mission ended ambiguous (else empty).
    """

    start: Pose | None
    target: FloatArray
    final_pose: Pose | None
    final_estimate: Pose | None
    candidates: list[Pose] = field(default_factory=list)


@dataclass(frozen=True, eq=False)
class MissionReport:
    """What a mission did and how well.

    Attributes
    ----------
    success : bool
        The mission ended with the estimate within the success radius of the target.
    status : str
        One line: ``reached target`` or why the mission ended early.
    outcome : Outcome
        The same as a code (``Outcome.REACHED``, ``Outcome.LOST``, ...).
    final_error_cm : float or None
        TRUE distance from the robot to the target at the end (cm), when the robot knows its pose;
        otherwise None.
    estimate_error_cm : float or None
        Distance between the final estimate and the target (cm).
    path_length_cm : float
        Distance driven, from odometry (forward and backward moves) (cm).
    planned_length_cm : float
        Length of the first successful plan (cm); 0 when nothing was planned.
    collisions : int or None
        True contacts with walls (simulator), None when unknown.
    map, planner, localiser : str
    seed : int or None
    collision : str
        Backend of the mission's collision checks (``index`` or ``fcl``).
    times : MissionTimes
        Wall-clock, CPU and robot time.
    counts : MissionCounts
        Turns, watchdog stops, re-localisations and re-plans.
    poses : MissionPoses
        Start, target, final pose and estimate, candidates.
    plans : list of (k, 2) ndarray
        Every planned path, in order.
    trace : list of TraceStep
    faults : list of FaultNote
        Every fault the mission met (a lost link, a sonar swept again) and what came of it
        (`toolkit.mission.recovery`).
    """

    success: bool
    status: str
    final_error_cm: float | None
    estimate_error_cm: float | None
    path_length_cm: float
    planned_length_cm: float
    collisions: int | None
    map: str
    planner: str
    localiser: str
    seed: int | None
    times: MissionTimes
    counts: MissionCounts
    poses: MissionPoses
    plans: list[FloatArray] = field(default_factory=list)
    trace: list[TraceStep] = field(default_factory=list)
    outcome: Outcome = Outcome.REACHED
    collision: str = "index"
    faults: list[FaultNote] = field(default_factory=list)

    def to_dict(self, trace: bool = True) -> dict[str, Any]:
        """JSON-ready dict (poses as [x, y, heading_deg]); `trace=False` leaves out the trace and plans."""
        d: dict[str, Any] = {
            "success": self.success,
            "outcome": self.outcome.value,
            "status": self.status,
            "final_error_cm": self.final_error_cm,
            "estimate_error_cm": self.estimate_error_cm,
            "completion_s": self.times.completion_s,
            "cpu_s": self.times.cpu_s,
            "robot_time_s": self.times.robot_time_s,
            "robot_time_split": None if self.times.split is None else self.times.split.to_dict(),
            "path_length_cm": self.path_length_cm,
            "planned_length_cm": self.planned_length_cm,
            "turns": self.counts.turns,
            "collisions": self.collisions,
            "watchdog_stops": self.counts.watchdog_stops,
            "relocalisations": self.counts.relocalisations,
            "replans": self.counts.replans,
            "map": self.map,
            "planner": self.planner,
            "localiser": self.localiser,
            "seed": self.seed,
            "collision": self.collision,
            "start": None if self.poses.start is None else self.poses.start.to_list_deg(),
            "target": [float(v) for v in self.poses.target],
            "final_pose": _deg(self.poses.final_pose),
            "final_estimate": _deg(self.poses.final_estimate),
            "ambiguous": len(self.poses.candidates) > 1,
            "candidates": [p.to_list_deg() for p in self.poses.candidates],
            "faults": [f.to_dict() for f in self.faults],
        }
        if trace:
            d["plans"] = [p.tolist() for p in self.plans]
            d["trace"] = [s.to_dict() for s in self.trace]
        return d

    @property
    def true_trajectory(self) -> FloatArray:
        """(n, 2) true positions along the trace (cm); empty when the robot does not know its pose."""
        pts = [s.true_pose.xy for s in self.trace if s.true_pose is not None]
        if self.poses.start is not None:
            pts.insert(0, self.poses.start.xy)
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
            f"map {self.map}, planner {self.planner}, localiser {self.localiser}, seed {self.seed}, "
            f"collision checks {self.collision}",
            f"final error {err} (estimate {_fmt(self.estimate_error_cm)} cm from target), "
            f"collisions {coll}",
            f"completion {self.times.completion_s:.3f} s wall-clock ({self.times.cpu_s:.3f} s CPU), "
            f"robot time {self.times.robot_time_s:.1f} s"
            + ("" if self.times.split is None else f": {self.times.split.describe()}"),
            f"driven {self.path_length_cm:.1f} cm (planned {self.planned_length_cm:.1f} cm), "
            f"turns {self.counts.turns}, "
            f"watchdog stops {self.counts.watchdog_stops}, re-localisations {self.counts.relocalisations}, "
            f"re-plans {self.counts.replans}",
        ]
        if self.faults:
            lost = [f for f in self.faults if f.kind == "link-lost"]
            back = sum(f.recovered for f in lost)
            offline = sum(f.outage_s for f in lost)
            sonar = sum(f.kind == "sonar" for f in self.faults)
            lines.append(f"faults: {len(lost)} lost link(s), {back} back (offline {offline:.1f} s, "
                         f"recovery {sum(f.recovery_robot_s for f in lost):.1f} s robot time), "
                         f"{sonar} sweep(s) taken again for a faulty sonar, "
                         f"{len(self.faults) - len(lost) - sonar} fix(es) off course")
        return "\n".join(lines)


def _deg(pose: Pose | None) -> list[float] | None:
    return None if pose is None else pose.to_list_deg()


def _fmt(v: float | None) -> str:
    return "?" if v is None else f"{v:.2f}"
