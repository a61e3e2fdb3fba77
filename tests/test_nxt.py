"""NxtRobot on nxt-python's socket backend against the virtual brick, its profile, and the locator errors."""

from __future__ import annotations

import io
import json
import math
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from toolkit.robots.nxt import NxtProfile, NxtRobot, ProfileError, connect_robot
from toolkit.robots.nxt_profile import calibrated_track_width, calibrated_wheel_diameter
from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld
from toolkit.world import Pose, Robot, RobotError, angle_diff, load_map, ray_cast

FAST = BrickConfig(time_factor=1000.0, max_step_s=0.01)


class Rig:
    """A brick server in this process, its truth log and a robot connected over the socket backend."""

    def __init__(self, pose: Pose, profile: NxtProfile | None = None, config: BrickConfig = FAST,
                 noise: float = 0.0) -> None:
        self.log = io.StringIO()
        self.world = BrickWorld(load_map("map1"), pose, config, sensor_noise=noise, rng=1, log=self.log)
        self.server = BrickServer(self.world, port=0).start()
        self.robot = connect_robot("socket", host="127.0.0.1", port=self.server.port, profile=profile)

    def records(self) -> list[dict[str, Any]]:
        return [json.loads(line) for line in self.log.getvalue().splitlines()]

    def close(self) -> None:
        self.robot.close()
        self.server.stop()


@pytest.fixture
def rig() -> Iterator[Rig]:
    r = Rig(Pose.from_deg(20.0, 20.0, 90.0))  # 85 cm free ahead (up the left corridor)
    yield r
    r.close()


def test_robot_implements_the_protocol(rig: Rig) -> None:
    assert isinstance(rig.robot, Robot)
    assert rig.robot.virtual and rig.robot.clock_source == "brick"
    info = rig.robot.info()
    assert info["battery_mv"] == 8000 and info["firmware"] == "1.31" and info["link"] == "ipvirtual"


def test_move_drives_the_tacho_distance_and_the_truth_agrees(rig: Rig) -> None:
    out = rig.robot.move(30.0)
    rec = rig.records()[-1]
    assert not out.watchdog and out.requested_cm == 30.0
    assert out.distance_cm == pytest.approx(30.0, abs=0.05)  # whole tacho degrees: 0.05 cm each
    x, y, heading = rec["pose"]
    assert (x, y) == pytest.approx((20.0, 50.0), abs=0.1) and heading == pytest.approx(90.0, abs=0.1)
    assert y - 20.0 == pytest.approx(out.distance_cm, abs=1e-3)  # odometry = truth on a non-slipping brick
    back = rig.robot.turnback()
    assert back.distance_cm == pytest.approx(-10.0, abs=0.05)
    assert rig.records()[-1]["pose"][1] == pytest.approx(40.0, abs=0.1)
    assert rig.world.collisions == 0


def test_turn_spins_in_place_by_the_track_width(rig: Rig) -> None:
    before = rig.world.pose
    for deg in (90.0, -45.0, 135.0):
        start = rig.world.pose
        rig.robot.turn(math.radians(deg))
        p = rig.world.pose
        assert math.degrees(float(angle_diff(p.theta, start.theta))) == pytest.approx(deg, abs=0.5)
        assert p.distance_to(before) < 1e-6
    assert rig.robot.robot_time_s > 0


def test_ultrascan_reads_the_walls_from_the_true_pose(rig: Rig) -> None:
    pose = rig.world.pose
    scan = rig.robot.ultrascan()
    assert len(scan) == 360
    assert np.allclose(np.degrees(scan.angles), np.arange(360), atol=1e-9)
    truth = ray_cast(rig.world.map.walls, pose.xy, pose.theta + scan.angles)
    assert scan.valid.all()
    assert np.max(np.abs(scan.ranges - np.round(truth))) <= 1.0
    assert rig.world.turret_angle == pytest.approx(0.0, abs=1e-12) and rig.world.pose == pose  # turret home
    few = rig.robot.ultrascan(np.radians([0.0, 90.0, -90.0]))
    assert np.degrees(few.angles).tolist() == pytest.approx([0.0, 90.0, -90.0])
    assert few.ranges.tolist() == pytest.approx([85.0, 20.0, 40.0], abs=1.0)


def test_watchdog_stops_before_the_wall_and_reports_it() -> None:
    r = Rig(Pose.from_deg(20.0, 20.0, 0.0))  # the wall x = 60 is 40 cm ahead
    try:
        out = r.robot.move(100.0)
        assert out.watchdog and r.robot.watchdog_stops == 1
        x = r.world.pose.x
        assert x - 20.0 == pytest.approx(out.distance_cm, abs=0.05)  # tachos count whole degrees
        gap = 60.0 - x
        assert r.world.geometry.radius_cm < gap <= r.robot.profile.watchdog_distance_cm + 1.0
        assert r.world.collisions == 0 and not r.world.moving
    finally:
        r.close()


def test_stall_against_an_unseen_corner_ends_the_move() -> None:
    # heading up at x = 40: the beam passes the corner (45, 45) that the 8 cm disc hits
    r = Rig(Pose.from_deg(40.0, 20.0, 90.0))
    try:
        out = r.robot.move(60.0)
        assert out.watchdog  # stopped early (the wheels stalled)
        assert r.world.collisions == 1
        assert r.world.pose.y == pytest.approx(20.0 + out.distance_cm, abs=0.05)
        assert r.world.pose.y < 45.0
    finally:
        r.close()


def test_robot_time_is_brick_time(rig: Rig) -> None:
    t0 = rig.world.time_s
    rig.robot.move(10.0)
    rig.robot.turn(1.0)
    assert rig.robot.robot_time_s == pytest.approx(rig.world.time_s - t0, abs=0.05)


def _sonar_failing_after(rig: Rig, reads: int, error: BaseException) -> Callable[[], float]:
    """The rig's sonar read, raising `error` from the read after the first `reads`."""
    calls = {"n": 0}
    real = rig.robot.read_sonar

    def read() -> float:
        calls["n"] += 1
        if calls["n"] > reads:
            raise error
        return real()

    return read


def test_ctrl_c_mid_move_stops_the_motors_and_says_so(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(rig.robot, "read_sonar", _sonar_failing_after(rig, 5, KeyboardInterrupt()))
    with pytest.raises(RobotError, match=r"interrupted by Ctrl-C; motors stopped"):
        rig.robot.move(50.0)
    assert rig.world.pose.y > 20.0  # it had started
    moved = rig.world.pose
    rig.world.run_for(1.0)
    assert rig.world.pose == moved and not rig.world.moving


def test_any_error_mid_scan_stops_the_motors(rig: Rig, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(rig.robot, "read_sonar", _sonar_failing_after(rig, 20, ValueError("sensor exploded")))
    with pytest.raises(RobotError, match=r"ultrascan failed: ValueError: sensor exploded; motors stopped"):
        rig.robot.ultrascan()
    assert not rig.world.moving


def test_lost_connection_becomes_a_robot_error() -> None:
    r = Rig(Pose.from_deg(20.0, 20.0, 90.0))
    r.server.stop()  # the brick goes away
    with pytest.raises(RobotError, match=r"move 10.0 cm failed: lost the connection.*could not stop the motors"):
        r.robot.move(10.0)
    r.robot.close()  # still closes quietly
    with pytest.raises(RobotError, match="closed"):
        r.robot.turn(1.0)


def test_reversed_drive_and_geared_turret_profile() -> None:
    # a profile for a robot whose motors are mounted backwards cannot be checked on this brick,
    # but the gearing can: two motor degrees per sensor degree reach the same readings
    geo = BrickConfig(time_factor=1000.0, max_step_s=0.01).geometry
    cfg = BrickConfig(geometry=type(geo)(turret_gear_ratio=2.0), time_factor=1000.0, max_step_s=0.01)
    r = Rig(Pose.from_deg(20.0, 20.0, 90.0), NxtProfile(turret_gear_ratio=2.0), config=cfg)
    try:
        scan = r.robot.ultrascan(np.radians([0.0, 90.0, 180.0]))
        assert scan.ranges.tolist() == pytest.approx([85.0, 20.0, 20.0], abs=1.0)
        assert r.world.motors[2].counts()[2] == 0
    finally:
        r.close()


# -- the profile ------------------------------------------------------------------------------------
def test_profile_round_trip(tmp_path: Path) -> None:
    p = NxtProfile(left_port="b", right_port="A", wheel_diameter_cm=5.7, track_width_cm=11.9, sonar_port=2,
                   watchdog_cm=15.0)
    assert p.left_port == "B"
    path = p.save(tmp_path / "sub" / "robot.yaml")
    assert path.read_text().startswith("# nxtnav robot profile")
    assert NxtProfile.load(path) == p
    assert p.geometry.wheel_diameter_cm == 5.7 and p.watchdog_distance_cm == 15.0
    assert NxtProfile().watchdog_distance_cm == NxtProfile().radius_cm + 4.0


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"wheel_diameter_cm": -5}, "wheel_diameter_cm"),
        ({"track_width_cm": "wide"}, "track_width_cm"),
        ({"left_port": "D"}, "left_port"),
        ({"turret_port": "A"}, "left_port, right_port, turret_port"),
        ({"sonar_port": 5}, "sonar_port"),
        ({"drive_power": 150}, "drive_power"),
        ({"reverse_drive": "maybe"}, "reverse_drive"),
        ({"watchdog_cm": 0}, "watchdog_cm"),
        ({"wheel_diametre_cm": 5.6}, "wheel_diametre_cm"),
    ],
)
def test_profile_errors_name_the_field(tmp_path: Path, data: dict[str, object], field: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text("\n".join(f"{k}: {v}" for k, v in data.items()))
    with pytest.raises(ProfileError) as err:
        NxtProfile.load(path)
    assert field in str(err.value) and str(path) in str(err.value)


def test_profile_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ProfileError, match="cannot read"):
        NxtProfile.load(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("left_port: [A\n")
    with pytest.raises(ProfileError, match="not valid YAML"):
        NxtProfile.load(bad)
    bad.write_text("- 1\n- 2\n")
    with pytest.raises(ProfileError, match="mapping"):
        NxtProfile.load(bad)


def test_calibration_formulas_invert_the_kinematics() -> None:
    true_d, true_track = 5.9, 12.7
    p = NxtProfile()
    deg = round(p.wheel_degrees(50.0))
    driven = deg / 360 * math.pi * true_d
    d = calibrated_wheel_diameter(p.wheel_diameter_cm, p.distance_cm(deg), driven)
    assert d == pytest.approx(true_d)
    p = p.updated(wheel_diameter_cm=d)
    spun = p.spin_degrees(math.radians(360)) * true_d / true_track
    assert calibrated_track_width(p.track_width_cm, 360.0, spun) == pytest.approx(true_track)
    with pytest.raises(ProfileError, match="measured distance"):
        calibrated_wheel_diameter(5.6, 50.0, 0.0)


# -- finding a brick without one --------------------------------------------------------------------
def test_no_server_gives_the_clear_message() -> None:
    with pytest.raises(RobotError, match=r"no brick server at 127.0.0.1:1\..*nxtnav brick serve"):
        connect_robot("socket", host="127.0.0.1", port=1)


def test_usb_without_a_brick_lists_the_fixes(monkeypatch: pytest.MonkeyPatch) -> None:
    import usb.core as usb_core
    # whatever this machine has (no libusb, or libusb and no brick), the message lists the fixes
    with pytest.raises(RobotError, match=r"no NXT brick found over USB.*cable.*udev rule.*libusb") as err:
        connect_robot("usb")
    assert "\n" not in str(err.value)
    # pyusb finds no LEGO device
    monkeypatch.setattr(usb_core, "find", lambda **kw: iter(()))
    with pytest.raises(RobotError, match=r"^no NXT brick found over USB\. Check"):
        connect_robot("usb")

    # the brick is there but the user may not open it
    def denied(**kw: object) -> object:
        raise usb_core.USBError("Access denied (insufficient permissions)", errno=13)

    monkeypatch.setattr(usb_core, "find", denied)
    with pytest.raises(RobotError, match=r"permission denied on the USB device.*udev rule"):
        connect_robot("usb")


def test_bluetooth_without_a_brick_mentions_pairing() -> None:
    with pytest.raises(RobotError, match=r"no NXT brick found over Bluetooth.*paired"):
        connect_robot("bluetooth", address="00:16:53:00:00:01")


def test_unknown_backend_and_missing_library(monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(RobotError, match="unknown NXT backend 'serial'; known: usb, bluetooth, socket"):
        connect_robot("serial")
    monkeypatch.setitem(sys.modules, "nxt", None)
    with pytest.raises(RobotError, match=r"nxt-python is not installed.*nxtnav\[nxt\]"):
        connect_robot("usb")


def test_wiring_cannot_change_on_a_connected_robot(rig: Rig) -> None:
    with pytest.raises(RobotError, match="wiring"):
        rig.robot.set_profile(NxtProfile(sonar_port=1))
    rig.robot.set_profile(NxtProfile(wheel_diameter_cm=6.0))
    assert rig.robot.geometry.wheel_diameter_cm == 6.0


def test_robot_from_profile_path(tmp_path: Path) -> None:
    path = NxtProfile(drive_power=70).save(tmp_path / "r.yaml")
    r = Rig(Pose.from_deg(20.0, 20.0, 90.0))
    try:
        robot = NxtRobot(r.robot.brick, path, owns_brick=False)
        assert robot.profile.drive_power == 70
        assert robot.move(5.0).distance_cm == pytest.approx(5.0, abs=0.05)
        robot.close()
        assert not r.robot.closed
    finally:
        r.close()


def test_real_motor_overshoot_and_wheel_slip_are_measured_not_assumed() -> None:
    # motors that brake past their limits, wheels that slip 1 %: odometry reports what the tachos
    # turned (overshoot included), the truth differs by the slip, and every motion ends at rest
    cfg = BrickConfig(time_factor=1000.0, max_step_s=0.01, brake_decel_deg_s2=20000.0, wheel_slip=0.01)
    r = Rig(Pose.from_deg(20.0, 20.0, 90.0), config=cfg)
    try:
        out = r.robot.move(30.0)
        assert not r.world.moving
        assert 0.0 < out.distance_cm - 30.0 < 0.5  # ~4 degrees past the limit at 400 deg/s
        true_d = r.world.pose.y - 20.0
        assert true_d == pytest.approx(out.distance_cm, rel=0.04) and true_d != pytest.approx(out.distance_cm,
                                                                                               abs=1e-3)
        h0 = r.world.pose.theta
        r.robot.turn(math.radians(90.0))
        assert math.degrees(float(angle_diff(r.world.pose.theta, h0))) == pytest.approx(90.0, abs=4.0)
        pose = r.world.pose
        scan = r.robot.ultrascan(np.radians(np.arange(0, 360, 30)))
        assert not r.world.moving and abs(r.world.motors[2].counts()[2]) <= 5
        assert np.all(np.diff(scan.angles) > 0)
        truth = ray_cast(r.world.map.walls, pose.xy, pose.theta + scan.angles)
        assert np.max(np.abs(scan.ranges - truth)) < 2.0  # read where the turret really pointed
    finally:
        r.close()


def test_pending_i2c_transactions_are_waited_for() -> None:
    cfg = BrickConfig(time_factor=1000.0, max_step_s=0.01, i2c_pending_polls=2)
    r = Rig(Pose.from_deg(20.0, 20.0, 90.0), config=cfg)
    try:
        assert r.robot.read_sonar() == 85.0
        assert r.robot.ultrascan(np.radians([90.0])).ranges.tolist() == [20.0]
    finally:
        r.close()


# -- the link nxtnav holds under the brick -----------------------------------------------------------
def test_the_robot_runs_on_a_socket_nxtnav_opened_and_closes_it_with_a_goodbye(rig: Rig) -> None:
    from toolkit.robots.nxt_link import SocketLink, link_of

    link = link_of(rig.robot.brick)
    assert isinstance(link, SocketLink) and link.open
    assert link.type == rig.robot.link == "ipvirtual"  # the server's answer to the connection-type query
    assert rig.robot.move(5.0).distance_cm == pytest.approx(5.0, abs=0.1)  # nxt-python talks through it
    rig.robot.close()
    assert not link.open
    assert rig.server.wait_departures(1, timeout=10)
    assert rig.server.departures[0].cause == "closed" and not rig.server.departures[0].driven


def test_a_server_that_accepts_and_never_answers_is_given_up_on_within_the_timeout() -> None:
    import socket
    import time

    from toolkit.robots.nxt_link import find_brick

    with socket.socket() as mute:  # listens, accepts into the backlog, says nothing
        mute.bind(("127.0.0.1", 0))
        mute.listen(1)
        port = mute.getsockname()[1]
        t0 = time.monotonic()
        with pytest.raises(RobotError, match=rf"no brick server at 127.0.0.1:{port} \(TimeoutError"):
            find_brick("socket", host="127.0.0.1", port=port, timeout_s=0.3)
        assert time.monotonic() - t0 < 5.0
