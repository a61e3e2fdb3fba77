"""A run as a time line: the events of a recording, or of a live `Recorder`, as typed items with times.

`Timeline` is fed the recording's event dicts one at a time (``feed``), from a file
(`timeline_of`, through `toolkit.recordings.replay.read_recording`) or as a `Recorder` writes them (a live
view listens to the recorder), and turns them into what a viewer or an exporter draws or publishes:

* `TruthItem`: the simulator's (or a truth source's) pose after a robot event;
* `OdometryItem`: the pose in the odometry frame, the localiser's motions (``predict``) added up
  from ``(0, 0, 0)``: turn in place, then drive;
* `SweepItem`: a scan with the time of each reading and the true pose it was taken at;
* `EstimateItem`: the localiser's estimate, its particles when recorded, and the odometry pose of
  the same moment (so that ``map -> odom`` is the estimate composed with the inverse odometry);
* `PlanItem`: a path the mission planned.

Times are seconds of the robot's clock (``t`` of the robot events). Localiser events have no clock
of their own and take the last robot event's time; a scan without a robot clock (an imported
sweep) is placed one second after the last event, so that each gets its own moment. A reading's
time is the scan's ``times_s`` when recorded, else the readings are spread evenly over the sweep:
reading ``i`` of ``n`` ends at ``t_start + (i + 1) (t - t_start) / n``.
"""

from __future__ import annotations

import datetime
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import PoseEstimate

from ..world import Map, Pose, RobotGeometry, Scan, map_from_dict, wrap_angle
from ..world.arrays import FloatArray
from .recorder import decode_floats, scan_from_fields

__all__ = ["CLOCKLESS_STEP_S", "EstimateItem", "Item", "OdometryItem", "PlanItem", "RunInfo", "SweepItem",
           "Timeline", "TruthItem", "run_info", "timeline_of"]


CLOCKLESS_STEP_S = 1.0
"""Seconds between scans that have no robot clock (imported sweeps) on the time line."""


@dataclass(frozen=True, eq=False)
class RunInfo:
    """What the header says that a view or an export needs.

    Attributes
    ----------
    map : Map
    robot_radius_cm : float
        The robot disc (the simulator's geometry; the default robot's elsewhere).
    sensor_offset_cm : float
        Distance of the sonar from the turret axis (readings are measured from the sensor).
    start_ns : int
        The recording's creation time (UTC, nanoseconds since the epoch); robot time 0 is this moment.
    label : str
        A name for the run (map, robot kind, localiser when known).
    """

    map: Map
    robot_radius_cm: float
    sensor_offset_cm: float
    start_ns: int
    label: str

    def stamp_ns(self, t: float) -> int:
        """The absolute time (ns since the epoch) of robot time `t` (s)."""
        return self.start_ns + round(t * 1e9)


@dataclass(frozen=True, eq=False)
class TruthItem:
    t: float
    pose: Pose
    heading_known: bool


@dataclass(frozen=True, eq=False)
class OdometryItem:
    t: float
    pose: Pose


@dataclass(frozen=True, eq=False)
class SweepItem:
    """One scan: `times` holds each reading's robot time (s); `truth` the true pose (None unknown)."""

    t: float
    t_start: float
    times: FloatArray
    scan: Scan
    id: int
    truth: Pose | None
    heading_known: bool
    label: str | None


@dataclass(frozen=True, eq=False)
class EstimateItem:
    """An estimate after a localiser call; `particles` (k, 3) and `weights` (k,) when recorded."""

    t: float
    estimate: PoseEstimate
    odometry: Pose
    particles: FloatArray | None
    weights: FloatArray | None
    cloud_size: int


@dataclass(frozen=True, eq=False)
class PlanItem:
    t: float
    path: FloatArray


Item = TruthItem | OdometryItem | SweepItem | EstimateItem | PlanItem


def _created_ns(text: Any) -> int:
    try:
        when = datetime.datetime.fromisoformat(str(text))
    except ValueError:
        return 0
    if when.tzinfo is None:
        when = when.replace(tzinfo=datetime.UTC)
    return round(when.timestamp()) * 1_000_000_000


def _pose(a: list[Any]) -> tuple[Pose, bool]:
    known = a[2] is not None
    return Pose(float(a[0]), float(a[1]), float(a[2]) if known else 0.0), known


def run_info(header: dict[str, Any], m: Map | None = None) -> RunInfo:
    """The `RunInfo` of a header line (its map is rebuilt unless `m` is given)."""
    geometry = (header.get("robot") or {}).get("geometry") or {}
    default = RobotGeometry()
    radius = float(geometry.get("radius_cm", default.radius_cm))
    offset = float(geometry.get("sensor_offset_cm", default.sensor_offset_cm))
    the_map = m if m is not None else map_from_dict(header["map"])
    label = f"{the_map.name} ({(header.get('robot') or {}).get('kind', '?')})"
    return RunInfo(the_map, radius, offset, _created_ns(header.get("created")), label)


class Timeline:
    """Turns event dicts into items (see the module docstring); `info` is set by the header."""

    def __init__(self) -> None:
        self.info: RunInfo | None = None
        self.t = 0.0
        self.odometry = Pose(0.0, 0.0, 0.0)

    def feed(self, e: dict[str, Any], m: Map | None = None) -> list[Item]:
        """The items of one event (a checked recording line); the header sets `info`."""
        kind = e["type"]
        if kind == "header":
            self.info = run_info(e, m)
            return []
        out: list[Item] = []
        if kind in ("turn", "move", "turnback"):
            self.t = float(e["t"])
            if e.get("true_pose") is not None:
                pose, known = _pose(e["true_pose"])
                out.append(TruthItem(self.t, pose, known))
        elif kind == "scan":
            out.extend(self._scan(e))
        elif kind == "predict":
            o = self.odometry
            theta = float(wrap_angle(o.theta + float(e["turn_rad"])))
            d = float(e["distance_cm"])
            self.odometry = Pose(o.x + d * math.cos(theta), o.y + d * math.sin(theta), theta)
            out.append(OdometryItem(self.t, self.odometry))
        elif kind == "estimate":
            out.append(self._estimate(e))
        elif kind == "plan":
            out.append(PlanItem(self.t, np.vstack([decode_floats(p) for p in e["path"]])))
        return out


    def _scan(self, e: dict[str, Any]) -> list[Item]:
        scan = scan_from_fields(e)
        n = len(scan)
        if e.get("t") is None:
            self.t += CLOCKLESS_STEP_S
            t_start = t = self.t
        else:
            t_start = float(e["t_start"]) if e.get("t_start") is not None else self.t
            t = self.t = float(e["t"])
        if "times_s" in e:
            times = decode_floats(e["times_s"])
        else:
            times = t_start + (np.arange(n) + 1.0) * ((t - t_start) / max(n, 1))
        truth, known = (None, False) if e.get("true_pose") is None else _pose(e["true_pose"])
        out: list[Item] = []
        if truth is not None:
            out.append(TruthItem(t, truth, known))
        out.append(SweepItem(t, t_start, times, scan, int(e["id"]), truth, known, e.get("label")))
        return out

    def _estimate(self, e: dict[str, Any]) -> EstimateItem:
        est = PoseEstimate(Pose(*[float(v) for v in e["pose"]]), np.vstack([decode_floats(r) for r in e["cov"]]),
                           bool(e["converged"]), int(e["iterations"]))
        cloud = e.get("particles")
        if cloud is None:
            return EstimateItem(self.t, est, self.odometry, None, None, 0)
        poses = np.vstack([decode_floats(p) for p in cloud["poses"]]) if cloud["poses"] else np.zeros((0, 3))
        return EstimateItem(self.t, est, self.odometry, poses, decode_floats(cloud["weights"]), int(cloud["n"]))


def timeline_of(path: str | Path) -> tuple[RunInfo, list[Item]]:
    """A recording's `RunInfo` and items (`toolkit.recordings.replay.read_recording` checks it first)."""
    from .replay import read_recording

    rec = read_recording(path)
    tl = Timeline()
    tl.feed(rec.header, rec.map)
    items: list[Item] = []
    for _, e in rec.events:
        items.extend(tl.feed(e))
    assert tl.info is not None
    return tl.info, items
