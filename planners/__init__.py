"""Path planners for a disc robot in a polygonal map, all validated by the shared FCL checker."""

from .base import PLANNERS, Planner, PlanningProblem, PlanResult, make_planner

__all__ = ["PLANNERS", "PlanResult", "Planner", "PlanningProblem", "make_planner"]
