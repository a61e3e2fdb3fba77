"""OMPL's geometric planners on the shared collision checker: ``rrtstar``, ``prm`` and any ``ompl:NAME``.

The state space is OMPL's 2-D `RealVectorStateSpace` bounded by the map's bounding box (cm). State
validity is the shared checker's point check and motion validity is its swept-disc segment check,
installed as a Python `MotionValidator` subclass, so OMPL never discretises an edge into states: every
edge the planner keeps was checked exactly once by FCL. The optimisation objective is path length, or
with ``objective="robot-time"`` the robot's time over OMPL's SE(2) space (`planners.ompl_objective`:
a motion turns in place to its segment's heading and drives; start and goal headings free); the
progress costs, ``bestCost`` and the first solution's cost (``first_solution_cost``) are then in seconds.

Time budget. `RRTConnect`, `RRT`, `KPIECE1` and other feasibility planners stop at their first
solution. Asymptotically optimal planners (`RRTstar`, `PRM` with a length objective, `BITstar`, ...)
never meet an unset cost threshold, so they use the whole budget and return the best path found; the
time and length of their *first* solution are reported in ``info`` (``first_solution_s``,
``first_solution_length_cm``) so the benchmark can show both. PRM and PRM* poll the time limit from a
second thread, where no Python code may run, so for them the first solution is not observed (NaN):
run them with ``stop_at_first=True`` to measure it (their planning time is then the time to the first
solution). ``stop_at_first=True`` sets the objective's cost threshold to infinity, so any planner
stops at its first exact solution.

Progress. Every call records the best cost found so far (the path length in cm, inf before the
first solution) as ``info["progress"]``, a list of ``[time_s, iterations, best_cost]`` samples: one at
every improvement and one every `progress_interval` of the budget, like the progress properties
(``best cost``, ``iterations``) of OMPL's own benchmark. The samples are taken where the termination
condition is polled (once per iteration), so in deterministic mode the interval is counted in
iterations (``iterations_per_s * progress_interval`` polls) and the sampled costs repeat exactly with
the seed; ``time_s`` is the wall-clock time since the call began. The cost comes from the planner's
``bestCost()`` where it has one (RRTstar, InformedRRTstar, BITstar, AORRTC, ...), else from the problem's
exact solution (RRTConnect and other feasibility planners: one sample, when they stop). PRM and PRMstar
in deterministic mode are queried after every 10 ms of their budget (a fixed number of iterations,
whatever the interval, so the interval never changes their roadmap), which is their progress
resolution; in wall-clock mode they poll from a thread of their own and report only the final cost.

Declared parameters. OMPL 2.0.1's Python bindings cannot convert ``Planner.params()``, so the
planner's parameters are read from its getter/setter pairs after setup (``getRange``/``setRange`` ->
``Range``; the names the ``settings`` option takes) and reported in ``info["params"]``.

Seeding and reproducibility. OMPL gives every RNG it creates (one per planner, one per state
sampler) a seed drawn from a process-wide seed generator, and `ompl.util.RNG.setSeed` re-seeds that
generator (after the first RNG exists it also logs an error, which is silenced here). The adapter
calls ``RNG.setSeed`` with a seed drawn from ``problem.rng`` just before it builds the space, the
planner and its samplers, so a planning call draws the same numbers whatever ran before it in the
process. Same draws are not yet the same path: a planner that runs until a wall-clock budget ends does
as many iterations as the machine manages, and PRM grows its roadmap while a second thread looks for
a solution. So by default (``deterministic=True``) the budget is counted in iterations, not seconds:
the planner stops after ``iterations_per_s * time_limit`` polls of its termination condition (one
per iteration of the tree planners; by default about what one laptop core manages per second on the
bundled maps: 5000 for RRT* and PRM), and PRM/PRM* grow their roadmap in this thread in rounds of that
budget, asking OMPL for the roadmap's shortest path after each round. The same seed then gives the
same path on any machine, in any process, with any number of benchmark workers. A wall-clock cap of
ten times the budget (at least 30 s) still ends a planner on a machine far slower than that; ``info["stopped_by"]``
says what ended each call (``iterations``, ``solution`` or ``time``; only ``time`` is not
reproducible). ``deterministic=False`` restores the wall-clock budget (all of it for the
asymptotically optimal planners).

OMPL statuses map to `PlanStatus`: an exact solution is a success (``EXACT``); an approximate
solution (a path that stops short of the goal) is a failure (``APPROXIMATE``); a timeout, an invalid
start or goal, an infeasible problem are failures too, with OMPL's own words as the detail.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
import ompl.base as ob
import ompl.geometric as og
import ompl.util as ou
from numpy.typing import ArrayLike, NDArray

from toolkit.world import CollisionChecker, ConfigError, RegistryError

from .base import PLANNERS, Planner, PlanningProblem, PlanStatus, Solution
from .declarations import OmplOptions
from .ompl_objective import PLANE_NEIGHBOURS, box_bounds, check_objective_impl, robot_time_objective, se2_space
from .ompl_polish import polish_solution

__all__ = ["OmplPlanner", "PrmPlanner", "RrtStarPlanner", "declared_params", "ompl_planner_names", "ompl_simplify"]

_LOG_LEVELS = {
    "none": ou.LOG_NONE,
    "error": ou.LOG_ERROR,
    "warn": ou.LOG_WARN,
    "info": ou.LOG_INFO,
    "debug": ou.LOG_DEBUG,
}

# planners that evaluate the termination condition from a second thread
_THREADED = frozenset({"PRM", "PRMstar"})
_TIME_CAP = 10.0  # deterministic mode: wall-clock cap, in multiples of the time limit ...
_TIME_CAP_MIN_S = 30.0  # ... and at least this long, so that a busy machine still gets reproducible paths
_ROADMAP_ROUND_S = 0.01  # deterministic PRM: budget (s) of one roadmap growth round (a query after each)
# deterministic mode: iterations per second of budget, about what one laptop core does on the bundled maps
_ITERATIONS_PER_S = {"PRMstar": 1000.0, "BITstar": 50000.0, "ABITstar": 50000.0, "AITstar": 50000.0}
_DEFAULT_ITERATIONS_PER_S = 5000.0
_OPTIMISING = frozenset({"RRTstar", "InformedRRTstar", "SORRTstar", "BITstar", "ABITstar", "AITstar", "EITstar",
                         "AORRTC", "PRM", "PRMstar", "LazyPRMstar", "FMT", "BFMT", "RRTXstatic", "RRTsharp",
                         "LBTRRT", "LazyLBTRRT", "CForest", "SST", "SPARS", "SPARStwo"})
"""OMPL's planners that improve their path under an optimisation objective (the others stop at a first
path, whatever the objective: they take ``length`` only, the default)."""
_UNDIRECTED = frozenset({"PRM", "PRMstar", "LazyPRM", "LazyPRMstar", "SPARS", "SPARStwo"})
"""Roadmap planners whose graph is undirected: an edge carries one cost for both directions, so they
cannot minimise robot time, whose motion and its reverse turn by different angles (``length`` only)."""
_RRTSTAR_FAMILY = frozenset({"RRTstar", "InformedRRTstar", "SORRTstar"})
"""Under robot-time their rewire factor is scaled by `PLANE_NEIGHBOURS` (BIT*'s is not: its batches need
the neighbours, measured 1.5-1.8 times the optimum's robot time on map1 with the scaled factor)."""
_PARAM_TYPES = (bool, int, float, str)
_NOT_PARAMS = frozenset({"Name", "ProblemDefinition"})

_STATUS = {  # OMPL's PlannerStatus names -> ours (OMPL's own words stay in info["ompl_status"] and the detail)
    "EXACT_SOLUTION": PlanStatus.EXACT,
    "APPROXIMATE_SOLUTION": PlanStatus.APPROXIMATE,
    "TIMEOUT": PlanStatus.TIMEOUT,
    "INVALID_START": PlanStatus.START_IN_COLLISION,
    "INVALID_GOAL": PlanStatus.GOAL_IN_COLLISION,
    "UNREACHABLE": PlanStatus.UNREACHABLE,
    "UNKNOWN": PlanStatus.NO_PATH,
}


def ompl_planner_names() -> list[str]:
    """Names of the OMPL geometric planners this OMPL build exposes to Python (``RRTstar``, ``PRM``, ...)."""
    return sorted(
        n for n in dir(og) if isinstance(getattr(og, n), type) and issubclass(getattr(og, n), ob.Planner)
    )


def declared_params(planner: Any) -> dict[str, bool | int | float | str]:
    """An OMPL planner's parameters: every getter with a setter beside it (``getRange``/``setRange`` ->
    ``Range``) whose value is a plain number, flag or string. Read after ``setup()`` (some defaults,
    such as the range, are set there)."""
    out: dict[str, bool | int | float | str] = {}
    for attr in sorted(dir(planner)):
        key = attr[3:]
        if not attr.startswith("get") or key in _NOT_PARAMS or not hasattr(planner, f"set{key}"):
            continue
        try:
            value = getattr(planner, attr)()
        except (TypeError, RuntimeError):  # a getter that takes arguments or cannot answer
            continue
        if isinstance(value, _PARAM_TYPES):
            out[key] = value
    return out


class _SegmentValidator(ob.MotionValidator):
    """OMPL motion validation by the shared checker's exact swept-disc segment check."""

    def __init__(self, si: ob.SpaceInformation, checker: CollisionChecker) -> None:
        super().__init__(si)
        self._checker = checker

    def checkMotion(self, s1: Any, s2: Any, *rest: Any) -> bool:
        return self._checker.segment_free((s1[0], s1[1]), (s2[0], s2[1]))


def _space(bounds: tuple[float, float, float, float], checker: CollisionChecker) -> tuple[Any, Any]:
    """OMPL's 2-D space on the box `bounds` and its space information, whose states and motions the
    shared checker validates (the validator is kept alive by the space information)."""
    space = ob.RealVectorStateSpace(2)
    space.setBounds(box_bounds(bounds))
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda s: bool(checker.point_free((s[0], s[1]))))
    si.setMotionValidator(_SegmentValidator(si, checker))
    return space, si


def ompl_simplify(path: ArrayLike, checker: CollisionChecker, bounds: tuple[float, float, float, float],
                  seed: int) -> NDArray[np.float64]:
    """OMPL's `PathSimplifier` (``simplifyMax``: vertex reduction, shortcuts, close-vertex collapse,
    until nothing improves) on any polyline, validated by the shared checker.

    Parameters
    ----------
    path : (k, 2) array_like
        Waypoints in cm (a collision-free path of the checker's robot).
    checker : CollisionChecker
    bounds : (xmin, ymin, xmax, ymax)
        The state space box (cm): the map's bounds.
    seed : int
        Seed of OMPL's random shortcuts (the process-wide seed generator is reset to it first).

    Returns
    -------
    (m, 2) ndarray
        The simplified path, same end points; the input when it has fewer than 3 waypoints.
    """
    arr = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(arr) < 3:
        return arr.copy()
    previous = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)  # re-seeding after the first RNG exists logs an error: expected here
    try:
        ou.RNG.setSeed(int(seed))
        space, si = _space(bounds, checker)
        si.setup()
        geo = og.PathGeometric(si)
        for x, y in arr:
            s = space.allocState()
            s[0], s[1] = float(x), float(y)
            geo.append(s)
        og.PathSimplifier(si).simplifyMax(geo)
    finally:
        ou.setLogLevel(previous)
    out = np.array([[geo.getState(i)[0], geo.getState(i)[1]] for i in range(geo.getStateCount())], dtype=float)
    out[0], out[-1] = arr[0], arr[-1]
    return out


def _polyline_length(points: NDArray[np.float64]) -> float:
    return float(np.sum(np.hypot(*np.diff(points, axis=0).T))) if len(points) >= 2 else 0.0


class _Progress:
    """Best-cost samples of one planning call: at every improvement and on a fixed grid.

    The grid counts polls (`every` polls) in deterministic mode, else wall-clock seconds
    (`interval_s`). Samples are ``[time_s, iterations, best_cost]`` with inf before a solution.
    """

    def __init__(self, t0: float, interval_s: float, every: int | None) -> None:
        self.t0 = t0
        self.interval_s = interval_s
        self.every = every
        self.samples: list[list[float]] = []
        self.best = math.inf
        self._next = float(every) if every is not None else interval_s

    def poll(self, polls: int, now: float, cost: float) -> None:
        """Record a sample when `cost` improves on the best or the grid's next point is reached."""
        clock = float(polls) if self.every is not None else now - self.t0
        on_grid = clock >= self._next
        if on_grid:
            step = float(self.every) if self.every is not None else self.interval_s
            self._next = (math.floor(clock / step) + 1) * step
        if cost < self.best or on_grid:
            self.best = min(self.best, cost)
            self.samples.append([now - self.t0, float(polls), self.best])

    def finish(self, polls: int, now: float, cost: float) -> list[list[float]]:
        """Add the final sample (unless the last one was taken at the same poll) and return them all."""
        self.best = min(self.best, cost)
        if not self.samples or self.samples[-1][1] != polls or self.samples[-1][2] != self.best:
            self.samples.append([now - self.t0, float(polls), self.best])
        return self.samples


class OmplPlanner(Planner):
    """Any OMPL geometric planner, validated by the shared checker.

    Parameters
    ----------
    planner : str
        OMPL class name in `ompl.geometric` ("RRTstar", "PRM", "BITstar", "RRTConnect", ...).
    options : OmplOptions, optional
        The wrapper's options (`planners.declarations.OmplOptions`; None: the defaults), below.
    settings : dict, optional
        OMPL's own settings by setter name without ``set``, e.g. ``{"GoalBias": 0.1}`` calls
        ``setGoalBias(0.1)``.
    **overrides
        Options on top of `options` by name (``simplify=True``).

    Notes
    -----
    What the options mean beyond their one-line descriptions (``nxtnav planners show rrtstar``):

    simplify : bool
        Run OMPL's path simplifier (shortcutting, vertex reduction) on the solution; the length before
        and after is reported in ``info``. Simplification time counts in the planning time.
    polish : bool or None
        Polish an optimising planner's solution under its objective (`planners.ompl_polish`; None: under
        robot-time only); its time and checks count, ``info`` holds the costs before and after.
    range : float or None
        Maximum edge length (cm) for planners with ``setRange`` (RRT family); None keeps OMPL's default.
    stop_at_first : bool
        Stop at the first exact solution even for asymptotically optimal planners.
    log_level : str
        OMPL's console log level while planning: "none", "error", "warn", "info" or "debug".
    deterministic : bool
        Count the budget in iterations (reproducible, see the module notes) rather than in seconds.
    iterations_per_s : float or None
        Iterations (termination-condition polls) per second of the problem's time limit when
        `deterministic`; None: about what a laptop core does (5000 for the tree planners, 1000 for
        PRMstar, 50000 for the BITstar family).
    progress_interval : float
        Seconds of budget between two progress samples (besides one at every improvement); in
        deterministic mode counted as ``iterations_per_s * progress_interval`` iterations.
    objective : {"length", "robot-time"}
        What the planner minimises: path length (cm, over the plane), or robot time (s, over SE(2),
        `planners.ompl_objective`, with the problem's `RobotTiming`).
    objective_impl : {"auto", "python", "compiled"}
        Robot-time's code, `planners.ompl_objective.robot_time_objective`; ``info["objective_impl"]`` says which.

    ``info`` holds ``ompl_status`` (OMPL's own words), ``first_solution_s``,
    ``first_solution_length_cm``, ``progress`` (``[time_s, iterations, best_cost]`` samples),
    ``params`` (the planner's declared parameters), ``length_before_simplify_cm`` /
    ``length_after_simplify_cm`` and ``simplify_time_s`` (when simplifying), and the OMPL ``seed`` used.
    """

    reports_progress = True
    objectives = ("length", "robot-time")

    @classmethod
    def objectives_for(cls, name: str) -> tuple[str, ...]:
        """``length`` alone for an OMPL planner that stops at its first path (RRTConnect, KPIECE1, ...) or
        keeps an undirected roadmap (PRM, PRM*, ...)."""
        planner = {"rrtstar": "RRTstar", "prm": "PRM"}.get(name, name.split(":", 1)[-1])
        return cls.objectives if planner in _OPTIMISING - _UNDIRECTED else ("length",)

    options_model = OmplOptions

    def __init__(self, planner: str = "RRTstar", options: OmplOptions | None = None, *,
                 settings: dict[str, Any] | None = None, **overrides: Any) -> None:
        known = ompl_planner_names()
        if planner not in known:
            raise RegistryError(f"unknown OMPL planner {planner!r}; known: {', '.join(known)}")
        o: OmplOptions = self.configure(options, overrides)
        own = self.objectives_for(f"ompl:{planner}")
        if o.objective not in own and o.objective in self.objectives:
            why = ("keeps an undirected roadmap, one cost per edge for both directions, and robot time turns "
                   "differently each way" if planner in _UNDIRECTED else
                   "stops at its first path and optimises no objective")
            raise ConfigError(f"planner 'ompl:{planner}' {why}; it takes {', '.join(own)} only")
        self._set_objective(o.objective)
        check_objective_impl(o.objective_impl)
        cls = getattr(og, planner)
        for key in settings or {}:
            if not hasattr(cls, f"set{key}"):
                raise ConfigError(f"OMPL planner {planner} has no setting {key!r} (no method set{key})")
        self.options = o
        self.planner = planner
        self.simplify, self.range, self.stop_at_first = o.simplify, o.range, o.stop_at_first
        polish = o.objective == "robot-time" if o.polish is None else o.polish
        self.polish = polish and planner in _OPTIMISING and not o.stop_at_first
        self.settings = dict(settings or {})
        self.log_level, self.deterministic = o.log_level, o.deterministic
        self.iterations_per_s = (_ITERATIONS_PER_S.get(planner, _DEFAULT_ITERATIONS_PER_S)
                                 if o.iterations_per_s is None else o.iterations_per_s)
        self.progress_interval = o.progress_interval
        if type(self) is OmplPlanner:
            setattr(self, "name", f"ompl:{planner}")  # noqa: B010 (an instance name, not the registry's)

    def _solve(self, problem: PlanningProblem) -> Solution:
        previous = ou.getLogLevel()
        ou.setLogLevel(_LOG_LEVELS[self.log_level])
        try:
            return self._solve_quiet(problem)
        finally:
            ou.setLogLevel(previous)

    def _polls(self, seconds: float) -> int:
        """Termination-condition polls that stand for `seconds` of budget (at least 1)."""
        return max(1, round(self.iterations_per_s * seconds))

    def _solve_quiet(self, problem: PlanningProblem) -> Solution:
        t0 = time.perf_counter()
        seed = int(problem.rng.integers(1, 2**31 - 1))
        ou.RNG.setSeed(seed)
        setup, planner = self._setup(problem)
        params = declared_params(planner)

        pdef = setup.getProblemDefinition()
        cap = max(problem.time_limit * _TIME_CAP, _TIME_CAP_MIN_S) if self.deterministic else problem.time_limit
        deadline = t0 + cap
        budget = self._polls(problem.time_limit) if self.deterministic else None
        progress = _Progress(t0, self.progress_interval,
                             self._polls(self.progress_interval) if self.deterministic else None)
        if self.planner in _THREADED and budget is not None:
            return self._grow_roadmap(setup, planner, problem, t0, budget, deadline, seed, progress, params)
        first: dict[str, float] = {}
        ended: dict[str, Any] = {"by": "time", "polls": 0}
        ptc = self._termination(planner, pdef, t0, deadline, budget, progress, first, ended)
        status = setup.solve(ptc)
        key = status.getStatus().name
        info: dict[str, Any] = {"ompl_planner": self.planner, "ompl_status": status.asString(), "seed": seed,
                                "stopped_by": ended["by"], "iterations": ended["polls"], "params": params}
        exact = key == "EXACT_SOLUTION" and setup.haveExactSolutionPath()
        if exact and ended["by"] == "time" and self.deterministic:
            ended["by"] = "solution"  # a feasibility planner returned its solution before the condition said stop
            info["stopped_by"] = "solution"
        final = self._cost_of(pdef.getSolutionPath()) if exact else math.inf
        if exact and not first and (self.planner not in _THREADED or self.stop_at_first):
            # solved in the last iteration after the condition was last polled, or stopped by the objective
            first["time"], first["length"] = time.perf_counter() - t0, final
        info["first_solution_s"] = first.get("time", math.nan)
        if self.objective == "robot-time":
            info["objective_impl"] = self._objective_kind  # "compiled" or "python"
        self._first_solution(info, first)
        info["progress"] = progress.finish(ended["polls"], time.perf_counter(), final)
        if not exact:
            return Solution(None, _STATUS.get(key, PlanStatus.ERROR), info, info["ompl_status"])
        return self._finish(setup, problem, info, t0)

    def _setup(self, problem: PlanningProblem) -> tuple[Any, Any]:
        """OMPL's `SimpleSetup` for `problem` (start, goal, path-length objective) and its planner,
        configured with `range` and `settings` and set up."""
        se2 = self.objective == "robot-time"
        space, si = (se2_space if se2 else _space)(problem.map.bounds, problem.checker)
        setup = og.SimpleSetup(si)
        start, goal = space.allocState(), space.allocState()
        for state, (x, y) in ((start, problem.start), (goal, problem.goal)):
            if se2:
                state.setX(float(x))
                state.setY(float(y))
                state.setYaw(math.atan2(problem.goal[1] - problem.start[1], problem.goal[0] - problem.start[0]))
            else:
                state[0], state[1] = float(x), float(y)
        setup.setStartAndGoalStates(start, goal)
        objective, self._objective_kind = robot_time_objective(
            si, problem.timing, (problem.start[0], problem.start[1]), (problem.goal[0], problem.goal[1]),
            self.options.objective_impl) if se2 else (ob.PathLengthOptimizationObjective(si), "length")
        self._ompl_objective = objective
        if self.stop_at_first:  # any solution satisfies the objective, so optimising planners stop at it
            objective.setCostThreshold(ob.Cost(math.inf))
        setup.setOptimizationObjective(objective)
        planner = getattr(og, self.planner)(si)
        if se2 and self.planner in _RRTSTAR_FAMILY:  # the plane's neighbour count (settings may override)
            planner.setRewireFactor(planner.getRewireFactor() * PLANE_NEIGHBOURS)
        if self.range is not None and hasattr(planner, "setRange"):
            planner.setRange(float(self.range))
        for key, value in self.settings.items():
            getattr(planner, f"set{key}")(value)
        setup.setPlanner(planner)
        setup.setup()
        return setup, planner

    def _termination(self, planner: Any, pdef: Any, t0: float, deadline: float, budget: int | None,
                     progress: _Progress, first: dict[str, float], ended: dict[str, Any]) -> Any:
        """The condition that ends the solve: at `deadline` (``time.perf_counter`` s), after `budget`
        polls, or at the first solution with `stop_at_first`. Each poll counts in ``ended["polls"]``
        and says what stopped it in ``ended["by"]``; the first solution's time (s after `t0`) and
        length (cm) go into `first`."""
        if self.planner in _THREADED:
            # the roadmap planners poll the condition from a second thread: a Python condition would
            # deadlock on the interpreter lock, so use OMPL's own timed condition
            return ob.timedPlannerTerminationCondition(max(deadline - time.perf_counter(), 0.0))
        cost_now = self._cost_reader(planner, pdef)

        def stop() -> bool:
            now = time.perf_counter()
            ended["polls"] += 1
            cost = cost_now()
            progress.poll(ended["polls"], now, cost)
            if not first and math.isfinite(cost):
                first["time"], first["length"] = now - t0, cost
            if first and self.stop_at_first:
                ended["by"] = "solution"
                return True
            if budget is not None and ended["polls"] >= budget:
                ended["by"] = "iterations"
                return True
            return now >= deadline

        return ob.PlannerTerminationCondition(stop)

    def _points(self, path: Any) -> NDArray[np.float64]:
        """An OMPL path's positions (cm), (k, 2)."""
        states = [path.getState(i) for i in range(path.getStateCount())]
        if self.objective == "length":
            return np.array([[s[0], s[1]] for s in states], dtype=float).reshape(-1, 2)
        return np.array([[s.getX(), s.getY()] for s in states], dtype=float).reshape(-1, 2)

    def _cost_of(self, path: Any) -> float:
        """A solution path's cost under the objective: its length (cm) or its robot time over SE(2) (s)."""
        if self.objective == "length":
            return float(path.length())
        return float(path.cost(self._ompl_objective).value())

    def _first_solution(self, info: dict[str, Any], first: dict[str, float]) -> None:
        """The first solution's cost into `info` (``first_solution_cost``; its length when that is the cost)."""
        cost = first.get("length", math.nan)
        info["first_solution_cost"] = cost
        info["first_solution_length_cm"] = cost if self.objective == "length" else math.nan

    def _cost_reader(self, planner: Any, pdef: Any) -> Callable[[], float]:
        """The best cost so far (inf before a solution): the planner's ``bestCost()`` where it has one
        (optimising tree planners publish their solution only at the end), else the problem's exact
        solution (read again only when the number of solutions changes)."""
        best_cost = getattr(planner, "bestCost", None)
        if best_cost is not None:
            return lambda: float(best_cost().value())
        seen = {"count": 0, "cost": math.inf}

        def from_problem() -> float:
            count = pdef.getSolutionCount()
            if count != seen["count"]:
                seen["count"] = count
                seen["cost"] = self._cost_of(pdef.getSolutionPath()) if pdef.hasExactSolution() else math.inf
            return seen["cost"]

        return from_problem

    def _grow_roadmap(self, setup: Any, planner: Any, problem: PlanningProblem, t0: float, budget: int,
                      deadline: float, seed: int, progress: _Progress, params: dict[str, Any]) -> Solution:
        """PRM and PRM* reproducibly: grow the roadmap in this thread in rounds of a fixed number of
        iterations (10 ms of budget); after each round OMPL's query (a solve with no time left) gives
        the roadmap's shortest path."""
        pdef = setup.getProblemDefinition()
        polls = {"n": 0, "round_end": 0}
        ended = "iterations"

        def stop() -> bool:
            polls["n"] += 1
            return polls["n"] > polls["round_end"] or time.perf_counter() >= deadline

        goal = np.asarray(problem.goal, dtype=float)
        first: dict[str, float] = {}
        found = None
        step = self._polls(_ROADMAP_ROUND_S)
        while polls["round_end"] < budget:
            polls["round_end"] = min(polls["round_end"] + step, budget)
            planner.growRoadmapPtc(ob.PlannerTerminationCondition(stop))
            pdef.clearSolutionPaths()
            setup.solve(ob.timedPlannerTerminationCondition(0.0))
            path = pdef.getSolutionPath() if pdef.hasSolution() else None
            if path is not None and path.getStateCount() >= 2:
                end = path.getState(path.getStateCount() - 1)
                if math.hypot(end[0] - goal[0], end[1] - goal[1]) < 1e-9:  # joins the goal (OMPL may call
                    found = path                                            # it approximate all the same)
                    if not first:
                        first = {"time": time.perf_counter() - t0, "length": self._cost_of(path)}
            cost = self._cost_of(found) if found is not None else math.inf
            progress.poll(min(polls["n"], polls["round_end"]), time.perf_counter(), cost)
            if time.perf_counter() >= deadline:
                ended = "time"
                break
            if found is not None and self.stop_at_first:
                ended = "solution"
                break
        iterations = min(polls["n"], budget)
        info: dict[str, Any] = {"ompl_planner": self.planner, "seed": seed, "stopped_by": ended,
                                "iterations": iterations, "milestones": int(planner.milestoneCount()),
                                "params": params,
                                "first_solution_s": first.get("time", math.nan),
                                "progress": progress.finish(iterations, time.perf_counter(),
                                                            self._cost_of(found) if found is not None else math.inf)}
        self._first_solution(info, first)
        if found is None:
            info["ompl_status"] = "no solution in the roadmap"
            if ended == "time":
                return Solution(None, PlanStatus.TIMEOUT, info)
            return Solution(None, PlanStatus.NO_PATH, info, "no path in the roadmap")
        info["ompl_status"] = "Exact solution"
        return self._finish(setup, problem, info, t0, found)

    def _finish(self, setup: Any, problem: PlanningProblem, info: dict[str, Any], t0: float,
                path: Any = None) -> Solution:
        """Simplify and polish (when asked), copy out and verify the solution path (`t0`: when the call began)."""
        checker = problem.checker
        si = setup.getSpaceInformation()
        if path is None:
            path = setup.getSolutionPath()
        if self.simplify:
            info["length_before_simplify_cm"] = _polyline_length(self._points(path))
            t_s = time.perf_counter()
            og.PathSimplifier(si).simplifyMax(path)
            info["simplify_time_s"] = time.perf_counter() - t_s
            info["length_after_simplify_cm"] = _polyline_length(self._points(path))
        arr = self._points(path)
        arr[0], arr[-1] = problem.start, problem.goal  # exact end points (OMPL may copy with rounding)
        if self.polish and checker.path_free(arr):
            arr, polished = polish_solution(arr, self._cost_of(path), checker, self.objective, problem.timing,
                                            info["seed"], si, self._ompl_objective)
            info.update(polished)
            done = [time.perf_counter() - t0, float(info["iterations"]), polished["cost_after_polish"]]
            info["progress"].append(done)
        if not checker.path_free(arr):
            return Solution(None, PlanStatus.INVALID_PATH, info)
        return Solution(arr, PlanStatus.EXACT, info)


class RrtStarPlanner(OmplPlanner):
    """OMPL's RRT* (asymptotically optimal; runs its whole budget, counted in iterations by default).

    Options as `OmplPlanner`."""

    name = "rrtstar"

    def __init__(self, options: OmplOptions | None = None, **overrides: Any) -> None:
        super().__init__("RRTstar", options, **overrides)


class PrmPlanner(OmplPlanner):
    """OMPL's PRM with a path-length objective (grows its roadmap for the whole budget). Options as `OmplPlanner`."""

    name = "prm"

    def __init__(self, options: OmplOptions | None = None, **overrides: Any) -> None:
        super().__init__("PRM", options, **overrides)


def _ompl_member(planner: str) -> Callable[..., OmplPlanner]:
    return partial(OmplPlanner, planner=planner)


PLANNERS.add_family("ompl", _ompl_member, ompl_planner_names, cls=OmplPlanner)
