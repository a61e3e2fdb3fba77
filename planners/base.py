"""The planner interface: `Planner` (a registry of plug-ins), `PlanningProblem` and `PlanResult`.

A planner is configured once (constructor keyword arguments) and queried many times with
`plan(problem)`. It validates states and motions only through ``problem.checker`` (the shared FCL
`CollisionChecker`), never raises for an unreachable goal (it returns a failed `PlanResult` with a
status) and draws its randomness only from ``problem.rng``.

Writing a planner is one file with one class::

    class Straight(Planner):
        name = "straight"

        def _solve(self, problem):
            path = np.array([problem.start, problem.goal])
            ok = problem.checker.segment_free(problem.start, problem.goal)
            return Solution(path if ok else None, "exact" if ok else "no straight path")
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from toolkit.world import CollisionChecker, Map, PlanningError, Registry, RngLike, as_rng, make_checker

__all__ = ["PLANNERS", "UNREACHABLE", "PlanResult", "Planner", "PlanningProblem", "Solution", "make_planner"]

FloatArray = NDArray[np.float64]

PLANNERS: Registry[Planner] = Registry("planner")

UNREACHABLE = "unreachable: start and goal lie in different free regions"
"""Status of a query no path can solve (told at once, before any search)."""


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
    """

    map: Map
    checker: CollisionChecker
    start: FloatArray
    goal: FloatArray
    time_limit: float = 1.0
    rng: np.random.Generator = field(default_factory=np.random.default_rng)

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
               rng: RngLike = None, checker: CollisionChecker | None = None) -> PlanningProblem:
        """A problem with a new checker for `robot_radius` (or the given one); radius 0 is a point robot."""
        return cls(map, checker or make_checker(map, robot_radius), np.asarray(start, float),
                   np.asarray(goal, float), time_limit, as_rng(rng))

    @property
    def robot_radius(self) -> float:
        return self.checker.robot_radius


@dataclass(frozen=True, eq=False)
class Solution:
    """What `Planner._solve` hands back: the path (None when there is none), the status and extras.

    Attributes
    ----------
    path : (k, 2) array_like or None
        Waypoints from start to goal (cm), or None when the planner found no path.
    status : str
        ``"exact"`` for a path, otherwise why there is none (``"timeout"``, ``"no path"``, ...).
    info : dict
        Planner-specific extras, copied into `PlanResult.info`.
    """

    path: ArrayLike | None
    status: str
    info: dict[str, Any] = field(default_factory=dict)


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
    status : str
        "exact" on success, otherwise why it failed ("timeout", "start in collision", ...).
    time_s : float
        Planning wall-clock time (s).
    collision_checks : int
        Checks the planner asked of the shared checker.
    info : dict
        Planner-specific extras (e.g. path length before simplification).
    """

    planner: str
    path: FloatArray
    success: bool
    status: str
    time_s: float
    collision_checks: int = 0
    info: dict[str, Any] = field(default_factory=dict)

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
            "status": self.status,
            "time_s": self.time_s,
            "collision_checks": self.collision_checks,
            "length_cm": self.length if self.success else None,
            "path": self.path.tolist(),
            "info": self.info,
        }


class Planner(ABC):
    """Base class of planners. Subclasses set `name` and implement `_solve`.

    Subclasses with a `name` register themselves; `make_planner(name, **options)` builds one.
    """

    name: ClassVar[str]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            PLANNERS.add(cls.name, cls)

    def plan(self, problem: PlanningProblem) -> PlanResult:
        """Solve `problem`; never raises for an unsolvable query (a failed result says why)."""
        checker = problem.checker
        checks0 = checker.checks
        t0 = time.perf_counter()
        info: dict[str, Any] = {}
        if not checker.point_free(problem.start):
            path, status = None, "start in collision"
        elif not checker.point_free(problem.goal):
            path, status = None, "goal in collision"
        elif (problem.map.region_of(problem.start) != problem.map.region_of(problem.goal)
              or not checker.connected(problem.start, problem.goal)):  # apart in the map, or only the robot's
            path, status = None, UNREACHABLE  # radius keeps them apart
        else:
            solution = self._solve(problem)
            path, status, info = solution.path, solution.status, solution.info
        elapsed = time.perf_counter() - t0
        checks = checker.checks - checks0
        if path is None:
            return PlanResult(self.name, np.empty((0, 2)), False, status, elapsed, checks, info)
        arr = np.asarray(path, dtype=float).reshape(-1, 2)
        return PlanResult(self.name, arr, True, status, elapsed, checks, info)

    @abstractmethod
    def _solve(self, problem: PlanningProblem) -> Solution:
        """The path (or None) with its status and extras, as a `Solution`.

        Start and goal are already known to be collision-free and in the same free region when this
        is called.
        """


def make_planner(name: str, **options: Any) -> Planner:
    """A planner by registry name with its options (``ompl:NAME`` reaches any OMPL geometric planner)."""
    return PLANNERS.create(name, **options)
