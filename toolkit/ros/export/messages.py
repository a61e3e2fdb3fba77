"""ROS 2 messages of a run, in SI units and REP-105 frames (`rosbags` message classes of `typestore`).

Conversions: cm to m (/100), radians as they are, a planar pose as a quaternion about z, a 3x3
covariance (x cm, y cm, heading rad) as the 6x6 of (x, y, z, roll, pitch, yaw) in m^2, m rad and
rad^2, zeros for the three dimensions a planar robot does not have. A sweep becomes one
``sensor_msgs/LaserScan`` (`laser_scan`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...world import Map, NxtnavError, Pose, Scan
from ...world.arrays import FloatArray
from .grid import OccupancyGrid
from .typestore import PARTICLE, PARTICLE_CLOUD, typestore

__all__ = ["ANGLE_TOLERANCE_RAD", "FRAMES", "ExportError", "covariance_6x6", "header", "laser_scan", "occupancy_grid",
           "particle_cloud", "path_msg", "pose_msg", "pose_with_covariance", "quaternion", "rep117_ranges", "transform",
           "yaw_of"]


FRAMES = {"map": "map", "odom": "odom", "base": "base_link", "sonar": "sonar_link"}
"""REP-105 frame names: the map, the odometry frame, the robot body, the sonar (on the turret axis)."""

ANGLE_TOLERANCE_RAD = 1e-6
"""How far a reading's angle may sit from its LaserScan slot (angle_min + k increment)."""

SNAP_TOLERANCE_RAD = 1e-3
"""For a sweep whose angles lie off any regular grid (a laser deskewed for the robot's motion): how far
a reading may be moved to the nearest slot of a finer grid (at most `MAX_SUBDIVISION` slots per step)."""

MAX_SUBDIVISION = 64


class ExportError(NxtnavError):
    """A recording that cannot be written as ROS 2 messages (the message says which part and why)."""


def _t(name: str) -> Any:
    return typestore().types[name]


def stamp(ns: int) -> Any:
    return _t("builtin_interfaces/msg/Time")(sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def header(ns: int, frame: str) -> Any:
    return _t("std_msgs/msg/Header")(stamp=stamp(ns), frame_id=frame)


def quaternion(yaw: float) -> Any:
    """The rotation by `yaw` (rad) about z."""
    return _t("geometry_msgs/msg/Quaternion")(x=0.0, y=0.0, z=math.sin(0.5 * yaw), w=math.cos(0.5 * yaw))


def yaw_of(q: Any) -> float:
    """The yaw (rad) of a quaternion about z (the inverse of `quaternion`)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pose_msg(pose: Pose) -> Any:
    """``geometry_msgs/Pose`` of a planar pose (cm, rad) in metres."""
    point = _t("geometry_msgs/msg/Point")(x=pose.x / 100.0, y=pose.y / 100.0, z=0.0)
    return _t("geometry_msgs/msg/Pose")(position=point, orientation=quaternion(pose.theta))


def covariance_6x6(cov: Any) -> FloatArray:
    """The 36 row-major values of a pose covariance from a planar one (cm^2, cm rad, rad^2)."""
    c = np.asarray(cov, dtype=float).reshape(3, 3)
    scale = np.array([0.01, 0.01, 1.0])
    out = np.zeros((6, 6))
    ix = np.array([0, 1, 5])
    out[np.ix_(ix, ix)] = c * np.outer(scale, scale)
    return out.ravel()


def pose_with_covariance(ns: int, frame: str, pose: Pose, cov: Any) -> Any:
    """``geometry_msgs/PoseWithCovarianceStamped``."""
    inner = _t("geometry_msgs/msg/PoseWithCovariance")(pose=pose_msg(pose), covariance=covariance_6x6(cov))
    return _t("geometry_msgs/msg/PoseWithCovarianceStamped")(header=header(ns, frame), pose=inner)


def odometry(ns: int, pose: Pose) -> Any:
    """``nav_msgs/Odometry`` of the body in the odometry frame (no covariance, no twist recorded)."""
    zero6 = np.zeros(36)
    vec = _t("geometry_msgs/msg/Vector3")
    twist = _t("geometry_msgs/msg/Twist")(linear=vec(x=0.0, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0))
    return _t("nav_msgs/msg/Odometry")(
        header=header(ns, FRAMES["odom"]), child_frame_id=FRAMES["base"],
        pose=_t("geometry_msgs/msg/PoseWithCovariance")(pose=pose_msg(pose), covariance=zero6),
        twist=_t("geometry_msgs/msg/TwistWithCovariance")(twist=twist, covariance=zero6))


def transform(ns: int, parent: str, child: str, pose: Pose) -> Any:
    """``geometry_msgs/TransformStamped``: `child` at `pose` (cm, rad) in `parent`."""
    tr = _t("geometry_msgs/msg/Vector3")(x=pose.x / 100.0, y=pose.y / 100.0, z=0.0)
    return _t("geometry_msgs/msg/TransformStamped")(
        header=header(ns, parent), child_frame_id=child,
        transform=_t("geometry_msgs/msg/Transform")(translation=tr, rotation=quaternion(pose.theta)))


def tf_message(transforms: list[Any]) -> Any:
    return _t("tf2_msgs/msg/TFMessage")(transforms=transforms)


def occupancy_grid(ns: int, grid: OccupancyGrid) -> Any:
    """``nav_msgs/OccupancyGrid`` in the map frame."""
    h, w = grid.cells.shape
    origin = pose_msg(Pose(grid.origin_cm[0], grid.origin_cm[1], 0.0))
    info = _t("nav_msgs/msg/MapMetaData")(map_load_time=stamp(ns), resolution=grid.resolution_cm / 100.0,
                                          width=w, height=h, origin=origin)
    return _t("nav_msgs/msg/OccupancyGrid")(header=header(ns, FRAMES["map"]), info=info,
                                            data=np.ascontiguousarray(grid.cells.reshape(-1), dtype=np.int8))


def path_msg(ns: int, path: Any) -> Any:
    """``nav_msgs/Path`` in the map frame; each pose faces along its segment (the last along the one before)."""
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    d = np.diff(p, axis=0)
    yaw = np.arctan2(d[:, 1], d[:, 0]) if len(d) else np.zeros(0)
    yaw = np.append(yaw, yaw[-1] if yaw.size else 0.0)
    stamped = _t("geometry_msgs/msg/PoseStamped")
    poses = [stamped(header=header(ns, FRAMES["map"]), pose=pose_msg(Pose(float(x), float(y), float(a))))
             for (x, y), a in zip(p, yaw, strict=True)]
    return _t("nav_msgs/msg/Path")(header=header(ns, FRAMES["map"]), poses=poses)


def particle_cloud(ns: int, poses: Any, weights: Any) -> Any:
    """``nav2_msgs/ParticleCloud`` in the map frame."""
    particle = _t(PARTICLE)
    items = [particle(pose=pose_msg(Pose(float(x), float(y), float(th))), weight=float(w))
             for (x, y, th), w in zip(np.asarray(poses, dtype=float).reshape(-1, 3), np.asarray(weights, dtype=float),
                                      strict=True)]
    return _t(PARTICLE_CLOUD)(header=header(ns, FRAMES["map"]), particles=items)


def _slots(angles: FloatArray, where: str) -> tuple[float, float, NDArray[np.int64], float]:
    """angle_min, increment, each reading's slot k (angle = angle_min + k increment) and how far the
    furthest reading lies from its slot (rad).

    Angles that turn one way only once unwrapped (a wrap from +pi to -pi) are unwrapped. A sweep on a
    regular grid keeps its angles to `ANGLE_TOLERANCE_RAD`; one off any grid (deskewed) goes on the
    coarsest grid of its smallest step divided by 2 ... `MAX_SUBDIVISION` that holds every reading
    within `SNAP_TOLERANCE_RAD`, the slots between them NaN.
    """
    if angles.size == 1:
        return float(angles[0]), 0.0, np.zeros(1, dtype=np.int64), 0.0
    d = np.diff(angles)
    if not (np.all(d > 0) or np.all(d < 0)):  # perhaps a wrap from +pi to -pi
        angles = np.unwrap(angles)
        d = np.diff(angles)
    if not (np.all(d > 0) or np.all(d < 0)):
        raise ExportError(f"{where}: its angles neither only grow nor only shrink; a LaserScan cannot hold them")
    step = float(d[np.argmin(np.abs(d))])
    off = np.inf
    for parts in range(1, MAX_SUBDIVISION + 1):
        inc = step / parts
        k = np.rint((angles - angles[0]) / inc).astype(np.int64)
        off = float(np.abs(angles - (angles[0] + k * inc)).max())
        if off <= (ANGLE_TOLERANCE_RAD if parts == 1 else SNAP_TOLERANCE_RAD) and k[-1] <= 100 * parts * angles.size:
            return float(angles[0]), inc, k, off
    raise ExportError(f"{where}: its angles are not on a regular grid (on the finest tried, a reading lies {off:.2g} "
                      f"rad from its slot); a LaserScan cannot hold them")


def laser_scan(ns: int, scan: Scan, times: FloatArray, duration_s: float, offset_cm: float, range_min_cm: float,
               range_max_cm: float, where: str) -> tuple[Any, float]:
    """``sensor_msgs/LaserScan`` of one sweep in the sonar frame.

    The readings sit in slots ``angle_min + k * angle_increment``: a sweep with windows (readings
    only near some directions) leaves the slots between them at NaN (no reading taken); a range is
    the reading plus the sensor's offset from the turret axis, in metres. ``range_min`` and
    ``range_max`` are the sensor's limits `range_min_cm` and `range_max_cm` (measured from the sensor)
    moved by the same offset, and every finite range lies within them (REP 117): a reading without an
    echo, or beyond the limit, is +inf; an echo closer than the sensor can measure (the NXT's readings
    under its ``min_range_cm`` are noise) is -inf. `ns` is the time of the first reading;
    ``time_increment`` the median time between readings in neighbouring slots; ``scan_time`` the
    sweep's whole duration. Returns the message and how far a reading was moved to its slot (rad; `_slots`).
    """
    angles = np.asarray(scan.angles, dtype=float)
    a0, inc, k, moved = _slots(angles, where)
    slots = np.full(int(k[-1]) + 1, np.nan)
    slots[k] = rep117_ranges(scan, offset_cm, range_min_cm, range_max_cm)
    t = np.asarray(times, dtype=float)
    dk = np.diff(k)
    # time per slot: from readings in neighbouring slots, or (a subdivided grid has none) from all of them
    pairs = dk == 1 if np.any(dk == 1) else dk > 0
    dt = float(np.median(np.diff(t)[pairs] / dk[pairs])) if pairs.any() else 0.0
    message = _t("sensor_msgs/msg/LaserScan")(
        header=header(ns, FRAMES["sonar"]), angle_min=a0, angle_max=a0 + float(k[-1]) * inc, angle_increment=inc,
        time_increment=dt, scan_time=float(duration_s), range_min=(range_min_cm + offset_cm) / 100.0,
        range_max=(range_max_cm + offset_cm) / 100.0, ranges=slots.astype(np.float32),
        intensities=np.zeros(0, dtype=np.float32))
    return message, moved


def rep117_ranges(scan: Scan, offset_cm: float, range_min_cm: float, range_max_cm: float) -> FloatArray:
    """A sweep's ranges (m) as a LaserScan holds them (REP 117): a finite value only for an echo
    within [`range_min_cm`, `range_max_cm`] of the sensor (cm), -inf for one closer, +inf for no echo
    or one beyond; measured from the turret axis (the reading plus `offset_cm`). Rounding to the
    message's float32 keeps order, so a range within the limits stays within the float32 limits.

    >>> from toolkit.world import Scan
    >>> s = Scan(np.zeros(4), np.array([3.0, 40.0, 300.0, np.inf]), np.array([True, True, True, False]))
    >>> rep117_ranges(s, 0.0, 6.0, 255.0).tolist()
    [-inf, 0.4, inf, inf]
    """
    r = np.asarray(scan.ranges, dtype=float)
    echo = np.asarray(scan.valid, dtype=bool) & np.isfinite(r)
    with np.errstate(invalid="ignore"):
        close = echo & (r < range_min_cm)
        far = echo & (r > range_max_cm)
    out = np.where(echo, (r + offset_cm) / 100.0, np.inf)
    out[close] = -np.inf
    out[far] = np.inf
    return out


def map_extent_cm(m: Map) -> float:
    """The longest distance inside the map's bounds (cm): no reading in it is longer."""
    xmin, ymin, xmax, ymax = m.bounds
    return math.hypot(xmax - xmin, ymax - ymin)
