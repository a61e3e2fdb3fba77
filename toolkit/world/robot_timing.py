"""How long the robot takes for each action: `RobotTiming`, the one account of robot time.

The simulator charges it (`toolkit.robots.sim.SimRobot`), the model clock checks it on the brick
(`toolkit.robots.model_clock`), and the planners' ``robot-time`` objective charges a path by it
(`toolkit.world.robot_cost`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from .arrays import FloatArray
from .typed import Real, typed_dataclass

__all__ = ["RobotTiming"]

_EPS_RAD = 1e-9


@typed_dataclass()
class RobotTiming:
    """How long a real NXT takes for each action (for `robot_time_s`); each field's unit and meaning is in
    its declaration.

    A sweep costs its readings plus the turret's travel: from the front through the requested
    angles in the order given, then back to the front (so the sensor cable never winds up). A full
    360-reading sweep at one-degree steps is 8.3 s of readings, 1.5 s of turret travel out and 1.5 s
    back: 11.3 s. The reading time and the turret rate are those of the default NXT profile on the
    virtual brick over a link of 3 ms per round trip (USB); drive and turn rates are kept below the
    brick's (about 19 cm/s and 150 deg/s with the profile's powers), so the model does not promise
    more than a robot gives.
    """

    drive_speed_cm_s: Real = Field(default=15.0, gt=0, json_schema_extra={"unit": "cm/s"},
                                   description="Straight-line speed.")
    turn_rate_deg_s: Real = Field(default=90.0, gt=0, json_schema_extra={"unit": "deg/s"},
                                  description="Spin-in-place rate.")
    reading_s: Real = Field(default=0.023, ge=0, json_schema_extra={"unit": "s"}, description=(
        "Time per sonar reading, the turret standing; the sensor gives at most ~50 readings/s."))
    turret_rate_deg_s: Real = Field(default=240.0, gt=0, json_schema_extra={"unit": "deg/s"},
                                    description="Turret speed (sensor degrees per second).")
    stop_turn_s: Real = Field(default=0.0, ge=0, json_schema_extra={"unit": "s"}, description=(
        "Fixed time of each stop-and-turn command besides the spin itself: 0 by default, the simulator's "
        "account so far; the brick's command round trip and motor settling when measured."))

    def move(self, distance_cm: float) -> float:
        """Time (s) to drive `distance_cm` (either sense)."""
        return abs(distance_cm) / self.drive_speed_cm_s

    def turn(self, angle_rad: float) -> float:
        """Time (s) to stop and spin by `angle_rad` (a zero turn costs nothing)."""
        if abs(angle_rad) <= _EPS_RAD:
            return 0.0
        return abs(math.degrees(angle_rad)) / self.turn_rate_deg_s + self.stop_turn_s

    def sweep(self, angles_rad: ArrayLike) -> tuple[float, float]:
        """(sweep, return) times (s) of an Ultrascan over `angles_rad` (relative, in the order given):
        the readings and the turret's travel from the front through them, then the travel back."""
        deg = np.degrees(np.asarray(angles_rad, dtype=float).ravel())
        if deg.size == 0:
            return 0.0, 0.0
        out = float(np.abs(np.diff(deg, prepend=0.0)).sum())
        return deg.size * self.reading_s + out / self.turret_rate_deg_s, abs(float(deg[-1])) / self.turret_rate_deg_s

    def scan(self, angles_rad: ArrayLike) -> float:
        """Whole time (s) of an Ultrascan over `angles_rad`, turret return included."""
        return sum(self.sweep(angles_rad))

    def reading_times(self, angles_rad: ArrayLike) -> FloatArray:
        """When each reading of an Ultrascan over `angles_rad` is done (s after the sweep starts): the
        turret's travel to each angle plus one reading time per reading; the last is the sweep time."""
        deg = np.degrees(np.asarray(angles_rad, dtype=float).ravel())
        return np.cumsum(np.abs(np.diff(deg, prepend=0.0)) / self.turret_rate_deg_s + self.reading_s)

    @property
    def cm_per_rad(self) -> float:
        """Driving distance (cm) that takes as long as spinning one radian: robot time in cm."""
        return self.drive_speed_cm_s / math.radians(self.turn_rate_deg_s)

    def to_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in self.__dataclass_fields__}
