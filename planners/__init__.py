"""Path planners for a disc robot in a polygonal map, all validated by one shared collision checker.

Importing the package registers every bundled planner in `PLANNERS`: ``min-turn`` (the paper's
Algorithm 1), ``rrtstar`` and ``prm`` (OMPL; any OMPL planner as ``ompl:NAME`` through
`make_planner`), ``astar`` (grid A*), and the references ``shortest``, ``min-link`` and ``fastest``
(least robot time).
See ``docs/planners.md``.
"""

from . import astar, min_turn, ompl_planners, reference, reference_time
from .astar import AStarPlanner
from .base import PLANNERS, Planner, PlanningProblem, PlanResult, PlanStatus, can_minimise, make_planner
from .metrics import PathMetrics, count_turns, path_length, path_metrics, turn_angle
from .min_turn import MinTurnPlanner
from .ompl_planners import OmplPlanner
from .reference import MinLinkPlanner, ShortestPathPlanner
from .reference_time import FastestPlanner

__all__ = [
    "PLANNERS",
    "AStarPlanner",
    "FastestPlanner",
    "MinLinkPlanner",
    "MinTurnPlanner",
    "OmplPlanner",
    "PathMetrics",
    "PlanResult",
    "PlanStatus",
    "Planner",
    "PlanningProblem",
    "ShortestPathPlanner",
    "astar",
    "can_minimise",
    "count_turns",
    "make_planner",
    "min_turn",
    "ompl_planners",
    "path_length",
    "path_metrics",
    "reference",
    "reference_time",
    "turn_angle",
]
