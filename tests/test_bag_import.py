"""`nxtnav import bag`: a ROS 1 bag written here with rosbags' writer, and the real Jarvis bag."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from localisation.base import Prior
from toolkit.cli import main
from toolkit.recordings.replay import read_recording, replay
from toolkit.ros.bag_import import import_bag, odometry_motions
from toolkit.world import LaserScanner, Pose, load_map

TS = get_typestore(Stores.ROS1_NOETIC)
TS.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
T = TS.types
LASER_X_M = 0.05  # the laser sits 5 cm ahead of the base
START_NS = 1_700_000_000_000_000_000
N_SCANS = 12
BEAMS = 90
JARVIS = Path(__file__).resolve().parents[1] / "maps" / "jarvis"


def _header(stamp_ns: int, frame: str) -> object:
    sec, nsec = divmod(stamp_ns, 1_000_000_000)
    return T["std_msgs/msg/Header"](seq=0, stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                    frame_id=frame)


def _quat(yaw: float) -> object:
    return T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _tf(stamp: int, parent: str, child: str, x: float, y: float, yaw: float) -> object:
    tr = T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0),
                                          rotation=_quat(yaw))
    return T["geometry_msgs/msg/TransformStamped"](header=_header(stamp, parent), child_frame_id=child, transform=tr)


def _true_pose(t_s: float) -> tuple[float, float, float]:
    """The robot's path (m, rad): up map1's left room, weaving, while turning slowly."""
    return 0.20 + 0.05 * math.sin(t_s), 0.20 + 0.10 * t_s, math.pi / 2 + 0.05 * t_s


def write_bag(path: Path, odom_offset: tuple[float, float, float] = (0.3, -0.2, 0.4)) -> None:
    """A bag of `N_SCANS` laser scans on map1 simulated from the true path (no noise), odometry on /tf in
    a frame offset from the map by `odom_offset`, and the true poses on /truth."""
    world = load_map("map1")
    laser = LaserScanner(noise_sd=0.0, min_range_cm=1.0, max_range_cm=500.0)
    angles = np.linspace(-math.pi, math.pi, BEAMS, endpoint=False)
    ox, oy, oth = odom_offset
    with Writer(path) as w:
        c_scan = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=TS)
        c_tf = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=TS)
        c_truth = w.add_connection("/truth", "geometry_msgs/msg/PoseStamped", typestore=TS)
        c_vel = w.add_connection("/cmd_vel", "geometry_msgs/msg/Twist", typestore=TS)
        for k in range(0, 10 * N_SCANS + 10):  # odometry at 20 Hz, from before the first scan to after the last
            t_ns = START_NS + k * 50_000_000
            x, y, th = _true_pose(k * 0.05)
            # odom -> base: the true pose seen from a frame at odom_offset in the map
            c, s = math.cos(-oth), math.sin(-oth)
            dx, dy = x - ox, y - oy
            odo = (c * dx - s * dy, s * dx + c * dy, th - oth)
            msg = T["tf2_msgs/msg/TFMessage"](transforms=[_tf(t_ns, "odom", "base_link", *odo),
                                                         _tf(t_ns, "base_link", "laser", LASER_X_M, 0.0, 0.0)])
            w.write(c_tf, t_ns, TS.serialize_ros1(msg, "tf2_msgs/msg/TFMessage"))
            if k % 10 == 5 and k // 10 < N_SCANS:  # scans at 2 Hz, taken in an instant (time_increment 0)
                sensor = np.array([x * 100 + LASER_X_M * 100 * math.cos(th), y * 100 + LASER_X_M * 100 * math.sin(th)])
                r = laser.measure(world.walls, sensor, th + angles, rng=0) / 100.0
                scan = T["sensor_msgs/msg/LaserScan"](
                    header=_header(t_ns, "laser"), angle_min=float(angles[0]), angle_max=float(angles[-1]),
                    angle_increment=float(angles[1] - angles[0]), time_increment=0.0, scan_time=0.5,
                    range_min=0.01, range_max=5.0, ranges=np.asarray(r, dtype=np.float32),
                    intensities=np.zeros(0, dtype=np.float32))
                w.write(c_scan, t_ns, TS.serialize_ros1(scan, "sensor_msgs/msg/LaserScan"))
                pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
                                                   orientation=_quat(th))
                truth = T["geometry_msgs/msg/PoseStamped"](header=_header(t_ns, "map"), pose=pose)
                w.write(c_truth, t_ns, TS.serialize_ros1(truth, "geometry_msgs/msg/PoseStamped"))
                vel = T["geometry_msgs/msg/Twist"](linear=T["geometry_msgs/msg/Vector3"](x=0.1, y=0.0, z=0.0),
                                                   angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.05))
                w.write(c_vel, t_ns, TS.serialize_ros1(vel, "geometry_msgs/msg/Twist"))


@pytest.fixture(scope="module")
def small_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("bag") / "small.bag"
    write_bag(path)
    return path


def _import(bag: Path, out: Path, **kw: object) -> object:
    return import_bag(bag, load_map("map1"), out, scan_topic="/scan", base_frame="base_link", truth_topic="/truth",
                      range_noise_cm=0.5, **kw)  # type: ignore[arg-type]


def test_import_writes_scans_motions_and_truth(small_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "rec.jsonl"
    result = _import(small_bag, out)
    assert result.scans == N_SCANS and result.skipped == 0 and result.truths == N_SCANS  # type: ignore[attr-defined]
    rec = read_recording(out)
    params = rec.header["sonar"]["params"]  # the message's limits (float32 in the bag), the noise asked for
    assert params["name"] == "laser" and params["noise_sd"] == 0.5
    assert (params["min_range_cm"], params["max_range_cm"]) == pytest.approx((1.0, 500.0), rel=1e-6)
    scans = [e for _, e in rec.events if e["type"] == "scan"]
    for k, e in enumerate(scans):  # the true poses are the bag's, in cm, at each scan's stamp
        x, y, th = _true_pose(0.25 + 0.5 * k)
        assert e["true_pose"] == pytest.approx([x * 100, y * 100, th], abs=1e-6)
        assert e["t_start"] == pytest.approx(0.5 * k, abs=1e-9)


def test_truth_offset_moves_the_truth_to_the_base(small_bag: Path, tmp_path: Path) -> None:
    """A truth that tracks a marker 5 cm ahead, 3 cm to the right of the base and turned by 10 degrees:
    with that offset, each true pose written is the marker's pose composed with it, the base's."""
    out = tmp_path / "rec.jsonl"
    _import(small_bag, out, truth_offset=(5.0, -3.0, math.radians(10.0)))
    rec = read_recording(out)
    assert rec.header["source"]["truth_offset"] == pytest.approx([5.0, -3.0, 10.0])
    scans = [e for _, e in rec.events if e["type"] == "scan"]
    for k, e in enumerate(scans):
        x, y, th = _true_pose(0.25 + 0.5 * k)
        c, s = math.cos(th), math.sin(th)
        want = [x * 100 + 5.0 * c + 3.0 * s, y * 100 + 5.0 * s - 3.0 * c, th + math.radians(10.0)]
        assert e["true_pose"] == pytest.approx(want, abs=1e-6)


def test_readings_in_the_base_frame_end_on_the_walls(small_bag: Path, tmp_path: Path) -> None:
    """The scans were cast from the laser 5 cm ahead of the base: re-expressed in the base frame and put at
    the true pose, every echo ends on a wall of the map."""
    out = tmp_path / "rec.jsonl"
    _import(small_bag, out)
    rec = read_recording(out)
    world = rec.map
    from toolkit.recordings.recorder import scan_from_fields

    for _, e in rec.events:
        if e["type"] != "scan":
            continue
        scan = scan_from_fields(e)
        x, y, th = e["true_pose"]
        a, r = th + scan.angles[scan.valid], scan.ranges[scan.valid]
        ends = np.column_stack([x + r * np.cos(a), y + r * np.sin(a)])
        assert scan.valid.sum() > 0.9 * BEAMS
        assert np.max(world.wall_distance(ends)) < 1e-3


def test_motions_compose_to_the_odometry(small_bag: Path, tmp_path: Path) -> None:
    """The predict calls between two scans, applied to the first true pose, give the second one (the
    odometry frame's offset from the map does not matter)."""
    out = tmp_path / "rec.jsonl"
    _import(small_bag, out)
    rec = read_recording(out)
    pose = None
    for _, e in rec.events:
        if e["type"] == "scan":
            if pose is not None:
                assert pose == pytest.approx([*e["true_pose"][:2], pose[2]], abs=1e-6)
                assert math.remainder(pose[2] - e["true_pose"][2], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
            pose = list(e["true_pose"])
        elif e["type"] == "predict" and pose is not None:
            pose[2] += e["turn_rad"]
            pose[0] += e["distance_cm"] * math.cos(pose[2])
            pose[1] += e["distance_cm"] * math.sin(pose[2])


def test_odometry_motions_compose_back() -> None:
    rng = np.random.default_rng(3)
    for delta in rng.normal(0, [10, 10, 1], size=(50, 3)):
        x = y = th = 0.0
        for turn, dist in odometry_motions(delta):
            th += turn
            x, y = x + dist * math.cos(th), y + dist * math.sin(th)
        assert (x, y) == pytest.approx((delta[0], delta[1]), abs=1e-9)
        assert math.remainder(th - delta[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
        assert all(abs(turn) <= math.pi / 2 + 1e-12 for turn, dist in odometry_motions(delta) if dist != 0)


def test_ekf_tracks_the_small_bag(small_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "rec.jsonl"
    _import(small_bag, out)
    rec = read_recording(out)
    x, y, th = _true_pose(0.25)
    start = Pose(x * 100 + 0.5, y * 100 - 0.5, th + 0.02)
    report = replay(rec, ["ekf"], initial=Prior(start, np.diag([4.0, 4.0, 0.001])))
    row = report.summary()["ekf"]
    assert not report.failures
    assert row["ape_rmse_cm"] < 0.5 and row["rmse_cm"] < 0.5
    assert row["cpu_s"] > 0


# -- bad input --------------------------------------------------------------------------------------

def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str]:
    with pytest.raises(SystemExit) as exc:
        main(["import", "bag", *args])
    err = capsys.readouterr().err.strip()
    return int(exc.value.code or 0), err


def test_missing_topic_lists_the_bags_topics(small_bag: Path, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "rec.jsonl"
    code, err = _cli(capsys, str(small_bag), "--map", "map1", "--scan-topic", "/lidar", "-o", str(out))
    assert code == 2 and len(err.splitlines()) == 1
    assert "'/lidar'" in err and "/scan (sensor_msgs/LaserScan)" in err and "/truth (geometry_msgs/PoseStamped)" in err
    assert not out.exists()


def test_a_topic_that_cannot_be_a_scan(small_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "rec.jsonl"
    code, err = _cli(capsys, str(small_bag), "--map", "map1", "--scan-topic", "/cmd_vel", "-o", str(out))
    assert code == 2 and len(err.splitlines()) == 1 and "geometry_msgs/Twist, which cannot be a scan" in err
    assert not out.exists()


@pytest.mark.parametrize("cut", [0.5, 0.05])
def test_truncated_bag(small_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], cut: float) -> None:
    data = small_bag.read_bytes()
    bad = tmp_path / "cut.bag"
    bad.write_bytes(data[: int(len(data) * cut)])
    out = tmp_path / "rec.jsonl"
    code, err = _cli(capsys, str(bad), "--map", "map1", "--scan-topic", "/scan", "-o", str(out))
    assert code == 2 and len(err.splitlines()) == 1 and "cannot read the bag" in err and str(bad) in err
    assert not out.exists() and list(tmp_path.iterdir()) == [bad]


def test_not_a_bag(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "notes.bag"
    bad.write_text("not a bag\n")
    code, err = _cli(capsys, str(bad), "--map", "map1", "--scan-topic", "/scan", "-o", str(tmp_path / "r.jsonl"))
    assert code == 2 and len(err.splitlines()) == 1 and "cannot read the bag" in err


def test_missing_tf_frame(small_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _cli(capsys, str(small_bag), "--map", "map1", "--scan-topic", "/scan", "--base-frame", "base_footprint",
                     "-o", str(tmp_path / "r.jsonl"))
    assert code == 2 and len(err.splitlines()) == 1 and "'base_footprint'" in err and "base_link" in err


# -- the real bag ---------------------------------------------------------------------------------

def _jarvis(out: Path, bag: str = "jarvis_circular_path_fast.bag", **kw: object) -> object:
    return import_bag(JARVIS / bag, load_map(JARVIS / "i-108_10mm.yaml"), out,
                      scan_topic="/driver_laser_navigation/laser_scan", truth_topic="/pose_ground_truth",
                      truth_frame=(1460.64, 334.25, math.radians(-1.536)), **kw)  # type: ignore[arg-type]


def test_jarvis_bag_imports(tmp_path: Path) -> None:
    out = tmp_path / "jarvis.jsonl"
    result = _jarvis(out, beams=120, scan_delay_s=0.125)
    # the first scan's first reading precedes the odometry; the second's, the first true pose
    assert (result.scans_in_bag, result.scans, result.truths) == (204, 203, 202)  # type: ignore[attr-defined]
    assert result.readings == 120 * result.scans  # type: ignore[attr-defined]
    assert 10.5 < result.odometry_m < 12.0  # type: ignore[attr-defined]
    rec = read_recording(out)
    assert rec.header["source"]["odometry"]["tf"] == "odom -> base_footprint"
    assert rec.header["sonar"]["params"]["max_range_cm"] == pytest.approx(25000.0)


@pytest.mark.slow
def test_jarvis_amcl_from_the_initial_pose(tmp_path: Path) -> None:
    """amcl with nav2's laser defaults tracks the real run from the authors' initial pose: within 3 cm and
    1 degree after rigid alignment (evo)."""
    out = tmp_path / "jarvis.jsonl"
    _jarvis(out, beams=120, scan_delay_s=0.125)
    prior = Prior(Pose.from_deg(1493.7, 607.9, 178.19), np.diag([100.0, 100.0, math.radians(5.0) ** 2]))
    report = replay(read_recording(out), ["amcl"], initial=prior)
    row = report.summary()["amcl"]
    assert row["ape_rmse_cm"] <= 3.0 and row["ape_heading_rmse_deg"] <= 1.0


@pytest.mark.slow
def test_jarvis_amcl_on_the_longer_bag(tmp_path: Path) -> None:
    """On the 74 s complex path, with the options chosen on the circular one, amcl meets all three of
    the issue's targets: 3 cm and 1 degree after alignment, 2 cm per metre driven (evo)."""
    out = tmp_path / "complex.jsonl"
    result = _jarvis(out, bag="jarvis_complex_path_fast.bag", beams=120, scan_delay_s=0.125)
    assert 17.0 < result.odometry_m < 19.0  # type: ignore[attr-defined]
    prior = Prior(Pose.from_deg(1932.5, 467.3, 178.7), np.diag([100.0, 100.0, math.radians(5.0) ** 2]))
    row = replay(read_recording(out), ["amcl"], initial=prior).summary()["amcl"]
    assert row["scored_updates"] > 580
    assert row["ape_rmse_cm"] <= 3.0 and row["ape_heading_rmse_deg"] <= 1.0 and row["rpe_per_m_cm"] <= 2.0
