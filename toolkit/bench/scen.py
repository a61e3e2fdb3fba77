"""Scenario benchmarks: grid queries with optimal lengths published by others (Moving AI, GPPC).

A ``.scen`` file lists queries on one map, each with its optimal length: octile scenarios (start and
goal are cells; 8-connected moves, no corner cutting) or any-angle scenarios (start and goal are
cell corners; any polyline that keeps out of blocked cells and their shared edges and corners). A
planner is exact on a kind when its path class is the benchmark's: ``astar`` on the map's own cells
for octile, ``shortest`` (a point robot's visibility graph) for any-angle. A published optimum is a
proof: an exact planner must equal it, and on any-angle scenarios no valid path is shorter.
"""

from __future__ import annotations

import csv
import math
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from planners import make_planner
from planners.base import Planner, PlanningProblem, PlanStatus, status_message

from ..number_format import MISSING, cell, csv_cell
from ..world import CollisionChecker, Map, MapError, NxtnavError, import_map, make_checker
from .common import finite_median, isolate_planners
from .executors import run_tasks
from .ompl_log import OmplExperiment, OmplPlannerData, ompl_status, write_ompl_log
from .peers import PEER_KIND, peer_path

__all__ = [
    "EXACT_PLANNER",
    "SCEN_COLUMNS",
    "ScenConfig",
    "ScenRecord",
    "ScenResult",
    "Scenario",
    "read_scen",
    "run_scen",
    "select_queries",
    "summarise",
    "write_scen_outputs",
]

Kind = Literal["octile", "any-angle"]
EXACT_PLANNER: dict[str, str] = {"octile": "astar", "any-angle": "shortest"}
SCEN_COLUMNS = ("query", "start_x", "start_y", "goal_x", "goal_y", "planner", "success", "length", "optimal",
                "error", "rel_error", "time_s", "preprocess_s", "status", "collision")
MATCH_TOL = 1e-6  # relative error below which a length equals the published optimum


@dataclass(frozen=True)
class Scenario:
    """One query of a ``.scen`` file (coordinates as in the file: x = column, y = row from the top)."""

    index: int
    line: int
    bucket: int
    map_name: str
    width: int
    height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal: float

    def world(self, m: Map, kind: Kind) -> tuple[np.ndarray, np.ndarray]:
        """Start and goal in the map's world frame (cm): cell centres (octile) or cell corners (any-angle)."""
        g = m.grid
        assert g is not None
        half = 0.5 if kind == "octile" else 0.0

        def conv(p: tuple[int, int]) -> np.ndarray:  # file rows count down from the top edge
            x, y = p
            return np.array([g.origin[0] + (x + half) * g.cell_cm, g.origin[1] + (g.height - y - half) * g.cell_cm])

        return conv(self.start), conv(self.goal)


def read_scen(path: str | os.PathLike[str], m: Map, kind: Kind) -> list[Scenario]:
    """Read and check a Moving AI / GPPC ``.scen`` file against the map it is run on.

    Raises
    ------
    NxtnavError
        One line naming the file, the line and the problem (malformed line, another map, other
        dimensions, a start or goal in a blocked cell).
    """
    p = Path(path)
    if kind not in EXACT_PLANNER:
        raise NxtnavError(f"--kind must be octile or any-angle, got {kind!r}")
    if m.grid is None:
        raise NxtnavError(f"map {m.name!r} is not a grid map; scenarios need a Moving AI .map or an imported grid")
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise NxtnavError(f"{p}: cannot read scenario file: {exc}") from None
    if not lines or not lines[0].strip().startswith("version"):
        raise NxtnavError(f"{p}: line 1: expected 'version 1' (a Moving AI scenario file)")
    cells = _cells(m)
    out: list[Scenario] = []
    for n, text in enumerate(lines[1:], start=2):
        if not text.strip():
            continue
        f = text.split("\t") if "\t" in text else text.split()
        if len(f) != 9:
            raise NxtnavError(f"{p}: line {n}: expected 9 fields (bucket, map, width, height, start x, start y, "
                              f"goal x, goal y, optimal length), got {len(f)}")
        try:
            bucket, w, h, sx, sy, gx, gy = (int(f[i]) for i in (0, 2, 3, 4, 5, 6, 7))
            opt = float(f[8])
        except ValueError:
            raise NxtnavError(f"{p}: line {n}: a field is not a number: {text.strip()!r}") from None
        if not math.isfinite(opt) or opt < 0:
            raise NxtnavError(f"{p}: line {n}: optimal length must be a finite non-negative number, got {f[8]}")
        map_file = Path(f[1]).name
        src = m.source.name if m.source is not None else f"{m.name}.map"
        if map_file != src and Path(map_file).stem != m.name:
            raise NxtnavError(f"{p}: line {n}: the query is for map {map_file!r}, not {src!r}")
        if (w, h) != (m.grid.width, m.grid.height):
            raise NxtnavError(f"{p}: line {n}: map size {w} x {h} differs from {src}'s {m.grid.width} x "
                              f"{m.grid.height}")
        for label, (x, y) in (("start", (sx, sy)), ("goal", (gx, gy))):
            if not (0 <= x < w and 0 <= y < h) or not cells[h - 1 - y, x]:
                raise NxtnavError(f"{p}: line {n}: {label} ({x}, {y}) is not a free cell of {src}")
        out.append(Scenario(len(out), n, bucket, map_file, w, h, (sx, sy), (gx, gy), opt))
    if not out:
        raise NxtnavError(f"{p}: no queries")
    return out


def _cells(m: Map) -> np.ndarray:
    from ..world import PointCollisionChecker

    return PointCollisionChecker(m).cells


def select_queries(queries: Sequence[Scenario], limit: int | None) -> list[Scenario]:
    """`limit` queries spread evenly over the file (first and last included); all when None."""
    if limit is None or limit >= len(queries):
        return list(queries)
    if limit < 1:
        raise NxtnavError(f"--limit must be >= 1, got {limit}")
    idx = np.unique(np.round(np.linspace(0, len(queries) - 1, limit)).astype(int))
    return [queries[i] for i in idx]


@dataclass(frozen=True)
class ScenConfig:
    """What one scenario benchmark runs."""

    scen: str
    map_path: str
    kind: Kind
    planners: tuple[str, ...]
    radius: float = 0.0
    cell_cm: float = 1.0
    time_limit: float = 10.0
    seed: int = 0
    planner_options: dict[str, dict[str, Any]] = field(default_factory=dict)
    collision: str = "index"
    """Collision backend for a disc robot (`toolkit.world.make_checker`); a point robot has its own checker."""

    @property
    def checker_backend(self) -> str:
        """The checker that answers: ``point`` for a point robot (radius 0), else `collision`."""
        return "point" if self.radius == 0 else self.collision

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["planners"] = list(self.planners)
        return d


@dataclass(frozen=True)
class ScenRecord:
    """One planner on one query."""

    query: Scenario
    planner: str
    success: bool
    length: float
    time_s: float
    preprocess_s: float
    status: PlanStatus
    detail: str = ""
    collision: str = "index"
    """The checker that validated the path (``point`` for a point robot and for the peers)."""

    @property
    def error(self) -> float:
        return self.length - self.query.optimal if self.success else math.nan

    @property
    def rel_error(self) -> float:
        if not self.success:
            return math.nan
        return self.error / self.query.optimal if self.query.optimal > 0 else self.error

    def row(self) -> dict[str, Any]:
        q = self.query
        return {"query": q.index, "start_x": q.start[0], "start_y": q.start[1], "goal_x": q.goal[0],
                "goal_y": q.goal[1], "planner": self.planner, "success": self.success,
                "length": self.length, "optimal": q.optimal, "error": self.error,
                "rel_error": self.rel_error, "time_s": self.time_s, "preprocess_s": self.preprocess_s,
                "status": status_message(self.status, self.detail), "collision": self.collision}


@dataclass(frozen=True)
class _Task:
    config: ScenConfig
    planner: str
    query: Scenario


_PROCESS_CACHE: dict[tuple[Any, ...], Any] = {}


def _cached(key: tuple[Any, ...], build: Callable[[], Any]) -> Any:
    if key not in _PROCESS_CACHE:
        _PROCESS_CACHE[key] = build()
    return _PROCESS_CACHE[key]


def _planner(c: ScenConfig, name: str) -> Planner:
    options = dict(c.planner_options.get(name, {}))
    if name == "astar":
        options.setdefault("resolution", None)  # the map's own cells
    return make_planner(name, **options)


def _prepared(checker: CollisionChecker, m: Map, at: np.ndarray) -> CollisionChecker:
    """`checker` with the structures it and the map build at their first use (cell raster, pinch
    points, region index) made now, like the map's import, outside every query's time."""
    checker.point_free(at)
    checker.segment_free(at, at)
    m.region_of(at)
    return checker


def _run_one(task: _Task) -> ScenRecord:
    """Plan one query (the map, checker and planner are kept per process, so graphs are built once)."""
    c = task.config
    m = _cached(("map", c.map_path, c.cell_cm), lambda: import_map(c.map_path, cell_cm=c.cell_cm))
    start, goal = task.query.world(m, c.kind)
    checker = _cached(("checker", c.map_path, c.cell_cm, c.radius, c.collision),
                      lambda: _prepared(make_checker(m, c.radius, c.collision), m, start))
    if task.planner in PEER_KIND:
        return _run_peer(task, m)
    planner = _cached(("planner", c.map_path, c.cell_cm, c.radius, task.planner), lambda: _planner(c, task.planner))
    rng = np.random.default_rng([c.seed, task.query.index])
    res = planner.plan(PlanningProblem(m, checker, start, goal, c.time_limit, rng))
    pre = float(res.info.get("graph_build_s", 0.0) or res.info.get("grid_build_s", 0.0) or 0.0)
    scale = 1.0 / m.grid.cell_cm if m.grid is not None else 1.0
    return ScenRecord(task.query, task.planner, res.success, res.length * scale if res.success else math.nan,
                      max(res.time_s - pre, 0.0), pre, res.status, res.detail, checker.backend)


def _crashed_one(task: _Task, reason: str) -> ScenRecord:
    """The record of a query whose worker process died while planning it (`reason`, as ``killed by
    signal 11 (SIGSEGV)``): a failed plan, its time unknown."""
    return ScenRecord(task.query, task.planner, False, math.nan, math.nan, 0.0, PlanStatus.ERROR,
                      f"crashed: {reason}", task.config.collision)


def _run_peer(task: _Task, m: Map) -> ScenRecord:
    c = task.config
    start, goal = task.query.world(m, c.kind)
    checker = _cached(("point-checker", c.map_path, c.cell_cm), lambda: _prepared(make_checker(m, 0.0), m, start))
    first = ("peer-ready", c.map_path, task.planner) not in _PROCESS_CACHE
    t0 = time.perf_counter()
    path, status, detail = peer_path(task.planner, m, checker, start, goal)
    elapsed = time.perf_counter() - t0
    _PROCESS_CACHE[("peer-ready", c.map_path, task.planner)] = True
    assert m.grid is not None
    length = float(np.sum(np.hypot(*np.diff(path, axis=0).T))) / m.grid.cell_cm if path is not None else math.nan
    # a peer's preparation happens inside its first query: reported as that query's preprocessing
    return ScenRecord(task.query, task.planner, path is not None, length, 0.0 if first else elapsed,
                      elapsed if first else 0.0, status, detail, checker.backend)


@dataclass
class ScenResult:
    """All records of a run (in query order), whether it completed, and its wall-clock time."""

    config: ScenConfig
    records: list[ScenRecord]
    complete: bool
    total_time_s: float
    started: float


def run_scen(config: ScenConfig, queries: Sequence[Scenario], *, workers: int = 1, dask_address: str | None = None,
             on_done: Callable[[ScenRecord], None] | None = None) -> ScenResult:
    """Run every planner of `config` on every query; an interrupt returns what finished (``complete=False``).

    The tasks name the map by its absolute path: a worker process may run in another folder."""
    task_config = replace(config, map_path=os.path.abspath(config.map_path))
    # query by query, every planner in turn: a machine whose load changes during the run weighs on all alike
    tasks = [_Task(task_config, p, q) for q in queries for p in config.planners]
    records: list[ScenRecord] = []
    t0 = time.perf_counter()
    started = time.time()
    complete = True
    try:
        for r in run_tasks(_run_one, tasks, workers=workers, dask_address=dask_address, on_done=on_done,
                           crashed=_crashed_one, isolate=isolate_planners(config.planners)):
            records.append(r)
    except KeyboardInterrupt:
        complete = False
    records.sort(key=lambda r: (config.planners.index(r.planner), r.query.index))
    return ScenResult(config, records, complete, time.perf_counter() - t0, started)


@dataclass(frozen=True)
class PlannerSummary:
    planner: str
    queries: int
    success: int
    exact: bool
    mismatches: int
    below_optimum: int
    median_rel_error: float
    max_rel_error: float
    median_time_s: float
    preprocess_s: float


def summarise(result: ScenResult) -> list[PlannerSummary]:
    """Per planner: successes, mismatches (exact planners), paths below the optimum, errors and times."""
    out = []
    kind = result.config.kind
    for name in result.config.planners:
        rs = [r for r in result.records if r.planner == name]
        ok = [r for r in rs if r.success]
        rel = np.array([r.rel_error for r in ok]) if ok else np.array([math.nan])
        exact = (EXACT_PLANNER[kind] == name and result.config.radius == 0) or PEER_KIND.get(name) == kind
        mism = sum(1 for r in rs if not r.success or abs(r.rel_error) > MATCH_TOL) if exact else 0
        # on any-angle scenarios every valid path is at least the optimum; on octile only exact ones are
        below = sum(1 for r in ok if r.rel_error < -MATCH_TOL) if (kind == "any-angle" or exact) else 0
        out.append(PlannerSummary(name, len(rs), len(ok), exact, mism, below,
                                  float(np.nanmedian(rel)) if ok else math.nan,
                                  float(np.nanmax(np.abs(rel))) if ok else math.nan,
                                  finite_median(r.time_s for r in rs),  # a crashed query's is NaN
                                  float(sum(r.preprocess_s for r in rs))))
    return out


def summary_markdown(result: ScenResult, total_queries: int) -> str:
    c = result.config
    lines = [f"# Scenario benchmark: {Path(c.scen).name} ({c.kind})", "",
             f"Map {Path(c.map_path).name}, robot radius {c.radius:g} cm, collision checks: {_checks(c)}, "
             f"{len(result.records)} runs of {len(c.planners) * total_queries} planned, {result.total_time_s:.1f} s "
             f"wall clock, seed {c.seed}."]
    if not result.complete:
        lines += ["", "**Incomplete: the run was interrupted; the rows below are the queries that finished.**"]
    lines += ["", "| planner | success | exact | mismatches | below optimum | median rel. error | max rel. error "
              "| median time (ms) | preprocessing (s) |", "|---|---|---|---|---|---|---|---|---|"]
    for s in summarise(result):
        lines.append(f"| {s.planner} | {s.success}/{s.queries} | {'yes' if s.exact else 'no'} | "
                     f"{s.mismatches if s.exact else MISSING} | {s.below_optimum} | "
                     f"{cell(s.median_rel_error, '.3g')} | {cell(s.max_rel_error, '.3g')} | "
                     f"{cell(s.median_time_s * 1e3, '.2f')} | "
                     f"{s.preprocess_s:.2f} |")
    lines += _peer_ratios(result)
    lines += ["", f"Exact planner for {c.kind}: `{EXACT_PLANNER[c.kind]}` (point robot); a mismatch is a failure "
              f"or |relative error| > {MATCH_TOL:g}. Below optimum: a path shorter than the published optimum, "
              "counted where no valid path can be shorter (any planner on any-angle scenarios: it passed "
              "through a wall; the exact planner and the octile peer on octile ones: it broke the move rules).",
              "Preprocessing (graph or grid building, once per worker process) is excluded from the per-query "
              "times."]
    return "\n".join(lines) + "\n"


def _checks(c: ScenConfig) -> str:
    """The checker in words (a point robot's is the exact point checker, whatever --collision asked)."""
    if c.radius == 0 and c.collision != "index":
        return f"point (exact; --collision {c.collision} applies to a robot of radius > 0)"
    return c.checker_backend


def _peer_ratios(result: ScenResult) -> list[str]:
    """Per peer: median time ratio against the exact planner on the same queries, and length agreement."""
    c = result.config
    ours = {r.query.index: r for r in result.records if r.planner == EXACT_PLANNER[c.kind] and r.success}
    out: list[str] = []
    for name in c.planners:
        if name not in PEER_KIND:
            continue
        pairs = [(r, ours[r.query.index]) for r in result.records
                 if r.planner == name and r.success and r.query.index in ours]
        if not pairs:
            out.append(f"- `{name}`: no query solved by both it and `{EXACT_PLANNER[c.kind]}`.")
            continue
        ratio = float(np.median([p.time_s / max(o.time_s, 1e-9) for p, o in pairs]))
        diff = np.array([p.length - o.length for p, o in pairs])
        agree = int(np.sum(np.abs(diff) <= MATCH_TOL * np.maximum(1.0, [o.length for _, o in pairs])))
        failed = sum(1 for r in result.records if r.planner == name and not r.success)
        out.append(f"- `{name}` against `{EXACT_PLANNER[c.kind]}` on {len(pairs)} queries both solved: median "
                   f"time ratio {ratio:.3g} (peer / ours), equal lengths on {agree}, peer shorter on "
                   f"{int(np.sum(diff < -1e-6))}, longer on {int(np.sum(diff > 1e-6))}; peer failures {failed}.")
    return ["", "Peers (same queries, same run):", "", *out] if out else []


def write_scen_outputs(result: ScenResult, out_dir: Path, total_queries: int) -> dict[str, Path]:
    """Write ``scen.csv``, ``summary.md`` and ``scen.log`` (OMPL benchmark format) into `out_dir`."""
    out_dir.mkdir(parents=True, exist_ok=True)
    files = {"csv": out_dir / "scen.csv", "summary": out_dir / "summary.md", "ompl": out_dir / "scen.log"}
    with files["csv"].open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=SCEN_COLUMNS)
        w.writeheader()
        for r in result.records:
            w.writerow({k: csv_cell(v, digits=None) for k, v in r.row().items()})  # exact: optima compared
    files["summary"].write_text(summary_markdown(result, total_queries), encoding="utf-8")
    c = result.config
    props = [("time REAL", "REAL"), ("solved BOOLEAN", "BOOLEAN"), ("status ENUM", "ENUM"),
             ("solution length REAL", "REAL"), ("optimal length REAL", "REAL"), ("relative error REAL", "REAL"),
             ("query INTEGER", "INTEGER")]
    blocks = []
    for name in c.planners:
        rows = [[r.time_s, r.success, ompl_status(r.success, r.status), r.length, r.query.optimal, r.rel_error,
                 r.query.index] for r in result.records if r.planner == name]
        blocks.append(OmplPlannerData(name, [(p.rsplit(" ", 1)[0], t) for p, t in props], rows,
                                      {"planner": name, "time_limit": c.time_limit}))
    exp = OmplExperiment(
        name=f"scen_{Path(c.scen).stem.replace('.', '_')}", planners=blocks, time_limit_s=c.time_limit,
        total_time_s=result.total_time_s, seed=c.seed, run_count=total_queries,
        setup=f"nxtnav scenario benchmark: {Path(c.scen).name} on {Path(c.map_path).name} ({c.kind}), "
              f"robot radius {c.radius:g} cm, collision checks {c.checker_backend}",
        properties={"robot_radius_cm": ("REAL", c.radius)}, cpuinfo=platform.processor() or platform.machine())
    write_ompl_log(files["ompl"], exp)
    return files


def load_scen_map(map_path: str | os.PathLike[str], cell_cm: float) -> Map:
    """The map a scenario runs on (a Moving AI ``.map``), imported at `cell_cm` cm per cell."""
    p = Path(map_path)
    if p.suffix != ".map":
        raise MapError(f"{p}: scenarios run on a Moving AI .map file")
    return import_map(p, cell_cm=cell_cm)
