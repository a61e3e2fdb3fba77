"""`nxtnav export REC --mcap DIR`: a recording as a ROS 2 bag, read back by two independent readers.

The bag is read with rosbags' reader (its messages decoded with the definitions the bag itself
carries) and with the `mcap` package's reader and its ROS 2 decoder; the scans, poses and clouds
must equal the recording's to the precision of the message fields (float32 in a LaserScan, float64
elsewhere). Bad input: one line, exit code 2, nothing written or overwritten.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from conftest import built_once, run_cli

from toolkit.recordings.recorder import decode_floats, scan_from_fields
from toolkit.recordings.replay import read_recording
from toolkit.robots.sim import RobotTiming
from toolkit.world import angle_diff

TOPICS = {"/map", "/tf", "/tf_static", "/odom", "/scan", "/amcl_pose", "/particle_cloud", "/plan", "/ground_truth"}
F32 = float(np.finfo(np.float32).eps)


def _mission(out: Path) -> None:
    assert run_cli(["run", "--map", "map1", "--record", str(out / "m1.jsonl")]) == 0


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return built_once(tmp_path_factory, "map1-mission-recording", _mission) / "m1.jsonl"


@pytest.fixture(scope="module")
def bag(recording: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("export") / "bag"
    assert run_cli(["export", str(recording), "--mcap", str(out)]) == 0
    return out


def _rosbags_messages(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message by topic, decoded by rosbags with the message definitions stored in the bag."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    out: dict[str, list[tuple[int, Any]]] = {}
    with Reader(bag) as reader:
        types: dict[str, Any] = {}
        for c in reader.connections:
            types.update(get_types_from_msg(c.msgdef.data, c.msgtype))
        store.register(types)
        for c, ns, raw in reader.messages():
            out.setdefault(c.topic, []).append((ns, store.deserialize_cdr(raw, c.msgtype)))
    return out


def _mcap_messages(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message by topic, decoded by the mcap package's ROS 2 decoder."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (file,) = bag.glob("*.mcap")
    out: dict[str, list[tuple[int, Any]]] = {}
    with file.open("rb") as fh:
        for _, channel, message, decoded in make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                log_time_order=True):
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


@pytest.fixture(scope="module")
def both(bag: Path) -> list[dict[str, list[tuple[int, Any]]]]:
    return [_rosbags_messages(bag), _mcap_messages(bag)]


def _events(recording: Path, kind: str) -> list[dict[str, Any]]:
    return [e for _, e in read_recording(recording).events if e["type"] == kind]


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _stamp(h: Any) -> int:
    return int(h.stamp.sec) * 1_000_000_000 + int(h.stamp.nanosec)


def test_export_of_a_mission_lists_the_nav2_topics(bag: Path) -> None:
    from rosbags.rosbag2 import Reader

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["storage_identifier"] == "mcap" and meta["relative_file_paths"] == ["bag.mcap"]
    with Reader(bag) as reader:
        assert set(reader.topics) == TOPICS and reader.message_count == meta["message_count"]
        assert {c.ext.serialization_format for c in reader.connections} == {"cdr"}
        assert reader.topics["/particle_cloud"].msgtype == "nav2_msgs/msg/ParticleCloud"
        assert reader.topics["/scan"].msgtype == "sensor_msgs/msg/LaserScan"


def test_scans_equal_the_recording(recording: Path, both: list[dict[str, list[tuple[int, Any]]]]) -> None:
    scans = _events(recording, "scan")
    timing = RobotTiming()
    for topics in both:
        msgs = [m for _, m in topics["/scan"]]
        assert len(msgs) == len(scans)
        for e, msg in zip(scans, msgs, strict=True):
            scan = scan_from_fields(e)
            ranges = np.asarray(msg.ranges, dtype=np.float64)
            taken = ~np.isnan(ranges)  # slots between a sweep's windows hold no reading
            assert taken.sum() == len(scan)
            k = np.flatnonzero(taken)
            angles = np.float64(msg.angle_min) + k * np.float64(msg.angle_increment)
            assert np.allclose(angles, scan.angles, rtol=0, atol=4 * F32 * (1 + k.max()) * 2 * math.pi)
            got = ranges[taken]
            assert np.array_equal(np.isinf(got), ~scan.valid)  # no echo: +inf (REP 117)
            assert np.allclose(got[scan.valid] * 100.0, scan.ranges[scan.valid], rtol=2 * F32, atol=0)
            assert msg.header.frame_id == "sonar_link"
            # the simulator's time model: one reading time plus the turret's travel between neighbours
            step_deg = abs(math.degrees(float(np.float64(msg.angle_increment))))
            assert msg.time_increment == pytest.approx(timing.reading_s + step_deg / timing.turret_rate_deg_s,
                                                       rel=4 * F32)
            assert msg.scan_time == pytest.approx(e["t"] - e["t_start"], rel=4 * F32)
            first = decode_floats(e["times_s"]).min()
            assert _stamp(msg.header) - _stamp(topics["/map"][0][1].header) == round(first * 1e9)


def test_estimates_and_clouds_equal_the_recording(recording: Path,
                                                  both: list[dict[str, list[tuple[int, Any]]]]) -> None:
    estimates = _events(recording, "estimate")
    for topics in both:
        poses = [m for _, m in topics["/amcl_pose"]]
        clouds = [m for _, m in topics["/particle_cloud"]]
        assert len(poses) == len(estimates) == len(clouds)
        for e, msg, cloud in zip(estimates, poses, clouds, strict=True):
            x, y, th = e["pose"]
            p = msg.pose.pose
            assert (p.position.x * 100.0, p.position.y * 100.0) == pytest.approx((x, y), rel=1e-15, abs=1e-12)
            assert abs(float(angle_diff(_yaw(p.orientation), th))) < 1e-12
            cov = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)
            want = np.vstack([decode_floats(r) for r in e["cov"]])
            got = cov[np.ix_([0, 1, 5], [0, 1, 5])] * np.outer([1e2, 1e2, 1.0], [1e2, 1e2, 1.0])
            assert np.allclose(got, want, rtol=1e-14, atol=0)
            assert msg.header.frame_id == "map"
            rec = e["particles"]
            assert len(cloud.particles) == len(rec["poses"]) <= 100 < rec["n"]
            xs = np.array([[q.pose.position.x * 100.0, q.pose.position.y * 100.0] for q in cloud.particles])
            assert np.allclose(xs, np.array(rec["poses"], dtype=float)[:, :2], rtol=1e-15, atol=1e-12)
            w = np.array([q.weight for q in cloud.particles])
            assert np.array_equal(w, decode_floats(rec["weights"])) and w.sum() == pytest.approx(1.0)


def _expected_truth_and_odometry(recording: Path) -> tuple[list[tuple[float, Any]], list[tuple[float, Any]]]:
    """(robot time s, pose) of every true pose and odometry pose the export publishes, in time order.

    Truth: after each robot event, and a sweep's also at its first reading (the robot stands while it
    sweeps). Odometry: the motions the localiser was told, added up (turn, then drive) from the
    origin, after each, and the pose of the moment at each sweep's first and last reading."""
    truths: list[tuple[float, Any]] = []
    odometry: list[tuple[float, Any]] = []
    t = x = y = th = 0.0
    for _, e in read_recording(recording).events:
        if e["type"] in ("turn", "move", "turnback"):
            t = e["t"]
            if e.get("true_pose") is not None:
                truths.append((t, e["true_pose"]))
        elif e["type"] == "scan":
            times = decode_floats(e["times_s"])
            first, last = float(times.min()), float(times.max())
            for when in sorted({first, last}):
                odometry.append((when, (x, y, th)))
            if e.get("true_pose") is not None:
                truths += [(first, e["true_pose"]), (e["t"], e["true_pose"])]
            t = e["t"]
        elif e["type"] == "predict":
            th += e["turn_rad"]
            x, y = x + e["distance_cm"] * math.cos(th), y + e["distance_cm"] * math.sin(th)
            odometry.append((t, (x, y, th)))
    return sorted(truths, key=lambda p: p[0]), sorted(odometry, key=lambda p: p[0])


def test_truth_plan_and_odometry_equal_the_recording(recording: Path,
                                                     both: list[dict[str, list[tuple[int, Any]]]]) -> None:
    truths, odometry = _expected_truth_and_odometry(recording)
    plans = _events(recording, "plan")
    assert len(odometry) == len(_events(recording, "predict")) + 2 * len(_events(recording, "scan"))
    for topics in both:
        start = topics["/map"][0][0]
        got = topics["/ground_truth"]
        assert len(got) == len(truths)
        for (when, (x, y, th)), (ns, m) in zip(truths, got, strict=True):
            p = m.pose.pose
            assert ns - start == round(when * 1e9)
            assert (p.position.x * 100.0, p.position.y * 100.0) == pytest.approx((x, y), rel=1e-15, abs=1e-12)
            assert abs(float(angle_diff(_yaw(p.orientation), th))) < 1e-12
        paths = [m for _, m in topics["/plan"]]
        assert len(paths) == len(plans) >= 1
        for e, path in zip(plans, paths, strict=True):
            xy = np.array([[q.pose.position.x * 100.0, q.pose.position.y * 100.0] for q in path.poses])
            assert np.allclose(xy, np.array(e["path"], dtype=float), rtol=1e-15, atol=1e-12)
        odo = topics["/odom"]
        assert len(odo) == len(odometry)
        for (when, (x, y, th)), (ns, m) in zip(odometry, odo, strict=True):
            p = m.pose.pose
            assert ns - start == round(when * 1e9)
            assert (p.position.x * 100.0, p.position.y * 100.0) == pytest.approx((x, y), abs=1e-9)
            assert abs(float(angle_diff(_yaw(p.orientation), th))) < 1e-9
            assert (m.header.frame_id, m.child_frame_id) == ("odom", "base_link")


def test_tf_chains_map_odom_base_to_the_estimate(both: list[dict[str, list[tuple[int, Any]]]]) -> None:
    """map -> odom composed with the latest odom -> base_link is the estimate of the same moment."""
    for topics in both:
        static = [t for _, m in topics["/tf_static"] for t in m.transforms]
        assert [(t.header.frame_id, t.child_frame_id) for t in static] == [("base_link", "sonar_link")]
        odom = None
        estimates = iter(m for _, m in topics["/amcl_pose"])
        checked = 0
        for _, m in topics["/tf"]:
            for t in m.transforms:
                q, v = t.transform.rotation, t.transform.translation
                if (t.header.frame_id, t.child_frame_id) == ("odom", "base_link"):
                    odom = (v.x, v.y, _yaw(q))
                    continue
                assert (t.header.frame_id, t.child_frame_id) == ("map", "odom") and odom is not None
                a = _yaw(q)
                x = v.x + math.cos(a) * odom[0] - math.sin(a) * odom[1]
                y = v.y + math.sin(a) * odom[0] + math.cos(a) * odom[1]
                est = next(estimates).pose.pose
                assert (x, y) == pytest.approx((est.position.x, est.position.y), abs=1e-12)
                assert abs(float(angle_diff(a + odom[2], _yaw(est.orientation)))) < 1e-9
                checked += 1
        assert checked > 10


def test_map_grid_matches_the_map(recording: Path, both: list[dict[str, list[tuple[int, Any]]]]) -> None:
    m = read_recording(recording).map
    for topics in both:
        (_, grid), = topics["/map"]
        res, w, h = grid.info.resolution * 100.0, grid.info.width, grid.info.height
        assert res == pytest.approx(1.0)
        cells = np.asarray(grid.data, dtype=np.int8).reshape(h, w)
        ox, oy = grid.info.origin.position.x * 100.0, grid.info.origin.position.y * 100.0
        cx, cy = np.meshgrid(ox + (np.arange(w) + 0.5) * res, oy + (np.arange(h) + 0.5) * res)
        centres = np.column_stack([cx.ravel(), cy.ravel()])
        d = np.asarray(m.wall_distance(centres)).reshape(h, w)
        inside = np.asarray(m.contains(centres)).reshape(h, w)
        assert set(np.unique(cells).tolist()) == {-1, 0, 100}
        tol = 1e-4  # cm: the grid's resolution is a float32 in the message
        assert np.all(d[cells == 100] <= res * math.sqrt(0.5) + tol)  # a wall meets every occupied cell
        assert np.all(cells[d > res * math.sqrt(0.5) + tol] != 100)
        assert np.all(inside[cells == 0]) and np.all(cells[inside & (d > res)] == 0)
        assert np.all(cells[~inside & (d > res)] == -1)


def test_particles_option_thins_each_cloud(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "thin"
    assert run_cli(["export", str(recording), "--mcap", str(out), "--particles", "7", "--grid-cm", "2"]) == 0
    topics = _rosbags_messages(out)
    assert all(len(m.particles) == 7 for _, m in topics["/particle_cloud"])
    assert all(sum(p.weight for p in m.particles) == pytest.approx(1.0) for _, m in topics["/particle_cloud"])
    assert topics["/map"][0][1].info.resolution == pytest.approx(0.02)


def test_an_empty_folder_is_filled(recording: Path, tmp_path: Path) -> None:
    out = tmp_path / "empty"
    out.mkdir()
    assert run_cli(["export", str(recording), "--mcap", str(out)]) == 0
    assert (out / "metadata.yaml").is_file() and [p.name for p in out.glob("*.mcap")] == ["empty.mcap"]
    assert [p.name for p in tmp_path.iterdir()] == ["empty"]  # no temporary folder left beside it


def test_a_non_empty_folder_is_refused_and_kept(recording: Path, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "taken"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert run_cli(["export", str(recording), "--mcap", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(out) in err and "not empty" in err
    assert [p.name for p in out.iterdir()] == ["notes.txt"] and (out / "notes.txt").read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


@pytest.mark.parametrize(("content", "needle"), [
    ("not json\n", "line 1: not valid JSON"),
    ('{"type":"header","format":"nxtnav-recording","version":99}\n', "format version 99 is not supported"),
])
def test_a_bad_recording_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str,
                                    needle: str) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text(content)
    assert run_cli(["export", str(bad), "--mcap", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and needle in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.jsonl"]


def test_a_deskewed_laser_recording_exports(tmp_path: Path) -> None:
    """An imported real bag's sweeps are deskewed: their angles wrap at +-pi and lie off any regular
    grid. Each still becomes a LaserScan, every reading in a slot within 1 mrad of its angle."""
    from toolkit.ros.bag_import import import_bag
    from toolkit.ros.export.messages import SNAP_TOLERANCE_RAD
    from toolkit.world import load_map

    jarvis = Path(__file__).resolve().parents[1] / "maps" / "jarvis"
    rec = tmp_path / "jarvis.jsonl"
    import_bag(jarvis / "jarvis_circular_path_fast.bag", load_map(jarvis / "i-108_10mm.yaml"), rec,
               scan_topic="/driver_laser_navigation/laser_scan", every=10, beams=120, scan_delay_s=0.125)
    out = tmp_path / "bag"
    assert run_cli(["export", str(rec), "--mcap", str(out)]) == 0
    scans = _events(rec, "scan")
    msgs = [m for _, m in _rosbags_messages(out)["/scan"]]
    assert len(msgs) == len(scans) > 10
    worst = 0.0
    for e, msg in zip(scans, msgs, strict=True):
        scan = scan_from_fields(e)
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        k = np.flatnonzero(~np.isnan(ranges))
        assert k.size == len(scan)
        angles = np.float64(msg.angle_min) + k * np.float64(msg.angle_increment)
        worst = max(worst, float(np.max(np.abs(angle_diff(angles, scan.angles)))))
        assert np.allclose(ranges[k][scan.valid] * 100.0, scan.ranges[scan.valid], rtol=2 * F32, atol=0)
    assert 1e-6 < worst <= SNAP_TOLERANCE_RAD + 1e-6
