"""OMPL's geometric planners on the shared FCL checker: ``rrtstar``, ``prm`` and any ``ompl:NAME``.

The state space is OMPL's 2-D `RealVectorStateSpace` bounded by the map's bounding box (cm). State
validity is the shared checker's point check and motion validity is its swept-disc segment check,
installed as a Python `MotionValidator` subclass, so OMPL never discretises an edge into states: every
edge the planner keeps was checked exactly once by FCL. The optimisation objective is path length.

Time budget. `RRTConnect`, `RRT`, `KPIECE1` and other feasibility planners stop at their first
solution. Asymptotically optimal planners (`RRTstar`, `PRM` with a length objective, `BITstar`, ...)
never meet an unset cost threshold, so they use the whole budget and return the best path found; the
time and length of their *first* solution are reported in ``info`` (``first_solution_s``,
``first_solution_length_cm``) so the benchmark can show both. PRM and PRM* poll the time limit from a
second thread, where no Python code may run, so for them the first solution is not observed (NaN):
run them with ``stop_at_first=True`` to measure it (their planning time is then the time to the first
solution). ``stop_at_first=True`` sets the objective's cost threshold to infinity, so any planner
stops at its first exact solution.

Seeding. OMPL gives every RNG it creates (one per planner, one per state sampler) a seed drawn from a
process-wide seed generator, and `ompl.util.RNG.setSeed` re-seeds that generator (after the first RNG
exists it also logs an error, which is silenced here). The adapter calls ``RNG.setSeed`` with a seed
drawn from ``problem.rng`` just before it builds the space, the planner and its samplers, so the
same problem seed gives the same random draws in any process. Whether it gives the same *path*
depends on the planner: planners that stop at a solution (RRTConnect, RRT, ``stop_at_first=True``)
are reproducible; planners that run until the time budget ends do a number of iterations that depends
on the machine's speed, and PRM grows its roadmap in a second thread, so their final paths can differ
between runs with the same seed.

OMPL statuses map to `PlanResult` statuses: an exact solution is a success ("exact"); an approximate
solution (a path that stops short of the goal) is a failure ("approximate solution"); "timeout",
"invalid start", "invalid goal", "infeasible", ... are failures too.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import ompl.base as ob
import ompl.geometric as og
import ompl.util as ou

from toolkit.world import CollisionChecker, RegistryError

from .base import Planner, PlanningProblem

__all__ = ["OmplPlanner", "PrmPlanner", "RrtStarPlanner", "ompl_planner_names"]

_LOG_LEVELS = {
    "none": ou.LOG_NONE,
    "error": ou.LOG_ERROR,
    "warn": ou.LOG_WARN,
    "info": ou.LOG_INFO,
    "debug": ou.LOG_DEBUG,
}

# planners that evaluate the termination condition from a second thread
_THREADED = frozenset({"PRM", "PRMstar"})

_STATUS = {
    "EXACT_SOLUTION": "exact",
    "APPROXIMATE_SOLUTION": "approximate solution",
    "TIMEOUT": "timeout",
    "INVALID_START": "invalid start",
    "INVALID_GOAL": "invalid goal",
    "UNRECOGNIZED_GOAL_TYPE": "unrecognized goal type",
    "CRASH": "crash",
    "ABORT": "abort",
    "INFEASIBLE": "infeasible",
    "UNKNOWN": "no solution",
}


def ompl_planner_names() -> list[str]:
    """Names of the OMPL geometric planners this OMPL build exposes to Python (``RRTstar``, ``PRM``, ...)."""
    return sorted(
        n for n in dir(og) if isinstance(getattr(og, n), type) and issubclass(getattr(og, n), ob.Planner)
    )


class _SegmentValidator(ob.MotionValidator):
    """OMPL motion validation by the shared checker's exact swept-disc segment check."""

    def __init__(self, si: ob.SpaceInformation, checker: CollisionChecker) -> None:
        super().__init__(si)
        self._checker = checker

    def checkMotion(self, s1: Any, s2: Any, *rest: Any) -> bool:
        return self._checker.segment_free((s1[0], s1[1]), (s2[0], s2[1]))


class OmplPlanner(Planner):
    """Any OMPL geometric planner, validated by the shared checker.

    Parameters
    ----------
    planner : str
        OMPL class name in `ompl.geometric` ("RRTstar", "PRM", "BITstar", "RRTConnect", ...).
    simplify : bool
        Run OMPL's path simplifier (shortcutting, vertex reduction) on the solution; the length before
        and after is reported in ``info``. Simplification time counts in the planning time.
    range : float or None
        Maximum edge length (cm) for planners with ``setRange`` (RRT family); None keeps OMPL's default.
    stop_at_first : bool
        Stop at the first exact solution even for asymptotically optimal planners.
    settings : dict, optional
        Extra planner settings by OMPL setter name without ``set``, e.g. ``{"GoalBias": 0.1}`` calls
        ``setGoalBias(0.1)``.
    log_level : str
        OMPL's console log level while planning: "none", "error", "warn", "info" or "debug".

    Notes
    -----
    ``info`` holds ``ompl_status`` (OMPL's own words), ``first_solution_s``,
    ``first_solution_length_cm``, ``length_before_simplify_cm`` / ``length_after_simplify_cm`` and
    ``simplify_time_s`` (when simplifying), and the OMPL ``seed`` used.
    """

    def __init__(
        self,
        planner: str = "RRTstar",
        simplify: bool = False,
        range: float | None = None,
        stop_at_first: bool = False,
        settings: dict[str, Any] | None = None,
        log_level: str = "none",
    ) -> None:
        known = ompl_planner_names()
        if planner not in known:
            raise RegistryError(f"unknown OMPL planner {planner!r}; known: {', '.join(known)}")
        if log_level not in _LOG_LEVELS:
            raise ValueError(f"log_level must be one of {', '.join(_LOG_LEVELS)}, got {log_level!r}")
        if range is not None and not (math.isfinite(range) and range > 0):
            raise ValueError(f"range must be a positive number of cm, got {range!r}")
        cls = getattr(og, planner)
        for key in settings or {}:
            if not hasattr(cls, f"set{key}"):
                raise ValueError(f"OMPL planner {planner} has no setting {key!r} (no method set{key})")
        self.planner = planner
        self.simplify = bool(simplify)
        self.range = range
        self.stop_at_first = bool(stop_at_first)
        self.settings = dict(settings or {})
        self.log_level = log_level
        if type(self) is OmplPlanner:
            setattr(self, "name", f"ompl:{planner}")  # noqa: B010 (an instance name, not the registry's)

    def _solve(self, problem: PlanningProblem) -> tuple[Any, ...]:
        previous = ou.getLogLevel()
        ou.setLogLevel(_LOG_LEVELS[self.log_level])
        try:
            return self._solve_quiet(problem)
        finally:
            ou.setLogLevel(previous)

    def _solve_quiet(self, problem: PlanningProblem) -> tuple[Any, ...]:
        t0 = time.perf_counter()
        checker = problem.checker
        seed = int(problem.rng.integers(1, 2**31 - 1))
        ou.RNG.setSeed(seed)

        space = ob.RealVectorStateSpace(2)
        bounds = ob.RealVectorBounds(2)
        xmin, ymin, xmax, ymax = problem.map.bounds
        bounds.setLow(0, xmin)
        bounds.setLow(1, ymin)
        bounds.setHigh(0, xmax)
        bounds.setHigh(1, ymax)
        space.setBounds(bounds)
        setup = og.SimpleSetup(space)
        si = setup.getSpaceInformation()
        setup.setStateValidityChecker(lambda s: bool(checker.point_free((s[0], s[1]))))
        validator = _SegmentValidator(si, checker)
        si.setMotionValidator(validator)
        start, goal = space.allocState(), space.allocState()
        start[0], start[1] = float(problem.start[0]), float(problem.start[1])
        goal[0], goal[1] = float(problem.goal[0]), float(problem.goal[1])
        setup.setStartAndGoalStates(start, goal)
        objective = ob.PathLengthOptimizationObjective(si)
        if self.stop_at_first:  # any solution satisfies the objective, so optimising planners stop at it
            objective.setCostThreshold(ob.Cost(math.inf))
        setup.setOptimizationObjective(objective)
        planner = getattr(og, self.planner)(si)
        if self.range is not None and hasattr(planner, "setRange"):
            planner.setRange(float(self.range))
        for key, value in self.settings.items():
            getattr(planner, f"set{key}")(value)
        setup.setPlanner(planner)
        setup.setup()

        pdef = setup.getProblemDefinition()
        deadline = t0 + problem.time_limit
        first: dict[str, float] = {}
        if self.planner in _THREADED:
            # the roadmap planners poll the condition from a second thread: a Python condition would
            # deadlock on the interpreter lock, so use OMPL's own timed condition
            ptc = ob.timedPlannerTerminationCondition(max(deadline - time.perf_counter(), 0.0))
        else:
            best_cost = getattr(planner, "bestCost", None)

            def solved() -> bool:
                if best_cost is not None:  # optimising tree planners publish their solution only at the end
                    return math.isfinite(best_cost().value())
                return bool(pdef.hasExactSolution())

            def stop() -> bool:
                now = time.perf_counter()
                if not first and solved():
                    first["time"] = now - t0
                    if best_cost is not None:
                        first["length"] = float(best_cost().value())
                    else:
                        first["length"] = float(pdef.getSolutionPath().length())
                if first and self.stop_at_first:
                    return True
                return now >= deadline

            ptc = ob.PlannerTerminationCondition(stop)

        status = setup.solve(ptc)
        key = status.getStatus().name
        info: dict[str, Any] = {"ompl_planner": self.planner, "ompl_status": status.asString(), "seed": seed}
        exact = key == "EXACT_SOLUTION" and setup.haveExactSolutionPath()
        if exact and not first and (self.planner not in _THREADED or self.stop_at_first):
            # solved in the last iteration after the condition was last polled, or stopped by the objective
            first["time"] = time.perf_counter() - t0
            first["length"] = float(pdef.getSolutionPath().length())
        info["first_solution_s"] = first.get("time", math.nan)
        info["first_solution_length_cm"] = first.get("length", math.nan)
        if not exact:
            return None, _STATUS.get(key, key.lower().replace("_", " ")), info

        path = setup.getSolutionPath()
        if self.simplify:
            info["length_before_simplify_cm"] = float(path.length())
            t_s = time.perf_counter()
            og.PathSimplifier(si).simplifyMax(path)
            info["simplify_time_s"] = time.perf_counter() - t_s
            info["length_after_simplify_cm"] = float(path.length())
        states = [path.getState(i) for i in range(path.getStateCount())]
        arr = np.array([[s[0], s[1]] for s in states], dtype=float)
        arr[0], arr[-1] = problem.start, problem.goal  # exact end points (OMPL may copy with rounding)
        if not checker.path_free(arr):
            return None, "invalid path", info
        return arr, "exact", info


class RrtStarPlanner(OmplPlanner):
    """OMPL's RRT* (asymptotically optimal; uses the whole time budget). Options as `OmplPlanner`."""

    name = "rrtstar"

    def __init__(self, **options: Any) -> None:
        super().__init__(planner="RRTstar", **options)


class PrmPlanner(OmplPlanner):
    """OMPL's PRM with a path-length objective (uses the whole time budget). Options as `OmplPlanner`."""

    name = "prm"

    def __init__(self, **options: Any) -> None:
        super().__init__(planner="PRM", **options)
