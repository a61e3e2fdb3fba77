"""NxtRobot over a link that drops or stalls: LinkLostError says what was under way, reconnect() reaches
the same brick again, stops the motors, turns the turret back, and the tachometers tell what happened."""

from __future__ import annotations

import math
from collections.abc import Iterator

import pytest

from toolkit.robots.brick_faults import FaultSchedule
from toolkit.robots.nxt import NxtRobot, connect_robot
from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld
from toolkit.world import LinkLostError, Pose, Resumption, RobotError, load_map

START = Pose.from_deg(20.0, 20.0, 90.0)  # 85 cm free ahead, up the left corridor of map1


class Rig:
    """A brick with scheduled faults in this process and an NXT robot on it."""

    def __init__(self, faults: list[str], run_on: bool = False, reply_timeout_s: float = 3.0) -> None:
        config = BrickConfig(time_factor=1000.0, max_step_s=0.01, brake_on_disconnect=not run_on)
        self.world = BrickWorld(load_map("map1"), START, config, sensor_noise=0.0, rng=1,
                                faults=FaultSchedule(faults, rng=1))
        self.server = BrickServer(self.world, port=0).start()
        self.robot = connect_robot("socket", host="127.0.0.1", port=self.server.port,
                                   reply_timeout_s=reply_timeout_s)
        self.t0 = self.world.time_s

    def back(self) -> Resumption:
        """Reconnect once the brick takes connections again."""
        assert self.server.wait_link_up(timeout=60)
        return self.robot.reconnect()

    def close(self) -> None:
        self.robot.close()
        self.server.stop()


@pytest.fixture
def make() -> Iterator[type[Rig]]:
    rigs: list[Rig] = []

    def build(*args: object, **kw: object) -> Rig:
        r = Rig(*args, **kw)  # type: ignore[arg-type]
        rigs.append(r)
        return r

    yield build  # type: ignore[misc]
    for r in rigs:
        r.close()


@pytest.mark.parametrize("run_on", [False, True])
def test_a_move_cut_by_a_dropped_link_is_measured_by_the_tachos_after_reconnecting(make: type[Rig],
                                                                                   run_on: bool) -> None:
    rig = make(["drop-link:1.0:0.5"], run_on=run_on)
    with pytest.raises(LinkLostError, match=r"move 40.0 cm failed: lost the connection") as err:
        rig.robot.move(40.0)
    assert err.value.action == "move" and err.value.requested == 40.0
    with pytest.raises(LinkLostError, match="reconnect first"):  # nothing goes out on a lost link
        rig.robot.turn(1.0)
    back = rig.back()
    assert back.action == "move" and back.requested == 40.0
    driven = rig.world.pose.y - START.y  # the brick's truth
    assert 2.0 < driven < 38.0, "the link should drop in the middle of the move"
    assert back.done == pytest.approx(driven, abs=0.05)  # no wheel slip here: the tachos tell the truth
    assert not rig.world.driven_ports() and not rig.world.moving  # reconnecting braked every motor
    out = rig.robot.move(5.0)  # and the robot works again
    assert out.distance_cm == pytest.approx(5.0, abs=0.1)
    assert rig.world.pose.y - START.y == pytest.approx(driven + out.distance_cm, abs=0.05)


def test_a_sweep_cut_by_a_dropped_link_leaves_the_turret_in_front_after_reconnecting(make: type[Rig]) -> None:
    rig = make(["drop-link:1.5:0.3"])
    with pytest.raises(LinkLostError) as err:
        rig.robot.ultrascan()
    assert err.value.action == "ultrascan"
    turret = rig.world.turret_angle
    assert abs(turret) > math.radians(5)  # it stopped somewhere in the sweep
    back = rig.back()
    assert back.action == "ultrascan" and back.done == 0.0
    assert back.tacho_before == {"turret": 0} and back.tacho_after is not None
    assert back.tacho_after["turret"] == round(math.degrees(turret))
    assert rig.world.turret_angle == pytest.approx(0.0, abs=math.radians(1.5))
    assert rig.robot.ultrascan().ranges.size == 360


def test_a_turn_cut_by_a_dropped_link_gives_the_angle_turned(make: type[Rig]) -> None:
    rig = make(["drop-link:0.6:0.3"])
    with pytest.raises(LinkLostError):
        rig.robot.turn(math.pi)
    back = rig.back()
    turned = rig.world.pose.theta - START.theta
    assert back.action == "turn" and 0.05 < back.done < math.pi - 0.05
    assert back.done == pytest.approx(turned, abs=math.radians(1.0))


def test_a_stall_longer_than_the_reply_timeout_is_a_lost_link_and_the_brick_is_found_after_it(
        make: type[Rig]) -> None:
    rig = make(["stall:1.0:2.5"], reply_timeout_s=0.5)
    with pytest.raises(LinkLostError, match="timed out"):
        rig.robot.move(40.0)
    assert rig.world.faults.fired[0] is not None
    back: Resumption | None = None
    for _ in range(20):  # each attempt waits at most the reply timeout; the stall ends within 2.5 s
        try:
            back = rig.robot.reconnect()
            break
        except LinkLostError as exc:
            assert "not back" in str(exc)
    assert back is not None and back.action == "move"
    assert back.done == pytest.approx(rig.world.pose.y - START.y, abs=0.05)


def test_a_link_that_stays_down_refuses_every_attempt_quickly(make: type[Rig]) -> None:
    rig = make(["drop-link:0.5:600"])
    with pytest.raises(LinkLostError):
        rig.robot.ultrascan()
    for _ in range(3):
        with pytest.raises(LinkLostError, match="the brick is not back: no brick server"):
            rig.robot.reconnect()
    rig.robot.close()  # closes quietly without a link
    with pytest.raises(RobotError, match="closed"):
        rig.robot.reconnect()


def test_a_robot_built_without_a_connector_cannot_reconnect(make: type[Rig]) -> None:
    rig = make([])
    bare = NxtRobot(rig.robot.brick, owns_brick=False)
    with pytest.raises(RobotError, match="cannot reconnect"):
        bare.reconnect()


def test_a_sweep_cut_by_a_short_stall_sends_nothing_more_on_the_broken_link() -> None:
    """After a reply timed out, a request on the same connection would get the late reply of the one before:
    the robot lets the connection go at once, even in the middle of a sweep."""
    config = BrickConfig(time_factor=1000.0, max_step_s=0.01)
    at_fault: list[int] = []
    world = BrickWorld(load_map("map1"), START, config, sensor_noise=0.0, rng=1,
                       faults=FaultSchedule(["stall:1.0:0.8"], rng=1))
    with BrickServer(world, port=0) as server:
        world.faults.on_fire = lambda fault, fired: at_fault.append(server.brick.telegrams)
        robot = connect_robot("socket", host="127.0.0.1", port=server.port, reply_timeout_s=0.4)
        try:
            with pytest.raises(LinkLostError, match="timed out") as err:
                robot.ultrascan()
            assert err.value.action == "ultrascan"
            assert server.wait_departures(1, timeout=30)  # the brick saw the connection go
            assert at_fault and server.brick.telegrams == at_fault[0]  # nothing sent after the stalled request
            back = robot.reconnect()
            assert back.action == "ultrascan"
            assert robot.ultrascan().ranges.size == 360  # and the new link answers in step
        finally:
            robot.close()
