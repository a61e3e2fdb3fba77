"""The Robot protocol shared by the simulator and the NXT, and the data it exchanges.

These are the paper's four functions: Move (forward, with the collision watchdog), Turn (about the
wheel-axis centre), Turnback (back off to a safe distance) and Ultrascan (a 360-degree turret sweep).
Only a simulator knows the true pose; localisers and planners never see it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field

from .errors import ConfigError
from .geometry import Pose
from .typed import Real, typed_dataclass, with_unit

__all__ = [
    "NO_ECHO",
    "BackoffDistance",
    "MoveOutcome",
    "Reconnectable",
    "Resumption",
    "Robot",
    "RobotCounters",
    "RobotGeometry",
    "Scan",
    "TruthSource",
    "WatchdogDistance",
    "default_scan_angles",
]

NO_ECHO = 255.0
"""The LEGO ultrasonic sensor's reading when no echo returns (cm)."""


def default_scan_angles(n: int = 360) -> NDArray[np.float64]:
    """`n` sensor angles (rad) evenly spaced over a full turn, starting straight ahead."""
    return np.arange(n, dtype=np.float64) * (2.0 * np.pi / n)



@typed_dataclass()
class RobotGeometry:
    """Physical constants of the robot (cm), with defaults for a typical NXT build (each field's
    description and unit is in its declaration)."""

    radius_cm: Real = Field(default=8.0, gt=0, json_schema_extra=with_unit("cm"), description=(
        "Radius of the disc that contains the robot, centred on the wheel axis midpoint."))
    wheel_diameter_cm: Real = Field(default=5.6, gt=0, json_schema_extra=with_unit("cm"), description=(
        "Drive wheel diameter (the standard NXT wheel is 5.6 cm)."))
    track_width_cm: Real = Field(default=12.0, gt=0, json_schema_extra=with_unit("cm"), description=(
        "Distance between the wheel contact points (a calibration value, 11-14 cm on typical builds)."))
    sensor_offset_cm: Real = Field(default=0.0, json_schema_extra=with_unit("cm"), description=(
        "Distance from the turret axis to the sensor face; the paper's turret is homocentric with the wheel "
        "axis and readings are taken from the centre, so the default is 0."))
    turret_gear_ratio: Real = Field(default=1.0, gt=0, json_schema_extra=with_unit("motor deg / sensor deg"),
                                    description=(
        "Turret motor degrees per degree of sensor rotation."))

    @property
    def wheel_circumference_cm(self) -> float:
        """Distance driven per wheel revolution (cm)."""
        return float(np.pi * self.wheel_diameter_cm)

    def to_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in self.__dataclass_fields__}


@dataclass(frozen=True, eq=False)
class Scan:
    """One turret sweep.

    Attributes
    ----------
    angles : (n,) ndarray
        Sensor directions relative to the robot heading (rad).
    ranges : (n,) ndarray
        Readings (cm); ``inf`` (simulated, no wall) or 255 (NXT, no echo) where `valid` is False.
    valid : (n,) bool ndarray
        Whether each reading is a usable echo.
    """

    angles: NDArray[np.float64]
    ranges: NDArray[np.float64]
    valid: NDArray[np.bool_]

    @classmethod
    def from_readings(cls, angles: ArrayLike, ranges: ArrayLike, max_range: float = NO_ECHO) -> Scan:
        """A scan whose invalid readings are the non-finite ones and those >= `max_range`."""
        a = np.asarray(angles, dtype=float).ravel()
        r = np.asarray(ranges, dtype=float).ravel()
        if a.shape != r.shape:
            raise ConfigError(f"{a.size} angles but {r.size} ranges")
        return cls(a, r, np.isfinite(r) & (r < max_range) & (r >= 0))

    def __len__(self) -> int:
        return int(self.angles.size)

    def subset(self, mask: ArrayLike) -> Scan:
        """The readings where `mask` is True."""
        m = np.asarray(mask, dtype=bool)
        return Scan(self.angles[m], self.ranges[m], self.valid[m])

    def to_dict(self) -> dict[str, Any]:
        """JSON form: angles in degrees, ranges in cm with ``None`` where there is no echo."""
        return {
            "angles_deg": np.degrees(self.angles).tolist(),
            "ranges_cm": [float(r) if v else None for r, v in zip(self.ranges, self.valid, strict=True)],
        }


@dataclass(frozen=True)
class MoveOutcome:
    """What a Move reported.

    Attributes
    ----------
    requested_cm : float
        Commanded distance (negative = backwards).
    distance_cm : float
        Distance the robot believes it drove (wheel odometry, not the truth).
    watchdog : bool
        True when the motion stopped early: the forward sonar read a wall within the watchdog distance
        (a potential collision), or the wheels stalled.
    stalled : bool
        True when it was the wheels that stalled (a contact the sonar need not hear; NXT).
    """

    requested_cm: float
    distance_cm: float
    watchdog: bool = False
    stalled: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"requested_cm": self.requested_cm, "distance_cm": self.distance_cm, "watchdog": self.watchdog}


@dataclass(frozen=True)
class Resumption:
    """What an action cut short by a lost link did, as the robot measured it once its link was back.

    Attributes
    ----------
    action : str
        The action that was cut short (``move``, ``turn``, ``turnback``, ``ultrascan``, ...; empty when
        none was under way).
    requested : float
        What it was asked to do: cm for moves, rad for turns, 0 otherwise.
    done : float
        What the wheels' tachometers say it did, in the same unit (0 for other actions).
    tacho_before, tacho_after : dict or None
        Rotation counts (degrees): of the motors the action drives (``left`` and ``right``, or
        ``turret``) when it started (None when the link broke before they were read), and of all three
        after the link came back (before the turret was turned back to the front).
    """

    action: str
    requested: float
    done: float
    tacho_before: dict[str, int] | None = None
    tacho_after: dict[str, int] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {"action": self.action, "requested": self.requested, "done": self.done,
                "tacho_before": self.tacho_before, "tacho_after": self.tacho_after}


@runtime_checkable
class Robot(Protocol):
    """What every robot (simulated or NXT) offers the localisation procedure and the mission.

    A backend of one's own needs no base class and no registry: any object with these members is a
    `Robot` (``isinstance`` checks them). What the mission demands of one: lengths in cm, angles in
    rad (counter-clockwise), times in s; `move` returns what the robot *believes* it drove (its
    odometry, never the truth) and stops a forward move when the sonar reads closer than the watchdog
    distance; `ultrascan` takes angles relative to the heading and marks the echoes in its `Scan`;
    `robot_time_s` only grows. The optional capabilities below (`WatchdogDistance`, `BackoffDistance`,
    `RobotCounters`, `Reconnectable`, `TruthSource`) are separate protocols the mission checks with
    ``isinstance``. ``docs/howto/robot-backend.md`` writes one and runs a mission on it.
    """

    geometry: RobotGeometry

    def move(self, distance_cm: float) -> MoveOutcome:
        """Drive straight; forward moves stop early when the sonar reads closer than the watchdog."""
        ...

    def turn(self, angle_rad: float) -> None:
        """Spin in place about the wheel-axis centre (counter-clockwise positive)."""
        ...

    def ultrascan(self, angles: ArrayLike | None = None) -> Scan:
        """Sweep the turret (default 360 readings, 1 degree apart) and return it to the front."""
        ...

    def turnback(self) -> MoveOutcome:
        """Back off from a wall to the safe distance."""
        ...

    def stop(self) -> None:
        """Stop all motors now."""
        ...

    def close(self) -> None:
        """Stop and release the robot."""
        ...

    @property
    def robot_time_s(self) -> float:
        """Time the robot has spent acting so far (modelled on the simulator, measured on the NXT)."""
        ...


# -- optional capabilities: a robot declares one by having its member (checked with isinstance) ----------
@runtime_checkable
class RobotCounters(Protocol):
    """A robot that keeps an account of its own work."""

    def counters(self) -> dict[str, float]:
        """Running totals: ``odometry_cm`` (driven, forward and backward), ``watchdog_stops``, and the
        robot time split ``sweep_s``, ``turret_return_s``, ``drive_s``, ``turn_s``, ``readings``."""
        ...


@runtime_checkable
class WatchdogDistance(Protocol):
    """A robot that says at which distance (cm) its watchdog stops a move."""

    @property
    def watchdog_distance_cm(self) -> float: ...


@runtime_checkable
class BackoffDistance(Protocol):
    """A robot that says how far (cm) its `turnback` reverses."""

    @property
    def backoff_distance_cm(self) -> float: ...


@runtime_checkable
class Reconnectable(Protocol):
    """A robot that can reach its brick again after a lost link (`LinkLostError`)."""

    def reconnect(self) -> Resumption:
        """Reconnect (raises `LinkLostError` while the link stays down, `RobotError` when it cannot come
        back); what the interrupted motion did, by the tachometers."""
        ...


@runtime_checkable
class TruthSource(Protocol):
    """Where reports take what only a simulated world knows (never given to a localiser): the robot's
    true pose and its contacts with the walls."""

    @property
    def true_pose(self) -> Pose: ...

    @property
    def collisions(self) -> int: ...
