"""`export_mcap`: a recording as a ROS 2 bag (rosbag2 folder, MCAP storage, CDR) written by `rosbags`.

The folder is written beside `out` under a temporary name and renamed into place when complete,
so a failure leaves nothing half-written; an existing non-empty `out` is refused and never touched.
"""

from __future__ import annotations

import json
import math
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ...recordings.recorder import thin_cloud
from ...recordings.timeline import EstimateItem, Item, OdometryItem, PlanItem, RunInfo, SweepItem, Timeline, TruthItem
from ...world import Pose, wrap_angle
from . import messages as msg
from .grid import rasterise
from .typestore import PARTICLE_CLOUD, typestore

if TYPE_CHECKING:
    from ...recordings.replay import Recording

__all__ = ["HEADER_KEY", "ROSBAG2_VERSION", "TOPICS", "ExportSummary", "export_mcap"]

HEADER_KEY = "nxtnav.header"
"""Key of the metadata's ``custom_data`` entry holding the recording's created time, map, robot and sonar (JSON)."""

ROSBAG2_VERSION: Literal[8] = 8
"""The rosbag2 metadata version written."""

TOPICS: dict[str, str] = {
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/odom": "nav_msgs/msg/Odometry",
    "/scan": "sensor_msgs/msg/LaserScan",
    "/amcl_pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "/particle_cloud": PARTICLE_CLOUD,
    "/plan": "nav_msgs/msg/Path",
    "/ground_truth": "geometry_msgs/msg/PoseWithCovarianceStamped",
}
"""Every topic the export may write, with its type; a topic with nothing to say (no particles, no
plan, no truth in the recording) is left out."""

_LATCHED = ("/map", "/tf_static")


@dataclass(frozen=True)
class ExportSummary:
    """What `export_mcap` wrote: the folder and, per topic, its type and message count."""

    path: Path
    topics: dict[str, tuple[str, int]] = field(default_factory=dict)
    moved_scans: int = 0
    """Sweeps whose angles lie off any regular grid (deskewed), put on a finer one (`messages._slots`)."""
    moved_rad: float = 0.0
    """How far the furthest of their readings was moved to its slot (rad)."""
    truncated: str | None = None
    """Where the recording was cut short (`toolkit.recordings.replay.Recording.truncated`); None when it is whole."""

    @property
    def messages(self) -> int:
        return sum(n for _, n in self.topics.values())


def _qos(latched: bool) -> list[Any]:
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    zero = QosTime(0, 0)
    return [Qos(QosHistory.KEEP_LAST, 1 if latched else 10, QosReliability.RELIABLE,
                QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE, zero, zero,
                QosLiveliness.AUTOMATIC, zero, False)]


def _check_target(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise msg.ExportError(f"{out} exists and is not a folder; give a new folder for the bag")
    if out.is_dir() and any(out.iterdir()):
        raise msg.ExportError(f"{out} exists and is not empty; give a new or empty folder (nothing was written)")


def _map_to_odom(estimate: Pose, odom: Pose) -> Pose:
    """The odometry frame's pose in the map: the estimate composed with the inverse of the odometry pose."""
    theta = float(wrap_angle(estimate.theta - odom.theta))
    c, s = math.cos(theta), math.sin(theta)
    return Pose(estimate.x - (c * odom.x - s * odom.y), estimate.y - (s * odom.x + c * odom.y), theta)


def _range_limits(rec: Recording, info: RunInfo) -> tuple[float, float]:
    """The recording's sensor's range limits (cm from the sensor): its model's ``min_range_cm`` and
    ``max_range_cm``; for a model without them (the ideal sonar), 0 and the longest distance in the map."""
    from ...recordings.replay import robot_model_of

    sonar = robot_model_of(rec).sonar
    rmin = float(getattr(sonar, "min_range_cm", 0.0))
    rmax = float(getattr(sonar, "max_range_cm", msg.map_extent_cm(info.map)))
    return rmin, max(rmax, rmin)


def _truth_message(ns: int, pose: Pose, heading_known: bool) -> tuple[str, int, Any]:
    """``/ground_truth`` at `ns`; an unknown heading has an infinite yaw variance."""
    var_yaw = 0.0 if heading_known else math.inf
    return "/ground_truth", ns, msg.pose_with_covariance(ns, msg.FRAMES["map"], pose, np.diag([0.0, 0.0, var_yaw]))


def _timeline(rec: Recording) -> tuple[RunInfo, list[Item]]:
    """The run's `RunInfo` and time-line items (`toolkit.recordings.timeline`) of a recording already read."""
    tl = Timeline()
    tl.feed(rec.header, rec.map)
    items: list[Item] = [it for _, e in rec.events for it in tl.feed(e)]
    assert tl.info is not None
    return tl.info, items


def _odometry_messages(ns: int, pose: Pose) -> list[tuple[str, int, Any]]:
    """``/odom`` and the ``odom -> base_link`` transform of `pose` at `ns`."""
    return [("/odom", ns, msg.odometry(ns, pose)),
            ("/tf", ns, msg.tf_message([msg.transform(ns, msg.FRAMES["odom"], msg.FRAMES["base"], pose)]))]


def _messages(info: RunInfo, items: list[Any], limits: tuple[float, float], resolution_cm: float,
              particles: int | None) -> tuple[list[tuple[str, int, Any]], list[float]]:
    """(topic, log time ns, message) of the whole run, in time order, and, per sweep put on a finer grid
    than its own, how far its furthest reading moved (rad).

    Odometry is published after each motion the localiser was told, and again at the first and the
    last reading of each sweep with the pose it was told for that sweep: the robot stands while it
    sweeps, and a reader that interpolates odometry (tf2, `nxtnav import bag`) finds the pose of
    every reading between two samples of it. For the same reason a sweep's true pose is published at
    its first reading as well as at its end."""
    out: list[tuple[str, int, Any]] = []
    snapped: list[float] = []
    t0 = info.stamp_ns(0.0)
    out.append(("/map", t0, msg.occupancy_grid(t0, rasterise(info.map, resolution_cm))))
    odom = Pose(0.0, 0.0, 0.0)
    out.append(("/tf_static", t0, msg.tf_message([msg.transform(t0, msg.FRAMES["base"], msg.FRAMES["sonar"],
                                                                 odom)])))
    out.append(("/tf", t0, msg.tf_message([msg.transform(t0, msg.FRAMES["odom"], msg.FRAMES["base"], odom)])))
    for it in items:
        ns = info.stamp_ns(it.t)
        if isinstance(it, TruthItem):
            out.append(_truth_message(ns, it.pose, it.heading_known))
        elif isinstance(it, OdometryItem):
            odom = it.pose
            out.extend(_odometry_messages(ns, odom))
        elif isinstance(it, SweepItem):
            first = info.stamp_ns(float(np.min(it.times))) if it.times.size else ns
            last = info.stamp_ns(float(np.max(it.times))) if it.times.size else ns
            for stamp in sorted({first, last}):
                out.extend(_odometry_messages(stamp, odom))
            if it.truth is not None and first != ns:  # the sweep's truth at its end comes as a TruthItem
                out.append(_truth_message(first, it.truth, it.heading_known))
            laser, moved = msg.laser_scan(first, it.scan, it.times, it.t - it.t_start, info.sensor_offset_cm,
                                          *limits, f"scan {it.id}")
            out.append(("/scan", ns, laser))
            if moved > msg.ANGLE_TOLERANCE_RAD:
                snapped.append(moved)
        elif isinstance(it, EstimateItem):
            est = it.estimate
            out.append(("/amcl_pose", ns, msg.pose_with_covariance(ns, msg.FRAMES["map"], est.pose, est.cov)))
            out.append(("/tf", ns, msg.tf_message([msg.transform(ns, msg.FRAMES["map"], msg.FRAMES["odom"],
                                                                 _map_to_odom(est.pose, it.odometry))])))
            if it.particles is not None and it.weights is not None and it.particles.shape[0]:
                p, w = (it.particles, it.weights) if particles is None else thin_cloud(it.particles, it.weights,
                                                                                       particles)
                out.append(("/particle_cloud", ns, msg.particle_cloud(ns, p, w)))
        elif isinstance(it, PlanItem):
            out.append(("/plan", ns, msg.path_msg(ns, it.path)))
    return out, snapped


def export_mcap(recording: str | Path, out: str | Path, *, resolution_cm: float = 1.0,
                particles: int | None = None) -> ExportSummary:
    """Write the recording `recording` as a rosbag2 folder `out` (MCAP, CDR); see ``docs/recording.md``.

    Parameters
    ----------
    recording : path
        A recording (`toolkit.recordings.recorder`); checked by `toolkit.recordings.replay.read_recording`.
    out : path
        A new or empty folder.
    resolution_cm : float
        Cell size of the ``/map`` occupancy grid (cm).
    particles : int or None
        At most this many particles per ``/particle_cloud`` message (`thin_cloud`); None keeps every
        recorded one.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    dest = Path(out)
    _check_target(dest)
    if particles is not None and particles < 1:
        raise msg.ExportError(f"particles per cloud must be at least 1, got {particles}")
    from ...recordings.replay import read_recording

    rec = read_recording(recording)
    info, items = _timeline(rec)
    messages, snapped = _messages(info, items, _range_limits(rec, info), resolution_cm, particles)
    messages.sort(key=lambda m: m[1])  # stable: same-time messages keep the run's order
    store = typestore()
    # the bag is written as TMP/NAME (its MCAP file is named after NAME), then moved to `dest`
    tmp = dest.parent / f".{dest.name}.partial-{os.getpid()}"
    if tmp.exists():
        shutil.rmtree(tmp)
    counts: dict[str, int] = {}
    try:
        _make_folder(tmp, dest)
        writer = Writer(tmp / dest.name, version=ROSBAG2_VERSION, storage_plugin=StoragePlugin.MCAP)
        # the recording's map, robot and sonar, so that `nxtnav view DIR` can draw the walls again
        writer.set_custom_data(HEADER_KEY, json.dumps({k: rec.header.get(k) for k in ("created", "map", "robot",
                                                                                      "sonar")}))
        writer.open()
        try:
            used = [t for t in TOPICS if any(m[0] == t for m in messages)]
            conns = {t: writer.add_connection(t, TOPICS[t], typestore=store, offered_qos_profiles=_qos(t in _LATCHED))
                     for t in used}
            for topic, ns, message in messages:
                writer.write(conns[topic], ns, store.serialize_cdr(message, TOPICS[topic]))
                counts[topic] = counts.get(topic, 0) + 1
        finally:
            writer.close()
        if dest.is_dir():
            dest.rmdir()  # empty (checked above): the finished bag takes its place
        (tmp / dest.name).rename(dest)
        tmp.rmdir()
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise msg.ExportError(f"cannot write the bag {dest}: {exc.strerror or exc}") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return ExportSummary(dest, {t: (TOPICS[t], counts[t]) for t in TOPICS if t in counts}, len(snapped),
                         max(snapped, default=0.0), rec.truncated)


def _make_folder(tmp: Path, dest: Path) -> None:
    """Create the temporary folder `tmp` the bag `dest` is written in; an error names `dest`, the
    user's path, not the temporary one."""
    if dest.parent.exists() and not dest.parent.is_dir():
        raise msg.ExportError(f"cannot write the bag {dest}: {dest.parent} is a file, not a folder")
    try:
        dest.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise msg.ExportError(f"cannot create the folder of the bag {dest}: {exc.strerror or exc}") from None
    if not os.access(dest.parent, os.W_OK | os.X_OK):
        raise msg.ExportError(f"cannot write the bag {dest}: its folder {dest.parent} is not writable")
    tmp.mkdir()
