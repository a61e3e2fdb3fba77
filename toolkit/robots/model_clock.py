"""The robot-time model as a clock beside any robot: what the model promises for the commands sent.

`ModelClock` wraps a `toolkit.world.Robot` (a real NXT, the virtual brick, the simulator), forwards
every command and adds up what `RobotTiming` says each one costs. On an NXT, `robot_time_s` is the
brick's measured time and `model_time_s` the model's for the very same commands, so the model, on
which the simulator's robot times rest, can be checked on the robot itself.
"""

from __future__ import annotations

from typing import Any

from numpy.typing import ArrayLike

from ..world import MoveOutcome, Robot, RobotGeometry, Scan
from .sim import RobotTiming

__all__ = ["ModelClock"]


class ModelClock:
    """A robot that forwards to `robot` and keeps the time model's account of the commands.

    Parameters
    ----------
    robot : Robot
        The robot to drive; other attributes (counters, ``true_pose``) are read through.
    timing : RobotTiming, optional
        The model (the simulator's default).

    Attributes
    ----------
    model_time_s : float
        The model's time (s) for every command sent so far: moves by the distance reported driven,
        turns by the angle commanded, sweeps by their angles (the requested ones; the angles the
        turret reached when the robot chose its default sweep).
    """

    def __init__(self, robot: Robot, timing: RobotTiming | None = None) -> None:
        self.robot = robot
        self.geometry: RobotGeometry = robot.geometry
        self.timing = timing or RobotTiming()
        self.model_time_s = 0.0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.robot, name)

    @property
    def robot_time_s(self) -> float:
        """The robot's own time (measured on an NXT, modelled on the simulator) (s)."""
        return float(self.robot.robot_time_s)

    def move(self, distance_cm: float) -> MoveOutcome:
        out = self.robot.move(distance_cm)
        self.model_time_s += self.timing.move(out.distance_cm)
        return out

    def turn(self, angle_rad: float) -> None:
        self.robot.turn(angle_rad)
        self.model_time_s += self.timing.turn(angle_rad)

    def ultrascan(self, angles: ArrayLike | None = None) -> Scan:
        scan = self.robot.ultrascan(angles)
        self.model_time_s += self.timing.scan(scan.angles if angles is None else angles)
        return scan

    def turnback(self) -> MoveOutcome:
        out = self.robot.turnback()
        self.model_time_s += self.timing.move(out.distance_cm)
        return out

    def stop(self) -> None:
        self.robot.stop()

    def close(self) -> None:
        self.robot.close()
