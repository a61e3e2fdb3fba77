"""The world layer: geometry, maps, collision checking, sonar models and the Robot protocol.

Planners and localisers import from here and nowhere else in `toolkit`.
"""

from .collision import CollisionChecker
from .conformant import ConformantChecker, RigidMove
from .errors import (
    ConfigError,
    LinkLostError,
    LocalisationError,
    MapError,
    NxtnavError,
    PlanningError,
    RegistryError,
    RobotError,
)
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
from .grids import OccupancyGrid, grid_to_map, polygonise
from .importers import import_map
from .laser import LaserScanner
from .maps import COORDINATE_LIMIT_CM, GridSpec, Map, Region, list_maps, load_map, map_from_dict
from .params import Configurable, OptionInfo, Options, configure, option
from .point_collision import CHECKER_BACKENDS, PointCollisionChecker, make_checker
from .registry import Registry
from .robot import (
    NO_ECHO,
    BackoffDistance,
    MoveOutcome,
    Reconnectable,
    Resumption,
    Robot,
    RobotCounters,
    RobotGeometry,
    Scan,
    TruthSource,
    WatchdogDistance,
    default_scan_angles,
)
from .robot_cost import (
    OBJECTIVE_UNITS,
    OBJECTIVES,
    PathCost,
    check_objective,
    objective_cost,
    path_cost,
    predicted_error_cm,
    robot_time_s,
    robot_times_s,
    segment_turns,
)
from .robot_model import FACETS, NXT_SONAR_SIGMA_CM, MotionNoise, RobotModel
from .robot_timing import RobotTiming
from .sonar import SONAR_MODELS, IdealSonar, NxtSonar, SonarModel, make_sonar

__all__ = [
    "CHECKER_BACKENDS",
    "COORDINATE_LIMIT_CM",
    "FACETS",
    "NO_ECHO",
    "NXT_SONAR_SIGMA_CM",
    "OBJECTIVES",
    "OBJECTIVE_UNITS",
    "SONAR_MODELS",
    "BackoffDistance",
    "CollisionChecker",
    "ConfigError",
    "Configurable",
    "ConformantChecker",
    "GridSpec",
    "IdealSonar",
    "LaserScanner",
    "LinkLostError",
    "LocalisationError",
    "Map",
    "MapError",
    "MotionNoise",
    "MoveOutcome",
    "NxtSonar",
    "NxtnavError",
    "OccupancyGrid",
    "OptionInfo",
    "Options",
    "PathCost",
    "PlanningError",
    "PointCollisionChecker",
    "Pose",
    "Reconnectable",
    "Region",
    "Registry",
    "RegistryError",
    "Resumption",
    "RigidMove",
    "RngLike",
    "Robot",
    "RobotCounters",
    "RobotError",
    "RobotGeometry",
    "RobotModel",
    "RobotTiming",
    "Scan",
    "SonarModel",
    "TruthSource",
    "WatchdogDistance",
    "angle_diff",
    "as_rng",
    "check_objective",
    "circular_mean",
    "configure",
    "default_scan_angles",
    "grid_to_map",
    "import_map",
    "list_maps",
    "load_map",
    "make_checker",
    "make_sonar",
    "map_from_dict",
    "objective_cost",
    "option",
    "path_cost",
    "polygonise",
    "predicted_error_cm",
    "ray_cast",
    "ray_wall_distances",
    "robot_time_s",
    "robot_times_s",
    "segment_turns",
    "wrap_angle",
]
