"""Scheduled faults of the virtual brick: a dropped link, a stalled brick, a stuck or garbage sensor, a
slipping motion; and what the brick knows of the motors each departing connection left running."""

from __future__ import annotations

import math
import socket
import struct

import numpy as np
import pytest

from toolkit.bench.faults import draw_faults as draw_bench_faults
from toolkit.bench.faults import fault_tasks
from toolkit.robots.brick_faults import (
    FAULT_CLASSES,
    FAULT_KINDS,
    SONAR_FAULT_PLUGINS,
    Fault,
    FaultKind,
    FaultSchedule,
    LinkControl,
    LinkFault,
    SonarFault,
    WheelFault,
    fault_class,
    known_fault_kinds,
    parse_fault,
)
from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld, MotorMode, RunState
from toolkit.world import ConfigError, Pose, load_map

FAST = BrickConfig(time_factor=1000.0, max_step_s=0.01)
HOLD = MotorMode.ON | MotorMode.BRAKE | MotorMode.REGULATED
BATTERY = bytes([0x00, 0x0B])
BATTERY_REPLY = b"\x02\x0b\x00" + struct.pack("<H", 8000)


def _world(faults: list[str], config: BrickConfig = FAST, noise: float = 0.0, seed: int = 0) -> BrickWorld:
    return BrickWorld(load_map("map1"), Pose.from_deg(20.0, 20.0, 90.0), config, sensor_noise=noise, rng=seed,
                      faults=FaultSchedule(faults, rng=seed))


def _raw(port: int, timeout: float = 5.0) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


# -- the specs --------------------------------------------------------------------------------------
@pytest.mark.parametrize(("text", "fault"), [
    ("drop-link:20:3", Fault("drop-link", 20.0, 3.0)),
    ("stall:0:0.5", Fault("stall", 0.0, 0.5)),
    ("sonar-stuck:12.5:4", Fault("sonar-stuck", 12.5, 4.0)),
    ("sonar-garbage:0.05", Fault("sonar-garbage", 0.0, 0.05)),
    ("sonar-garbage:30:1", Fault("sonar-garbage", 30.0, 1.0)),
    ("motor-slip:7:0.5", Fault("motor-slip", 7.0, 0.5)),
])
def test_fault_specs_read_as_written(text: str, fault: Fault) -> None:
    assert parse_fault(text) == fault
    assert parse_fault(fault.text) == fault


@pytest.mark.parametrize(("text", "needle"), [
    ("meteor:1:2", "unknown kind 'meteor'"),
    ("drop-link:20", "expected drop-link:AT_S:DOWN_S"),
    ("drop-link:x:3", "AT_S must be a number, got 'x'"),
    ("drop-link:-1:3", "AT_S must be a time >= 0 s"),
    ("drop-link:1:0", "DOWN_S must be in (0, 3600] wall-clock seconds"),
    ("stall:1:nan", "DUR_S must be in (0, 3600]"),
    ("sonar-garbage:1.5", "P must be a probability in (0, 1]"),
    ("motor-slip:1:2", "FRACTION must be a fraction in [0, 1]"),
    ("sonar-stuck:1:2:3", "expected sonar-stuck:AT_S:DUR_S"),
])
def test_bad_fault_specs_say_what_is_wrong(text: str, needle: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_fault(text)
    assert needle in str(err.value) and repr(text) in str(err.value)


# -- the link ---------------------------------------------------------------------------------------
def _until_cut(s: socket.socket) -> int:
    """Ask the battery level until the brick cuts the link; the number of answers it gave."""
    answers = 0
    while True:
        s.sendall(BATTERY)
        reply = s.recv(64)
        if not reply:
            return answers
        assert reply == BATTERY_REPLY
        answers += 1


def test_a_dropped_link_cuts_refuses_and_comes_back_on_the_same_port_with_the_world_kept() -> None:
    world = _world(["drop-link:0.5:1.5"])
    with BrickServer(world, port=0) as srv:
        a = _raw(srv.port)
        set_out = bytes([0x80, 0x04, 2, 30, HOLD, 1, 0, RunState.RUNNING]) + struct.pack("<I", 720)
        a.sendall(set_out)  # the turret turns while the link lives
        answers = _until_cut(a)
        a.close()
        # each answer costs the brick 0.01 s: the link dropped at brick time 0.5 s
        assert world.faults.wait(0, timeout=0) and world.faults.fired[0] is not None
        assert world.faults.fired[0].time_s == pytest.approx(0.5, abs=0.011) and 45 <= answers <= 50
        turret = world.motors[2].position
        assert turret > 0
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", srv.port), timeout=5)
        assert srv.wait_link_up(timeout=30)
        with _raw(srv.port) as b:  # the same port, the same robot
            b.sendall(bytes([0x00, 0x06, 2]))
            state = b.recv(64)
            assert state[:3] == b"\x02\x06\x00"
            assert struct.unpack_from("<i", state, 13)[0] == round(turret)
        assert srv.wait_departures(2, timeout=10)
        cut = srv.departures[0]
        assert cut.cause == "cut" and cut.driven == (2,) and cut.unbounded == ()  # tacho-limited: it stops itself
        assert world.faults.to_dict()[0]["acted"] == 1


def test_a_stalled_brick_answers_late_then_as_before() -> None:
    world = _world(["stall:0.3:2"])
    with BrickServer(world, port=0) as srv, _raw(srv.port, timeout=0.5) as s:
        with pytest.raises(TimeoutError):  # a reply that takes more than 0.5 s: the stall
            _until_cut(s)
        assert world.faults.fired[0] is not None
        s.settimeout(30)
        assert s.recv(64) == BATTERY_REPLY  # the reply it owed
        s.settimeout(0.5)
        s.sendall(BATTERY)
        assert s.recv(64) == BATTERY_REPLY  # answering in time again
        assert srv.live_connections == 1


# -- the sensor -------------------------------------------------------------------------------------
def _readings(world: BrickWorld, n: int, dt: float = 0.1) -> list[int]:
    out = []
    for _ in range(n):
        world.motors[2].position += 7.0  # the turret turns between readings: the true range changes
        out.append(world.measure_sonar())
        world.run_for(dt)
    return out


def test_a_stuck_sensor_repeats_its_last_reading_for_its_duration() -> None:
    clean = _readings(_world([], noise=1.0), 60)
    stuck = _readings(_world(["sonar-stuck:1.95:3"], noise=1.0), 60)
    assert stuck[:20] == clean[:20]  # before the fault (brick times 0 .. 1.9 s)
    assert stuck[20:50] == [clean[19]] * 30  # brick times 2.0 .. 4.9 s: the last reading, over and over
    assert len(set(clean[20:50])) > 5  # (what it should have read)
    assert stuck[50:] == clean[50:]  # and after its duration, the sensor's own readings again


def test_garbage_readings_are_random_values_at_the_given_rate() -> None:
    clean = np.array(_readings(_world([], noise=0.0), 400))
    dirty = np.array(_readings(_world(["sonar-garbage:0.3"], noise=0.0), 400))
    changed = dirty != clean
    assert 0.22 < changed.mean() < 0.38  # P = 0.3 (a random value equal to the true one is rare)
    assert dirty[changed].min() < 20 and dirty[changed].max() > 200  # drawn from 0..255, not from the room
    again = np.array(_readings(_world(["sonar-garbage:0.3"], noise=0.0), 400))
    assert np.array_equal(dirty, again)  # seeded: the same garbage every time


# -- the wheels -------------------------------------------------------------------------------------
def _drive(world: BrickWorld, degrees: int) -> float:
    """Both wheels forward by `degrees` of tacho; the distance the robot moved (cm)."""
    start = world.pose
    for port in (0, 1):
        world.command_motor(port, 40, HOLD, 1, 0, RunState.RUNNING, degrees)
    world.run_for(5.0)
    assert not world.driven_ports()
    return world.pose.distance_to(start)


def test_a_slipping_motion_drives_its_fraction_and_the_next_one_is_whole() -> None:
    world = _world(["motor-slip:1:0.6"])
    per_deg = world.geometry.wheel_circumference_cm / 360.0
    assert _drive(world, 100) == pytest.approx(100 * per_deg, abs=1e-6)  # before the fault's time
    slipped = _drive(world, 200)
    assert slipped == pytest.approx(0.6 * 200 * per_deg, abs=1e-6)
    assert world.motors[0].position == pytest.approx(300.0)  # the tachos counted every degree
    assert _drive(world, 100) == pytest.approx(100 * per_deg, abs=1e-6)
    assert world.faults.to_dict()[0]["acted"] == 1


# -- what a departing client leaves running ----------------------------------------------------------
def test_the_brick_knows_which_motors_a_departing_client_left_running_without_a_limit() -> None:
    world = _world([], config=BrickConfig(time_factor=1000.0, max_step_s=0.01, brake_on_disconnect=False))
    with BrickServer(world, port=0) as srv:
        s = _raw(srv.port)
        s.sendall(bytes([0x80, 0x04, 2, 30, HOLD, 1, 0, RunState.RUNNING]) + struct.pack("<I", 0))  # no limit
        s.sendall(bytes([0x80, 0x04, 0, 30, HOLD, 1, 0, RunState.RUNNING]) + struct.pack("<I", 90))
        s.sendall(BATTERY)
        assert s.recv(64) == BATTERY_REPLY
        s.close()
        assert srv.wait_departures(1, timeout=10)
        gone = srv.departures[0]
        assert gone.cause == "closed" and gone.driven == (0, 2) and gone.unbounded == (2,)
        world.run_for(10.0)
        assert world.driven_ports() == [2]  # the limited wheel stopped on its own; the turret runs on


def test_the_reassembly_window_is_a_checked_option() -> None:
    assert BrickConfig().reassembly_s == 0.25
    with pytest.raises(ConfigError, match="reassembly_s"):
        BrickConfig(reassembly_s=0.0)
    world = BrickWorld(load_map("map1"), Pose(20, 20, 0), BrickConfig(time_factor=1000.0, reassembly_s=0.05),
                       sensor_noise=0.0, rng=0)
    with BrickServer(world, port=0) as srv, _raw(srv.port) as s:
        s.sendall(b"\x00\x04\x02")  # a telegram cut short whose rest never comes: refused after the window
        reply = s.recv(64)
        assert reply[:2] == b"\x02\x04" and reply[2] != 0


def test_every_kind_is_scheduled_on_the_brick_time() -> None:
    assert FAULT_KINDS == ("drop-link", "stall", "sonar-stuck", "sonar-garbage", "motor-slip")
    schedule = FaultSchedule(["drop-link:2:1", "stall:1:1", "sonar-stuck:5:1"])
    assert schedule.due(0.5) == [] and schedule.due(1.0) == [1] and schedule.due(10.0) == [0]
    assert schedule.due(20.0) == []  # link faults fire once; sensor faults act when read
    assert math.isclose(schedule.fired[1].time_s, 1.0) and schedule.fired[2] is None  # type: ignore[union-attr]



# -- a sensor fault kind of one's own (SonarFault) ----------------------------------------------------
class _Deaf(SonarFault):
    """Every reading from AT_S on is lost (255) with probability P, drawn from the schedule's stream."""

    arg_name = "P"
    arg_rule = "a probability in [0, 1]"

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        return 0.0 <= arg <= 1.0

    def reading(self, value: int, time_s: float, rng: np.random.Generator) -> int | None:
        return 255 if rng.random() < self.fault.arg else None


_Deaf.name = "sonar-deaf"  # set after the body: registered only inside `added`


def test_a_sensor_fault_kind_of_ones_own_is_scheduled_like_the_builtin_ones() -> None:
    with SONAR_FAULT_PLUGINS.added({"sonar-deaf": _Deaf}):
        assert parse_fault("sonar-deaf:1.95:0.5") == Fault("sonar-deaf", 1.95, 0.5)
        with pytest.raises(ConfigError, match=r"fault 'sonar-deaf:1:2': P must be a probability in \[0, 1\]"):
            parse_fault("sonar-deaf:1:2")
        clean = _readings(_world([], noise=0.0), 200)
        deaf = _readings(_world(["sonar-deaf:1.95:0.5"], noise=0.0), 200)
        assert deaf[:20] == clean[:20]  # before its time
        lost = [d == 255 and c != 255 for c, d in zip(clean[20:], deaf[20:], strict=True)]
        assert 0.35 < np.mean(lost) < 0.65
        assert deaf == _readings(_world(["sonar-deaf:1.95:0.5"], noise=0.0), 200)  # seeded
        schedule = FaultSchedule(["sonar-deaf:0:1"], rng=0)
        assert schedule.sonar(40, 0.5) == 255 and schedule.to_dict()[0]["acted"] == 1
    with pytest.raises(ConfigError, match=r"unknown kind 'sonar-deaf'; known: drop-link, stall, sonar-stuck, "
                       r"sonar-garbage, motor-slip$"):
        parse_fault("sonar-deaf:1:0.5")  # gone with its block


def test_a_sensor_fault_kind_may_not_take_a_builtin_name() -> None:
    with pytest.raises(ConfigError, match="'stall' is a built-in kind's name"):
        type("Stall", (SonarFault,), {"name": "stall", "reading": lambda self, v, t, rng: None})


# -- every kind a registered class with its own rules ------------------------------------------------------
class _Hiccup(LinkFault):
    """The brick answers nothing for ARG wall-clock seconds, twice over (a link fault of one's own)."""

    arg_name = "DUR_S"

    def carry_out(self, link: LinkControl) -> bool:
        link.stall(2.0 * self.fault.arg)
        return False


class _Skid(WheelFault):
    """Every motion of the wheels from AT_S on drives ARG of its tacho travel (a wheel fault of one's own)."""

    arg_name = "FRACTION"
    arg_rule = "a fraction in (0, 1]"
    draw_range = (0.2, 0.3)

    @classmethod
    def arg_ok(cls, arg: float) -> bool:
        return 0 < arg <= 1

    def take(self, port: int, wheels: tuple[int, int], time_s: float) -> tuple[float, bool] | None:
        return self.fault.arg, True


_Hiccup.name = "hiccup"
_Skid.name = "skid"


def test_an_unknown_kind_is_an_error_listing_the_known_ones_never_another_kinds_rule() -> None:
    known = "known: drop-link, stall, sonar-stuck, sonar-garbage, motor-slip$"
    with pytest.raises(ConfigError, match=r"unknown fault kind 'skid'; " + known):
        Fault("skid", 1.0, 0.5)  # before: checked as a motor-slip fraction
    with pytest.raises(ConfigError, match=r"unknown fault kind 'skid'; " + known):
        fault_class("skid")
    assert known_fault_kinds() == list(FAULT_KINDS)
    assert FAULT_CLASSES.get("motor-slip").draw_range == (0.5, 0.9)


def test_a_link_fault_kind_of_ones_own_is_carried_out_by_the_server() -> None:
    with FAULT_CLASSES.added({"hiccup": _Hiccup}):
        assert "hiccup" in known_fault_kinds()
        with pytest.raises(ConfigError, match=r"DUR_S must be in \(0, 3600\] wall-clock seconds"):
            parse_fault("hiccup:1:0")  # the rule of its family
        world = _world(["hiccup:0.3:1"])
        with BrickServer(world, port=0) as srv, _raw(srv.port, timeout=1.5) as s:
            with pytest.raises(TimeoutError):  # stalled for 2 s: no reply within 1.5 s, nor a cut link
                for _ in range(200):
                    s.sendall(BATTERY)
                    assert s.recv(64) == BATTERY_REPLY
            assert srv.live_connections == 1 and world.faults.to_dict()[0]["acted"] == 1
    assert "hiccup" not in known_fault_kinds()


def test_a_wheel_fault_kind_of_ones_own_slips_every_motion_and_the_bench_draws_it_in_its_range() -> None:
    with FAULT_CLASSES.added({"skid": _Skid}):
        schedule = FaultSchedule(["skid:2:0.25"])
        assert schedule.slip(1, (1, 0), 1.0) is None  # before its time
        assert [schedule.slip(p, (1, 0), 3.0) for p in (1, 0, 1)] == [0.25, 0.25, 0.25]
        assert schedule.to_dict()[0]["acted"] == 3 and schedule.sonar(40, 3.0) == 40  # the wheels only
        rng = np.random.default_rng(0)
        drawn = [f for _ in range(50) for f in draw_bench_faults(rng, ("skid",), 100.0)]
        assert all(f.kind == "skid" and 0.2 <= f.arg <= 0.3 and 10.0 <= f.at_s <= 85.0 for f in drawn)
    with FAULT_CLASSES.added({"hiccup": _Hiccup}):  # no draw range: the bench refuses it by name
        with pytest.raises(ConfigError, match="'hiccup' has no draw range"):
            draw_bench_faults(np.random.default_rng(0), ("hiccup",), 100.0)
        with pytest.raises(ConfigError, match="fault kinds must be some of drop-link, stall, sonar-stuck, "
                           "sonar-garbage, motor-slip, got hiccup"):
            fault_tasks(1, 0, ("hiccup",))


def test_a_fault_kind_must_say_what_it_acts_on() -> None:
    with pytest.raises(ConfigError, match="'odd' must subclass LinkFault, SonarFault or WheelFault"):
        type("Odd", (FaultKind,), {"name": "odd"})
    assert "odd" not in FAULT_CLASSES
