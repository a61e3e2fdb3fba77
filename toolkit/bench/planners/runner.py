"""Running the planner benchmark: planner names, run seeds, queries, one run, the whole benchmark."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from datetime import datetime
from functools import lru_cache
from typing import Any

import numpy as np
import shapely

from planners import PLANNERS, PlanningProblem, PlanStatus, make_planner
from planners.declarations import planner_kwargs
from planners.metrics import count_turns, path_length, path_metrics

from ...seeds import derive_seed
from ...world import (
    OBJECTIVES,
    CollisionChecker,
    Map,
    NxtnavError,
    PlanningError,
    check_objective,
    load_map,
    make_checker,
    objective_cost,
    predicted_error_cm,
    robot_time_s,
)
from ..common import cached_map, isolate_planners
from ..execution import execution_error
from ..executors import TasksInterrupted, collect_tasks
from .records import (
    LARGE_MAP_WALLS,
    REFERENCE_PLANNERS,
    BenchmarkConfig,
    BenchmarkResult,
    ProgressSample,
    Query,
    QueryMode,
    ReferenceResult,
    ReferenceTask,
    RunRecord,
    RunTask,
)
from .simplify import simplify_path

log = logging.getLogger(__name__)


# -- planners ------------------------------------------------------------------------------------
def known_planners() -> list[str]:
    """Registered planner names (``ompl:NAME`` reaches any OMPL geometric planner as well)."""
    return PLANNERS.names()


def check_planner_names(names: Sequence[str]) -> None:
    """Raise `RegistryError` (listing the known names) for a name that is neither registered nor
    ``ompl:NAME`` of an OMPL planner."""
    for n in names:
        PLANNERS.check(n)


# -- seeds and queries ---------------------------------------------------------------------------
def _streams(seed: int) -> tuple[np.random.SeedSequence, np.random.SeedSequence, np.random.SeedSequence]:
    """Independent (planning, execution, query) seed sequences of a run seed."""
    plan, execute, query = np.random.SeedSequence(seed).spawn(3)
    return plan, execute, query


def _simplify_seed(seed: int) -> int:
    """The seed of a run's path simplification: a fourth stream of the run seed (the first three,
    `_streams`, are the same whether it is drawn or not)."""
    return int(np.random.SeedSequence(seed).spawn(4)[3].generate_state(1)[0] & 0x7FFFFFFF)


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
                 label: str | None = None, collision: str = "index") -> list[Query]:
    """The queries of a map: one (the presets) or one random pair per run.

    Random pairs are free for the robot disc (checked by the `collision` backend), in the same
    connected part of the c-space and at least a quarter of the map's bounding-box diagonal apart.
    `label` (default the map's name) names the map in the queries and in the run seeds.
    """
    name = m.name if label is None else label
    if mode == "presets":
        if m.start is None or m.target is None:
            raise PlanningError(f"map {m.name!r} has no start/target presets; use random queries")
        return [Query(name, 0, (float(m.start[0]), float(m.start[1])),
                      (float(m.target[0]), float(m.target[1])))]
    if mode != "random":
        raise PlanningError(f"queries must be 'presets' or 'random', got {mode!r}")
    checker = make_checker(m, robot_radius, collision)
    xmin, ymin, xmax, ymax = m.bounds
    sep = 0.25 * math.hypot(xmax - xmin, ymax - ymin)
    out = []
    for r in range(runs):
        rng = np.random.default_rng(_streams(derive_seed(seed, name, r))[2])
        s, g = _random_query(m, checker, rng, sep)
        out.append(Query(name, r, s, g))
    return out


# -- per-process caches --------------------------------------------------------------------------
@lru_cache(maxsize=32)
def _checker(map_name: str, radius: float, collision: str = "index") -> CollisionChecker:
    return make_checker(cached_map(map_name), radius, collision)


def planner_for(name: str, m: Map, options: dict[str, Any] | None = None,
                progress_interval: float | None = None) -> Any:
    """The planner `name` as the benchmarks configure it for map `m` (None: skipped on this map), with
    `options` (checked against its declarations, `planners.declarations`) over the benchmark's own and,
    for a planner that reports progress, best-cost samples every `progress_interval` seconds of budget.

    What the benchmark gives a planner is its class's declaration (`planners.Planner`): its
    ``grid_map_options`` on a map imported from a grid (`astar` plans on the map's own cells), its
    ``large_map_options`` on a map of more than `LARGE_MAP_WALLS` walls (the references adapt, see
    there; None skips it), and `progress_interval` when it ``reports_progress`` (OMPL's planners sample
    their best cost every `progress_interval` seconds of budget; None: their default).
    """
    cls = PLANNERS.class_of(name)
    large = len(m.walls) > LARGE_MAP_WALLS
    if large and cls.large_map_options is None:
        return None
    bench: dict[str, Any] = {**(cls.grid_map_options if m.grid is not None else {}),
                             **((cls.large_map_options or {}) if large else {})}
    if progress_interval is not None and cls.reports_progress:
        bench["progress_interval"] = progress_interval
    return make_planner(name, **{**bench, **planner_kwargs(name, options or {})})


@lru_cache(maxsize=64)
def _planner(name: str, map_name: str, progress_interval: float | None = None,
             options: tuple[tuple[str, Any], ...] = ()) -> Any:
    return planner_for(name, cached_map(map_name), dict(options), progress_interval=progress_interval)


def _path_tuple(path: np.ndarray) -> tuple[tuple[float, float], ...]:
    return tuple((float(x), float(y)) for x, y in np.asarray(path, dtype=float).reshape(-1, 2))


def run_reference(task: ReferenceTask) -> ReferenceResult:
    """Solve one query with `shortest` and `min-link` (the yardsticks of the ratios)."""
    q = task.query
    checker = _checker(q.map, task.robot_radius, task.collision)
    t0 = time.perf_counter()
    results: dict[str, Any] = {}
    statuses = []
    for name in REFERENCE_PLANNERS:
        planner = _planner(name, q.map)
        if planner is None:
            statuses.append(f"{name}: skipped on a map of {len(cached_map(q.map).walls)} walls")
            continue
        problem = PlanningProblem(cached_map(q.map), checker, np.array(q.start), np.array(q.goal), task.time_limit,
                                  np.random.default_rng(0), task.timing)
        res = planner.plan(problem)
        statuses.append(f"{name}: {res.message}")
        if res.success:
            results[name] = res.path
    sp, ml, fa = results.get("shortest"), results.get("min-link"), results.get("fastest")
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
        fastest_time_s=robot_time_s(fa, task.timing) if fa is not None else math.nan,
        fastest_path=_path_tuple(fa) if fa is not None else (),
    )


def crashed_run(task: RunTask, reason: str) -> RunRecord:
    """The record of `task` whose worker process died while running it (`reason`: how, as
    ``killed by signal 11 (SIGSEGV)``): a failed run with status `PlanStatus.ERROR`, like a planner
    that raised, its planning time unknown (NaN)."""
    q = task.query
    return RunRecord.build(map=task.map, planner=task.planner, run=task.run, seed=task.seed, query=q.index,
                           start=q.start, goal=q.goal, collision="point" if task.robot_radius <= 0 else task.collision,
                           simplify=task.simplify, success=False, status=PlanStatus.ERROR, detail=f"crashed: {reason}",
                           time_s=math.nan, collision_checks=0)


def run_task(task: RunTask) -> RunRecord:
    """Run one planner on one query (a picklable top-level function for the executors).

    The raw path is measured and driven; then it is simplified (`RunTask.simplify`) and the
    simplified path is measured and driven with the same noise draws (common random numbers). A
    planner that raises is recorded as a failed run with status `PlanStatus.ERROR` (never lost).
    """
    q = task.query
    m = cached_map(task.map)
    checker = _checker(task.map, task.robot_radius, task.collision)
    plan_ss, exec_ss, _ = _streams(task.seed)
    base: dict[str, Any] = {"map": task.map, "planner": task.planner, "run": task.run, "seed": task.seed,
                            "query": q.index, "start": q.start, "goal": q.goal, "collision": checker.backend,
                            "simplify": task.simplify}
    problem = PlanningProblem(m, checker, np.array(q.start), np.array(q.goal), task.time_limit,
                              np.random.default_rng(plan_ss), task.timing)
    checks0 = checker.checks
    t0 = time.perf_counter()
    try:
        res = _planner(task.planner, task.map, task.progress_interval, task.options).plan(problem)
    except NxtnavError:
        raise
    except Exception as exc:  # a crashing planner is a result, not the end of the benchmark
        log.warning("planner %s crashed on %s run %d: %s", task.planner, task.map, task.run, exc)
        return RunRecord.build(**base, success=False, status=PlanStatus.ERROR, detail=f"{type(exc).__name__}: {exc}",
                         time_s=time.perf_counter() - t0, collision_checks=checker.checks - checks0)
    base["progress"] = _progress(res.info)
    base["objective"] = res.objective
    base["reference_cost"] = dict(task.reference_costs).get(res.objective, math.nan)
    base["params"] = tuple(sorted(res.info.get("params", {}).items()))
    if not res.success or len(res.path) < 1:
        return RunRecord.build(**base, success=False, status=res.status, detail=res.detail, time_s=res.time_s,
                         collision_checks=res.collision_checks)
    path = np.asarray(res.path, dtype=float).reshape(-1, 2)
    raw = _measure(path, checker, task, q.goal, exec_ss, res.objective)
    simplified: dict[str, Any] = {}
    if task.simplify != "none":
        short, t_simplify = simplify_path(task.simplify, path, checker, m.bounds, _simplify_seed(task.seed))
        if not checker.path_free(short):  # never expected: every method validates with this checker
            raise PlanningError(f"{task.simplify} simplification of {task.planner}'s path on {task.map} run "
                                f"{task.run} is not collision-free")
        met = _measure(short, checker, task, q.goal, exec_ss, res.objective)
        simplified = {"simplify_time_s": t_simplify, "simplified_path": _path_tuple(short),
                      **{f"simplified_{k}": met[k] for k in _SIMPLIFIED_METRICS}}
    first_len = res.info.get("first_solution_length_cm", raw["length_cm"])
    return RunRecord.build(**base, success=True, status=res.status, detail=res.detail, time_s=res.time_s,
                     collision_checks=res.collision_checks, first_solution_s=_first_solution(res.info, res.time_s),
                     first_solution_length_cm=float(first_len) if first_len is not None else math.nan,
                     path=_path_tuple(path), **raw, **simplified)


#: What `_measure` returns and the `RunRecord` fields of the simplified path take (prefixed).
_SIMPLIFIED_METRICS = ("length_cm", "turns", "turn_angle_rad", "min_clearance_cm", "length_ratio", "turn_ratio",
                       "exec_error_cm", "exec_collision_fraction", "robot_time_s", "predicted_error_cm",
                       "objective_cost")


def _measure(path: np.ndarray, checker: CollisionChecker, task: RunTask, goal: tuple[float, float],
             exec_ss: np.random.SeedSequence, objective: str) -> dict[str, Any]:
    """Path metrics, its cost to the robot and under `objective`, and the open-loop execution error of one
    path (NaN when not driven)."""
    met = path_metrics(path, checker, reference_length=task.reference_length, reference_turns=task.reference_turns)
    out = {"length_cm": met.length_cm, "turns": float(met.turns), "turn_angle_rad": met.turn_angle_rad,
           "min_clearance_cm": met.min_clearance_cm, "mean_clearance_cm": met.mean_clearance_cm,
           "length_ratio": met.length_ratio, "turn_ratio": met.turn_ratio,
           "exec_error_cm": math.nan, "exec_median_cm": math.nan, "exec_collision_fraction": math.nan,
           "robot_time_s": robot_time_s(path, task.timing), "predicted_error_cm": predicted_error_cm(path, task.noise),
           "objective_cost": objective_cost(objective, path, task.timing)}
    if len(path) >= 2 and task.exec_repeats > 0:
        fresh = np.random.SeedSequence(exec_ss.entropy, spawn_key=exec_ss.spawn_key)  # spawn() counts its
        ex = execution_error(path, checker, goal=goal, repeats=task.exec_repeats,  # children: the same draws
                             noise=task.noise, rng=fresh)                           # for every path of a run
        out.update(exec_error_cm=ex.mean_cm, exec_median_cm=ex.median_cm, exec_collision_fraction=ex.collision_fraction)
    return out


def _first_solution(info: dict[str, Any], time_s: float) -> float:
    """Time to the first solution (s): reported by anytime planners, else the planning time.

    NaN when an anytime planner could not observe it (OMPL's PRM in wall-clock mode grows its
    roadmap in a thread).
    """
    if "first_solution_s" not in info:
        return time_s
    v = info["first_solution_s"]
    return float(v) if v is not None and math.isfinite(float(v)) else math.nan


def _progress(info: dict[str, Any]) -> tuple[ProgressSample, ...]:
    """The best-cost samples a planner reported (empty for planners that report none)."""
    return tuple((float(t), int(i), float(c)) for t, i, c in info.get("progress", ()))


def _options(config: BenchmarkConfig, planner: str) -> dict[str, Any]:
    """The planner's options: the benchmark's objective under its own ``--set`` options."""
    own = dict(config.planner_options.get(planner, {}))
    if config.objective is not None:
        own.setdefault("objective", config.objective)
    return own


def check_objectives(config: BenchmarkConfig) -> None:
    """A `ConfigError` (before any planning) when a planner cannot minimise the objective it is given."""
    for name in config.planners:
        objective = _options(config, name).get("objective")
        if objective is not None:
            cls = PLANNERS.class_of(name)
            check_objective(objective, cls.objectives_for(name), f"planner {name!r}")


def run_benchmark(
    config: BenchmarkConfig,
    *,
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[Any], None] | None = None,
) -> BenchmarkResult:
    """Run the benchmark: the references of every query, then every planner run.

    Ctrl-C ends the run early: the result then holds the finished runs and ``complete`` is False
    (the written files say so). A run whose worker process dies (a crash in OMPL) is a failed run
    (`crashed_run`) and the benchmark goes on.

    Parameters
    ----------
    config : BenchmarkConfig
    workers : int
        Processes (1 runs in this process, unless a planner is named ``ompl:NAME``: then in one worker
        process, `toolkit.bench.common.isolate_planners`).
    dask_address : str or None
        Dask scheduler address or ``"local"`` (see `toolkit.bench.executors.run_tasks`).
    on_done : callable or None
        Called with each `ReferenceResult` and `RunRecord` as it finishes (progress bars);
        `config.n_tasks()` is the total.
    """
    check_planner_names(config.planners)
    check_objectives(config)
    started = datetime.now()
    t0 = time.perf_counter()
    maps = {name: load_map(name) for name in config.maps}
    queries: list[Query] = []
    for name, m in maps.items():
        queries.extend(make_queries(m, config.queries, config.runs, config.seed, config.robot_radius, label=name,
                                    collision=config.collision))
    ref_tasks = [ReferenceTask(q, config.robot_radius, collision=config.collision, timing=config.timing)
                 for q in queries]
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
                    map=name, planner=planner, run=run, seed=derive_seed(config.seed, name, run),
                    query=ref.query, time_limit=config.time_limit, robot_radius=config.robot_radius,
                    exec_repeats=config.exec_repeats, noise=config.noise,
                    reference_length=None if math.isnan(ref.shortest_length_cm) else ref.shortest_length_cm,
                    reference_turns=ref.min_link_turns, collision=config.collision, simplify=config.simplify,
                    progress_interval=config.progress_interval,
                    options=tuple(sorted(_options(config, planner).items())), timing=config.timing,
                    reference_costs=tuple((o, ref.cost(o)) for o in OBJECTIVES),
                ))
    complete = True
    try:
        records = collect_tasks(run_task, tasks, workers=workers, dask_address=dask_address, on_done=on_done,
                                crashed=crashed_run, isolate=isolate_planners(config.planners))
    except TasksInterrupted as exc:
        records, complete = list(exc.results), False
    records.sort(key=lambda r: (config.maps.index(r.map), config.planners.index(r.planner), r.run))
    refs.sort(key=lambda r: (config.maps.index(r.query.map), r.query.index))
    return BenchmarkResult(config, tuple(records), tuple(refs), started, time.perf_counter() - t0,
                           {name: m.name for name, m in maps.items()}, complete)
