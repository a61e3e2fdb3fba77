"""Read back a bag that `export_mcap` wrote, as time-line items (for `nxtnav view DIR`).

The map, robot and sonar come from the metadata's ``custom_data`` (`HEADER_KEY`); the messages
are turned back into the toolkit's units (cm, rad, robot seconds since the ``/map`` stamp).
"""

from __future__ import annotations

import json
import math
from collections import defaultdict, deque
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import PoseEstimate

from ...recordings.timeline import EstimateItem, Item, OdometryItem, PlanItem, RunInfo, SweepItem, TruthItem, run_info
from ...world import Pose, Scan
from ...world.yaml_text import YAMLError, load_yaml
from .messages import ExportError, yaw_of
from .typestore import typestore
from .writer import HEADER_KEY

__all__ = ["timeline_of_bag"]


def _header(folder: Path) -> dict[str, Any]:
    meta = folder / "metadata.yaml"
    try:
        doc = load_yaml(meta.read_text(encoding="utf-8"))
        text = doc["rosbag2_bagfile_information"]["custom_data"][HEADER_KEY]
        header = json.loads(text)
    except OSError as exc:
        raise ExportError(f"{folder}: not a rosbag2 folder ({meta.name}: {exc.strerror or exc})") from None
    except (YAMLError, KeyError, TypeError, json.JSONDecodeError):
        raise ExportError(f"{folder}: not a bag written by nxtnav export ({meta.name} has no custom_data "
                          f"'{HEADER_KEY}')") from None
    return {"type": "header", **header}


def _pose(p: Any) -> Pose:
    return Pose(p.position.x * 100.0, p.position.y * 100.0, yaw_of(p.orientation))


def _cov(c: Any) -> np.ndarray:
    six = np.asarray(c, dtype=float).reshape(6, 6)
    ix = [0, 1, 5]
    return six[np.ix_(ix, ix)] * np.outer([100.0, 100.0, 1.0], [100.0, 100.0, 1.0])


def _stamp(h: Any) -> int:
    return int(h.stamp.sec) * 1_000_000_000 + int(h.stamp.nanosec)


def _scan(msg: Any, offset_cm: float) -> tuple[Scan, np.ndarray]:
    ranges = np.asarray(msg.ranges, dtype=float)
    k = np.flatnonzero(~np.isnan(ranges))
    angles = np.asarray(float(msg.angle_min) + k * float(msg.angle_increment), dtype=np.float64)
    got = ranges[k]
    valid = np.isfinite(got)
    cm = np.where(valid, got * 100.0 - offset_cm, np.inf)
    return Scan(angles, cm, valid), k


def timeline_of_bag(folder: str | Path) -> tuple[RunInfo, list[Item]]:
    """The `RunInfo` and items of a bag written by `export_mcap` (see the module docstring)."""
    from rosbags.rosbag2 import Reader
    from rosbags.rosbag2.errors import ReaderError

    path = Path(folder)
    info = run_info(_header(path))
    store = typestore()
    msgs: list[tuple[str, int, Any]] = []
    try:
        with Reader(path) as reader:
            for c, ns, raw in reader.messages():
                msgs.append((c.topic, ns, store.deserialize_cdr(raw, c.msgtype)))
    except ReaderError as exc:
        raise ExportError(f"{path}: cannot read the bag ({exc})") from None
    start = next((_stamp(m.header) for t, _, m in msgs if t == "/map"), info.start_ns)
    clouds: dict[int, deque[Any]] = defaultdict(deque)
    for topic, _, m in msgs:
        if topic == "/particle_cloud":
            clouds[_stamp(m.header)].append(m)
    odom = Pose(0.0, 0.0, 0.0)
    items: list[Item] = []
    for topic, ns, m in msgs:
        t = (ns - start) / 1e9
        if topic == "/ground_truth":
            known = math.isfinite(float(m.pose.covariance[35]))
            items.append(TruthItem(t, _pose(m.pose.pose), known))
        elif topic == "/odom":
            odom = _pose(m.pose.pose)
            items.append(OdometryItem(t, odom))
        elif topic == "/scan":
            scan, k = _scan(m, info.sensor_offset_cm)
            first = (_stamp(m.header) - start) / 1e9
            times = first + (k - k.min()) * float(m.time_increment)
            items.append(SweepItem(t, t - float(m.scan_time), times, scan, len(items), None, False, None))
        elif topic == "/amcl_pose":
            est = PoseEstimate(_pose(m.pose.pose), _cov(m.pose.covariance), False)
            queue = clouds.get(_stamp(m.header))
            cloud = queue.popleft() if queue else None
            if cloud is None:
                items.append(EstimateItem(t, est, odom, None, None, 0))
            else:
                poses = np.array([[*_pose(q.pose).xy, _pose(q.pose).theta] for q in cloud.particles]).reshape(-1, 3)
                weights = np.array([q.weight for q in cloud.particles], dtype=float)
                items.append(EstimateItem(t, est, odom, poses, weights, len(weights)))
        elif topic == "/plan":
            items.append(PlanItem(t, np.array([[q.pose.position.x * 100.0, q.pose.position.y * 100.0]
                                               for q in m.poses])))
    return info, items
