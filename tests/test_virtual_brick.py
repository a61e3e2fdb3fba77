"""The virtual NXT brick: framing, the simulated mechanics, and the server against the real nxt-python."""

from __future__ import annotations

import io
import json
import math
import socket
import struct
import time
from collections.abc import Iterator

import numpy as np
import nxt.brick
import nxt.error
import nxt.locator
import nxt.motor
import nxt.sensor
import nxt.sensor.generic
import pytest
from conftest import wait_until

from toolkit.robots.virtual_brick import BrickServer, VirtualBrick
from toolkit.robots.virtual_brick_protocol import Frame, Status, split_telegrams
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld, MotorMode, RunState
from toolkit.world import CollisionChecker, Pose, RobotError, RobotGeometry, load_map, ray_cast

FAST = BrickConfig(time_factor=1000.0, max_step_s=0.01)
HOLD = MotorMode.ON | MotorMode.BRAKE | MotorMode.REGULATED


def _world(pose: Pose | None = None, **kw: object) -> BrickWorld:
    kw.setdefault("sensor_noise", 0.0)
    pose = pose or Pose(20.0, 20.0, 0.0)
    return BrickWorld(load_map("map1"), pose, kw.pop("config", FAST), rng=0, **kw)  # type: ignore[arg-type]


@pytest.fixture
def server() -> Iterator[BrickServer]:
    log = io.StringIO()
    srv = BrickServer(_world(log=log), port=0).start()
    srv.log = log  # type: ignore[attr-defined]
    yield srv
    srv.stop()


def _raw(port: int) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def _ask(s: socket.socket, data: bytes) -> bytes:
    s.sendall(data)
    return s.recv(1024)


def _brick(port: int) -> nxt.brick.Brick:
    return nxt.locator.find(backends=["socket"], server_host="127.0.0.1", server_port=port, config=None)


# -- framing ----------------------------------------------------------------------------------------
def test_split_separates_glued_telegrams_and_control_bytes() -> None:
    set_out = bytes([0x80, 0x04, 0, 50, HOLD, 1, 0, 0x20]) + struct.pack("<I", 360)
    get_out = bytes([0x00, 0x06, 0])
    ls_write = bytes([0x00, 0x0F, 3, 2, 1, 0x02, 0x42])
    frames = split_telegrams(b"\x98" + set_out + get_out + ls_write + b"\x99")
    assert [f.kind for f in frames] == ["type", "telegram", "telegram", "telegram", "close"]
    assert frames[1].data == set_out and not frames[1].wants_reply
    assert frames[2].data == get_out and frames[2].wants_reply
    assert frames[3].data == ls_write


@pytest.mark.parametrize(
    ("data", "truncated"),
    [(b"\x00", True), (b"\x00\x04\x00\x32", True), (b"\x00\x0f\x03", True), (b"\x00\x7f", False),
     (b"\x55\x01\x02", False), (b"\x01\xee", False)],
)
def test_unframeable_bytes_become_one_garbage_frame(data: bytes, truncated: bool) -> None:
    frames = split_telegrams(data)
    assert len(frames) == 1 and frames[0].kind == "garbage" and frames[0].data == data
    assert frames[0].truncated is truncated


# -- mechanics --------------------------------------------------------------------------------------
def test_tacho_limited_motor_stops_exactly_and_turns_at_the_commanded_speed() -> None:
    w = _world()
    m = w.motors[2]  # the turret: the robot does not move
    m.command(50, HOLD, 1, 0, RunState.RUNNING, 720)
    w.run_for(0.5)
    cruise = m.speed
    w.run_for(2.0)
    assert cruise == pytest.approx(50 * FAST.deg_per_s_per_power)
    assert m.counts()[2] == 720 and m.speed == 0.0 and m.run_state == RunState.IDLE
    assert w.pose == Pose(20.0, 20.0, 0.0)
    assert w.turret_angle == pytest.approx(math.radians(720))


def test_wheels_drive_the_true_pose_by_their_tachos() -> None:
    w = _world(Pose(20.0, 20.0, math.pi / 2))
    g = w.geometry
    deg = 40.0 / g.wheel_circumference_cm * 360.0
    for port in (0, 1):
        w.motors[port].command(60, HOLD, 1, 0, RunState.RUNNING, round(deg))
    w.run_for(5.0)
    p = w.pose
    assert p.y - 20.0 == pytest.approx(round(deg) / 360.0 * g.wheel_circumference_cm, abs=1e-6)
    assert p.x == pytest.approx(20.0, abs=1e-9) and p.theta == pytest.approx(math.pi / 2)
    spin = round(math.degrees(math.pi / 2) * g.track_width_cm / g.wheel_diameter_cm)
    w.motors[0].command(-40, HOLD, 1, 0, RunState.RUNNING, spin)
    w.motors[1].command(40, HOLD, 1, 0, RunState.RUNNING, spin)
    w.run_for(5.0)
    turned = spin * g.wheel_diameter_cm / g.track_width_cm  # what the rounded tacho count gives (deg)
    assert abs(abs(math.degrees(w.pose.theta)) - (90.0 + turned)) < 1e-6 or \
        abs(math.degrees(w.pose.theta) + 270.0 - turned) < 1e-6
    assert abs(turned - 90.0) < 0.5
    assert w.pose.distance_to(p) < 1e-9


def test_robot_never_passes_through_a_wall_and_counts_the_collision() -> None:
    log = io.StringIO()
    w = _world(Pose(20.0, 20.0, 0.0), log=log)  # the wall x = 60 lies 40 cm ahead
    for port in (0, 1):
        w.motors[port].command(80, MotorMode.ON, 0, 0, RunState.RUNNING, 0)  # run forever
    for _ in range(600):
        w.run_for(0.01)
    cc = CollisionChecker(w.map, w.geometry.radius_cm)
    assert 60.0 - w.pose.x >= w.geometry.radius_cm - 1e-2  # at the contact, not beyond
    assert 60.0 - w.pose.x < w.geometry.radius_cm + 0.05
    assert cc.clearance(w.pose.xy) > -0.01
    assert w.collisions == 1 and w.in_contact
    w.stop_all()
    rec = json.loads(log.getvalue().splitlines()[-1])
    assert rec["collisions"] == 1 and rec["pose"][0] == pytest.approx(w.pose.x, abs=1e-3)


def test_coasting_motor_runs_on_then_stops() -> None:
    w = _world()
    m = w.motors[2]
    m.command(50, MotorMode.ON | MotorMode.REGULATED, 1, 0, RunState.RUNNING, 0)
    w.run_for(0.5)
    m.command(0, 0, 0, 0, RunState.IDLE, 0)  # idle: coast
    before = m.position
    w.run_for(1.0)
    coast = m.position - before
    v = 50 * FAST.deg_per_s_per_power
    assert coast == pytest.approx(v * v / (2 * FAST.coast_decel_deg_s2), rel=0.02)
    assert not w.moving


def test_start_pose_in_a_wall_is_refused() -> None:
    with pytest.raises(RobotError, match="collision"):
        _world(Pose(2.0, 2.0, 0.0))


def test_clock_is_capped_per_exchange() -> None:
    now = [0.0]
    w = BrickWorld(load_map("map1"), Pose(20, 20, 0), BrickConfig(time_factor=10.0, max_step_s=0.05),
                   clock=lambda: now[0])
    now[0] = 0.002
    assert w.advance() == pytest.approx(0.02)
    now[0] = 5.0  # the client was away for seconds: the brick moves on by one step only
    assert w.advance() == pytest.approx(0.05)
    assert w.time_s == pytest.approx(0.07)


# -- the server and garbage -------------------------------------------------------------------------
BATTERY = bytes([0x00, 0x0B])


@pytest.mark.parametrize(
    ("data", "status"),
    [
        (b"\x00\x7f", Status.UNKNOWN_OPCODE),
        (b"\x01\xee\x01", Status.UNKNOWN_OPCODE),
        (b"\x55\x01", Status.UNKNOWN_OPCODE),
        (b"\x00\x04\x00\x32", Status.INSANE_PACKET),  # set output state cut short, reply wanted
        (b"\x00\x06\x07", Status.OUT_OF_RANGE),  # output port 7
        (b"\x00\x07\x09", Status.OUT_OF_RANGE),  # input port 10
        (b"\x00\x0f\x03\x02\x01\x02\x42", Status.CHANNEL_NOT_CONFIGURED),  # I2C before set input mode
        (b"\x00\x01", Status.NO_ACTIVE_PROGRAM),
        (b"\x01\x80" + b"x.rxe".ljust(20, b"\0"), Status.FILE_NOT_FOUND),
        (b"\x01\x94" + struct.pack("<IHH", 0x00020001, 0, 4), Status.MODULE_NOT_FOUND),
    ],
)
def test_bad_telegrams_get_the_error_status_and_the_link_lives_on(server: BrickServer, data: bytes,
                                                                   status: int) -> None:
    with _raw(server.port) as s:
        reply = _ask(s, data)
        assert reply[0] == 0x02 and reply[1] == data[1] and reply[2] == status
        ok = _ask(s, BATTERY)
        assert ok[:3] == b"\x02\x0b\x00" and struct.unpack("<H", ok[3:5])[0] == 8000


def test_random_garbage_never_stops_the_server(server: BrickServer) -> None:
    rng = np.random.default_rng(7)
    s = _raw(server.port)
    s.settimeout(0.5)
    reconnects = 0
    for i in range(150):
        n = int(rng.integers(1, 40))
        chunk = bytes(rng.integers(0, 256, n, dtype=np.uint8))
        if i % 3 == 0:  # make many of them look like commands
            chunk = bytes([int(rng.choice([0x00, 0x01, 0x80, 0x81])), int(rng.integers(0, 0xA5))]) + chunk
        try:
            s.sendall(chunk)
            time.sleep(0.002)  # fault injection: the garbage reaches the brick apart from the probe after it
            got = b""
            for _ in range(5):  # the probe's reply may follow error replies to the garbage
                s.sendall(BATTERY)
                got += s.recv(4096)
                if b"\x02\x0b\x00\x40\x1f" in got:
                    break
            assert b"\x02\x0b\x00\x40\x1f" in got
        except (OSError, AssertionError):
            s.close()  # the garbage held 0x99 (close): the brick hung up on this client only
            s = _raw(server.port)
            s.settimeout(0.5)
            reconnects += 1
    s.close()
    assert server.brick.errors > 50
    with _raw(server.port) as s2:  # still serving
        assert _ask(s2, BATTERY)[:3] == b"\x02\x0b\x00"
    assert reconnects < 150


def test_nxt_python_reads_info_sensor_and_motors(server: BrickServer) -> None:
    w = server.world
    with _brick(server.port) as b:
        assert b._sock.type == "ipvirtual"
        name, _, _, flash = b.get_device_info()
        assert name == "nxtnav-virtual" and flash > 0
        assert b.get_firmware_version() == ((1, 124), (1, 31))
        assert b.get_battery_level() == 8000
        assert b.keep_alive() > 0
        b.play_tone(440, 10)
        us = b.get_sensor(nxt.sensor.Port.S4)  # autodetected from the sensor's identification registers
        assert isinstance(us, nxt.sensor.generic.Ultrasonic)
        assert us.get_measurement_units() == "10E-2m"
        truth = ray_cast(w.map.walls, w.pose.xy, np.array([w.pose.theta]))[0]
        assert us.get_distance() == round(float(truth)) == 40
        a = b.get_motor(nxt.motor.Port.C)
        b.set_output_state(nxt.motor.Port.C, 30, nxt.motor.Mode(HOLD), nxt.motor.RegulationMode.SPEED, 0,
                           nxt.motor.RunState.RUNNING, 90)
        for _ in range(500):
            if b.get_output_state(nxt.motor.Port.C)[5] == nxt.motor.RunState.IDLE:
                break
        assert a.get_tacho().rotation_count == 90
        truth = ray_cast(w.map.walls, w.pose.xy, np.array([w.pose.theta + math.pi / 2]))[0]
        assert us.get_distance() == round(float(truth))  # the turret now looks left
        b.reset_motor_position(nxt.motor.Port.C, False)
        assert a.get_tacho().rotation_count == 0 and a.get_tacho().tacho_count == 90
        with pytest.raises(nxt.error.DirectProtocolError):
            b.get_current_program_name()
        assert b.read_io_map(0x00010001, 20, 4)[1] == struct.pack("<I", int(w.time_s * 1000))
        b.set_brick_name("robbie")
        assert b.get_device_info()[0] == "robbie"


def test_sensor_on_an_empty_port_is_a_bus_error(server: BrickServer) -> None:
    with _brick(server.port) as b:
        sensor = nxt.sensor.generic.Ultrasonic(b, nxt.sensor.Port.S1, check_compatible=False)
        with pytest.raises(nxt.error.I2CError):
            sensor.get_distance()


def test_client_dropping_mid_move_leaves_the_motors_stopped(server: BrickServer) -> None:
    w = server.world
    b = _brick(server.port)
    for port in (nxt.motor.Port.A, nxt.motor.Port.B):  # drive forever
        b.set_output_state(port, 40, nxt.motor.Mode(HOLD), nxt.motor.RegulationMode.SPEED, 0,
                           nxt.motor.RunState.RUNNING, 0)
    for _ in range(5):
        b.get_output_state(nxt.motor.Port.A)
    assert w.moving and w.pose.x > 20.0
    b._sock._sock.close()  # vanish without the goodbye byte
    b._sock._sock = None  # (so that nxt-python's own close does not try to say it later)
    wait_until(lambda: not w.moving, 5.0, "the brick stopping the robot of a vanished client")
    stopped_at = w.pose
    with _brick(server.port) as b2:  # a new client finds the motors stopped and the robot still
        for _ in range(20):
            state = b2.get_output_state(nxt.motor.Port.A)
        assert state[1] == 0 and state[5] == nxt.motor.RunState.IDLE
        assert b2.get_output_state(nxt.motor.Port.B)[7] == b2.get_output_state(nxt.motor.Port.B)[7]
    assert w.pose == stopped_at and w.collisions == 0
    rec = json.loads(server.log.getvalue().splitlines()[-1])
    assert rec["pose"][0] == pytest.approx(stopped_at.x, abs=1e-3)


def test_one_client_leaving_leaves_the_server_serving(server: BrickServer) -> None:
    for _ in range(3):
        with _brick(server.port) as b:
            assert b.get_battery_level() == 8000
    assert server.clients == 3


def test_handler_refuses_everything_without_raising() -> None:
    brick = VirtualBrick(_world())
    rng = np.random.default_rng(3)
    for _ in range(2000):
        data = bytes(rng.integers(0, 256, int(rng.integers(0, 30)), dtype=np.uint8))
        for frame in split_telegrams(data):
            if frame.kind in ("telegram", "garbage"):
                reply = brick.handle(frame)
                assert reply is None or (reply[0] == 0x02 and len(reply) >= 3)
    assert brick.handle(Frame("garbage", b"\x00")) == b"\x02\x00" + bytes([Status.INSANE_PACKET])


def test_brick_geometry_is_its_own() -> None:
    geo = RobotGeometry(wheel_diameter_cm=5.8, track_width_cm=12.5)
    w = _world(config=BrickConfig(geometry=geo, time_factor=1000.0))
    assert w.geometry.wheel_diameter_cm == 5.8
    with pytest.raises(ValueError, match="motor ports"):
        BrickConfig(left_port=0, right_port=0)


def test_real_motor_brakes_past_its_limit() -> None:
    cfg = BrickConfig(time_factor=1000.0, brake_decel_deg_s2=40000.0)
    w = _world(config=cfg)
    m = w.motors[2]
    w.command_motor(2, 50, HOLD, 1, 0, RunState.RUNNING, 360)
    w.run_for(3.0)
    v = 50 * cfg.deg_per_s_per_power
    assert m.run_state == RunState.IDLE and m.speed == 0.0
    assert m.position == pytest.approx(360.0 + v * v / (2 * 40000.0), abs=0.5)


def test_wheel_slip_moves_the_truth_off_the_tachos() -> None:
    w = _world(Pose(20.0, 20.0, math.pi / 2), config=BrickConfig(time_factor=1000.0, wheel_slip=0.05))
    for port in (0, 1):
        w.command_motor(port, 50, HOLD, 1, 0, RunState.RUNNING, 720)
    w.run_for(5.0)
    tacho_cm = 720 / 360 * w.geometry.wheel_circumference_cm
    assert w.pose.distance_to(Pose(20.0, 20.0 + tacho_cm, math.pi / 2)) > 0.05
    assert w.pose.y - 20.0 == pytest.approx(tacho_cm, rel=0.2)
    with pytest.raises(ValueError, match="wheel_slip"):
        BrickConfig(wheel_slip=-0.1)


def test_real_time_brick_runs_its_motors_while_the_client_is_silent() -> None:
    world = BrickWorld(load_map("map1"), Pose(20.0, 20.0, 0.0), BrickConfig(time_factor=1.0, max_step_s=0.25))
    assert world.free_running and not _world().free_running  # real time ticks; fast bricks wait for clients
    with BrickServer(world, port=0) as srv, _raw(srv.port) as s:
        s.sendall(bytes([0x80, 0x04, 2, 30, HOLD, 1, 0, 0x20]) + struct.pack("<I", 0))  # turret, no reply
        # no telegram: only the brick's own clock can move the motor
        wait_until(lambda: world.motors[2].position > 10.0, 5.0, "the turret turning on the brick's own clock")


def test_nxt_python_waits_out_a_pending_bus() -> None:
    world = _world(config=BrickConfig(time_factor=1000.0, max_step_s=0.01, i2c_pending_polls=3))
    with BrickServer(world, port=0) as srv, _brick(srv.port) as b:
        us = nxt.sensor.generic.Ultrasonic(b, nxt.sensor.Port.S4)
        assert us.get_distance() == 40
        b.ls_write(nxt.sensor.Port.S4, bytes([0x02, 0x42]), 1)
        with pytest.raises(nxt.error.I2CPendingError):
            b.ls_read(nxt.sensor.Port.S4)
