"""A LEGO Mindstorms NXT robot driven through nxt-python (USB, Bluetooth or nxt-python's socket link).

`NxtRobot` implements the `toolkit.world.Robot` protocol with the paper's four functions:

Move
    Both wheels turn by the tacho count of the distance (the brick stops each motor at its tacho
    limit) while the robot polls the ultrasonic sensor: a forward move stops early when the sensor
    reads closer than the watchdog distance (the collision watchdog) or when the wheels stall. The
    outcome reports the distance the tachos say was driven.
Turn
    The wheels turn in opposite senses by ``angle * track / wheel diameter`` degrees.
Ultrascan
    The turret steps through the requested angles (one reading per degree by default), reading the
    sensor at each step, then turns back to the front (so its cable never winds up). The scan
    records the angle the turret's tacho reached.
Turnback
    Reverses ``backoff_cm``.

Every motion is tacho-limited on the brick (the firmware stops the motor at its limit even when the
computer has crashed or the link is lost), and ends with the motors braked. Any failure during an
action (an exception, Ctrl-C) brakes the motors and raises `RobotError` saying what happened. A lost
link (the connection closed, a reply that does not come within ``reply_timeout_s``) raises
`toolkit.world.LinkLostError`, which says what was under way; `NxtRobot.reconnect` reaches the brick
again, brakes every motor, turns the turret back to the front and reads the tachometers to tell how
much of the interrupted motion happened (a `toolkit.world.Resumption`).
``robot_time_s`` is measured: the brick's own millisecond tick (read from the firmware's command
module) when the brick offers it, otherwise the wall clock around each action.

nxt-python (GPL-3.0, extra ``nxt``) is imported only when a robot is created. `connect_robot` is the
one entry point the command line uses::

    robot = connect_robot("socket", host="127.0.0.1", port=2727)       # the virtual brick
    robot = connect_robot("usb", profile="myrobot.yaml")                 # a real brick
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import importlib.util
import logging
import math
import socket
import struct
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..world import LinkLostError, MoveOutcome, Resumption, RobotError, Scan
from .nxt_profile import NxtProfile, ProfileError

__all__ = ["BACKENDS", "DEFAULT_REPLY_TIMEOUT_S", "NxtProfile", "NxtRobot", "ProfileError", "connect_robot",
           "find_brick"]

_log = logging.getLogger(__name__)

BACKENDS = ("usb", "bluetooth", "socket")
"""The nxt-python backends `connect_robot` accepts."""

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


def _link_broken(exc: BaseException) -> bool:
    """Whether `exc` means the link itself failed (closed, reset, timed out, the USB device gone)."""
    return isinstance(exc, OSError | EOFError | struct.error)


def _import_nxt() -> ModuleType:
    """nxt-python, imported on first use; a clear error when the extra is missing."""
    try:
        nxt = importlib.import_module("nxt")
        for sub in ("nxt.locator", "nxt.motor", "nxt.sensor", "nxt.error", "nxt.brick"):
            importlib.import_module(sub)
    except ImportError as exc:
        raise RobotError(f"nxt-python is not installed ({exc}); install it with: pip install 'nxtnav[nxt]'") \
            from None
    return nxt


def _describe(exc: BaseException) -> str:
    """One line naming what went wrong with the link or the command."""
    if isinstance(exc, struct.error | EOFError | ConnectionError | BrokenPipeError):
        return f"lost the connection to the brick ({type(exc).__name__}: {exc or 'no reply'})"
    if isinstance(exc, OSError):
        return f"link error ({exc.strerror or exc})"
    text = str(exc) or type(exc).__name__
    return f"{type(exc).__name__}: {text}"


class NxtRobot:
    """A LEGO NXT robot (implements `toolkit.world.Robot`); see the module docstring.

    Parameters
    ----------
    brick : nxt.brick.Brick
        A connected brick (see `connect_robot` / `find_brick`).
    profile : NxtProfile, path or None
        Wiring and calibration; a path is read as a YAML profile; None uses the defaults.
    owns_brick : bool
        Whether `close` also closes the brick connection.
    reply_timeout_s : float or None
        Seconds to wait for one reply before the link counts as lost (socket and Bluetooth links;
        None waits for ever, as nxt-python does).
    connector : callable or None
        Finds the brick again for `reconnect` (called with `reply_timeout_s`; `connect_robot` gives
        one); None: this robot cannot reconnect.
    """

    def __init__(self, brick: Any, profile: NxtProfile | str | Path | None = None, *,
                 owns_brick: bool = True, reply_timeout_s: float | None = DEFAULT_REPLY_TIMEOUT_S,
                 connector: _Connector | None = None) -> None:
        self._nxt = _import_nxt()
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
        _set_reply_timeout(brick, reply_timeout_s)
        self.link = str(getattr(getattr(brick, "_sock", None), "type", None) or "unknown")
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
        self.watchdog_stops = 0
        self.odometry_cm = 0.0
        self.sonar_reads = 0
        # the split of robot_time_s (s) and the readings of the sweeps, as the simulator keeps them
        self.sweep_s = 0.0
        self.turret_return_s = 0.0
        self.drive_s = 0.0
        self.turn_s = 0.0
        self.readings = 0
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

    @property
    def watchdog_distance_cm(self) -> float:
        """The distance (cm) at which the watchdog stops a move (the profile's)."""
        return float(self.profile.watchdog_distance_cm)

    @property
    def backoff_distance_cm(self) -> float:
        """How far (cm) `turnback` reverses (the profile's)."""
        return float(self.profile.backoff_cm)

    def counters(self) -> dict[str, float]:
        """The robot's running totals (`toolkit.world.RobotCounters`)."""
        return {"watchdog_stops": float(self.watchdog_stops), "odometry_cm": self.odometry_cm,
                "sweep_s": self.sweep_s, "turret_return_s": self.turret_return_s, "drive_s": self.drive_s,
                "turn_s": self.turn_s, "readings": float(self.readings)}

    def set_profile(self, profile: NxtProfile) -> None:
        """Use new calibration values (the wiring must stay the same)."""
        old = self.profile
        wiring = ("left_port", "right_port", "turret_port", "sonar_port")
        changed = [k for k in wiring if getattr(old, k) != getattr(profile, k)]
        if changed:
            raise RobotError(f"cannot change the wiring ({', '.join(changed)}) of a connected robot")
        self.profile = profile
        self.geometry = profile.geometry
        self._drive_sign = -1 if profile.reverse_drive else 1
        self._turret_sign = -1 if profile.reverse_turret else 1

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
            return f"could not stop the motors: {_describe(exc)}"
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
            if _link_broken(exc):
                raise self._lost(what, exc) from exc
            stopped = self._safe_stop()
            raise RobotError(f"{what} failed: {_describe(exc)}; {stopped}") from exc
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
        _log.info("%s: the link to the brick is lost (%s)", what, _describe(exc))
        return LinkLostError(f"{what} failed: {_describe(exc)}; could not stop the motors: the link is lost "
                             "(the brick stops each motor at its tacho limit)", action, requested)

    def _note_start(self, counts: dict[str, int]) -> None:
        """Remember the counts of the motors the action under way drives, as it starts."""
        if self._pending is not None:
            self._pending = replace(self._pending, tacho_before=counts)

    def _drop_link(self) -> None:
        """Close the connection without a goodbye (the other end is gone or not answering)."""
        self.link_down = True
        link: Any = getattr(self.brick, "_sock", None)
        raw = getattr(link, "_sock", None)
        if raw is not None:
            with contextlib.suppress(OSError):
                raw.close()
            link._sock = None

    def reconnect(self) -> Resumption:
        """Try once to reach the brick again after a lost link.

        On success: the sensor is set up again, every motor braked, the turret turned back to the
        front, and the tachometers read (the brick keeps its counts while the link is down), so the
        returned `Resumption` tells how much of the interrupted motion happened. The interrupted
        action's time up to now counts as robot time (the brick's tick went on). Raises
        `LinkLostError` when the brick cannot be reached (try again later), `RobotError` when this
        robot cannot reconnect at all.
        """
        self._check_open()
        if self._connector is None:
            raise RobotError("this NXT robot cannot reconnect (it was not connected by connect_robot)")
        self._drop_link()
        try:
            brick = self._connector(self.reply_timeout_s)
        except RobotError as exc:
            raise LinkLostError(f"the brick is not back: {exc}") from None
        self.brick = brick
        self.link_down = False
        pending = self._interrupted or _Pending("", 0.0, None)
        with self._action("reconnect"):
            now = self._clock()
            self._start_sensor()
            for port in (self._left, self._right, self._turret):
                self._brake(port)
            counts = self._counts()
            self._turret_to(0, counts["turret"])
            self._brake(self._turret)
        self._add_interrupted_time(pending, now)
        self._interrupted = None
        done = self._done(pending, counts)
        _log.info("link back; the interrupted %s did %.2f of %.2f", pending.action or "action", done, pending.requested)
        return Resumption(pending.action, pending.requested, done, pending.tacho_before, counts)

    def _add_interrupted_time(self, pending: _Pending, now: tuple[str, float]) -> None:
        """Count the interrupted action's time, from its start to `now` on the brick's clock, as robot time."""
        if pending.start is None:
            return
        dt = self._elapsed(pending.start, now)
        if 0 <= dt <= _MAX_OUTAGE_S:
            self._time += dt
            if pending.split is not None:
                setattr(self, pending.split, getattr(self, pending.split) + dt)

    def _done(self, pending: _Pending, counts: dict[str, int]) -> float:
        """What the tachos say the interrupted motion did (cm or rad; 0 when it had not started)."""
        before = pending.tacho_before
        if before is None or pending.action not in ("move", "turn"):
            return 0.0
        sgn = self._drive_sign
        left = (counts["left"] - before["left"]) * sgn
        right = (counts["right"] - before["right"]) * sgn
        if pending.action == "turn":
            return self.profile.spin_rad(0.5 * (right - left))
        return self.profile.distance_cm(0.5 * (left + right))

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

    # -- the paper's functions --------------------------------------------------------------------
    def _wheels(self, left_deg: float, right_deg: float, power: int, watchdog: bool) -> tuple[float, float, str]:
        """Turn the wheels by the given angles (deg, robot sense); returns what they turned and why."""
        ports = [self._left, self._right]
        sgn = self._drive_sign
        start = [self._state(p)[0] for p in ports]
        self._note_start({"left": start[0], "right": start[1]})
        wanted = [round(left_deg) * sgn, round(right_deg) * sgn]
        if watchdog and all(self.read_sonar() < self.profile.watchdog_distance_cm for _ in range(2)):
            return 0.0, 0.0, "watchdog"
        why = "done"
        if any(wanted):
            for port, w in zip(ports, wanted, strict=True):
                if w:
                    self._run(port, power if w > 0 else -power, abs(w))
                else:
                    self._brake(port)
            why, _ = self._wait(ports, start, [s + w for s, w in zip(start, wanted, strict=True)], watchdog)
        for port in ports:
            self._brake(port)
        end = self._settle(ports, [self._state(p)[0] for p in ports])
        return (end[0] - start[0]) * sgn, (end[1] - start[1]) * sgn, why

    def move(self, distance_cm: float) -> MoveOutcome:
        """Drive `distance_cm` straight (negative = backwards); forward moves run the watchdog."""
        d = float(distance_cm)
        if not math.isfinite(d):
            raise RobotError(f"move distance must be finite, got {distance_cm!r}")
        with self._action(f"move {d:.1f} cm", "drive_s", motion=("move", d)):
            deg = self.profile.wheel_degrees(d)
            left, right, why = self._wheels(deg, deg, self.profile.drive_power, watchdog=d > 0)
        done = self.profile.distance_cm(0.5 * (left + right))
        stopped = why != "done"
        if stopped:
            self.watchdog_stops += 1
            _log.info("move %.1f cm stopped after %.1f cm (%s)", d, done, why)
        self.odometry_cm += abs(done)
        return MoveOutcome(d, done, stopped, stalled=why == "stalled")

    def turn(self, angle_rad: float) -> None:
        """Spin in place by `angle_rad` (counter-clockwise positive)."""
        a = float(angle_rad)
        if not math.isfinite(a):
            raise RobotError(f"turn angle must be finite, got {angle_rad!r}")
        with self._action(f"turn {math.degrees(a):.1f} deg", "turn_s", motion=("turn", a)):
            w = self.profile.spin_degrees(a)
            self._wheels(-w, w, self.profile.turn_power, watchdog=False)

    def turnback(self) -> MoveOutcome:
        """Reverse `backoff_cm` after a watchdog stop."""
        return self.move(-self.profile.backoff_cm)

    def _turret_to(self, target: int, pos: int) -> int:
        """Turn the turret motor from position `pos` to `target` (deg); return where it ended."""
        delta = target - pos
        if delta:
            power = self.profile.turret_power
            self._run(self._turret, power if delta > 0 else -power, abs(delta))
            _, (pos,) = self._wait([self._turret], [pos], [target], watchdog=False)
            (pos,) = self._settle([self._turret], [pos])
        return pos

    def ultrascan(self, angles: ArrayLike | None = None) -> Scan:
        """Step the turret over `angles` (rad, relative to the heading, counter-clockwise; default a
        full turn in ``scan_step_deg`` steps), read the sensor at each, then turn it back."""
        if angles is None:
            n = max(1, round(360.0 / self.profile.scan_step_deg))
            rel = np.arange(n) * math.radians(self.profile.scan_step_deg)
        else:
            rel = np.asarray(angles, dtype=float).ravel()
        if not np.all(np.isfinite(rel)):
            raise RobotError("scan angles must be finite")
        gear, sgn = self.profile.turret_gear_ratio, self._turret_sign
        got = np.empty(rel.size)
        ranges = np.empty(rel.size)
        back = 0.0
        with self._action("ultrascan", "sweep_s", motion=("ultrascan", 0.0)):
            pos, _ = self._state(self._turret)
            self._note_start({"turret": pos})
            try:
                for i, a in enumerate(rel):
                    pos = self._turret_to(round(math.degrees(a) * gear) * sgn, pos)
                    got[i] = math.radians(pos * sgn / gear)
                    ranges[i] = self.read_sonar()
            except BaseException as exc:
                # whatever went wrong, the turret goes back (its cable); over a broken link nothing is sent
                # (a late reply would answer the next request), and reconnecting turns it back
                if not _link_broken(exc):
                    self._turret_home()
                raise
            back = self._turret_home()
        self.sweep_s -= back
        self.turret_return_s += back
        self.readings += int(rel.size)
        return Scan.from_readings(got, ranges)

    def _turret_home(self) -> float:
        """Turn the turret back to the front and brake it; the time it took (s)."""
        t_back = self._clock()
        self._turret_to(0, self._state(self._turret)[0])
        self._brake(self._turret)
        return self._elapsed(t_back, self._clock())

    def stop(self) -> None:
        """Brake all three motors now."""
        self._check_open()
        if self.link_down:
            raise LinkLostError("could not stop the motors: the link to the brick is lost")
        try:
            for port in (self._left, self._right, self._turret):
                self._brake(port)
            self._state(self._left)
        except Exception as exc:
            raise RobotError(f"could not stop the motors: {_describe(exc)}") from exc

    def close(self) -> None:
        """Brake the motors and release the brick (idempotent)."""
        if self.closed:
            return
        if not self.link_down:
            self._safe_stop()
        self.closed = True
        if self.owns_brick and not self.link_down:
            try:
                self.brick.close()
            except Exception:  # the link is already gone: release it without a goodbye
                self._drop_link()
                self.brick._sock = None

    def __enter__(self) -> NxtRobot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def robot_time_s(self) -> float:
        """Time spent in actions so far (s): brick ticks when available, else wall clock."""
        return self._time

    @property
    def clock_source(self) -> str:
        """``brick`` when `robot_time_s` counts the brick's tick, ``wall`` otherwise."""
        return "brick" if self._tick_ok else "wall"

    def info(self) -> dict[str, Any]:
        """Brick name, firmware and protocol versions, battery (mV) and link type."""
        self._check_open()
        try:
            name, address, _, flash = self.brick.get_device_info()
            (pmaj, pmin), (fmaj, fmin) = self.brick.get_firmware_version()
            battery = int(self.brick.get_battery_level())
        except Exception as exc:
            raise RobotError(f"cannot read the brick's information: {_describe(exc)}") from exc
        return {"name": name, "address": address, "firmware": f"{fmaj}.{fmin}", "protocol": f"{pmaj}.{pmin}",
                "battery_mv": battery, "free_flash": int(flash), "link": self.link}


# -- finding a brick -------------------------------------------------------------------------------
class _MuteSocketBackend(logging.Filter):
    """nxt-python logs a traceback when a socket connection is refused; we report it ourselves."""

    def filter(self, record: logging.LogRecord) -> bool:
        return False


def _no_brick_message(backend: str, host: str | None, port: int | None, detail: str = "") -> str:
    extra = f" ({detail})" if detail else ""
    if backend == "usb":
        return ("no NXT brick found over USB" + extra + ". Check: the brick is switched on and the USB cable "
                "plugged in; your user may open the device (install the udev rule from docs/hardware.md, "
                "then unplug and replug the brick); libusb-1.0 is installed; no other program (another "
                "nxt-python, NXT-G, BricxCC) holds the brick")
    if backend == "bluetooth":
        missing = importlib.util.find_spec("bluetooth") is None
        return ("no NXT brick found over Bluetooth" + extra + ". Check: "
                + ("PyBluez is installed (pip install pybluez); " if missing else "")
                + "Bluetooth is on in the brick's menu and on this computer; the brick is paired "
                "(bluetoothctl pair <address>, PIN 1234) and within range; give its address with --bt-address")
    return (f"no brick server at {host}:{port}" + extra + ". Start one with `nxtnav brick serve --port "
            f"{port}` (the virtual brick) or `nxt-server` on the computer with the brick, and check the "
            "host and port")


def _set_reply_timeout(brick: Any, timeout_s: float | None) -> None:
    """Make the link's socket (socket and Bluetooth backends) give up on a reply after `timeout_s`."""
    raw = getattr(getattr(brick, "_sock", None), "_sock", None)
    if raw is not None and hasattr(raw, "settimeout"):
        raw.settimeout(timeout_s)


def _socket_brick(nxt: ModuleType, host: str, port: int, timeout_s: float) -> Any:
    """A brick behind a brick server, reached within `timeout_s` seconds (nxt-python's own socket
    connection waits for ever on a server that accepts but does not answer)."""
    backend = importlib.import_module("nxt.backend.socket")
    link = backend.SocketSock(host, port)
    raw = socket.create_connection((host, port), timeout=timeout_s)
    link._sock = raw
    try:
        link.send(bytes((0x98,)))  # the socket link's connection-type query
        kind = link.recv()
        if not kind:
            raise ConnectionResetError("the server closed the connection")
    except BaseException:
        raw.close()
        raise
    link.type = "ip" + kind.decode("ascii", "replace")
    return nxt.brick.Brick(link)


def find_brick(backend: str, *, host: str | None = None, port: int | None = None, name: str | None = None,
               address: str | None = None, timeout_s: float | None = None) -> Any:
    """Connect to one brick with nxt-python's locator; failures become a `RobotError` with the fixes.

    Parameters
    ----------
    backend : {"usb", "bluetooth", "socket"}
        How to reach the brick.
    host, port : str, int
        The brick server of the socket backend (default 127.0.0.1:2727).
    name : str or None
        Only accept a brick with this name.
    address : str or None
        Bluetooth address of the brick (``00:16:53:xx:xx:xx``).
    timeout_s : float or None
        Socket backend without a `name`: give up after this many seconds on a server that does not
        answer (None: nxt-python's locator, which waits for ever).
    """
    if backend not in BACKENDS:
        raise RobotError(f"unknown NXT backend {backend!r}; known: {', '.join(BACKENDS)}")
    nxt = _import_nxt()
    kwargs: dict[str, Any] = {}
    if backend == "socket":
        host = host or "127.0.0.1"
        port = 2727 if port is None else int(port)
        kwargs.update(server_host=host, server_port=port)
    if name:
        kwargs["name"] = name
    if address:
        kwargs["host"] = address
    mute = _MuteSocketBackend()
    sock_log = logging.getLogger("nxt.backend.socket")
    sock_log.addFilter(mute)
    try:
        if backend == "socket" and timeout_s is not None and not name:
            assert host is not None and port is not None
            return _socket_brick(nxt, host, port, timeout_s)
        with warnings.catch_warnings():
            # nxt-python's socket backend leaves the socket of a refused connection to the collector
            warnings.simplefilter("ignore", ResourceWarning)
            # usb/bluetooth read nxt-python's own config file (~/.nxt-python.conf: name, host)
            config = None if backend == "socket" else "default"
            return nxt.locator.find(backends=[backend], config=config, **kwargs)
    except nxt.locator.BrickNotFoundError:
        raise RobotError(_no_brick_message(backend, host, port)) from None
    except Exception as exc:
        kind = type(exc).__name__
        if kind == "NoBackendError":
            detail = "pyusb finds no libusb backend: install libusb-1.0"
        elif getattr(exc, "errno", None) == 13 or isinstance(exc, PermissionError):
            detail = "permission denied on the USB device"
        elif isinstance(exc, ConnectionRefusedError):
            raise RobotError(_no_brick_message(backend, host, port)) from None
        elif isinstance(exc, OSError | ValueError):
            detail = f"{kind}: {exc or 'no answer'}"
        else:
            raise
        raise RobotError(_no_brick_message(backend, host, port, detail)) from None
    finally:
        sock_log.removeFilter(mute)


def connect_robot(backend: str, *, host: str | None = None, port: int | None = None,
                  profile: NxtProfile | str | Path | None = None, name: str | None = None,
                  address: str | None = None, reply_timeout_s: float | None = DEFAULT_REPLY_TIMEOUT_S) -> NxtRobot:
    """Find a brick and return an `NxtRobot` on it (the mission's and the CLI's entry point).

    Parameters
    ----------
    backend : {"usb", "bluetooth", "socket"}
        How to reach the brick; ``socket`` talks to `nxtnav brick serve` or nxt-python's ``nxt-server``.
    host, port : str, int
        Brick server address for the socket backend (default 127.0.0.1:2727).
    profile : NxtProfile, path or None
        Robot profile (YAML path or object); None uses the defaults.
    name, address : str or None
        Restrict the search to a brick name / Bluetooth address.
    reply_timeout_s : float or None
        Seconds to wait for one reply before the link counts as lost (`DEFAULT_REPLY_TIMEOUT_S`); the
        robot can `NxtRobot.reconnect` to the same brick.

    Raises
    ------
    RobotError
        No brick found (the message lists the usual fixes), nxt-python missing, or the brick does
        not answer as an NXT robot should.
    """
    prof = profile if isinstance(profile, NxtProfile) or profile is None else NxtProfile.load(profile)
    again = functools.partial(_find_again, backend, host, port, name, address)
    brick = find_brick(backend, host=host, port=port, name=name, address=address)
    try:
        return NxtRobot(brick, prof, owns_brick=True, reply_timeout_s=reply_timeout_s, connector=again)
    except Exception:
        with contextlib.suppress(Exception):
            brick.close()
        raise


def _find_again(backend: str, host: str | None, port: int | None, name: str | None, address: str | None,
                timeout_s: float | None) -> Any:
    """`find_brick` for `NxtRobot.reconnect`: the same brick, bounded by the reply timeout where it can be."""
    return find_brick(backend, host=host, port=port, name=name, address=address, timeout_s=timeout_s)
