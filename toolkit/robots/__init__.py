"""Robot implementations of the `toolkit.world.Robot` protocol."""

from .sim import MotionNoise, RobotTiming, SimRobot, simulated_sonar

__all__ = ["MotionNoise", "RobotTiming", "SimRobot", "simulated_sonar"]
