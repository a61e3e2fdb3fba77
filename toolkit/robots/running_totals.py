"""The running totals a robot keeps of its own work, written once for the simulator and the NXT."""

from __future__ import annotations

__all__ = ["RunningTotals"]


class RunningTotals:
    """What a robot counts as it works (`toolkit.world.RobotCounters`): the distance driven (cm, forward and
    backward), the watchdog's stops, and the robot time split (s) into sweeps, turret returns, drives and
    turns, with the sonar readings of the sweeps. `reset_totals` sets every one to zero."""

    watchdog_stops: int
    odometry_cm: float
    sweep_s: float
    turret_return_s: float
    drive_s: float
    turn_s: float
    readings: int

    def reset_totals(self) -> None:
        """Every total back to zero."""
        self.watchdog_stops = 0
        self.odometry_cm = 0.0
        self.sweep_s = 0.0
        self.turret_return_s = 0.0
        self.drive_s = 0.0
        self.turn_s = 0.0
        self.readings = 0

    def counters(self) -> dict[str, float]:
        """The running totals by name (`toolkit.world.RobotCounters`)."""
        return {"watchdog_stops": float(self.watchdog_stops), "odometry_cm": self.odometry_cm,
                "sweep_s": self.sweep_s, "turret_return_s": self.turret_return_s, "drive_s": self.drive_s,
                "turn_s": self.turn_s, "readings": float(self.readings)}
