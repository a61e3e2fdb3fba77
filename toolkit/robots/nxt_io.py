"""The brick under an NXT robot: wiring, clock, motor and sensor commands, and the guard of every action.

`NxtBrickIo` is the lower half of `toolkit.robots.nxt.NxtRobot` (see that module for what the robot
does): it sends nxt-python's direct commands, polls the motors to their tacho limits, reads the
ultrasonic sensor over I2C, and runs every action inside `_action`, which times it and turns any
failure into a `RobotError` with the motors braked, or a lost link into a `LinkLostError`.
"""

from __future__ import annotations

import contextlib
import logging
import struct
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..world import LinkLostError, RobotError
from .nxt_link import describe_failure, import_nxt, link_broken, link_of
from .nxt_profile import NxtProfile
from .running_totals import RunningTotals

__all__ = ["DEFAULT_REPLY_TIMEOUT_S", "NxtBrickIo"]

_log = logging.getLogger("toolkit.robots.nxt")

_COMMAND_MODULE_ID = 0x00010001  # the firmware's command module; its IO map holds the tick
_TICK_OFFSET = 20
_US_ADDRESS = 0x02
_US_DISTANCE = 0x42
_US_COMMAND = 0x41
_US_CONTINUOUS = 0x02
_VIRTUAL_LINK = "ipvirtual"
_ARRIVAL_TOLERANCE_DEG = 3
_SETTLE_POLLS = 50
_MAX_OUTAGE_S = 86_400.0  # a brick tick further on than this after a reconnect: the brick restarted

DEFAULT_REPLY_TIMEOUT_S = 3.0
"""Seconds the robot waits for one reply of the brick before it takes the link as lost (socket and
Bluetooth links; a working link answers in milliseconds, Bluetooth in tens of them)."""

_Connector = Callable[[float | None], Any]
"""Finds the brick again: called with the reply timeout (s), returns a connected nxt-python brick."""


@dataclass(frozen=True)
class _Pending:
    """The action under way: its kind, what it was asked, the tachos at its start and its start clock."""

    action: str
    requested: float
    split: str | None
    start: tuple[str, float] | None = None
    tacho_before: dict[str, int] | None = None


class NxtBrickIo(RunningTotals):
    """The brick under an `NxtRobot`: its wiring and clock, the motor and sensor commands, the polling of
    the motors, and the guard every action runs in (`_action`). `NxtRobot` adds the paper's functions
    and reconnecting; the parameters are those of `NxtRobot`.

    """

    def __init__(self, brick: Any, profile: NxtProfile | str | Path | None = None, *,
                 owns_brick: bool = True, reply_timeout_s: float | None = DEFAULT_REPLY_TIMEOUT_S,
                 connector: _Connector | None = None) -> None:
        self._nxt = import_nxt()
        if profile is None:
            profile = NxtProfile()
        elif not isinstance(profile, NxtProfile):
            profile = NxtProfile.load(profile)
        self.profile = profile
        self.geometry = profile.geometry
        self.brick = brick
        self.owns_brick = owns_brick
        self.reply_timeout_s = reply_timeout_s
        self._connector = connector
        self.link_down = False
        self._depth = 0  # actions under way (one calls another's public method)
        self._pending: _Pending | None = None
        self._interrupted: _Pending | None = None
        own = link_of(brick)
        if own is not None:
            own.set_reply_timeout(reply_timeout_s)
        self.link = own.type if own is not None else "unknown"
        self.virtual = self.link == _VIRTUAL_LINK
        motor = self._nxt.motor
        self._left = motor.Port[profile.left_port]
        self._right = motor.Port[profile.right_port]
        self._turret = motor.Port[profile.turret_port]
        self._sonar = self._nxt.sensor.Port(profile.sonar_port - 1)
        self._drive_sign = -1 if profile.reverse_drive else 1
        self._turret_sign = -1 if profile.reverse_turret else 1
        self._hold = motor.Mode.ON | motor.Mode.BRAKE | motor.Mode.REGULATED
        self.closed = False
        self._time = 0.0
        self._last_sonar = 0.0
        self._tick_ok = True
        self.sonar_reads = 0
        self.reset_totals()  # the split of robot_time_s and the readings of the sweeps, as the simulator keeps them
        with self._action("connect"):
            self._start_sensor()
            for port in (self._left, self._right, self._turret):
                self.brick.reset_motor_position(port, False)
                self._brake(port)
            self._tick_ok = self._tick() is not None

    def _start_sensor(self) -> None:
        """Power the ultrasonic sensor's port and set it measuring continuously."""
        self.brick.set_input_mode(self._sonar, self._nxt.sensor.Type.LOW_SPEED_9V, self._nxt.sensor.Mode.RAW)
        if not self.virtual:
            time.sleep(0.1)  # the sensor's I2C bus needs a moment after power-up
        self._i2c_write(_US_COMMAND, bytes((_US_CONTINUOUS,)))

    # -- low level --------------------------------------------------------------------------------
    def _tick(self) -> int | None:
        """The brick's millisecond tick, or None when the brick does not offer it."""
        if not self._tick_ok:
            return None
        try:
            _, data = self.brick.read_io_map(_COMMAND_MODULE_ID, _TICK_OFFSET, 4)
            return int(struct.unpack("<I", bytes(data[:4]))[0])
        except self._nxt.error.ProtocolError:
            self._tick_ok = False
            return None

    def _clock(self) -> tuple[str, float]:
        tick = self._tick() if self._tick_ok else None
        return ("brick", float(tick)) if tick is not None else ("wall", time.monotonic())

    @staticmethod
    def _elapsed(start: tuple[str, float], end: tuple[str, float]) -> float:
        if start[0] != end[0]:
            return 0.0
        if start[0] == "brick":
            return ((int(end[1]) - int(start[1])) % (1 << 32)) / 1000.0
        return end[1] - start[1]

    def _run(self, port: Any, power: int, limit: int) -> None:
        """Set a motor going for `limit` tacho degrees: every motion is bounded on the brick itself, so a
        crashed or disconnected computer cannot leave the robot driving (a real NXT keeps running its
        motors when the link drops)."""
        if int(limit) <= 0:
            raise RobotError(f"refusing an unbounded motor command (tacho limit {limit})")
        m = self._nxt.motor
        self.brick.set_output_state(port, int(power), self._hold, m.RegulationMode.SPEED, 0, m.RunState.RUNNING,
                                    int(limit))

    def _brake(self, port: Any) -> None:
        m = self._nxt.motor
        self.brick.set_output_state(port, 0, self._hold, m.RegulationMode.SPEED, 0, m.RunState.RUNNING, 0)

    def _state(self, port: Any) -> tuple[int, bool]:
        """(rotation count in deg, whether the firmware reports the motor idle)."""
        s = self.brick.get_output_state(port)
        return int(s[9]), s[5] == self._nxt.motor.RunState.IDLE

    def tacho_counts(self) -> dict[str, int]:
        """The rotation counts (degrees, as the brick reports them) of the left, right and turret motors."""
        with self._action("read the tachometers"):
            return self._counts()

    def _counts(self) -> dict[str, int]:
        return {"left": self._state(self._left)[0], "right": self._state(self._right)[0],
                "turret": self._state(self._turret)[0]}

    def _i2c_write(self, register: int, values: bytes) -> None:
        self.brick.ls_write(self._sonar, bytes((_US_ADDRESS, register)) + values, 0)

    def read_sonar(self) -> float:
        """One ultrasonic reading (cm; 255 = no echo) in the turret's current direction."""
        if self._depth:  # inside an action (the watchdog of a move, a sweep)
            return self._read_sonar()
        with self._action("read the sonar"):
            return self._read_sonar()

    def _read_sonar(self) -> float:
        err = self._nxt.error
        if not self.virtual and self.profile.sonar_interval_s > 0:
            wait = self._last_sonar + self.profile.sonar_interval_s - time.monotonic()
            if wait > 0:
                time.sleep(wait)
        last: Exception | None = None
        for _ in range(3):
            try:
                self.brick.ls_write(self._sonar, bytes((_US_ADDRESS, _US_DISTANCE)), 1)
                for _ in range(30):
                    try:
                        if self.brick.ls_get_status(self._sonar) >= 1:
                            break
                    except err.I2CPendingError:
                        continue
                data = self.brick.ls_read(self._sonar)
                self._last_sonar = time.monotonic()
                if data:
                    self.sonar_reads += 1
                    return float(data[-1])
            except err.DirectProtocolError as exc:
                last = exc
        raise RobotError(f"the ultrasonic sensor on port {self.profile.sonar_port} does not answer ({last}); "
                         "check its cable and the profile's sonar_port")

    # -- guarding ---------------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self.closed:
            raise RobotError("the NXT robot is closed")

    def _safe_stop(self) -> str:
        try:
            for port in (self._left, self._right, self._turret):
                self._brake(port)
            self._state(self._left)  # a reply proves the brick has taken the brake commands
        except Exception as exc:  # the link itself is gone
            return f"could not stop the motors: {describe_failure(exc)}"
        return "motors stopped"

    @contextlib.contextmanager
    def _action(self, what: str, split: str | None = None, motion: tuple[str, float] | None = None) -> Iterator[None]:
        """Run one action: time it (adding the time to `split`, a counter such as ``drive_s``) and
        turn any failure into a `RobotError` with the motors stopped; a broken link into a
        `LinkLostError` that remembers the `motion` (kind, requested amount) under way."""
        self._check_open()
        if self.link_down:
            raise LinkLostError(f"{what}: the link to the brick is lost; reconnect first")
        start: tuple[str, float] | None = None
        if motion is not None:
            self._pending = _Pending(motion[0], motion[1], split)
        self._depth += 1
        try:
            start = self._clock()
            if self._pending is not None and motion is not None:
                self._pending = replace(self._pending, start=start)
            yield
            dt = self._elapsed(start, self._clock())
            self._time += dt
            if split is not None:
                setattr(self, split, getattr(self, split) + dt)
        except LinkLostError:
            raise
        except RobotError as exc:
            stopped = self._safe_stop()
            raise RobotError(f"{what}: {exc}; {stopped}") from exc
        except KeyboardInterrupt:
            stopped = self._safe_stop()
            raise RobotError(f"{what} interrupted by Ctrl-C; {stopped}") from None
        except Exception as exc:
            if link_broken(exc):
                raise self._lost(what, exc) from exc
            stopped = self._safe_stop()
            raise RobotError(f"{what} failed: {describe_failure(exc)}; {stopped}") from exc
        finally:
            self._depth -= 1
            if motion is not None:
                self._pending = None

    def _lost(self, what: str, exc: BaseException) -> LinkLostError:
        """The link broke during `what`: remember the motion under way, let the link go, say so."""
        pending = self._pending
        if self._interrupted is None:  # a failed reconnect keeps the first interruption
            self._interrupted = pending or _Pending("", 0.0, None)
        self._drop_link()
        action = pending.action if pending is not None else ""
        requested = pending.requested if pending is not None else 0.0
        _log.info("%s: the link to the brick is lost (%s)", what, describe_failure(exc))
        return LinkLostError(f"{what} failed: {describe_failure(exc)}; could not stop the motors: the link is lost "
                             "(the brick stops each motor at its tacho limit)", action, requested)

    def _note_start(self, counts: dict[str, int]) -> None:
        """Remember the counts of the motors the action under way drives, as it starts."""
        if self._pending is not None:
            self._pending = replace(self._pending, tacho_before=counts)

    def _drop_link(self) -> None:
        """Close the connection without a goodbye (the other end is gone or not answering)."""
        self.link_down = True
        own = link_of(self.brick)
        if own is not None:
            own.drop()

    def _wait(self, ports: list[Any], start: list[int], targets: list[int], watchdog: bool) -> tuple[str, list[int]]:
        """Poll until the motors reach their targets.

        Returns why the wait ended (``done``, ``watchdog`` or ``stalled``) and the last positions read.
        """
        last = list(start)
        sense = [1 if t >= s else -1 for s, t in zip(start, targets, strict=True)]
        still_since: tuple[str, float] | None = None
        deadline = time.monotonic() + self.profile.motion_timeout_s
        threshold = self.profile.watchdog_distance_cm
        while True:
            states = [self._state(p) for p in ports]
            pos = [s[0] for s in states]
            reached = all(d * (q - t) >= 0 for d, q, t in zip(sense, pos, targets, strict=True))
            if reached or all(s[1] for s in states):  # at (or past) the limit, or the firmware is done
                return "done", pos
            if watchdog and self.read_sonar() < threshold and self.read_sonar() < threshold:  # read twice (sim.py)
                return "watchdog", pos
            if pos != last:
                last, still_since = pos, None
            elif still_since is None:
                still_since = self._clock()
            elif self._elapsed(still_since, self._clock()) > self.profile.stall_s:
                # regulation may give up a degree or two short of the limit: that is arrival
                near = all(abs(q - t) <= _ARRIVAL_TOLERANCE_DEG for q, t in zip(pos, targets, strict=True))
                return ("done" if near else "stalled"), pos
            if time.monotonic() > deadline:
                raise RobotError(f"motion did not finish within {self.profile.motion_timeout_s:g} s")

    def _settle(self, ports: list[Any], pos: list[int]) -> list[int]:
        """Positions once the motors have come to rest (a real motor runs on a little past its
        limit or after the brake): two equal readings in a row, or after a bounded number of polls."""
        for _ in range(_SETTLE_POLLS):
            now = [self._state(p)[0] for p in ports]
            if now == pos:
                break
            pos = now
        return pos

    def _turret_to(self, target: int, pos: int) -> int:
        """Turn the turret motor from position `pos` to `target` (deg); return where it ended."""
        delta = target - pos
        if delta:
            power = self.profile.turret_power
            self._run(self._turret, power if delta > 0 else -power, abs(delta))
            _, (pos,) = self._wait([self._turret], [pos], [target], watchdog=False)
            (pos,) = self._settle([self._turret], [pos])
        return pos
