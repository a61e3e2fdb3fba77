"""What the planner benchmark runs and records: its configuration, tasks, run records and result."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import Field, InstanceOf, field_validator, model_validator

from planners import PlanStatus

from ...robots.sim import MotionNoise
from ...world import CHECKER_BACKENDS, RobotGeometry, RobotTiming
from ...world.typed import typed_dataclass
from .simplify import SimplifyMethod

#: Columns of ``runs.csv``, in order: the raw path's metrics, its first solution, then the simplified path's,
#: then the objective the planner minimised, the path's cost under it, the query's reference cost under it,
#: and the raw path's robot time (s) and predicted open-loop error (cm).
RUN_COLUMNS = ("map", "planner", "run", "seed", "success", "time_s", "length_cm", "turns", "turn_angle_rad",
               "min_clearance_cm", "collision_checks", "length_ratio", "exec_error_cm", "first_solution_s",
               "first_solution_length_cm", "simplify", "simplify_time_s", "simplified_length_cm", "simplified_turns",
               "simplified_min_clearance_cm", "simplified_length_ratio", "simplified_exec_error_cm", "collision",
               "objective", "objective_cost", "reference_cost", "robot_time_s", "predicted_error_cm")

#: Columns of ``runs.csv`` that hold wall-clock measures: they differ between two runs of the same seed.
TIMING_COLUMNS = frozenset({"time_s", "first_solution_s", "simplify_time_s"})

#: Columns of ``progress.csv``: one best-cost sample of an anytime planner's run per row.
PROGRESS_COLUMNS = ("map", "planner", "run", "seed", "time_s", "iterations", "best_cost_cm")

ProgressSample = tuple[float, int, float]
"""``(time_s, iterations, best_cost_cm)``: wall-clock time since the planning call began, termination
condition polls (about one per iteration) and the best path length so far (inf before a solution)."""


QueryMode = Literal["presets", "random"]


REFERENCE_PLANNERS = ("shortest", "min-link", "fastest")
"""The references: the optimum of a query by length, by turns (an upper bound, `planners.reference`)
and by robot time (`planners.reference_time`)."""



REFERENCE_TIME_LIMIT_S = 30.0


@dataclass(frozen=True)
class Query:
    """One start/goal pair on a map (cm)."""

    map: str
    index: int
    start: tuple[float, float]
    goal: tuple[float, float]

    def to_dict(self) -> dict[str, Any]:
        return {"map": self.map, "index": self.index, "start": list(self.start), "goal": list(self.goal)}


LARGE_MAP_WALLS = 200
"""Above this many walls (imported real maps) the references adapt: `shortest` grows the walls by a
16-gon instead of a 64-gon (its length tolerance, reported per path, stays below about 1 cm) and
`min-link`, whose dense graph grows with the map's area squared, is skipped."""


# -- tasks ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReferenceTask:
    """Compute the exact references of one query."""

    query: Query
    robot_radius: float
    time_limit: float = REFERENCE_TIME_LIMIT_S
    collision: str = "index"
    timing: RobotTiming = field(default_factory=RobotTiming)


@dataclass(frozen=True)
class ReferenceResult:
    """The exact references of one query (NaN / None when a reference planner is missing or failed)."""

    query: Query
    shortest_length_cm: float
    shortest_turns: int | None
    min_link_turns: int | None
    min_link_length_cm: float
    status: str
    time_s: float
    shortest_path: tuple[tuple[float, float], ...] = ()
    min_link_path: tuple[tuple[float, float], ...] = ()
    fastest_time_s: float = math.nan
    fastest_path: tuple[tuple[float, float], ...] = ()

    def cost(self, objective: str) -> float:
        """The query's reference cost under `objective`: shortest length (cm), min-link turns, least
        robot time (s); NaN when that reference is missing."""
        if objective == "length":
            return self.shortest_length_cm
        if objective == "turns":
            return math.nan if self.min_link_turns is None else float(self.min_link_turns)
        return self.fastest_time_s

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["query"] = self.query.to_dict()
        for k in ("shortest_path", "min_link_path", "fastest_path"):
            d[k] = [list(p) for p in getattr(self, k)]
        return d


@dataclass(frozen=True)
class RunTask:
    """One planner run: plan a query, measure the path, drive it open-loop."""

    map: str
    planner: str
    run: int
    seed: int
    query: Query
    time_limit: float
    robot_radius: float
    exec_repeats: int
    noise: MotionNoise
    reference_length: float | None = None
    reference_turns: int | None = None
    collision: str = "index"
    simplify: SimplifyMethod = "ompl"
    progress_interval: float = 0.01
    options: tuple[tuple[str, Any], ...] = ()
    """The planner's `--set` options (checked against its declarations), as sorted pairs; its objective
    is one of them."""
    timing: RobotTiming = field(default_factory=RobotTiming)
    reference_costs: tuple[tuple[str, float], ...] = ()
    """The query's reference cost under each objective (`ReferenceResult.cost`)."""


@dataclass(frozen=True)
class RunKey:
    """Which run a record is: map, planner, run number, seed and query (index, start and goal in cm)."""

    map: str
    planner: str
    run: int
    seed: int
    query: int
    start: tuple[float, float]
    goal: tuple[float, float]


@dataclass(frozen=True)
class PathMeasures:
    """One path's measures (NaN when there is no path): its metrics against the references, its
    open-loop execution error over the drives, its cost to the robot (robot time, predicted error) and
    its cost under the run's objective.

    The execution error is measured (`toolkit.bench.execution`); ``predicted_error_cm`` is the closed
    form of `toolkit.world.predicted_error_cm` (root mean square, no walls).
    """

    length_cm: float = math.nan
    turns: float = math.nan
    turn_angle_rad: float = math.nan
    min_clearance_cm: float = math.nan
    mean_clearance_cm: float = math.nan
    length_ratio: float = math.nan
    turn_ratio: float = math.nan
    exec_error_cm: float = math.nan
    exec_median_cm: float = math.nan
    exec_collision_fraction: float = math.nan
    robot_time_s: float = math.nan
    predicted_error_cm: float = math.nan
    objective_cost: float = math.nan
    path: tuple[tuple[float, float], ...] = field(default=(), repr=False)

    def to_dict(self, prefix: str = "") -> dict[str, Any]:
        d = {f"{prefix}{k}": v for k, v in asdict(self).items()}
        d[f"{prefix}path"] = [list(p) for p in self.path]
        return d


_KEY_FIELDS = frozenset(RunKey.__dataclass_fields__)
_MEASURE_FIELDS = frozenset(PathMeasures.__dataclass_fields__)
_SIMPLIFIED = "simplified_"


@dataclass(frozen=True)
class RunRecord:
    """The outcome of one `RunTask` (metrics are NaN when the plan failed).

    ``time_s`` is the planning time (anytime planners use the whole budget); ``first_solution_s``
    and ``first_solution_length_cm`` the time to their first solution and its length (the planning
    time and the path for planners that stop there). ``progress`` holds the best-cost samples of
    planners that report them (OMPL's), ``params`` their declared parameters. `raw` measures the
    planner's path, `simplified` the path after `RunTask.simplify` (NaN when it is ``none`` or the plan
    failed); ``simplify_time_s`` is the simplification time, not part of ``time_s``. ``objective`` is
    what the planner minimised and ``reference_cost`` the reference optimum of the query under it (its
    unit: cm, turns or s; `REFERENCE_PLANNERS`).

    The fields of `key` and of `raw` read as the record's own (``record.map``, ``record.length_cm``),
    and those of `simplified` with the prefix ``simplified_`` (``record.simplified_length_cm``): the
    names of ``runs.csv``'s columns. `build` makes a record from those flat names.
    """

    key: RunKey
    success: bool
    status: PlanStatus
    time_s: float
    collision_checks: int
    detail: str = ""
    collision: str = "index"
    """The checker that answered (``index``, ``fcl``, or ``point`` for a point robot)."""
    objective: str = "length"
    reference_cost: float = math.nan
    first_solution_s: float = math.nan
    first_solution_length_cm: float = math.nan
    simplify: str = "none"
    simplify_time_s: float = math.nan
    raw: PathMeasures = field(default_factory=PathMeasures)
    simplified: PathMeasures = field(default_factory=PathMeasures)
    progress: tuple[ProgressSample, ...] = field(default=(), repr=False)
    params: tuple[tuple[str, bool | int | float | str], ...] = field(default=(), repr=False)

    @classmethod
    def build(cls, **flat: Any) -> RunRecord:
        """A record from flat names: the key's and the raw measures' own, ``simplified_*`` for the
        simplified path's, and the record's other fields."""
        key = {k: flat.pop(k) for k in list(flat) if k in _KEY_FIELDS}
        raw = {k: flat.pop(k) for k in list(flat) if k in _MEASURE_FIELDS}
        simplified = {k[len(_SIMPLIFIED):]: flat.pop(k) for k in list(flat)
                      if k.startswith(_SIMPLIFIED) and k[len(_SIMPLIFIED):] in _MEASURE_FIELDS}
        return cls(RunKey(**key), raw=PathMeasures(**raw), simplified=PathMeasures(**simplified), **flat)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or "key" not in self.__dict__:
            raise AttributeError(name)
        if name in _KEY_FIELDS:
            return getattr(self.key, name)
        if name in _MEASURE_FIELDS:
            return getattr(self.raw, name)
        if name.startswith(_SIMPLIFIED) and name[len(_SIMPLIFIED):] in _MEASURE_FIELDS:
            return getattr(self.simplified, name[len(_SIMPLIFIED):])
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {k: getattr(self.key, k) for k in RunKey.__dataclass_fields__}
        d.update({k: getattr(self, k) for k in self.__dataclass_fields__ if k not in ("key", "raw", "simplified")})
        d.update(self.raw.to_dict())
        d.update(self.simplified.to_dict(_SIMPLIFIED))
        d["status"] = str(self.status)
        d["progress"] = [list(s) for s in self.progress]
        d["params"] = dict(self.params)
        d["start"], d["goal"] = list(self.key.start), list(self.key.goal)
        return d


# -- the benchmark -------------------------------------------------------------------------------
@typed_dataclass()
class BenchmarkConfig:
    """What to benchmark.

    Parameters
    ----------
    maps, planners : sequence of str
        Map names (or files) and planner names (registry names or ``ompl:NAME``).
    runs : int
        Runs per planner and map.
    time_limit : float
        Planning budget per run (s).
    seed : int
        Benchmark seed (every run seed derives from it).
    queries : {"presets", "random"}
        Start/goal per run.
    exec_repeats : int
        Open-loop drives per successful run for the execution error (0 skips it).
    robot_radius : float
        Robot disc radius (cm).
    noise : MotionNoise
        Motion noise of the execution error (the paper's BotSim noise by default).
    collision : {"index", "fcl"}
        Collision backend of the shared checker (`toolkit.world.make_checker`).
    simplify : {"none", "shortcut", "ompl"}
        How each path is simplified before its simplified metrics are measured (`.simplify`).
    progress_interval : float
        Seconds of budget between two best-cost samples of the anytime planners (besides one at
        every improvement).
    planner_options : mapping
        Per planner name, options checked against its declarations (`planners.declarations`; the
        command line's ``--set NAME.KEY=VALUE``).
    objective : str or None
        What every planner minimises (`toolkit.world.OBJECTIVES`); None: each its own default. A
        planner's ``objective`` option overrides it.
    timing : RobotTiming
        The robot's speed, turn rate and stop-and-turn time: its robot time.
    """

    maps: Annotated[tuple[str, ...], Field(min_length=1)]
    planners: Annotated[tuple[str, ...], Field(min_length=1)]
    runs: int = Field(default=50, ge=1)
    time_limit: float = Field(default=1.0, gt=0, allow_inf_nan=False)
    seed: int = 0
    queries: QueryMode = "presets"
    exec_repeats: int = Field(default=100, ge=0)
    robot_radius: float = Field(default=RobotGeometry().radius_cm, ge=0, allow_inf_nan=False)
    noise: InstanceOf[MotionNoise] = Field(default_factory=MotionNoise)
    collision: str = "index"
    simplify: SimplifyMethod = "ompl"
    progress_interval: float = Field(default=0.01, gt=0, allow_inf_nan=False)
    planner_options: dict[str, dict[str, Any]] = Field(default_factory=dict)
    objective: str | None = None
    timing: InstanceOf[RobotTiming] = Field(default_factory=RobotTiming)

    @field_validator("collision")
    @classmethod
    def _backend(cls, value: str) -> str:
        if value not in CHECKER_BACKENDS:
            raise ValueError(f"must be one of {', '.join(CHECKER_BACKENDS)}")
        return value

    @model_validator(mode="after")
    def _each_once(self) -> BenchmarkConfig:
        for what, names in (("map", self.maps), ("planner", self.planners)):
            if len(set(names)) != len(names):
                raise ValueError(f"{what} listed twice in {', '.join(names)}")
        return self

    def n_queries(self) -> int:
        return len(self.maps) * (1 if self.queries == "presets" else self.runs)

    def n_tasks(self) -> int:
        """Tasks the benchmark runs: the references of each query, then every planner run."""
        return self.n_queries() + len(self.maps) * len(self.planners) * self.runs

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["maps"], d["planners"] = list(self.maps), list(self.planners)
        d["noise"] = self.noise.to_dict()
        d["timing"] = self.timing.to_dict()
        return d


@dataclass(frozen=True, eq=False)
class BenchmarkResult:
    """Every run and reference of a benchmark, with its configuration and timing."""

    config: BenchmarkConfig
    records: tuple[RunRecord, ...]
    references: tuple[ReferenceResult, ...]
    started: datetime
    total_time_s: float
    map_names: dict[str, str] = field(default_factory=dict)
    complete: bool = True
    """False when Ctrl-C ended the run early: `records` holds the runs that had finished."""

    def to_dict(self) -> dict[str, Any]:
        return {"config": self.config.to_dict(), "started": self.started.isoformat(timespec="seconds"),
                "total_time_s": self.total_time_s, "references": [r.to_dict() for r in self.references],
                "records": [r.to_dict() for r in self.records]}
