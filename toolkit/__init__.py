"""nxtnav: localisation and navigation with one rotating ultrasonic sensor (LEGO NXT and simulation).

The names below load on first use (`toolkit.world` pulls in numpy, shapely and FCL), so that the
command line starts its error handling before the heavy imports.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
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


def __getattr__(name: str) -> Any:
    if name in __all__:
        from . import world

        return getattr(world, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
