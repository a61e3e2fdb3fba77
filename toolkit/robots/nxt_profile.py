"""The NXT robot profile: wiring and calibration of one LEGO robot, kept in a small YAML file.

Example file (every key is optional; missing keys take the defaults below)::

    # nxtnav robot profile
    left_port: A            # left drive wheel motor
    right_port: B           # right drive wheel motor
    turret_port: C          # sensor turret motor
    sonar_port: 4           # ultrasonic sensor input (1-4)
    wheel_diameter_cm: 5.6
    track_width_cm: 12.0
    turret_gear_ratio: 1.0  # turret motor degrees per degree of sensor rotation
    drive_power: 50
    watchdog_cm: 12.0

`nxtnav nxt calibrate` measures ``wheel_diameter_cm`` and ``track_width_cm`` and writes the file.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import yaml

from ..world import NxtnavError, RobotGeometry
from ..world.yaml_text import YAMLError, load_yaml

__all__ = ["NxtProfile", "ProfileError", "calibrated_track_width", "calibrated_wheel_diameter"]


class ProfileError(NxtnavError):
    """A robot profile file or value is invalid."""


_MOTOR_PORTS = ("A", "B", "C")


@dataclass(frozen=True)
class NxtProfile:
    """Wiring and calibration of an NXT robot (lengths in cm, angles in degrees).

    Parameters
    ----------
    left_port, right_port, turret_port : {"A", "B", "C"}
        Motor outputs of the left wheel, right wheel and sensor turret (three different ports).
    sonar_port : {1, 2, 3, 4}
        Input port of the ultrasonic sensor.
    wheel_diameter_cm : float
        Drive wheel diameter (standard NXT wheel 5.6 cm); calibrated by driving a known distance.
    track_width_cm : float
        Distance between the wheel contact points; calibrated by spinning a known angle.
    radius_cm : float
        Radius of the disc containing the robot (planning and collision margin).
    turret_gear_ratio : float
        Turret motor degrees per degree of sensor rotation.
    sensor_offset_cm : float
        Distance from the turret axis to the sensor face.
    reverse_drive, reverse_turret : bool
        Set when a positive motor power drives the robot backwards / turns the turret clockwise.
    drive_power, turn_power, turret_power : int
        Motor powers (1-100) for moves, spins and turret steps.
    watchdog_cm : float or None
        A forward move stops when the sonar reads closer than this (default radius + 4 cm).
    backoff_cm : float
        How far Turnback reverses (cm).
    scan_step_deg : float
        Turret step between two readings of a default Ultrascan (1 degree = 360 readings).
    sonar_interval_s : float
        Least wall time between two sonar reads on a real brick (the sensor gives ~50 readings/s);
        not applied on the virtual brick.
    stall_s : float
        A motion whose tachos have not changed for this long (brick or wall seconds) is stopped.
    motion_timeout_s : float
        Upper bound on one motion (wall seconds) before the robot gives up with an error.
    """

    left_port: str = "A"
    right_port: str = "B"
    turret_port: str = "C"
    sonar_port: int = 4
    wheel_diameter_cm: float = 5.6
    track_width_cm: float = 12.0
    radius_cm: float = 8.0
    turret_gear_ratio: float = 1.0
    sensor_offset_cm: float = 0.0
    reverse_drive: bool = False
    reverse_turret: bool = False
    drive_power: int = 50
    turn_power: int = 40
    turret_power: int = 30
    watchdog_cm: float | None = None
    backoff_cm: float = 10.0
    scan_step_deg: float = 1.0
    sonar_interval_s: float = 0.02
    stall_s: float = 0.5
    motion_timeout_s: float = 60.0

    def __post_init__(self) -> None:
        for k in ("left_port", "right_port", "turret_port"):
            v = getattr(self, k)
            if not isinstance(v, str) or v.upper() not in _MOTOR_PORTS:
                raise ProfileError(f"profile field {k}: expected one of A, B, C, got {v!r}")
            object.__setattr__(self, k, v.upper())
        ports = (self.left_port, self.right_port, self.turret_port)
        if len(set(ports)) != 3:
            raise ProfileError(f"profile fields left_port, right_port, turret_port must differ, got {ports}")
        if not (isinstance(self.sonar_port, int) and not isinstance(self.sonar_port, bool)
                and 1 <= self.sonar_port <= 4):
            raise ProfileError(f"profile field sonar_port: expected 1, 2, 3 or 4, got {self.sonar_port!r}")
        for k in ("wheel_diameter_cm", "track_width_cm", "radius_cm", "turret_gear_ratio", "backoff_cm",
                  "scan_step_deg", "stall_s", "motion_timeout_s"):
            _check_number(k, getattr(self, k), positive=True)
        for k in ("sensor_offset_cm", "sonar_interval_s"):
            _check_number(k, getattr(self, k), positive=False)
        if self.watchdog_cm is not None:
            _check_number("watchdog_cm", self.watchdog_cm, positive=True)
        for k in ("drive_power", "turn_power", "turret_power"):
            v = getattr(self, k)
            if not (isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 100):
                raise ProfileError(f"profile field {k}: expected a whole number from 1 to 100, got {v!r}")
        for k in ("reverse_drive", "reverse_turret"):
            if not isinstance(getattr(self, k), bool):
                raise ProfileError(f"profile field {k}: expected true or false, got {getattr(self, k)!r}")

    # -- derived ----------------------------------------------------------------------------------
    @property
    def geometry(self) -> RobotGeometry:
        """The robot constants the planners and localisers use."""
        return RobotGeometry(radius_cm=self.radius_cm, wheel_diameter_cm=self.wheel_diameter_cm,
                             track_width_cm=self.track_width_cm, sensor_offset_cm=self.sensor_offset_cm,
                             turret_gear_ratio=self.turret_gear_ratio)

    @property
    def watchdog_distance_cm(self) -> float:
        """The watchdog threshold in effect (cm)."""
        return self.radius_cm + 4.0 if self.watchdog_cm is None else float(self.watchdog_cm)

    def wheel_degrees(self, distance_cm: float) -> float:
        """Wheel rotation (deg) that drives the robot `distance_cm`."""
        return distance_cm / (math.pi * self.wheel_diameter_cm) * 360.0

    def distance_cm(self, wheel_deg: float) -> float:
        """Distance (cm) driven by a wheel rotation of `wheel_deg`."""
        return wheel_deg / 360.0 * math.pi * self.wheel_diameter_cm

    def spin_degrees(self, angle_rad: float) -> float:
        """Rotation (deg) of each wheel, in opposite senses, that spins the robot by `angle_rad`."""
        return math.degrees(angle_rad) * self.track_width_cm / self.wheel_diameter_cm

    def spin_rad(self, wheel_deg: float) -> float:
        """The spin (rad) of the robot when each wheel turns `wheel_deg` in opposite senses (the inverse
        of `spin_degrees`)."""
        return math.radians(wheel_deg * self.wheel_diameter_cm / self.track_width_cm)

    # -- files ------------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: Any, where: str = "profile") -> NxtProfile:
        """A profile from a mapping; unknown keys and bad values raise `ProfileError` naming them."""
        if data is None:
            data = {}
        if not isinstance(data, dict):
            raise ProfileError(f"{where}: expected a mapping of profile fields, got {type(data).__name__}")
        known = {f.name: f for f in fields(cls)}
        unknown = sorted(set(map(str, data)) - set(known))
        if unknown:
            raise ProfileError(f"{where}: unknown profile field {unknown[0]!r}; known: {', '.join(known)}")
        values = dict(data)
        for k in ("sonar_port", "drive_power", "turn_power", "turret_power"):
            v = values.get(k)
            if isinstance(v, float) and v.is_integer():
                values[k] = int(v)
        for k in ("wheel_diameter_cm", "track_width_cm", "radius_cm", "turret_gear_ratio", "sensor_offset_cm",
                  "backoff_cm", "scan_step_deg", "sonar_interval_s", "stall_s", "motion_timeout_s",
                  "watchdog_cm"):
            v = values.get(k)
            if isinstance(v, int) and not isinstance(v, bool):
                values[k] = float(v)
        try:
            return cls(**values)
        except ProfileError as exc:
            raise ProfileError(f"{where}: {exc}") from None

    @classmethod
    def load(cls, path: str | Path) -> NxtProfile:
        """Read a profile YAML file."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as exc:
            raise ProfileError(f"cannot read robot profile {p}: {exc.strerror or exc}") from None
        try:
            data = load_yaml(text)
        except YAMLError as exc:
            raise ProfileError(f"robot profile {p} is not valid YAML: {str(exc).splitlines()[0]}") from None
        return cls.from_dict(data, where=str(p))

    def save(self, path: str | Path) -> Path:
        """Write the profile as YAML (with a comment header); returns the path."""
        p = Path(path)
        body = yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=False)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("# nxtnav robot profile (cm, degrees); see docs/hardware.md\n" + body, encoding="utf-8")
        return p

    def updated(self, **changes: Any) -> NxtProfile:
        """A copy with some fields changed (validated)."""
        return replace(self, **changes)


def _check_number(name: str, value: Any, positive: bool) -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or (positive and value <= 0) or (not positive and value < 0):
        need = "a positive number" if positive else "a number >= 0"
        raise ProfileError(f"profile field {name}: expected {need}, got {value!r}")


def calibrated_wheel_diameter(diameter_cm: float, commanded_cm: float, measured_cm: float) -> float:
    """Wheel diameter that makes a commanded drive match the measured one.

    The wheels turned ``commanded / (pi * diameter)`` revolutions and the robot covered
    `measured_cm`, so the true diameter is ``diameter * measured / commanded``.
    """
    for name, v in (("commanded distance", commanded_cm), ("measured distance", measured_cm)):
        if not (math.isfinite(v) and v > 0):
            raise ProfileError(f"{name} must be a positive number of cm, got {v!r}")
    return diameter_cm * measured_cm / commanded_cm


def calibrated_track_width(track_cm: float, commanded_deg: float, measured_deg: float) -> float:
    """Track width that makes a commanded spin match the measured one.

    Each wheel turned ``commanded * track / diameter`` degrees and the robot spun `measured_deg`, so
    the true track is ``track * commanded / measured``.
    """
    for name, v in (("commanded angle", commanded_deg), ("measured angle", measured_deg)):
        if not (math.isfinite(v) and v > 0):
            raise ProfileError(f"{name} must be a positive number of degrees, got {v!r}")
    return track_cm * commanded_deg / measured_deg
