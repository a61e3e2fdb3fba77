"""A ROS bag as a recording that `nxtnav replay` runs localisers over (``docs/recording.md``).

`import_bag` reads a bag (`toolkit.ros.bag_reader`) and writes one ``nxtnav-recording``:

* a ``reset`` with a null prior (``nxtnav replay --initial-pose`` gives the localisers a prior instead);
* per scan kept (every `every`-th message of the scan topic), the odometry since the previous one
  as ``predict`` calls, then the ``scan`` and an ``update`` with all its readings.

Frames. The tracked pose is the base frame's (``base_footprint``) in the map, in cm and rad. A
scan's readings are re-expressed in the base frame at the scan's stamp: each echo's end point (from
the sensor's pose in the base frame, ``/tf``) becomes an angle and a range from the base's origin,
so the localisers' homocentric sensor sees the same wall points; a reading without an echo keeps its
direction. The end points are also de-skewed: the reading taken ``i * time_increment`` after the
stamp is placed where odometry says the robot was then, not at the stamp.

Odometry. From a ``nav_msgs/Odometry`` topic or the ``/tf`` chain from the odometry frame to the base
frame, interpolated at each scan's stamp. The planar motion between two scans, (dx, dy, dyaw) in
the earlier base frame, becomes a turn towards the displacement and a drive (``predict``), then a
turn to the new heading (a second ``predict``): a holonomic robot's sideways step is exact, not
lost. A displacement more than 90 degrees behind the heading is driven in reverse.

Ground truth. The poses of a pose topic, interpolated at each scan's stamp, after `truth_frame`
(the pose of the truth's frame in the map: a ground-truth system has its own frame) and before
`truth_offset` (the pose of the base in the body the truth tracks: a marker or sensor mounted away
from the base, or turned against it). Scans outside
the odometry's time span are skipped (counted in the result).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..recordings.recorder import Recorder
from ..world import LaserScanner, Map, Pose, Scan, wrap_angle
from .bag_reader import BagData, BagError, LaserScanMsg, PoseSeries, read_bag, se2_compose, se2_inverse

__all__ = ["BagImport", "OdometryNoise", "import_bag", "odometry_motions", "rebase_scan"]

M_TO_CM = 100.0
MAX_GAP_S = PoseSeries.max_gap_ns / 1e9
"""Longest gap between two odometry samples that a pose is interpolated across (s), unless both are the
same pose (`toolkit.ros.bag_reader.PoseSeries`)."""


@dataclass(frozen=True)
class OdometryNoise:
    """The motion noise the localisers are told for a bag's odometry (`localisation.models.MotionModel`):
    ``botsim`` semantics, `motion` a fraction of each drive and `turn` a fraction of each turn (and rad
    of heading noise per drive)."""

    model: str = "botsim"
    motion: float = 0.05
    turn: float = 0.01

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, "motion": self.motion, "turn": self.turn}


@dataclass(frozen=True)
class BagImport:
    """What `import_bag` wrote.

    Attributes
    ----------
    bag : str
    map : str
    scans_in_bag, scans, skipped : int
        Scan messages in the bag, written, and skipped (no odometry at their stamp, or no reading).
    readings, echoes : int
        Readings written, and how many of them are echoes.
    predicts, truths : int
        ``predict`` lines, and scans with a true pose.
    duration_s, odometry_m : float
        Time from the first scan written to the last; distance odometry says was driven (m).
    lines : int
    """

    bag: str
    map: str
    scans_in_bag: int
    scans: int
    skipped: int
    readings: int
    echoes: int
    predicts: int
    truths: int
    duration_s: float
    odometry_m: float
    lines: int

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def odometry_motions(delta: Any) -> list[tuple[float, float]]:
    """The planar motion `delta` (dx cm, dy cm, dyaw rad, in the starting frame) as (turn rad, drive cm)
    steps: turn towards the displacement and drive (in reverse when it lies behind), then turn to the
    final heading. The steps compose back to `delta` exactly.

    >>> [tuple(round(v, 6) for v in s) for s in odometry_motions((0.0, 5.0, 0.0))]
    [(1.570796, 5.0), (-1.570796, 0.0)]
    >>> [tuple(round(v, 6) for v in s) for s in odometry_motions((-3.0, 0.0, 0.1))]
    [(0.0, -3.0), (0.1, 0.0)]
    """
    dx, dy, dth = (float(v) for v in np.asarray(delta, dtype=float).ravel()[:3])
    d = math.hypot(dx, dy)
    if d == 0.0:
        return [(dth, 0.0)] if dth != 0.0 else []
    rot1 = math.atan2(dy, dx)
    if abs(rot1) > math.pi / 2.0:
        rot1 = wrap_angle(rot1 - math.pi)
        d = -d
    rot2 = wrap_angle(dth - rot1)
    return [(rot1, d)] + ([(rot2, 0.0)] if rot2 != 0.0 else [])


def rebase_scan(msg: LaserScanMsg, sensor: Any, motion: Any, pick: Any) -> tuple[Scan, np.ndarray]:
    """The readings `pick` of `msg` as a `Scan` in the base frame at the stamp (cm, rad), and their times (ns).

    `sensor` is the sensor's pose in the base frame (m, m, rad); `motion` (len(pick), 3) the base's pose
    at each reading's time in the base frame at the stamp (identity rows: no de-skewing). An echo is a
    finite reading within the message's limits; its end point gives the angle and range; a reading
    without an echo keeps its direction and reads inf.
    """
    r = msg.ranges[pick]
    with np.errstate(invalid="ignore"):
        echo = np.isfinite(r) & (r >= msg.range_min) & (r <= msg.range_max)
    at = se2_compose(np.asarray(motion, dtype=float), np.broadcast_to(np.asarray(sensor, dtype=float), motion.shape))
    direction = at[:, 2] + msg.angles[pick]
    rr = np.where(echo, r, 0.0)
    ex = at[:, 0] + rr * np.cos(direction)
    ey = at[:, 1] + rr * np.sin(direction)
    angles = np.where(echo, np.arctan2(ey, ex), np.asarray(wrap_angle(direction)))
    ranges = np.where(echo, np.hypot(ex, ey) * M_TO_CM, np.inf)
    return Scan(angles, ranges, echo), msg.times_ns[pick]


def _beam_pick(ranges: np.ndarray, beams: int) -> np.ndarray:
    """The readings kept of a message: `beams` evenly spread (all for 0) over those taken; a NaN slot
    holds no measurement (REP 117: erroneous or not taken, as between the windows of a sweep), so
    it is no reading at all."""
    taken = np.flatnonzero(~np.isnan(ranges))
    n = taken.size
    if beams <= 0 or beams >= n:
        return taken
    return taken[np.unique(np.linspace(0, n - 1, beams).round().astype(np.int64))]


BASE_FRAMES = ("base_footprint", "base_link")
"""The robot's frame when none is named, in this order of preference: REP 105's two names for it."""


def _base_frame(data: BagData, odom_frame: str) -> str:
    """The first of `BASE_FRAMES` that ``/tf`` links to `odom_frame`; an error listing the frames there
    when none is."""
    for name in BASE_FRAMES:
        if data.tf.chain(odom_frame, name) is not None:
            return name
    names = " or ".join(map(repr, BASE_FRAMES))
    raise BagError(f"{data.path}: no transform chain in /tf from {odom_frame!r} to {names}; frames there: "
                   f"{', '.join(data.tf.frames) or 'none'} (name the robot's with --base-frame)")


class _Odometry:
    """Base poses in the odometry frame (m, rad) at any time: from a topic or from /tf. `label` says
    which in words; `source` is the same for the recording's header."""

    def __init__(self, data: BagData, topic: str | None, odom_frame: str, base_frame: str | None) -> None:
        self._series: list[PoseSeries]
        if topic is not None:
            series = data.poses[topic]
            self.frame, self.base = series.frame or odom_frame, series.child or base_frame or BASE_FRAMES[0]
            self._at: Callable[[Any], tuple[np.ndarray, np.ndarray]] = series.at
            self.source: dict[str, Any] = {"topic": topic, "frame": self.frame, "base_frame": self.base}
            self.label = f"topic {topic} ({self.frame} -> {self.base})"
            self._series = [series]
        else:
            if not data.tf.edges:
                raise BagError(f"{data.path}: no /tf or /tf_static messages for odometry from {odom_frame!r}; "
                               f"give --odom-topic")
            base = base_frame if base_frame is not None else _base_frame(data, odom_frame)
            self.frame, self.base = odom_frame, base
            data.tf.lookup(odom_frame, base, np.zeros(0, dtype=np.int64))  # the chain must exist
            self._at = lambda t: data.tf.lookup(odom_frame, base, t)
            self.source = {"tf": f"{odom_frame} -> {base}", "frame": odom_frame, "base_frame": base}
            self.label = f"/tf {odom_frame} -> {base}"
            self._series = [data.tf.edges[e] for e in data.tf.chain(odom_frame, base) or []
                            if e not in data.tf.static]

    def at(self, t_ns: Any) -> tuple[np.ndarray, np.ndarray]:
        return self._at(t_ns)

    def describe(self) -> str:
        """Its samples in words (count, span, largest gap), for an error."""
        return "; ".join(s.describe() for s in self._series) or "static transforms only"


def _sensor_pose(data: BagData, base: str, frame: str, t_ns: int) -> tuple[np.ndarray, bool]:
    if frame == base or not frame:
        return np.zeros(3), True
    pose, ok = data.tf.lookup(base, frame, np.array([t_ns], dtype=np.int64))
    return pose[0], bool(ok[0])


def _metres(pose: tuple[float, float, float]) -> np.ndarray:
    """A pose (cm, cm, rad) as the bag's (m, m, rad)."""
    return np.array([pose[0] / M_TO_CM, pose[1] / M_TO_CM, pose[2]])


def _degrees(pose: tuple[float, float, float]) -> list[float]:
    """A pose (cm, cm, rad) as the recording's header states it (cm, cm, degrees)."""
    return [float(pose[0]), float(pose[1]), math.degrees(pose[2])]


def import_bag(bag: str | Path, map: Map, out: str | Path, *, scan_topic: str, odom_topic: str | None = None,
               odom_frame: str = "odom", base_frame: str | None = None, truth_topic: str | None = None,
               every: int = 1, beams: int = 0, truth_frame: tuple[float, float, float] = (0.0, 0.0, 0.0),
               range_noise_cm: float = 2.0, noise: OdometryNoise | None = None, deskew: bool = True,
               scan_delay_s: float = 0.0, truth_delay_s: float = 0.0,
               truth_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> BagImport:
    """Write the bag `bag` as a recording on `map` to `out` (module docstring).

    Parameters
    ----------
    scan_topic, odom_topic, truth_topic : str
        Topics of the scans, the odometry (None: ``/tf`` from `odom_frame` to `base_frame`), the truth.
    base_frame : str or None
        The robot's frame; None: the first of `BASE_FRAMES` in ``/tf`` (an odometry topic names its own).
    every : int
        Keep every `every`-th scan message.
    beams : int
        Readings kept per scan, evenly spread over the message's (0: all).
    truth_frame : (x cm, y cm, heading rad)
        Pose of the ground truth's frame in the map.
    truth_offset : (x cm, y cm, heading rad)
        Pose of the base frame in the body the truth tracks: the true pose written is the truth's,
        composed with this.
    range_noise_cm : float
        The ``laser`` model's reading noise written in the header (what the localisers are told).
    noise : OdometryNoise
        The odometry noise written in the header.
    deskew : bool
        Place each reading where odometry says the robot was when it was taken.
    scan_delay_s, truth_delay_s : float
        How late the scans' and the truth's stamps are against the odometry's clock (s): a driver that
        stamps a scan when it ends or arrives. A scan's first reading was taken at its stamp minus
        `scan_delay_s` on the odometry's clock; the truth of that moment is the truth topic's pose
        stamped `truth_delay_s` later.

    The recording is written to a temporary file beside `out` and renamed at the end: a bag that fails
    half-way leaves nothing behind.
    """
    if every < 1 or beams < 0:
        raise BagError(f"every must be >= 1 and beams >= 0, got {every}, {beams}")
    path = Path(bag)
    topics = {t: o for t, o in ((odom_topic, "--odom-topic"), (truth_topic, "--truth-topic")) if t}
    data = read_bag(path, scan_topic=scan_topic, pose_topics=topics)
    if not data.scans:
        raise BagError(f"{path}: topic {scan_topic!r} holds no messages")
    odo = _Odometry(data, odom_topic, odom_frame, base_frame)
    first = data.scans[0]
    laser = LaserScanner(noise_sd=float(range_noise_cm), min_range_cm=max(first.range_min, 0.0) * M_TO_CM,
                         max_range_cm=max(first.range_max, first.range_min + 1e-3) * M_TO_CM)
    truth_frames_m = (_metres(truth_frame), _metres(truth_offset))
    target = Path(out)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.part")
    source = {"kind": "ros-bag", "file": str(path), "scan_topic": scan_topic, "scan_type": data.scan_type,
              "sensor_frame": first.frame, "odometry": odo.source, "truth_topic": truth_topic,
              "truth_frame": _degrees(truth_frame), "truth_offset": _degrees(truth_offset),
              "every": every, "beams": beams, "deskewed": bool(deskew), "scans_in_bag": len(data.scans),
              "scan_delay_s": float(scan_delay_s), "truth_delay_s": float(truth_delay_s)}
    try:
        delays = (round(scan_delay_s * 1e9), round(truth_delay_s * 1e9))
        result = _write(data, map, tmp, odo, laser, truth_topic, truth_frames_m, every, beams, deskew,
                        noise or OdometryNoise(), source, delays)
        os.replace(tmp, target)
    except OSError as exc:  # named by the user's path, not the temporary file's
        tmp.unlink(missing_ok=True)
        raise BagError(f"cannot write the recording {target}: {exc.strerror or exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return result


def _truth_at(series: PoseSeries | None, t_ns: int, frames_m: tuple[np.ndarray, np.ndarray]) -> Pose | None:
    """The true pose of the base at `t_ns` (cm, rad) from the truth's `series`, placed by `frames_m` (the
    truth's frame in the map, the base in the body the truth tracks; m, m, rad); None when unknown."""
    if series is None:
        return None
    pose, known = series.at(np.array([t_ns], dtype=np.int64))
    if not known[0]:
        return None
    g = se2_compose(se2_compose(frames_m[0], pose[0]), frames_m[1])
    return Pose(float(g[0] * M_TO_CM), float(g[1] * M_TO_CM), float(g[2]))


def _write(data: BagData, map: Map, tmp: Path, odo: _Odometry, laser: LaserScanner, truth_topic: str | None,
           truth_frames_m: tuple[np.ndarray, np.ndarray], every: int, beams: int, deskew: bool,
           noise: OdometryNoise, source: dict[str, Any], delays: tuple[int, int]) -> BagImport:
    kept = [(i, m) for i, m in enumerate(data.scans) if i % every == 0]
    scan_delay, truth_delay = delays
    stamps = np.array([m.stamp for _, m in kept], dtype=np.int64) - scan_delay  # on the odometry's clock
    ref, known = odo.at(stamps)
    if not known.any():
        raise BagError(f"{data.path}: no odometry from {odo.label} at the stamps of the scans on "
                       f"{source['scan_topic']!r} ({odo.describe()}; a scan needs two samples around its stamp at "
                       f"most {MAX_GAP_S:g} s apart)")
    t0 = int(stamps[known][0])
    source = {**source, "time_origin_ns": t0}
    rec = Recorder(tmp, map=map, robot={"kind": "ros", "imported": "ros-bag", "base_frame": odo.base},
                   sonar={"model": "laser", "params": laser.to_dict()}, seed=None,
                   extra={"noise": noise.to_dict(), "source": source})
    truth_series = data.poses.get(truth_topic) if truth_topic else None
    counts = {"readings": 0, "echoes": 0, "predicts": 0, "truths": 0, "scans": 0}
    driven = 0.0
    prev: np.ndarray | None = None
    last_t = 0.0
    try:
        rec.reset_event(None)
        for k, (_i, msg) in enumerate(kept):
            if not known[k]:
                continue
            sensor, ok = _sensor_pose(data, odo.base, msg.frame, int(stamps[k]))
            if not ok:
                continue
            pick = _beam_pick(msg.ranges, beams)
            if not pick.size:  # nothing measured (every slot NaN)
                continue
            motion = np.zeros((pick.size, 3))
            if deskew:
                at, ok_i = odo.at(msg.times_ns[pick] - scan_delay)
                rel = se2_compose(se2_inverse(np.broadcast_to(ref[k], at.shape)), at)
                motion = np.where(ok_i[:, None], rel, 0.0)
            scan, times = rebase_scan(msg, sensor, motion, pick)
            times = times - scan_delay
            if prev is not None:
                delta = se2_compose(se2_inverse(prev), ref[k])
                driven += math.hypot(float(delta[0]), float(delta[1]))
                for turn, dist in odometry_motions((delta[0] * M_TO_CM, delta[1] * M_TO_CM, delta[2])):
                    rec.event("predict", turn_rad=float(turn), distance_cm=float(dist))
                    counts["predicts"] += 1
            prev = ref[k]
            truth = _truth_at(truth_series, int(stamps[k]) + truth_delay, truth_frames_m)
            counts["truths"] += truth is not None
            t_rel = (times - t0) / 1e9
            rec.stamped_scan(scan, (stamps[k] - t0) / 1e9, float(t_rel.max()), truth, times_s=t_rel)
            rec.update_event(scan)
            last_t = (stamps[k] - t0) / 1e9
            counts["scans"] += 1
            counts["readings"] += len(scan)
            counts["echoes"] += int(scan.valid.sum())
    except BaseException:
        rec.close(end=False)
        raise
    rec.close("imported", None)
    return BagImport(str(data.path), map.name, len(data.scans), counts["scans"], len(kept) - counts["scans"],
                     counts["readings"], counts["echoes"], counts["predicts"], counts["truths"], last_t, driven,
                     rec.lines)
