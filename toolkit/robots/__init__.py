"""Robot implementations of the `toolkit.world.Robot` protocol."""

from .sim import MotionNoise, RobotTiming, SimRobot

__all__ = ["MotionNoise", "RobotTiming", "SimRobot"]
