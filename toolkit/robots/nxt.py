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
import logging
from pathlib import Path
from typing import Any

from ..world import LinkLostError, Resumption, RobotError
from .nxt_actions import NxtActions
from .nxt_io import _MAX_OUTAGE_S, DEFAULT_REPLY_TIMEOUT_S, _Pending
from .nxt_link import BACKENDS, describe_failure, find_brick, link_of
from .nxt_profile import NxtProfile, ProfileError

__all__ = ["BACKENDS", "DEFAULT_REPLY_TIMEOUT_S", "NxtProfile", "NxtRobot", "ProfileError", "connect_robot",
           "find_brick"]

_log = logging.getLogger(__name__)


class NxtRobot(NxtActions):
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

    @property
    def watchdog_distance_cm(self) -> float:
        """The distance (cm) at which the watchdog stops a move (the profile's)."""
        return float(self.profile.watchdog_distance_cm)

    @property
    def backoff_distance_cm(self) -> float:
        """How far (cm) `turnback` reverses (the profile's)."""
        return float(self.profile.backoff_cm)

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
        own = link_of(brick)
        if own is not None:
            own.set_reply_timeout(self.reply_timeout_s)
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
            raise RobotError(f"cannot read the brick's information: {describe_failure(exc)}") from exc
        return {"name": name, "address": address, "firmware": f"{fmaj}.{fmin}", "protocol": f"{pmaj}.{pmin}",
                "battery_mv": battery, "free_flash": int(flash), "link": self.link}




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
