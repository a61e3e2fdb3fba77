"""The paper's functions of an NXT robot: move (with the collision watchdog), turn, ultrascan, turnback.

`NxtActions` is the middle of `toolkit.robots.nxt.NxtRobot`: each function is one guarded action of
`toolkit.robots.nxt_io.NxtBrickIo` (see `toolkit.robots.nxt` for what each does on the brick).
"""

from __future__ import annotations

import logging
import math

import numpy as np
from numpy.typing import ArrayLike

from ..world import LinkLostError, MoveOutcome, RobotError, Scan
from .command_checks import finite_command
from .nxt_io import NxtBrickIo
from .nxt_link import describe_failure, link_broken

__all__ = ["NxtActions"]

_log = logging.getLogger("toolkit.robots.nxt")


class NxtActions(NxtBrickIo):
    """Move, turn, ultrascan, turnback and stop, on the brick of `NxtBrickIo`."""

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
        d = finite_command(distance_cm, "move distance")
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
        a = finite_command(angle_rad, "turn angle")
        with self._action(f"turn {math.degrees(a):.1f} deg", "turn_s", motion=("turn", a)):
            w = self.profile.spin_degrees(a)
            self._wheels(-w, w, self.profile.turn_power, watchdog=False)

    def turnback(self) -> MoveOutcome:
        """Reverse `backoff_cm` after a watchdog stop."""
        return self.move(-self.profile.backoff_cm)

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
                if not link_broken(exc):
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
            raise RobotError(f"could not stop the motors: {describe_failure(exc)}") from exc
