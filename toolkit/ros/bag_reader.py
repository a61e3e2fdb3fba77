"""Reading ROS bags through `rosbags` (ROS 1 ``.bag``, ROS 2 ``.db3`` or ``.mcap``, no ROS needed).

`read_bag` makes one pass over the messages of the topics asked for and returns a `BagData`: the
scans (``sensor_msgs/LaserScan`` or ``sensor_msgs/Range``) as `LaserScanMsg`, the transforms of
``/tf`` and ``/tf_static`` as a `TfTree`, and pose topics (``nav_msgs/Odometry``,
``geometry_msgs/PoseStamped``, ``geometry_msgs/PoseWithCovarianceStamped``) as `PoseSeries`.
Everything is planar: x, y (metres, as in ROS) and yaw (rad) of each pose; heights, roll and pitch
are dropped. Stamps are integer nanoseconds of the messages' headers.

A bag that cannot be opened or read, a topic the bag lacks, and a topic of a type that cannot be
what it is asked to be raise `BagError` (one line: the file, the topic, and the topics it has).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..world import ConfigError, wrap_angle
from ..world.arrays import FloatArray, IntArray

__all__ = ["POSE_TYPES", "SCAN_TYPES", "BagData", "BagError", "LaserScanMsg", "PoseSeries", "TfTree", "check_topic",
           "read_bag", "se2_compose", "se2_inverse"]


LASER_SCAN = "sensor_msgs/msg/LaserScan"
RANGE = "sensor_msgs/msg/Range"
SCAN_TYPES = (LASER_SCAN, RANGE)
ODOMETRY = "nav_msgs/msg/Odometry"
POSE_TYPES = (ODOMETRY, "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped")
TF_TOPICS = ("/tf", "/tf_static")


class BagError(ConfigError):
    """A bag that cannot be read, or a topic it lacks or whose type does not fit (one line)."""


# -- planar transforms ---------------------------------------------------------------------------------

def se2_compose(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a * b`` for planar poses (..., 3) of x, y, yaw: `b` expressed in `a`'s frame, in `a`'s parent."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def se2_inverse(a: FloatArray) -> FloatArray:
    """The inverse of planar poses (..., 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1], wrap_angle(-a[..., 2])], axis=-1)


def _yaw(q: Any) -> float:
    """Yaw (rad) of a quaternion message (x, y, z, w)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _stamp(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


@dataclass
class PoseSeries:
    """Planar poses over time: `stamps` (ns, ascending), `poses` (n, 3: x m, y m, yaw rad).

    `at` interpolates linearly (the yaw along the shorter way) between the two samples around a time;
    a time outside the samples, or between two samples more than `max_gap_ns` apart, has no pose,
    unless those two samples are the same pose: the robot stood still between them (a driver that
    publishes only on motion, or a robot that stands while its sensor sweeps), however long.
    """

    frame: str
    child: str
    stamps: IntArray
    poses: FloatArray
    max_gap_ns: int = 500_000_000

    @classmethod
    def build(cls, frame: str, child: str, stamps: Iterable[int], poses: Iterable[Any],
              max_gap_ns: int = 500_000_000) -> PoseSeries:
        t = np.asarray(list(stamps), dtype=np.int64)
        p = np.asarray(list(poses), dtype=float).reshape(-1, 3)
        order = np.argsort(t, kind="stable")
        t, p = t[order], p[order]
        keep = np.ones(t.size, dtype=bool)
        keep[1:] = t[1:] != t[:-1]  # one pose per stamp (the first one)
        return cls(frame, child, t[keep], p[keep], max_gap_ns)

    def __len__(self) -> int:
        return int(self.stamps.size)

    def describe(self) -> str:
        """Its time span and largest gap between samples, in words (s from its first sample)."""
        if self.stamps.size == 0:
            return "no samples"
        span = (self.stamps[-1] - self.stamps[0]) / 1e9
        gap = float(np.diff(self.stamps).max()) / 1e9 if self.stamps.size > 1 else 0.0
        return f"{self.stamps.size} samples over {span:.1f} s, gaps up to {gap:.2f} s"

    def at(self, t_ns: Any) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Poses (m, m, rad) at times `t_ns` (ns), shape (..., 3), and whether each is known."""
        t = np.asarray(t_ns, dtype=np.int64)
        n = self.stamps.size
        if n == 0:
            return np.full((*t.shape, 3), np.nan), np.zeros(t.shape, dtype=bool)
        if n == 1:
            same = t == self.stamps[0]
            return np.broadcast_to(self.poses[0], (*t.shape, 3)).copy(), same
        j = np.clip(np.searchsorted(self.stamps, t, side="right"), 1, n - 1)
        t0, t1 = self.stamps[j - 1], self.stamps[j]
        p0, p1 = self.poses[j - 1], self.poses[j]
        still = np.all(p0 == p1, axis=-1)
        known = (t >= self.stamps[0]) & (t <= self.stamps[-1]) & (((t1 - t0) <= self.max_gap_ns) | still)
        f = ((t - t0) / np.maximum(t1 - t0, 1)).astype(float)[..., None]
        d = p1 - p0
        d[..., 2] = wrap_angle(d[..., 2])
        out = p0 + f * d
        out[..., 2] = wrap_angle(out[..., 2])
        return out, known


@dataclass
class TfTree:
    """The transforms of a bag's ``/tf`` and ``/tf_static``: one `PoseSeries` per (parent, child) edge
    (a static edge holds at every time). `lookup` chains edges from a frame up to an ancestor."""

    edges: dict[tuple[str, str], PoseSeries] = field(default_factory=dict)
    static: set[tuple[str, str]] = field(default_factory=set)

    @property
    def frames(self) -> list[str]:
        return sorted({f for e in self.edges for f in e})

    def _parent(self, child: str) -> str | None:
        for p, c in self.edges:
            if c == child:
                return p
        return None

    def chain(self, ancestor: str, frame: str) -> list[tuple[str, str]] | None:
        """The edges from `ancestor` down to `frame` (empty when they are the same; None: not linked)."""
        path: list[tuple[str, str]] = []
        cur = frame
        seen = {cur}
        while cur != ancestor:
            parent = self._parent(cur)
            if parent is None or parent in seen:
                return None
            path.append((parent, cur))
            seen.add(parent)
            cur = parent
        return path[::-1]

    def lookup(self, ancestor: str, frame: str, t_ns: Any) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Pose of `frame` in `ancestor` at times `t_ns`, and whether every edge knew it then."""
        path = self.chain(ancestor, frame)
        t = np.asarray(t_ns, dtype=np.int64)
        if path is None:
            raise BagError(f"no transform chain from {ancestor!r} to {frame!r} in /tf or /tf_static; "
                           f"frames there: {', '.join(self.frames) or 'none'}")
        out = np.zeros((*t.shape, 3))
        known = np.ones(t.shape, dtype=bool)
        for edge in path:
            series = self.edges[edge]
            if edge in self.static:
                pose, ok = np.broadcast_to(series.poses[-1], (*t.shape, 3)), np.ones(t.shape, dtype=bool)
            else:
                pose, ok = series.at(t)
            out = se2_compose(out, pose)
            known &= ok
        return out, known


@dataclass
class LaserScanMsg:
    """One scan message: a ``LaserScan``, or a ``Range`` as a scan of one reading.

    Attributes
    ----------
    stamp : int
        Header stamp (ns): the time of the first reading.
    frame : str
        The sensor's frame.
    angles : (n,) ndarray
        Direction of each reading in the sensor's frame (rad).
    ranges : (n,) ndarray
        Readings (m) as the message holds them (inf, nan and out-of-limit values included).
    time_increment : float
        Seconds between readings (0 when the message does not say).
    range_min, range_max : float
        The message's limits (m).
    """

    stamp: int
    frame: str
    angles: FloatArray
    ranges: FloatArray
    time_increment: float
    range_min: float
    range_max: float

    @property
    def times_ns(self) -> IntArray:
        """When each reading was taken (ns)."""
        step = self.time_increment if math.isfinite(self.time_increment) and self.time_increment > 0 else 0.0
        return self.stamp + np.rint(np.arange(self.ranges.size) * step * 1e9).astype(np.int64)


def _scan_msg(msg: Any, msgtype: str) -> LaserScanMsg:
    if msgtype == RANGE:
        return LaserScanMsg(_stamp(msg.header), str(msg.header.frame_id), np.zeros(1),
                            np.array([float(msg.range)]), 0.0, float(msg.min_range), float(msg.max_range))
    r = np.asarray(msg.ranges, dtype=float)
    a = float(msg.angle_min) + np.arange(r.size, dtype=np.float64) * float(msg.angle_increment)
    return LaserScanMsg(_stamp(msg.header), str(msg.header.frame_id), a, r, float(msg.time_increment),
                        float(msg.range_min), float(msg.range_max))


def _pose_of(msg: Any, msgtype: str) -> tuple[str, str, tuple[float, float, float]]:
    """(frame, child frame, (x, y, yaw)) of a pose message (child: '' where the type has none)."""
    pose = msg.pose.pose if msgtype != "geometry_msgs/msg/PoseStamped" else msg.pose
    child = str(msg.child_frame_id) if msgtype == ODOMETRY else ""
    return str(msg.header.frame_id), child, (float(pose.position.x), float(pose.position.y), _yaw(pose.orientation))


@dataclass
class BagData:
    """What `read_bag` found: the bag's topics and types, the scans, the transforms and pose series."""

    path: Path
    topics: dict[str, str]
    start_ns: int
    scans: list[LaserScanMsg]
    scan_type: str
    tf: TfTree
    poses: dict[str, PoseSeries]


def _topic_list(topics: dict[str, str]) -> str:
    return ", ".join(f"{t} ({ty.replace('/msg/', '/')})" for t, ty in sorted(topics.items())) or "none"


def check_topic(path: Path, topics: dict[str, str], topic: str, option: str, types: tuple[str, ...],
                what: str) -> None:
    """`topic` must be in the bag and of one of `types` (`what` says what it was to be)."""
    if topic not in topics:
        raise BagError(f"{path}: no topic {topic!r} ({option}); the bag's topics: {_topic_list(topics)}")
    if topics[topic] not in types:
        raise BagError(f"{path}: topic {topic!r} ({option}) is {topics[topic].replace('/msg/', '/')}, which cannot "
                       f"be {what} (expected {' or '.join(t.replace('/msg/', '/') for t in types)})")


def read_bag(path: str | Path, *, scan_topic: str, pose_topics: dict[str, str] | None = None,
             tf: bool = True) -> BagData:
    """Read the scans of `scan_topic`, the pose series of `pose_topics` (topic -> the option that named
    it) and, with `tf`, ``/tf`` and ``/tf_static`` from a bag (module docstring)."""
    from rosbags.highlevel import AnyReader, AnyReaderError

    p = Path(path)
    if not p.exists():
        raise BagError(f"bag {str(p)!r} not found")
    pose_topics = dict(pose_topics or {})
    try:
        with AnyReader([p]) as reader:
            topics = {c.topic: c.msgtype for c in reader.connections}
            check_topic(p, topics, scan_topic, "--scan-topic", SCAN_TYPES, "a scan")
            for topic, option in pose_topics.items():
                check_topic(p, topics, topic, option, POSE_TYPES, "a pose")
            wanted = {scan_topic, *pose_topics, *([t for t in TF_TOPICS if t in topics] if tf else [])}
            conns = [c for c in reader.connections if c.topic in wanted]
            return _collect(p, reader, conns, topics, scan_topic, pose_topics)
    except BagError:
        raise
    except (AnyReaderError, OSError) as exc:
        raise BagError(f"{p}: cannot read the bag: {' '.join(str(exc).split())}") from None
    except Exception as exc:  # a damaged message: rosbags raises whatever its decoder met
        raise BagError(f"{p}: cannot read the bag ({type(exc).__name__}: {' '.join(str(exc).split())})") from None


def _collect(p: Path, reader: Any, conns: list[Any], topics: dict[str, str], scan_topic: str,
             pose_topics: dict[str, str]) -> BagData:
    scans: list[LaserScanMsg] = []
    edges: dict[tuple[str, str], tuple[list[int], list[tuple[float, float, float]]]] = {}
    static: set[tuple[str, str]] = set()
    series: dict[str, tuple[str, str, list[int], list[tuple[float, float, float]]]] = {}
    for conn, _t, raw in reader.messages(connections=conns):
        msg = reader.deserialize(raw, conn.msgtype)
        if conn.topic == scan_topic:
            scans.append(_scan_msg(msg, conn.msgtype))
        elif conn.topic in pose_topics:
            frame, child, pose = _pose_of(msg, conn.msgtype)
            entry = series.setdefault(conn.topic, (frame, child, [], []))
            entry[2].append(_stamp(msg.header))
            entry[3].append(pose)
        else:
            for tr in msg.transforms:
                key = (str(tr.header.frame_id).lstrip("/"), str(tr.child_frame_id).lstrip("/"))
                tt, q = tr.transform.translation, tr.transform.rotation
                st, ps = edges.setdefault(key, ([], []))
                st.append(_stamp(tr.header))
                ps.append((float(tt.x), float(tt.y), _yaw(q)))
                if conn.topic == "/tf_static":
                    static.add(key)
    tree = TfTree({k: PoseSeries.build(k[0], k[1], st, ps) for k, (st, ps) in edges.items()}, static)
    poses = {t: PoseSeries.build(f.lstrip("/"), c.lstrip("/"), st, ps) for t, (f, c, st, ps) in series.items()}
    return BagData(p, topics, int(reader.start_time), scans, topics[scan_topic], tree, poses)
