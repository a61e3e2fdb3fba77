"""The world layer: geometry, maps, collision checking, sonar models and the Robot protocol.

Planners and localisers import from here and nowhere else in `toolkit`.
"""

from .collision import CollisionChecker
from .errors import LocalisationError, MapError, NxtnavError, PlanningError, RegistryError, RobotError
from .geometry import (
    Pose,
    RngLike,
    angle_diff,
    as_rng,
    circular_mean,
    ray_cast,
    ray_wall_distances,
    wrap_angle,
)
from .maps import Map, list_maps, load_map, map_from_dict
from .registry import Registry
from .robot import NO_ECHO, MoveOutcome, Robot, RobotGeometry, Scan, default_scan_angles
from .sonar import SONAR_MODELS, IdealSonar, NxtSonar, SonarModel, make_sonar

__all__ = [
    "NO_ECHO",
    "SONAR_MODELS",
    "CollisionChecker",
    "IdealSonar",
    "LocalisationError",
    "Map",
    "MapError",
    "MoveOutcome",
    "NxtSonar",
    "NxtnavError",
    "PlanningError",
    "Pose",
    "Registry",
    "RegistryError",
    "RngLike",
    "Robot",
    "RobotError",
    "RobotGeometry",
    "Scan",
    "SonarModel",
    "angle_diff",
    "as_rng",
    "circular_mean",
    "default_scan_angles",
    "list_maps",
    "load_map",
    "make_sonar",
    "map_from_dict",
    "ray_cast",
    "ray_wall_distances",
    "wrap_angle",
]
