"""nxtnav: localisation and navigation with one rotating ultrasonic sensor (LEGO NXT and simulation)."""

from .world import (
    CollisionChecker,
    Map,
    MapError,
    NxtnavError,
    Pose,
    RobotGeometry,
    Scan,
    load_map,
)

__all__ = ["CollisionChecker", "Map", "MapError", "NxtnavError", "Pose", "RobotGeometry", "Scan", "load_map"]
__version__ = "0.1.0"
