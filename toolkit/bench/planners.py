"""The planner benchmark: every planner on every map and query, the same checks, honest numbers.

A benchmark is a set of tasks ``(map, planner, run, seed, start, goal)``. The start and goal of run
``r`` on a map are the map's presets (``queries="presets"``) or a random pair of free positions drawn
from the run's seed (``queries="random"``); every planner gets the same query for the same run. The
exact references (`shortest` for the length ratio, `min-link` for the turn ratio) are computed once
per query. Each run records the planner's result, the path metrics of `planners.metrics` and the
execution error of `toolkit.bench.execution` (the path driven open-loop under motion noise).

Seeds: the seed of run ``r`` on map ``m`` is derived from the benchmark seed, the map name and ``r``
with `numpy.random.SeedSequence`; it is shared by the planners (common random numbers: the same
query and the same motion noise for every planner in a run) and split into independent streams for
planning, execution and query sampling. Same seed, same results, on every executor.

Outputs (`write_results`): ``runs.csv``, ``paths.jsonl``, ``references.csv``, ``summary.md``,
box plots ``boxplot_<metric>.png``, ``exec_vs_turns.png`` (execution error against turns),
``paths.png`` (run 0 of every planner on every map), ``benchmark.log`` (OMPL's log format: one experiment with every
run, the map as an enum run property) and ``ompl/<map>-<queries>.log`` (one OMPL experiment per map
and query set, for Planner Arena), and ``config.json``.
"""

from __future__ import annotations

import csv
import importlib
import json
import logging
import math
import pkgutil
import platform
import time
import zlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from datetime import datetime
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

import numpy as np
import shapely

from ..robots.sim import MotionNoise
from ..world import CollisionChecker, Map, NxtnavError, PlanningError, RobotGeometry, load_map
from .execution import execution_error
from .executors import TasksInterrupted, collect_tasks
from .ompl_log import OmplExperiment, OmplPlannerData, ompl_status, write_ompl_log

__all__ = [
    "RUN_COLUMNS",
    "BenchmarkConfig",
    "BenchmarkResult",
    "Query",
    "ReferenceResult",
    "ReferenceTask",
    "RunRecord",
    "RunTask",
    "check_out_dir",
    "check_planner_names",
    "format_summary",
    "known_planners",
    "load_planner_plugins",
    "make_queries",
    "run_benchmark",
    "run_reference",
    "run_seed",
    "run_task",
    "summarise",
    "turns_error_correlation",
    "write_results",
]

log = logging.getLogger(__name__)

#: Columns of ``runs.csv``, in order.
RUN_COLUMNS = ("map", "planner", "run", "seed", "success", "time_s", "length_cm", "turns", "turn_angle_rad",
               "min_clearance_cm", "collision_checks", "length_ratio", "exec_error_cm")

QueryMode = Literal["presets", "random"]
REFERENCE_PLANNERS = ("shortest", "min-link")
REFERENCE_TIME_LIMIT_S = 30.0


# -- planners ------------------------------------------------------------------------------------
def load_planner_plugins() -> None:
    """Import every module of the `planners` package so that all planners are registered."""
    import planners

    for info in pkgutil.iter_modules(planners.__path__):
        if not info.name.startswith("_"):
            try:
                importlib.import_module(f"planners.{info.name}")
            except ImportError as exc:  # pragma: no cover - an optional dependency missing
                log.warning("planner module planners.%s not loaded: %s", info.name, exc)


def known_planners() -> list[str]:
    """Registered planner names (``ompl:NAME`` reaches any OMPL geometric planner as well)."""
    load_planner_plugins()
    from planners import PLANNERS

    return PLANNERS.names()


def check_planner_names(names: Sequence[str]) -> None:
    """Raise `PlanningError` for a name that is neither registered nor ``ompl:NAME``."""
    known = known_planners()
    bad = [n for n in names if n not in known and not (n.startswith("ompl:") and len(n) > 5)]
    if bad:
        raise PlanningError(f"unknown planner {', '.join(bad)}; known: {', '.join(known)} (or ompl:NAME)")
    from planners import make_planner

    for n in names:
        if n.startswith("ompl:"):
            make_planner(n)  # an unknown OMPL planner name fails here, listing the known ones


# -- seeds and queries ---------------------------------------------------------------------------
def _name_key(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def run_seed(seed: int, map_name: str, run: int) -> int:
    """The seed of run `run` on map `map_name` (shared by all planners), derived from `seed`."""
    ss = np.random.SeedSequence([int(seed) & 0xFFFFFFFF, _name_key(map_name), int(run)])
    return int(ss.generate_state(1, np.uint32)[0])


def _streams(seed: int) -> tuple[np.random.SeedSequence, np.random.SeedSequence, np.random.SeedSequence]:
    """Independent (planning, execution, query) seed sequences of a run seed."""
    plan, execute, query = np.random.SeedSequence(seed).spawn(3)
    return plan, execute, query


@dataclass(frozen=True)
class Query:
    """One start/goal pair on a map (cm)."""

    map: str
    index: int
    start: tuple[float, float]
    goal: tuple[float, float]

    def to_dict(self) -> dict[str, Any]:
        return {"map": self.map, "index": self.index, "start": list(self.start), "goal": list(self.goal)}


def _random_query(m: Map, checker: CollisionChecker, rng: np.random.Generator, min_separation: float,
                  attempts: int = 200) -> tuple[tuple[float, float], tuple[float, float]]:
    cspace = m.free_space(checker.robot_radius)
    parts = list(getattr(cspace, "geoms", [cspace]))
    areas = np.array([p.area for p in parts])
    for _ in range(attempts):
        part = parts[int(rng.choice(len(parts), p=areas / areas.sum()))]
        pts = m.sample_free(16, clearance=checker.robot_radius, rng=rng)
        pts = pts[shapely.contains_xy(part, pts[:, 0], pts[:, 1])]
        pts = pts[np.asarray(checker.point_free(pts), dtype=bool)] if len(pts) else pts
        if len(pts) < 2:
            continue
        a = pts[0]
        far = pts[1:][np.hypot(*(pts[1:] - a).T) >= min_separation]
        if len(far):
            b = far[0]
            return (float(a[0]), float(a[1])), (float(b[0]), float(b[1]))
    raise PlanningError(f"map {m.name!r}: found no free start/goal pair {min_separation:.0f} cm apart")


def make_queries(m: Map, mode: QueryMode, runs: int, seed: int, robot_radius: float,
                 label: str | None = None) -> list[Query]:
    """The queries of a map: one (the presets) or one random pair per run.

    Random pairs are free for the robot disc (checked by FCL), in the same connected part of the
    c-space and at least a quarter of the map's bounding-box diagonal apart. `label` (default the
    map's name) names the map in the queries and in the run seeds.
    """
    name = m.name if label is None else label
    if mode == "presets":
        if m.start is None or m.target is None:
            raise PlanningError(f"map {m.name!r} has no start/target presets; use random queries")
        return [Query(name, 0, (float(m.start[0]), float(m.start[1])),
                      (float(m.target[0]), float(m.target[1])))]
    if mode != "random":
        raise PlanningError(f"queries must be 'presets' or 'random', got {mode!r}")
    checker = CollisionChecker(m, robot_radius)
    xmin, ymin, xmax, ymax = m.bounds
    sep = 0.25 * math.hypot(xmax - xmin, ymax - ymin)
    out = []
    for r in range(runs):
        rng = np.random.default_rng(_streams(run_seed(seed, name, r))[2])
        s, g = _random_query(m, checker, rng, sep)
        out.append(Query(name, r, s, g))
    return out


# -- per-process caches --------------------------------------------------------------------------
@lru_cache(maxsize=32)
def _map(name: str) -> Map:
    return load_map(name)


@lru_cache(maxsize=32)
def _checker(map_name: str, radius: float) -> CollisionChecker:
    return CollisionChecker(_map(map_name), radius)


LARGE_MAP_WALLS = 200
"""Above this many walls (imported real maps) the references adapt: `shortest` grows the walls by a
16-gon instead of a 64-gon (its length tolerance, reported per path, stays below about 1 cm) and
`min-link`, whose dense graph grows with the map's area squared, is skipped."""


def planner_for(name: str, m: Map) -> Any:
    """The planner `name` as the benchmarks configure it for map `m` (None: skipped on this map).

    On a map imported from a grid, `astar` plans on the map's own cells; on a map of more than
    `LARGE_MAP_WALLS` walls the references adapt (see there).
    """
    load_planner_plugins()
    from planners import make_planner

    large = len(m.walls) > LARGE_MAP_WALLS
    if name == "astar" and m.grid is not None:
        return make_planner(name, resolution=None)
    if name == "shortest" and large:
        return make_planner(name, n_sides=16)
    if name == "min-link" and large:
        return None
    return make_planner(name)


@lru_cache(maxsize=64)
def _planner(name: str, map_name: str) -> Any:
    return planner_for(name, _map(map_name))


# -- tasks ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReferenceTask:
    """Compute the exact references of one query."""

    query: Query
    robot_radius: float
    time_limit: float = REFERENCE_TIME_LIMIT_S


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

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["query"] = self.query.to_dict()
        d["shortest_path"] = [list(p) for p in self.shortest_path]
        d["min_link_path"] = [list(p) for p in self.min_link_path]
        return d


def _path_tuple(path: np.ndarray) -> tuple[tuple[float, float], ...]:
    return tuple((float(x), float(y)) for x, y in np.asarray(path, dtype=float).reshape(-1, 2))


def run_reference(task: ReferenceTask) -> ReferenceResult:
    """Solve one query with `shortest` and `min-link` (the yardsticks of the ratios)."""
    from planners import PLANNERS, PlanningProblem
    from planners.metrics import count_turns, path_length

    load_planner_plugins()
    q = task.query
    checker = _checker(q.map, task.robot_radius)
    t0 = time.perf_counter()
    results: dict[str, Any] = {}
    statuses = []
    for name in REFERENCE_PLANNERS:
        if name not in PLANNERS:
            statuses.append(f"{name}: not registered")
            continue
        planner = _planner(name, q.map)
        if planner is None:
            statuses.append(f"{name}: skipped on a map of {len(_map(q.map).walls)} walls")
            continue
        problem = PlanningProblem(_map(q.map), checker, np.array(q.start), np.array(q.goal), task.time_limit,
                                  np.random.default_rng(0))
        res = planner.plan(problem)
        statuses.append(f"{name}: {res.status}")
        if res.success:
            results[name] = res.path
    sp, ml = results.get("shortest"), results.get("min-link")
    return ReferenceResult(
        query=q,
        shortest_length_cm=path_length(sp) if sp is not None else math.nan,
        shortest_turns=count_turns(sp) if sp is not None else None,
        min_link_turns=count_turns(ml) if ml is not None else None,
        min_link_length_cm=path_length(ml) if ml is not None else math.nan,
        status="; ".join(statuses),
        time_s=time.perf_counter() - t0,
        shortest_path=_path_tuple(sp) if sp is not None else (),
        min_link_path=_path_tuple(ml) if ml is not None else (),
    )


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


@dataclass(frozen=True)
class RunRecord:
    """The outcome of one `RunTask` (metrics are NaN when the plan failed).

    ``time_s`` is the planning time (anytime planners use the whole budget); ``first_solution_s``
    the time to their first solution (the planning time for planners that stop there).
    """

    map: str
    planner: str
    run: int
    seed: int
    query: int
    start: tuple[float, float]
    goal: tuple[float, float]
    success: bool
    status: str
    time_s: float
    collision_checks: int
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
    first_solution_s: float = math.nan
    path: tuple[tuple[float, float], ...] = field(default=(), repr=False)

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["path"] = [list(p) for p in self.path]
        d["start"], d["goal"] = list(self.start), list(self.goal)
        return d


def run_task(task: RunTask) -> RunRecord:
    """Run one planner on one query (a picklable top-level function for the executors).

    A planner that raises is recorded as a failed run with status ``error: ...`` (never lost).
    """
    from planners import PlanningProblem
    from planners.metrics import path_metrics

    q = task.query
    m = _map(task.map)
    checker = _checker(task.map, task.robot_radius)
    plan_ss, exec_ss, _ = _streams(task.seed)
    base: dict[str, Any] = {"map": task.map, "planner": task.planner, "run": task.run, "seed": task.seed,
                            "query": q.index, "start": q.start, "goal": q.goal}
    problem = PlanningProblem(m, checker, np.array(q.start), np.array(q.goal), task.time_limit,
                              np.random.default_rng(plan_ss))
    checks0 = checker.checks
    t0 = time.perf_counter()
    try:
        res = _planner(task.planner, task.map).plan(problem)
    except NxtnavError:
        raise
    except Exception as exc:  # a crashing planner is a result, not the end of the benchmark
        log.warning("planner %s crashed on %s run %d: %s", task.planner, task.map, task.run, exc)
        return RunRecord(**base, success=False, status=f"error: {type(exc).__name__}: {exc}",
                         time_s=time.perf_counter() - t0, collision_checks=checker.checks - checks0)
    if not res.success or len(res.path) < 1:
        return RunRecord(**base, success=False, status=res.status, time_s=res.time_s,
                         collision_checks=res.collision_checks)
    path = np.asarray(res.path, dtype=float).reshape(-1, 2)
    met = path_metrics(path, checker, reference_length=task.reference_length,
                       reference_turns=task.reference_turns)
    if len(path) >= 2 and task.exec_repeats > 0:
        ex = execution_error(path, checker, goal=q.goal, repeats=task.exec_repeats, noise=task.noise, rng=exec_ss)
        exec_mean, exec_median, exec_coll = ex.mean_cm, ex.median_cm, ex.collision_fraction
    else:
        exec_mean = exec_median = exec_coll = math.nan
    return RunRecord(
        **base,
        success=True,
        status=res.status,
        time_s=res.time_s,
        collision_checks=res.collision_checks,
        length_cm=met.length_cm,
        turns=float(met.turns),
        turn_angle_rad=met.turn_angle_rad,
        min_clearance_cm=met.min_clearance_cm,
        mean_clearance_cm=met.mean_clearance_cm,
        length_ratio=met.length_ratio,
        turn_ratio=met.turn_ratio,
        exec_error_cm=exec_mean,
        exec_median_cm=exec_median,
        exec_collision_fraction=exec_coll,
        first_solution_s=_first_solution(res.info, res.time_s),
        path=_path_tuple(path),
    )


def _first_solution(info: dict[str, Any], time_s: float) -> float:
    """Time to the first solution (s): reported by anytime planners, else the planning time.

    NaN when an anytime planner could not observe it (OMPL's PRM grows its roadmap in a thread).
    """
    if "first_solution_s" not in info:
        return time_s
    v = info["first_solution_s"]
    return float(v) if v is not None and math.isfinite(float(v)) else math.nan


# -- the benchmark -------------------------------------------------------------------------------
@dataclass(frozen=True)
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
    """

    maps: tuple[str, ...]
    planners: tuple[str, ...]
    runs: int = 50
    time_limit: float = 1.0
    seed: int = 0
    queries: QueryMode = "presets"
    exec_repeats: int = 100
    robot_radius: float = RobotGeometry().radius_cm
    noise: MotionNoise = field(default_factory=MotionNoise)

    def __post_init__(self) -> None:
        if not self.maps:
            raise PlanningError("no maps to benchmark")
        if not self.planners:
            raise PlanningError("no planners to benchmark")
        if len(set(self.maps)) != len(self.maps):
            raise PlanningError(f"map listed twice in {', '.join(self.maps)}")
        if len(set(self.planners)) != len(self.planners):
            raise PlanningError(f"planner listed twice in {', '.join(self.planners)}")
        if self.runs < 1:
            raise PlanningError(f"runs must be >= 1, got {self.runs}")
        if not (math.isfinite(self.time_limit) and self.time_limit > 0):
            raise PlanningError(f"time limit must be a positive number of seconds, got {self.time_limit}")
        if self.exec_repeats < 0:
            raise PlanningError(f"exec repeats must be >= 0, got {self.exec_repeats}")
        if self.queries not in ("presets", "random"):
            raise PlanningError(f"queries must be 'presets' or 'random', got {self.queries!r}")
        if not (math.isfinite(self.robot_radius) and self.robot_radius > 0):
            raise PlanningError(f"robot radius must be a positive number of cm, got {self.robot_radius}")

    def n_queries(self) -> int:
        return len(self.maps) * (1 if self.queries == "presets" else self.runs)

    def n_tasks(self) -> int:
        """Tasks the benchmark runs: the references of each query, then every planner run."""
        return self.n_queries() + len(self.maps) * len(self.planners) * self.runs

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["maps"], d["planners"] = list(self.maps), list(self.planners)
        d["noise"] = self.noise.to_dict()
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


def run_benchmark(
    config: BenchmarkConfig,
    *,
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[Any], None] | None = None,
) -> BenchmarkResult:
    """Run the benchmark: the references of every query, then every planner run.

    Parameters
    ----------
    config : BenchmarkConfig
    workers : int
        Processes (1 runs in this process).
    dask_address : str or None
        Dask scheduler address or ``"local"`` (see `toolkit.bench.executors.run_tasks`).
    on_done : callable or None
        Called with each `ReferenceResult` and `RunRecord` as it finishes (progress bars);
        `config.n_tasks()` is the total.

    Ctrl-C ends the run early: the result then holds the finished runs and ``complete`` is False
    (the written files say so).
    """
    check_planner_names(config.planners)
    started = datetime.now()
    t0 = time.perf_counter()
    maps = {name: load_map(name) for name in config.maps}
    queries: list[Query] = []
    for name, m in maps.items():
        queries.extend(make_queries(m, config.queries, config.runs, config.seed, config.robot_radius, label=name))
    ref_tasks = [ReferenceTask(q, config.robot_radius) for q in queries]
    try:
        refs = collect_tasks(run_reference, ref_tasks, workers=workers, dask_address=dask_address, on_done=on_done)
    except TasksInterrupted:  # no planner has run yet: nothing to keep
        raise KeyboardInterrupt from None
    ref_of = {(r.query.map, r.query.index): r for r in refs}
    tasks = []
    for name in config.maps:
        for run in range(config.runs):
            qi = 0 if config.queries == "presets" else run
            ref = ref_of[(name, qi)]
            for planner in config.planners:
                tasks.append(RunTask(
                    map=name, planner=planner, run=run, seed=run_seed(config.seed, name, run),
                    query=ref.query, time_limit=config.time_limit, robot_radius=config.robot_radius,
                    exec_repeats=config.exec_repeats, noise=config.noise,
                    reference_length=None if math.isnan(ref.shortest_length_cm) else ref.shortest_length_cm,
                    reference_turns=ref.min_link_turns,
                ))
    complete = True
    try:
        records = collect_tasks(run_task, tasks, workers=workers, dask_address=dask_address, on_done=on_done)
    except TasksInterrupted as exc:
        records, complete = list(exc.results), False
    records.sort(key=lambda r: (config.maps.index(r.map), config.planners.index(r.planner), r.run))
    refs.sort(key=lambda r: (config.maps.index(r.query.map), r.query.index))
    return BenchmarkResult(config, tuple(records), tuple(refs), started, time.perf_counter() - t0,
                           {name: m.name for name, m in maps.items()}, complete)


# -- summaries -----------------------------------------------------------------------------------
def _median(values: Iterable[float]) -> float:
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    return float(np.median(v)) if len(v) else math.nan


def summarise(result: BenchmarkResult) -> dict[str, list[dict[str, Any]]]:
    """Per map, one row per planner: runs, success rate and medians over the successful runs."""
    out: dict[str, list[dict[str, Any]]] = {}
    for m in result.config.maps:
        rows = []
        for p in result.config.planners:
            rs = [r for r in result.records if r.map == m and r.planner == p]
            ok = [r for r in rs if r.success]
            rows.append({
                "planner": p,
                "runs": len(rs),
                "success_rate": len(ok) / len(rs) if rs else math.nan,
                "median_time_s": _median(r.time_s for r in ok),
                "median_first_solution_s": _median(r.first_solution_s for r in ok),
                "median_length_cm": _median(r.length_cm for r in ok),
                "median_length_ratio": _median(r.length_ratio for r in ok),
                "median_turns": _median(r.turns for r in ok),
                "median_turn_ratio": _median(r.turn_ratio for r in ok),
                "median_min_clearance_cm": _median(r.min_clearance_cm for r in ok),
                "median_exec_error_cm": _median(r.exec_error_cm for r in ok),
                "median_exec_collision_fraction": _median(r.exec_collision_fraction for r in ok),
                "median_collision_checks": _median(float(r.collision_checks) for r in ok),
            })
        out[m] = rows
    return out


def _fmt(v: float, spec: str) -> str:
    return "–" if v is None or not math.isfinite(v) else format(v, spec)


def _pct(v: float) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{100 * v:.0f}%"


def format_summary(result: BenchmarkResult) -> str:
    """``summary.md``: the settings, then one Markdown table per map."""
    c = result.config
    nz = c.noise
    lines = [
        "# Planner benchmark",
        "",
        f"- maps: {', '.join(c.maps)}; planners: {', '.join(c.planners)}",
        f"- {c.runs} runs per planner and map, {c.time_limit:g} s budget, seed {c.seed}, queries: {c.queries}",
        f"- robot radius {c.robot_radius:g} cm; execution error: mean final distance to the goal over "
        f"{c.exec_repeats} open-loop drives, noise {nz.model} (motion {nz.motion:g}, turn {nz.turn:g})",
        f"- started {result.started.isoformat(timespec='seconds')}, total {result.total_time_s:.1f} s",
        "",
        "Medians over the successful runs. Time is the planning time (anytime planners such as RRT* and PRM "
        "use the whole budget); first solution is the time to their first path (– when the planner cannot "
        "observe it). Length ratio = length / shortest path; turns are heading changes above 1 degree; exec "
        "error = mean distance (cm) from the goal after driving the path open-loop; exec collisions = share "
        "of those drives that touched a wall.",
    ]
    summary = summarise(result)
    for m in c.maps:
        refs = [r for r in result.references if r.query.map == m]
        lines += ["", f"## {m}", ""]
        if c.queries == "presets" and refs:
            r = refs[0]
            lines.append(f"Query: start ({r.query.start[0]:g}, {r.query.start[1]:g}), goal ({r.query.goal[0]:g}, "
                         f"{r.query.goal[1]:g}); shortest {_fmt(r.shortest_length_cm, '.1f')} cm, min-link "
                         f"{'–' if r.min_link_turns is None else r.min_link_turns} turns.")
        elif refs:
            ml_turns = _median(float(r.min_link_turns) for r in refs if r.min_link_turns is not None)
            lines.append(f"{len(refs)} random queries; median shortest path "
                         f"{_fmt(_median(r.shortest_length_cm for r in refs), '.1f')} cm, median min-link turns "
                         f"{_fmt(ml_turns, 'g')}.")
        lines += ["",
                  "| planner | success | median time (ms) | first solution (ms) | length ratio | turns | "
                  "exec error (cm) | exec collisions | collision checks |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for row in summary[m]:
            lines.append(
                f"| {row['planner']} | {_pct(row['success_rate'])} | "
                f"{_fmt(1e3 * row['median_time_s'], '.2f')} | {_fmt(1e3 * row['median_first_solution_s'], '.2f')} | "
                f"{_fmt(row['median_length_ratio'], '.3f')} | "
                f"{_fmt(row['median_turns'], 'g')} | {_fmt(row['median_exec_error_cm'], '.2f')} | "
                f"{_pct(row['median_exec_collision_fraction'])} | "
                f"{_fmt(row['median_collision_checks'], '.0f')} |")
        rho, n = turns_error_correlation(result, m)
        if math.isfinite(rho):
            lines += ["", f"Execution error vs turns over all successful runs: Spearman rank correlation "
                          f"{rho:+.2f} (n = {n})."]
    return "\n".join(lines) + "\n"


def turns_error_correlation(result: BenchmarkResult, map_name: str) -> tuple[float, int]:
    """Spearman rank correlation of execution error with turns over the successful runs on a map.

    Returns ``(rho, n)``; rho is NaN with fewer than 3 runs or when either quantity is constant.
    """
    from scipy.stats import spearmanr

    pts = [(r.turns, r.exec_error_cm) for r in result.records
           if r.map == map_name and r.success and math.isfinite(r.turns) and math.isfinite(r.exec_error_cm)]
    if len(pts) < 3:
        return math.nan, len(pts)
    t, e = np.array(pts).T
    if np.ptp(t) == 0 or np.ptp(e) == 0:
        return math.nan, len(pts)
    return float(spearmanr(t, e).statistic), len(pts)


# -- writers -------------------------------------------------------------------------------------
def check_out_dir(out: str | Path, force: bool = False) -> Path:
    """The output folder, created; a non-empty existing folder is refused unless `force`."""
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise NxtnavError(f"--out {str(p)!r} exists and is not a folder")
    if p.is_dir() and any(p.iterdir()) and not force:
        raise NxtnavError(f"--out {str(p)!r} is not empty; choose another folder or pass --force to overwrite")
    p.mkdir(parents=True, exist_ok=True)
    return p


def _csv_value(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        if not math.isfinite(v):
            return ""
        return f"{v:.10g}"
    return str(v)


def write_runs_csv(result: BenchmarkResult, path: Path) -> None:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(RUN_COLUMNS)
        for r in result.records:
            row = []
            for col in RUN_COLUMNS:
                v = getattr(r, col)
                if col == "turns" and isinstance(v, float) and math.isfinite(v):
                    v = int(v)
                row.append(_csv_value(v))
            w.writerow(row)


def write_paths_jsonl(result: BenchmarkResult, path: Path) -> None:
    with path.open("w", encoding="utf-8") as fh:
        for r in result.records:
            doc = {"map": r.map, "planner": r.planner, "run": r.run, "seed": r.seed, "success": r.success,
                   "path": [list(p) for p in r.path], "status": r.status, "query": r.query,
                   "start": list(r.start), "goal": list(r.goal), "time_s": r.time_s,
                   "first_solution_s": r.first_solution_s if math.isfinite(r.first_solution_s) else None}
            fh.write(json.dumps(doc) + "\n")


def write_references_csv(result: BenchmarkResult, path: Path) -> None:
    cols = ("map", "query", "start_x", "start_y", "goal_x", "goal_y", "shortest_length_cm", "min_link_turns",
            "min_link_length_cm", "status")
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in result.references:
            q = r.query
            w.writerow([_csv_value(v) for v in (q.map, q.index, q.start[0], q.start[1], q.goal[0], q.goal[1],
                                                r.shortest_length_cm, r.min_link_turns, r.min_link_length_cm,
                                                r.status)])


_OMPL_PROPERTIES = (
    ("time", "REAL"),
    ("first solution time", "REAL"),
    ("solved", "BOOLEAN"),
    ("status", "ENUM"),
    ("approximate solution", "BOOLEAN"),
    ("correct solution", "BOOLEAN"),
    ("solution length", "REAL"),
    ("solution clearance", "REAL"),
    ("solution segments", "INTEGER"),
    ("solution turns", "INTEGER"),
    ("solution turn angle", "REAL"),
    ("length ratio", "REAL"),
    ("turn ratio", "REAL"),
    ("execution error", "REAL"),
    ("execution error median", "REAL"),
    ("execution collision fraction", "REAL"),
    ("collision checks", "INTEGER"),
    ("run", "INTEGER"),
    ("seed", "INTEGER"),
    ("query", "INTEGER"),
)


def _ompl_row(r: RunRecord) -> list[Any]:
    ok = r.success
    segments = max(len(r.path) - 1, 0) if ok else None
    return [r.time_s, r.first_solution_s, ok, ompl_status(ok, r.status), False if ok else None, True if ok else None,
            r.length_cm, r.min_clearance_cm, segments, int(r.turns) if ok else None, r.turn_angle_rad,
            r.length_ratio, r.turn_ratio, r.exec_error_cm, r.exec_median_cm, r.exec_collision_fraction,
            r.collision_checks, r.run, r.seed, r.query]


def _ompl_experiment(result: BenchmarkResult, maps: Sequence[str], name: str) -> OmplExperiment:
    c = result.config
    multi = len(maps) > 1
    props = list(_OMPL_PROPERTIES) + ([("map", "ENUM")] if multi else [])
    planners = []
    for p in c.planners:
        rows = []
        for r in result.records:
            if r.planner == p and r.map in maps:
                row = _ompl_row(r)
                if multi:
                    row.append(list(maps).index(r.map))
                rows.append(row)
        planners.append(OmplPlannerData(p, props, rows, {"planner": p, "time_limit": c.time_limit}))
    setup = [f"nxtnav planner benchmark: maps {', '.join(maps)}; queries {c.queries}",
             f"robot radius {c.robot_radius:g} cm; planners validated by the shared FCL collision checker",
             f"execution error: {c.exec_repeats} open-loop drives, noise {json.dumps(c.noise.to_dict())}"]
    for ref in result.references:
        if ref.query.map in maps:
            q = ref.query
            setup.append(f"{q.map} query {q.index}: start {q.start} goal {q.goal} shortest "
                         f"{_fmt(ref.shortest_length_cm, '.3f')} cm min-link turns {ref.min_link_turns}")
    return OmplExperiment(
        name=name,
        planners=planners,
        time_limit_s=c.time_limit,
        total_time_s=result.total_time_s,
        seed=c.seed,
        run_count=c.runs,
        setup="\n".join(setup),
        properties={"robot_radius_cm": ("REAL", c.robot_radius), "exec_repeats": ("INTEGER", c.exec_repeats),
                    "motion_noise": ("REAL", c.noise.motion), "turn_noise": ("REAL", c.noise.turn)},
        enums={"map": list(maps)} if multi else {},
        date=result.started,
        cpuinfo=platform.processor() or platform.machine(),
    )


def write_results(result: BenchmarkResult, out: str | Path, *, plots: bool = True) -> dict[str, Path]:
    """Write every output file of `result` into folder `out` (see the module docstring)."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    files = {"runs": d / "runs.csv", "paths": d / "paths.jsonl", "references": d / "references.csv",
             "summary": d / "summary.md", "ompl_log": d / "benchmark.log", "config": d / "config.json"}
    write_runs_csv(result, files["runs"])
    write_paths_jsonl(result, files["paths"])
    write_references_csv(result, files["references"])
    c = result.config
    planned = c.runs * len(c.maps) * len(c.planners)
    note = "" if result.complete else (f"**INCOMPLETE**: interrupted after {len(result.records)} of {planned} "
                                       "planner runs; the tables cover only the finished runs.\n\n")
    files["summary"].write_text(note + format_summary(result), encoding="utf-8")
    files["config"].write_text(json.dumps({"config": c.to_dict(), "started": result.started.isoformat(),
                                           "total_time_s": result.total_time_s, "complete": result.complete,
                                           "runs_done": len(result.records), "runs_planned": planned},
                                          indent=1), encoding="utf-8")
    write_ompl_log(files["ompl_log"], _ompl_experiment(result, c.maps, f"nxtnav-planners-{c.queries}"))
    for stale in (d / "ompl").glob("*.log"):  # per-map logs of an earlier benchmark (--force) would mix in
        if stale.stem.endswith(("-presets", "-random")):
            stale.unlink()
    for m in c.maps:
        key = f"ompl_{m}"
        files[key] = write_ompl_log(d / "ompl" / f"{Path(m).stem}-{c.queries}.log",
                                    _ompl_experiment(result, [m], f"{Path(m).stem}-{c.queries}"))
    if plots:
        from .planners_plots import save_plots

        files.update(save_plots(result, d))
    return files
