"""The error hierarchy of nxtnav: every error the toolkit raises on purpose derives from `NxtnavError`."""

from __future__ import annotations

__all__ = [
    "ConfigError",
    "LinkLostError",
    "LocalisationError",
    "MapError",
    "NxtnavError",
    "PlanningError",
    "RegistryError",
    "RobotError",
]


class NxtnavError(Exception):
    """Base class of every error nxtnav raises on purpose; the CLI prints its message as one line."""


class ConfigError(NxtnavError, ValueError):
    """Options that cannot work together (a budget too small for the map, say): bad input, never a result."""


class MapError(NxtnavError):
    """A map file or map geometry is missing, malformed or invalid."""


class PlanningError(NxtnavError):
    """A planning problem is malformed (planners report an unreachable goal as a failed result instead)."""


class LocalisationError(NxtnavError):
    """A localiser was used wrongly (for example a tracker without a prior)."""


class RobotError(NxtnavError):
    """The robot (simulated or real) cannot carry out a command or lost its connection."""


class LinkLostError(RobotError):
    """The link to the robot broke during an action (a pulled cable, Bluetooth out of range, a brick that
    stopped answering); the robot may be reached again (see `toolkit.world.Resumption`).

    Attributes
    ----------
    action : str
        The action that was cut short (``move``, ``turn``, ``turnback``, ``ultrascan``, ...).
    requested : float
        What it was asked to do: cm for moves, rad for turns, 0 otherwise.
    """

    def __init__(self, message: str, action: str = "", requested: float = 0.0) -> None:
        super().__init__(message)
        self.action = action
        self.requested = requested


class RegistryError(NxtnavError, KeyError):
    """An unknown or duplicate plug-in name."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""
