"""How far a robot reverses after a watchdog stop and where its watchdog stops a move (cm).

The mission's context and its recovery both ask these; they live apart from both.
"""

from __future__ import annotations

from ..world import BackoffDistance, Robot, WatchdogDistance

__all__ = ["BACKOFF_CM", "backoff_cm", "watchdog_cm"]

BACKOFF_CM = 10.0
"""How far (cm) a robot that does not say (`toolkit.world.BackoffDistance`) reverses in `turnback`."""


def backoff_cm(robot: Robot) -> float:
    """How far (cm) `robot`'s `turnback` reverses: its own when it says (`toolkit.world.BackoffDistance`),
    else `BACKOFF_CM`."""
    return float(robot.backoff_distance_cm) if isinstance(robot, BackoffDistance) else BACKOFF_CM


def watchdog_cm(robot: Robot) -> float:
    """The distance (cm) at which `robot`'s watchdog stops a move: its own when it says
    (`toolkit.world.WatchdogDistance`), else the radius plus 4 cm."""
    if isinstance(robot, WatchdogDistance):
        return float(robot.watchdog_distance_cm)
    return float(robot.geometry.radius_cm) + 4.0
