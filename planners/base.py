"""The planner interface: `Planner` (a registry of plug-ins), `PlanningProblem` and `PlanResult`.

A planner is configured once (constructor keyword arguments) and queried many times with
`plan(problem)`. It validates states and motions only through ``problem.checker`` (the shared
`CollisionChecker`: the indexed checker, or FCL with ``--collision fcl``), never raises for an
unreachable goal (it returns a failed `PlanResult` with a status) and draws its randomness only
from ``problem.rng``.

Writing a planner is one file with one class: ``docs/howto/planner.md`` writes one that passes the
suite, and `Planner` lists what the suite demands (``nxtnav planners check MODULE:CLASS`` checks it).
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from toolkit.world import (
    CollisionChecker,
    Configurable,
    Map,
    Options,
    PlanningError,
    Registry,
    RngLike,
    RobotTiming,
    as_rng,
    check_objective,
    make_checker,
    objective_cost,
)
from toolkit.world.arrays import FloatArray

__all__ = ["PLANNERS", "PlanResult", "PlanStatus", "Planner", "PlanningProblem", "Solution", "can_minimise",
           "make_planner", "status_message"]


PLANNERS: Registry[Planner] = Registry("planner")


class PlanStatus(StrEnum):
    """How a plan ended: a code (`PlanResult.status`); `PlanResult.detail` adds the planner's words."""

    EXACT = "exact"
    """A path from start to goal, checked free."""
    APPROXIMATE = "approximate solution"
    """A path that stops short of the goal (OMPL): a failure."""
    TIMEOUT = "timeout"
    """The budget ran out before a path was found."""
    NO_PATH = "no path"
    """The planner's search ended without a path (its graph, grid or rounds hold none)."""
    UNREACHABLE = "unreachable"
    """No path can exist: start and goal lie in different free regions (told before any search)."""
    START_IN_COLLISION = "start in collision"
    GOAL_IN_COLLISION = "goal in collision"
    INVALID_PATH = "invalid path"
    """The planner returned a path the shared checker refuses."""
    ERROR = "error"
    """The planner (or a peer) failed in another way; the detail says how."""


@dataclass(eq=False)
class PlanningProblem:
    """One query: get a disc robot from `start` to `goal` in `map`.

    Parameters
    ----------
    map : Map
    checker : CollisionChecker
        The shared checker (its radius is the robot radius); planners use nothing else for validity.
    start, goal : (2,) array_like
        Positions in cm.
    time_limit : float
        Planning budget in seconds.
    rng : None, int or Generator
        Seed of every random draw of the planner (normalised to a Generator).
    timing : RobotTiming
        The robot's speed, turn rate and stop-and-turn cost: what the ``robot-time`` objective charges.
    """

    map: Map
    checker: CollisionChecker
    start: FloatArray
    goal: FloatArray
    time_limit: float = 1.0
    rng: np.random.Generator = field(default_factory=np.random.default_rng)
    timing: RobotTiming = field(default_factory=RobotTiming)

    def __post_init__(self) -> None:
        self.start = np.asarray(self.start, dtype=float).reshape(2)
        self.goal = np.asarray(self.goal, dtype=float).reshape(2)
        self.rng = as_rng(self.rng)
        for label, p in (("start", self.start), ("goal", self.goal)):
            if not np.all(np.isfinite(p)):
                raise PlanningError(f"{label} {p.tolist()} is not finite")
        if not (math.isfinite(self.time_limit) and self.time_limit > 0):
            raise PlanningError(f"time limit must be a positive number of seconds, got {self.time_limit!r}")

    @classmethod
    def create(cls, map: Map, robot_radius: float, start: ArrayLike, goal: ArrayLike, time_limit: float = 1.0,
               rng: RngLike = None, checker: CollisionChecker | None = None,
               timing: RobotTiming | None = None) -> PlanningProblem:
        """A problem with a new checker for `robot_radius` (or the given one); radius 0 is a point robot."""
        return cls(map, checker or make_checker(map, robot_radius), np.asarray(start, float),
                   np.asarray(goal, float), time_limit, as_rng(rng), timing or RobotTiming())

    @property
    def robot_radius(self) -> float:
        return self.checker.robot_radius


def status_message(status: PlanStatus, detail: str = "") -> str:
    """A status in words with its detail: ``"no path (no path on the grid)"``, or just ``"exact"``."""
    return f"{status} ({detail})" if detail and detail != status else str(status)


@dataclass(frozen=True, eq=False)
class Solution:
    """What `Planner._solve` hands back: the path (None when there is none), the status and extras.

    Attributes
    ----------
    path : (k, 2) array_like or None
        Waypoints from start to goal (cm), or None when the planner found no path.
    status : PlanStatus
        `PlanStatus.EXACT` for a path, otherwise why there is none.
    info : dict
        Planner-specific extras, copied into `PlanResult.info`.
    detail : str
        The planner's own words on the status (e.g. ``"no path on the grid"``), or "".
    """

    path: ArrayLike | None
    status: PlanStatus
    info: dict[str, Any] = field(default_factory=dict)
    detail: str = ""


@dataclass(frozen=True, eq=False)
class PlanResult:
    """What a planner returns.

    Attributes
    ----------
    planner : str
        Registry name of the planner.
    path : (k, 2) ndarray
        Waypoints from start to goal in cm (empty (0, 2) when it failed).
    success : bool
        True when `path` joins start and goal and is collision-free.
    status : PlanStatus
        `PlanStatus.EXACT` on success, otherwise why it failed.
    time_s : float
        Planning wall-clock time (s).
    collision_checks : int
        Checks the planner asked of the shared checker.
    info : dict
        Planner-specific extras (e.g. path length before simplification).
    detail : str
        The planner's own words on the status, or "".
    objective : str
        What the planner minimised (`toolkit.world.OBJECTIVES`).
    objective_cost : float
        The path's cost under `objective` (cm, turns or s; inf when the plan failed).
    """

    planner: str
    path: FloatArray
    success: bool
    status: PlanStatus
    time_s: float
    collision_checks: int = 0
    info: dict[str, Any] = field(default_factory=dict)
    detail: str = ""
    objective: str = "length"
    objective_cost: float = math.inf

    @property
    def message(self) -> str:
        """The status in words, with the planner's detail (``"no path (no path on the grid)"``)."""
        return status_message(self.status, self.detail)

    @property
    def length(self) -> float:
        """Path length (cm); inf when the plan failed."""
        if not self.success or len(self.path) < 2:
            return 0.0 if self.success else math.inf
        return float(np.sum(np.hypot(*np.diff(self.path, axis=0).T)))

    def to_dict(self) -> dict[str, Any]:
        return {
            "planner": self.planner,
            "success": self.success,
            "status": str(self.status),
            "detail": self.detail,
            "time_s": self.time_s,
            "collision_checks": self.collision_checks,
            "length_cm": self.length if self.success else None,
            "objective": self.objective,
            "objective_cost": self.objective_cost if self.success else None,
            "path": self.path.tolist(),
            "info": self.info,
        }


class Planner(Configurable, ABC):
    """Base class of planners. Subclasses set `name`, declare `options_model` and implement `_solve`.

    Subclasses with a `name` register themselves; `make_planner(name, **options)` builds one. The
    suite's planner tests are parametrised over `PLANNERS`, so a registered planner must:

    - set ``name`` in the class body (a string; that registers it) and implement `_solve`;
    - declare its options once, as a `toolkit.world.Options` model in ``options_model`` (at least one
      option: type, default, range, unit, description in its ``Field``), and take them as
      ``__init__(options=None, **overrides)`` through `configure`: a planner given its model's defaults
      plans the same path as one given none;
    - solve the preset queries of map1, map2, map3 and pillars for a disc of 8 cm with a path from the
      start to the goal that clears every wall by the radius (never shorter than ``shortest``), and
      route round a thin wall for a disc and for a point robot;
    - validate states and motions only through ``problem.checker``, draw every random number from
      ``problem.rng`` (the same seed gives the same path) and keep to ``problem.time_limit`` (s);
    - return a failed result with a `PlanStatus`, never raise, for a goal it cannot reach.

    A planner that minimises more than path length says so in ``objectives`` (`toolkit.world.OBJECTIVES`,
    its default first), takes the choice as its ``objective`` keyword (`_set_objective` checks it) and
    reads the robot's `RobotTiming` from ``problem.timing``; `plan` reports the path's cost under it.

    `planners.conformance.check_planner` (``nxtnav planners check MODULE:CLASS``) runs these checks on
    a class and says what is missing; ``docs/howto/planner.md`` writes a planner that passes them.
    """

    name: ClassVar[str]
    options_model: ClassVar[type[Options] | None] = None
    """The options (`planners.declarations.planner_options` answers for every name, OMPL's too)."""
    grid_map_options: ClassVar[Mapping[str, Any]] = {}
    """Options the benchmarks give it on a map imported from a grid (astar: plan on the map's own cells)."""
    large_map_options: ClassVar[Mapping[str, Any] | None] = {}
    """Options the benchmarks give it on a map of more than ``LARGE_MAP_WALLS`` walls (an imported real
    map; `toolkit.bench.planners`); None: it is skipped there (too slow to be a reference)."""
    objectives: ClassVar[tuple[str, ...]] = ("length",)
    """The objectives it can minimise (`toolkit.world.OBJECTIVES`), its default first; it takes the chosen
    one as its ``objective`` constructor keyword and keeps it as ``self.objective``."""
    reports_progress: ClassVar[bool] = False
    """Whether it takes ``progress_interval`` (seconds of budget between best-cost samples): the benchmarks
    then pass theirs (OMPL's planners)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            PLANNERS.add(cls.name, cls)

    @classmethod
    def objectives_for(cls, name: str) -> tuple[str, ...]:
        """The objectives planner `name` (this class's registry name, or a family member's such as
        ``ompl:NAME``) can minimise; the class's `objectives` unless a family says otherwise."""
        return cls.objectives

    def _set_objective(self, objective: str | None) -> str:
        """Check and keep `objective` (None: the planner's default, ``objectives[0]``); a `ConfigError`
        names the objectives it can minimise."""
        chosen = self.objectives[0] if objective is None else objective
        self.objective = check_objective(chosen, self.objectives, f"planner {getattr(self, 'name', '?')!r}")
        return self.objective

    @property
    def minimises(self) -> str:
        """The objective it minimises (``self.objective``, else its default)."""
        return str(getattr(self, "objective", None) or self.objectives[0])

    def plan(self, problem: PlanningProblem) -> PlanResult:
        """Solve `problem`; never raises for an unsolvable query (a failed result says why)."""
        checker = problem.checker
        checks0 = checker.checks
        t0 = time.perf_counter()
        info: dict[str, Any] = {}
        detail = ""
        if not checker.point_free(problem.start):
            path, status = None, PlanStatus.START_IN_COLLISION
        elif not checker.point_free(problem.goal):
            path, status = None, PlanStatus.GOAL_IN_COLLISION
        elif problem.map.region_of(problem.start) != problem.map.region_of(problem.goal):
            path, status, detail = None, PlanStatus.UNREACHABLE, "start and goal lie in different free regions"
        elif not checker.connected(problem.start, problem.goal):
            path, status, detail = None, PlanStatus.UNREACHABLE, "the robot's radius keeps start and goal apart"
        else:
            solution = self._solve(problem)
            path, status, info, detail = solution.path, PlanStatus(solution.status), solution.info, solution.detail
        elapsed = time.perf_counter() - t0
        checks = checker.checks - checks0
        if path is None:
            return PlanResult(self.name, np.empty((0, 2)), False, status, elapsed, checks, info, detail,
                              self.minimises)
        arr = np.asarray(path, dtype=float).reshape(-1, 2)
        cost = objective_cost(self.minimises, arr, problem.timing)
        return PlanResult(self.name, arr, True, status, elapsed, checks, info, detail, self.minimises, cost)

    @abstractmethod
    def _solve(self, problem: PlanningProblem) -> Solution:
        """The path (or None) with its status and extras, as a `Solution`.

        Start and goal are already known to be collision-free and in the same free region when this
        is called.
        """


def can_minimise(name: str, objective: str) -> bool:
    """Whether the registered planner `name` (``ompl:NAME`` included) can minimise `objective`."""
    return objective in PLANNERS.class_of(name).objectives_for(name)


def make_planner(name: str, **options: Any) -> Planner:
    """A planner by registry name with its options (``ompl:NAME`` reaches any OMPL geometric planner)."""
    return PLANNERS.create(name, **options)
