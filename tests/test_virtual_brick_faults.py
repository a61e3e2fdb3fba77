"""Faults of the virtual brick's link found by trying it as a hostile network would: who may brake a
motor by leaving, telegrams cut by TCP, and a client killed in the middle of a motion."""

from __future__ import annotations

import signal
import socket
import struct
import subprocess
import sys
import time

import pytest
from conftest import wait_until

from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld, MotorMode, RunState
from toolkit.world import Pose, load_map

FAST = BrickConfig(time_factor=1000.0, max_step_s=0.01)
HOLD = MotorMode.ON | MotorMode.BRAKE | MotorMode.REGULATED
BATTERY = bytes([0x00, 0x0B])
BATTERY_REPLY = b"\x02\x0b\x00" + struct.pack("<H", 8000)


def _raw(port: int) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def _run_motor(s: socket.socket, port: int, power: int, limit: int = 0) -> None:
    """SET_OUTPUT_STATE without a reply, then a battery query to know the brick has executed it."""
    s.sendall(bytes([0x80, 0x04, port, power & 0xFF, HOLD, 1, 0, RunState.RUNNING]) + struct.pack("<I", limit))
    s.sendall(BATTERY)
    assert s.recv(64) == BATTERY_REPLY


def _world(config: BrickConfig = FAST, pose: Pose | None = None) -> BrickWorld:
    return BrickWorld(load_map("map1"), pose or Pose.from_deg(20.0, 20.0, 90.0), config, sensor_noise=0.0, rng=0)


def test_a_second_client_leaving_does_not_brake_the_first_clients_motors() -> None:
    world = _world()
    with BrickServer(world, port=0) as srv:
        a = _raw(srv.port)
        _run_motor(a, 2, 40)  # client A sets the turret going (no limit)
        assert world.motors[2].driven
        with _raw(srv.port) as b:  # client B comes, asks something and leaves
            b.sendall(BATTERY)
            assert b.recv(64) == BATTERY_REPLY
        assert srv.wait_departures(1, timeout=5.0)  # B's departure handled (its motors released)
        assert world.motors[2].driven, "another client's departure braked client A's motor"
        a.close()  # the owner leaves: its motor is braked
        wait_until(lambda: not world.motors[2].driven, 5.0, "the owner's motor braked when it left")


def test_a_client_may_stop_only_what_it_started_by_leaving() -> None:
    world = _world()
    with BrickServer(world, port=0) as srv:
        a, b = _raw(srv.port), _raw(srv.port)
        _run_motor(a, 2, 40)
        _run_motor(b, 0, 30)
        _run_motor(b, 1, 30)
        b.close()
        assert srv.wait_departures(1, timeout=5.0)
        assert not world.motors[0].driven and not world.motors[1].driven
        assert world.motors[2].driven
        a.close()
        assert srv.wait_departures(2, timeout=5.0)
        assert not world.motors[2].driven


@pytest.mark.parametrize("cut", [1, 3, 8, 12])
def test_a_telegram_split_across_tcp_segments_is_reassembled(cut: int) -> None:
    world = _world()
    set_out = bytes([0x00, 0x04, 2, 25, HOLD, 1, 0, RunState.RUNNING]) + struct.pack("<I", 90)
    with BrickServer(world, port=0) as srv, _raw(srv.port) as s:
        s.sendall(set_out[:cut])
        time.sleep(0.05)  # fault injection, a slow link: the first piece arrives alone
        s.sendall(set_out[cut:])
        assert s.recv(64) == b"\x02\x04\x00", "the reassembled telegram was not executed"
        assert world.motors[2].driven and world.motors[2].tacho_limit == 90
        for piece in (BATTERY[:1], BATTERY[1:]):  # a two-byte query cut in the middle
            s.sendall(piece)
            time.sleep(0.05)  # fault injection, a slow link: each piece arrives alone
        assert s.recv(64) == BATTERY_REPLY
    assert srv.brick.errors == 0


def test_a_second_telegram_glued_and_cut_waits_for_its_rest() -> None:
    world = _world()
    with BrickServer(world, port=0) as srv, _raw(srv.port) as s:
        s.sendall(BATTERY + BATTERY[:1])
        assert s.recv(64) == BATTERY_REPLY
        time.sleep(0.05)  # fault injection, a slow link: the rest comes later
        s.sendall(BATTERY[1:])
        assert s.recv(64) == BATTERY_REPLY
    assert srv.brick.errors == 0


def test_a_fragment_whose_rest_never_comes_is_refused_and_the_link_lives_on() -> None:
    with BrickServer(_world(), port=0) as srv, _raw(srv.port) as s:
        s.sendall(b"\x00\x04\x02")  # set output state cut short, reply wanted; nothing follows
        reply = s.recv(64)
        assert reply[:2] == b"\x02\x04" and reply[2] != 0
        s.sendall(BATTERY)
        assert s.recv(64) == BATTERY_REPLY


def test_a_real_nxt_runs_unlimited_motors_on_after_the_link_drops() -> None:
    """The brick imitates a real NXT with `brake_on_disconnect=False`: what the next test relies on."""
    world = _world(BrickConfig(time_factor=1000.0, max_step_s=0.01, brake_on_disconnect=False))
    with BrickServer(world, port=0) as srv:
        s = _raw(srv.port)
        _run_motor(s, 2, 40)
        s.close()
        assert srv.wait_departures(1, timeout=5.0)
        world.run_for(2.0)
        assert world.motors[2].driven and world.motors[2].position > 500


_CLIENT = """
import sys
from toolkit.robots.nxt import connect_robot
robot = connect_robot("socket", host="127.0.0.1", port=int(sys.argv[1]))
print("connected", flush=True)
robot.move(float(sys.argv[2]))
print("done", flush=True)
"""


def test_killing_the_client_mid_move_stops_the_robot_within_the_commanded_distance() -> None:
    """NxtRobot bounds every motion on the brick: killed mid-move, the robot still stops in time."""
    # each exchange takes 2 ms: the move lasts a good fraction of a second of wall time, so the kill
    # lands in its middle however fast the machine is
    world = _world(BrickConfig(time_factor=1000.0, max_step_s=0.01, brake_on_disconnect=False, latency_s=0.002))
    commanded = 30.0
    with BrickServer(world, port=0) as srv:
        child = subprocess.Popen([sys.executable, "-c", _CLIENT, str(srv.port), str(commanded)],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            left = world.motors[world.config.left_port]
            wait_until(lambda: left.position > 120.0, 60.0, "the client's move starting")
            child.send_signal(signal.SIGKILL)
        finally:
            if child.poll() is None:
                child.kill()
            out, _ = child.communicate(timeout=10)
        assert "done" not in out, "the client finished before it was killed: the test proves nothing"
        at_kill = world.pose.y - 20.0
        assert at_kill < commanded - 1.0
        assert srv.wait_departures(1, timeout=10.0)  # the server has noticed the dead link
        world.run_for(10.0)  # ten brick seconds with nobody in control
        driven = world.pose.y - 20.0
        assert not any(m.driven for m in world.motors), "a motor still runs with nobody in control"
        assert at_kill < driven <= commanded + 0.05
        assert world.collisions == 0
