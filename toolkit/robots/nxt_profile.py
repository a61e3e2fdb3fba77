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
from dataclasses import asdict, replace
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import BeforeValidator, Field, StrictBool, model_validator

from ..world import ConfigError, RobotGeometry
from ..world.typed import Real, Whole, build, typed_dataclass, worded
from ..world.yaml_text import YAMLError, load_yaml

__all__ = ["NxtProfile", "ProfileError", "calibrated_track_width", "calibrated_wheel_diameter"]


class ProfileError(ConfigError):
    """A robot profile file or value is invalid."""


def _port(value: Any) -> Any:
    """A motor port as written (``a`` or ``A``), upper-case; anything else is left to the field's check."""
    return value.upper() if isinstance(value, str) else value


MotorPort = Annotated[Literal["A", "B", "C"], BeforeValidator(_port)]
Power = Annotated[Whole, Field(ge=1, le=100, json_schema_extra={"unit": "% of full motor power"})]


def _field(default: Any, unit: str, text: str, **limits: Any) -> Any:
    return Field(default, json_schema_extra={"unit": unit}, description=text, **limits)


@typed_dataclass()
class NxtProfile:
    """Wiring and calibration of an NXT robot (lengths in cm, angles in degrees); each field's range,
    unit and meaning is in its declaration, and the profile file holds the same fields."""

    left_port: MotorPort = Field(default="A", description="Motor output of the left wheel.")
    right_port: MotorPort = Field(default="B", description="Motor output of the right wheel.")
    turret_port: MotorPort = Field(default="C", description="Motor output of the sensor turret.")
    sonar_port: Whole = Field(default=4, ge=1, le=4, description="Input port of the ultrasonic sensor (1-4).")
    wheel_diameter_cm: Real = _field(5.6, "cm", "Drive wheel diameter (standard NXT wheel 5.6 cm); calibrated "
                                                "by driving a known distance.", gt=0)
    track_width_cm: Real = _field(12.0, "cm", "Distance between the wheel contact points; calibrated by spinning "
                                              "a known angle.", gt=0)
    radius_cm: Real = _field(8.0, "cm", "Radius of the disc containing the robot (planning and collision margin).",
                             gt=0)
    turret_gear_ratio: Real = _field(1.0, "motor deg / sensor deg", "Turret motor degrees per degree of sensor "
                                                                    "rotation.", gt=0)
    sensor_offset_cm: Real = _field(0.0, "cm", "Distance from the turret axis to the sensor face.", ge=0)
    reverse_drive: StrictBool = Field(default=False, description="A positive motor power drives the robot backwards.")
    reverse_turret: StrictBool = Field(default=False, description="A positive motor power turns the turret clockwise.")
    drive_power: Power = Field(default=50, description="Motor power of moves.")
    turn_power: Power = Field(default=40, description="Motor power of spins.")
    turret_power: Power = Field(default=30, description="Motor power of turret steps.")
    watchdog_cm: Real | None = _field(None, "cm", "A forward move stops when the sonar reads closer than this "
                                                  "(default: radius + 4 cm).", gt=0)
    backoff_cm: Real = _field(10.0, "cm", "How far Turnback reverses.", gt=0)
    scan_step_deg: Real = _field(1.0, "deg", "Turret step between two readings of a default Ultrascan (1 degree "
                                             "= 360 readings).", gt=0)
    sonar_interval_s: Real = _field(0.02, "s", "Least wall time between two sonar reads on a real brick (the "
                                               "sensor gives ~50 readings/s); not applied on the virtual brick.", ge=0)
    stall_s: Real = _field(0.5, "s", "A motion whose tachos have not changed for this long (brick or wall "
                                     "seconds) is stopped.", gt=0)
    motion_timeout_s: Real = _field(60.0, "s", "Upper bound on one motion (wall seconds) before the robot gives "
                                               "up with an error.", gt=0)

    @model_validator(mode="after")
    def _ports_differ(self) -> NxtProfile:
        ports = (self.left_port, self.right_port, self.turret_port)
        if len(set(ports)) != 3:
            raise worded(f"profile fields left_port, right_port, turret_port must differ, got {ports}")
        return self

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
        """A profile from a mapping (None: the defaults); unknown keys and bad values raise `ProfileError`
        naming `where`, the field and the value."""
        if data is not None and not isinstance(data, dict):
            raise ProfileError(f"{where}: expected a mapping of profile fields, got {type(data).__name__}")
        try:
            return build(cls, data or {}, where)
        except ConfigError as exc:
            raise ProfileError(str(exc)) from None

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
