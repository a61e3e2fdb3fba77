"""Planners over time: best-cost samples, first solutions, simplified paths, progress in OMPL's database,
time to a target length and the budget sweep."""

from __future__ import annotations

import csv
import itertools
import json
import math
import sqlite3
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
import shapely
from conftest import built_once, run_cli

from planners import PlanningProblem, PlanResult, make_planner
from planners.metrics import count_turns, path_length
from planners.ompl_planners import ompl_simplify
from toolkit.bench.planners import (
    BenchmarkConfig,
    BenchmarkResult,
    Query,
    ReferenceResult,
    RunRecord,
    cost_band,
    run_budget_sweep,
    shortcut_path,
    time_within,
    within_rows,
)
from toolkit.world import load_map, make_checker

RADIUS = 8.0
BUDGET_S = 0.06
ANYTIME = ("rrtstar", "prm", "ompl:BITstar", "ompl:InformedRRTstar")


def _plan(name: str, seed: int, budget: float = BUDGET_S, map_name: str = "map2", **options: object) -> PlanResult:
    m = load_map(map_name)
    problem = PlanningProblem.create(m, RADIUS, m.start, m.target, budget, rng=seed)
    return make_planner(name, **options).plan(problem)


def _free(map_name: str, path: np.ndarray) -> bool:
    """Independent of the checker: every segment inside the map and at least the radius from every wall."""
    m = load_map(map_name)
    line = shapely.LineString(path)
    return bool(m.polygon.covers(line)) and float(line.distance(m.wall_lines)) >= RADIUS - 1e-6


# -- the samples of OMPL's planners -------------------------------------------------------------
@pytest.mark.parametrize("name", [*ANYTIME, "ompl:RRTConnect"])
def test_progress_samples_repeat_with_the_seed_and_end_at_the_path(name: str) -> None:
    a, b = _plan(name, 5), _plan(name, 5)
    assert a.success and b.success
    pa, pb = a.info["progress"], b.info["progress"]
    assert [(i, c) for _, i, c in pa] == [(i, c) for _, i, c in pb]  # the iteration grid and the costs repeat
    times = [t for t, _, _ in pa]
    assert times == sorted(times) and times[0] > 0
    costs = [c for _, _, c in pa]
    assert all(x >= y for x, y in itertools.pairwise(costs))  # a best cost never grows
    finite = [c for c in costs if math.isfinite(c)]
    assert finite[0] == pytest.approx(a.info["first_solution_length_cm"])
    assert finite[-1] == pytest.approx(path_length(a.path), abs=1e-6)  # the last sample is the returned path
    assert a.info["first_solution_s"] <= times[-1]


@pytest.mark.parametrize("name", ["rrtstar", "ompl:BITstar"])
def test_samples_lie_on_the_iteration_grid(name: str) -> None:
    r = _plan(name, 3, progress_interval=0.01)
    per_s = 50000 if "BIT" in name else 5000
    step, budget = round(per_s * 0.01), round(per_s * BUDGET_S)
    iterations = {int(i) for _, i, _ in r.info["progress"]}
    assert set(range(step, budget + 1, step)) <= iterations
    assert max(iterations) == budget


@pytest.mark.parametrize("name", ["rrtstar", "prm"])
def test_the_sampling_interval_does_not_change_the_path(name: str) -> None:
    a, b = _plan(name, 8, progress_interval=0.01), _plan(name, 8, progress_interval=0.003)
    assert np.array_equal(a.path, b.path)
    assert len(b.info["progress"]) >= len(a.info["progress"])


@pytest.mark.parametrize("name", ["rrtstar", "prm", "ompl:BITstar"])
def test_a_shorter_budget_is_the_start_of_a_longer_one(name: str) -> None:
    """The iteration-counted budget carries over to the samples: the path at half the budget has the
    best cost the longer run had at that iteration (the polish starts from that path, and shortens it)."""
    long, short = _plan(name, 9, budget=2 * BUDGET_S), _plan(name, 9, budget=BUDGET_S, polish=False)
    polished = _plan(name, 9, budget=BUDGET_S, polish=True)
    at = max(int(i) for _, i, _ in short.info["progress"])
    before = [c for _, i, c in long.info["progress"] if i <= at]
    assert short.success and polished.success
    assert path_length(short.path) == pytest.approx(before[-1], abs=1e-6)
    assert polished.info["cost_before_polish"] == pytest.approx(before[-1], abs=1e-6)
    assert path_length(polished.path) <= path_length(short.path) + 1e-9


def test_declared_parameters_are_reported() -> None:
    r = _plan("rrtstar", 1, range=12.5, settings={"GoalBias": 0.2})
    params = r.info["params"]
    assert params["Range"] == pytest.approx(12.5) and params["GoalBias"] == pytest.approx(0.2)
    assert params["RewireFactor"] == pytest.approx(1.1)  # OMPL's default, untouched
    assert all(isinstance(v, bool | int | float | str) for v in params.values())


# -- simplification -----------------------------------------------------------------------------
def test_shortcut_keeps_a_free_subset_of_the_waypoints_and_never_lengthens() -> None:
    m = load_map("map3")
    checker = make_checker(m, RADIUS)
    a = make_planner("astar").plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    short = shortcut_path(a.path, checker)
    assert len(short) < len(a.path) and _free("map3", short)
    assert np.array_equal(short[0], a.path[0]) and np.array_equal(short[-1], a.path[-1])
    rows = {tuple(p) for p in a.path}
    assert all(tuple(p) in rows for p in short)
    assert path_length(short) <= path_length(a.path) + 1e-9
    assert count_turns(short) < count_turns(a.path)
    assert np.array_equal(short, shortcut_path(a.path, checker))  # deterministic


def test_ompl_simplifier_is_seeded_free_and_no_longer() -> None:
    m = load_map("map2")
    checker = make_checker(m, RADIUS)
    raw = make_planner("ompl:RRTConnect").plan(PlanningProblem(m, checker, m.start, m.target, 1.0, 4)).path
    a, b = ompl_simplify(raw, checker, m.bounds, 11), ompl_simplify(raw, checker, m.bounds, 11)
    assert np.array_equal(a, b)
    assert _free("map2", a)
    assert np.array_equal(a[0], m.start) and np.array_equal(a[-1], m.target)
    assert path_length(a) <= path_length(raw) + 1e-9


# -- the benchmark's files -----------------------------------------------------------------------
@pytest.fixture(scope="module")
def bench_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    def build(folder: Path) -> None:
        assert run_cli(["bench", "planners", "--maps", "map1,map2", "--planners", "min-turn,rrtstar,ompl:RRTConnect",
                        "--runs", "2", "--time-limit", str(BUDGET_S), "--seed", "2", "--exec-repeats", "5",
                        "--no-plots", "--out", str(folder / "b")]) == 0

    return built_once(tmp_path_factory, "bench_anytime", build) / "b"


def _csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def test_every_run_has_a_first_solution_and_a_simplified_path(bench_dir: Path) -> None:
    runs = _csv(bench_dir / "runs.csv")
    refs = {r["map"]: float(r["shortest_length_cm"]) for r in _csv(bench_dir / "references.csv")}
    docs = [json.loads(line) for line in (bench_dir / "paths.jsonl").read_text().splitlines()]
    paths = {(d["map"], d["planner"], d["run"]): d for d in docs}
    # OMPL's budgets are counted in iterations, so they solve on any machine; min-turn's budget is
    # wall-clock time, which a loaded machine can run out of: its runs are checked when they succeed
    assert runs and all(r["success"] == "true" for r in runs if r["planner"] != "min-turn")
    for r in (r for r in runs if r["success"] == "true"):
        doc = paths[(r["map"], r["planner"], int(r["run"]))]
        assert 0 < float(r["first_solution_s"]) <= float(r["time_s"]) + 1e-9
        first, length = float(r["first_solution_length_cm"]), float(r["length_cm"])
        assert first >= length - 1e-6 >= refs[r["map"]] - 1e-3  # improves on its first path, never beats shortest
        simple = np.array(doc["simplified_path"], float)
        assert r["simplify"] == "ompl" and _free(r["map"], simple)
        assert float(r["simplified_length_cm"]) == pytest.approx(path_length(simple), rel=1e-9)
        assert float(r["simplified_length_cm"]) <= length + 1e-6
        assert int(r["simplified_turns"]) == count_turns(simple)
        assert float(r["simplified_length_ratio"]) == pytest.approx(path_length(simple) / refs[r["map"]], rel=1e-6)
        assert float(r["simplify_time_s"]) > 0 and float(r["simplified_exec_error_cm"]) > 0


def test_progress_csv_holds_the_samples_of_the_ompl_planners(bench_dir: Path) -> None:
    runs = {(r["map"], r["planner"], r["run"]): r for r in _csv(bench_dir / "runs.csv")}
    progress = _csv(bench_dir / "progress.csv")
    assert {p["planner"] for p in progress} == {"rrtstar", "ompl:RRTConnect"}  # min-turn reports none
    for key, run in runs.items():
        mine = [p for p in progress if (p["map"], p["planner"], p["run"]) == key]
        if run["planner"] == "min-turn" or run["success"] != "true":
            continue
        costs = [float(p["best_cost_cm"]) for p in mine if p["best_cost_cm"]]
        assert costs[0] == pytest.approx(float(run["first_solution_length_cm"]), rel=1e-9)
        assert costs[-1] == pytest.approx(float(run["length_cm"]), rel=1e-6)


def test_ompl_benchmark_statistics_stores_the_progress_rows(bench_dir: Path, tmp_path: Path) -> None:
    exe = Path(sys.executable).with_name("ompl_benchmark_statistics")
    db = tmp_path / "out.db"
    proc = subprocess.run([str(exe), str(bench_dir / "benchmark.log"), "-d", str(db)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    samples = _csv(bench_dir / "progress.csv")
    con = sqlite3.connect(db)
    try:
        rows = con.execute("SELECT c.name, r.run, r.solution_length, p.time, p.iterations, p.best_cost "
                           "FROM progress p JOIN runs r ON r.id = p.runid JOIN plannerConfigs c ON c.id = r.plannerid "
                           "ORDER BY r.id, p.time").fetchall()
        settings = dict(con.execute("SELECT name, settings FROM plannerConfigs").fetchall())
    finally:
        con.close()
    assert len(rows) == len(samples)
    assert {name for name, *_ in rows} == {"rrtstar", "ompl:RRTConnect"}
    by_run: dict[tuple[str, int, float], list[float]] = {}
    for name, run, solution, _, _, cost in rows:
        by_run.setdefault((name, run, solution), []).append(math.inf if cost is None else cost)
    for (_, _, solution), costs in by_run.items():
        assert min(costs) == pytest.approx(solution, rel=1e-6)  # the best sample is the run's solution
    assert "RewireFactor = 1.1" in settings["rrtstar"] and "simplify = ompl" in settings["min-turn"]


# -- time to a target, curves ---------------------------------------------------------------------
_Q = Query("m", 0, (0.0, 0.0), (1.0, 0.0))


def _rec(run: int, progress: tuple[tuple[float, int, float], ...] = (), length: float = math.nan,
         time_s: float = 1.0, success: bool = True) -> RunRecord:
    return RunRecord.build(map="m", planner="p", run=run, seed=0, query=0, start=_Q.start, goal=_Q.goal,
                           success=success, status="exact", time_s=time_s, collision_checks=0, length_cm=length,
                           progress=progress)


def test_time_within_reads_the_first_sample_under_the_target() -> None:
    samples = ((0.01, 10, math.inf), (0.02, 20, 120.0), (0.04, 40, 104.0), (0.09, 90, 101.0))
    assert time_within(_rec(0, samples, 101.0), 100.0) == 0.04
    assert time_within(_rec(0, samples, 101.0), 100.0, within=0.02) == 0.09
    assert math.isnan(time_within(_rec(0, samples, 101.0), 100.0, within=0.005))
    assert time_within(_rec(0, length=104.9, time_s=0.3), 100.0) == 0.3  # one path: its planning time
    assert math.isnan(time_within(_rec(0, length=105.1, time_s=0.3), 100.0))
    assert math.isnan(time_within(_rec(0, samples, 101.0, success=False), 100.0))


def test_cost_band_is_the_quartiles_of_the_step_curves() -> None:
    runs = [_rec(0, ((0.1, 1, 110.0), (0.3, 3, 100.0))), _rec(1, ((0.2, 2, 120.0),)),
            _rec(2, ((0.1, 1, 130.0), (0.2, 2, 105.0))), _rec(3, success=False)]
    grid = np.array([0.05, 0.1, 0.25, 0.5])
    band = cost_band(runs, {("m", 0): 100.0}, grid)
    assert band is not None
    # at 0.25 s the runs stand at 1.10, 1.20, 1.05 and inf (the failed one)
    col = np.sort([1.10, 1.20, 1.05, 1e300])
    assert band.median[2] == pytest.approx(np.quantile(col, 0.5))
    assert band.q25[2] == pytest.approx(np.quantile(col, 0.25))
    assert band.q75[2] == math.inf  # a quarter of the runs has no path
    assert band.median[0] == math.inf  # before any solution
    assert band.median[3] == pytest.approx(np.quantile([1.0, 1.2, 1.05, 1e300], 0.5))  # final values held


# -- the budget sweep ---------------------------------------------------------------------------
def test_budget_sweep_continues_the_shorter_budget_and_finds_the_time_within() -> None:
    config = BenchmarkConfig(maps=("map2",), planners=("min-turn", "rrtstar"), runs=2, seed=1, exec_repeats=3,
                             planner_options={"rrtstar": {"polish": False}})  # the planner's own best cost
    sweep = run_budget_sweep(config, [0.1, 0.02])
    assert sweep.budgets == (0.02, 0.1) and sweep.complete
    short, long = sweep.results
    assert short.config.time_limit == 0.02 and long.config.time_limit == 0.1
    for a in (r for r in short.records if r.planner == "rrtstar" and r.success):
        b = next(r for r in long.records if r.planner == "rrtstar" and r.run == a.run)
        at = max(i for _, i, _ in a.progress)
        assert a.length_cm == pytest.approx([c for _, i, c in b.progress if i <= at][-1], abs=1e-6)
    ref = short.references[0].shortest_length_cm
    for row in within_rows(sweep):
        recs = {b: [r for r in res.records if r.planner == row["planner"]] for b, res in zip(sweep.budgets,
                                                                                               sweep.results,
                                                                                               strict=True)}
        first = {}
        for b in sweep.budgets:  # by hand: the smallest budget of each run within 5 %
            for r in recs[b]:
                if r.success and r.length_cm <= 1.05 * ref and r.run not in first:
                    first[r.run] = r
        assert row["raw_reached"] == len(first)
        if first:
            assert row["raw_turns"] == pytest.approx(float(np.median([r.turns for r in first.values()])))
            assert row["raw_time_s"] == pytest.approx(float(np.median([r.time_s for r in first.values()])))


def test_budget_sweep_command_writes_its_tables(tmp_path: Path) -> None:
    out = tmp_path / "s"
    assert run_cli(["bench", "planners", "--maps", "map1", "--planners", "min-turn,ompl:RRTConnect", "--runs", "1",
                    "--budgets", "0.05,0.02", "--exec-repeats", "2", "--simplify", "shortcut", "--out", str(out)]) == 0
    rows = _csv(out / "budgets.csv")
    assert [(r["planner"], r["budget_s"]) for r in rows] == [("min-turn", "0.02"), ("min-turn", "0.05"),
                                                             ("ompl:RRTConnect", "0.02"), ("ompl:RRTConnect", "0.05")]
    assert (out / "budget-0.02s" / "runs.csv").is_file() and (out / "budget-0.05s" / "benchmark.log").is_file()
    assert (out / "budget_sweep.png").read_bytes()[:4] == b"\x89PNG"
    text = (out / "budgets.md").read_text()
    assert "## map1" in text and "Time to within 5 %" in text
    within = _csv(out / "within.csv")
    assert {r["planner"] for r in within} == {"min-turn", "ompl:RRTConnect"}


def test_cost_over_time_figure_is_drawn(tmp_path: Path) -> None:
    from toolkit.bench.planners.plots import save_cost_over_time

    cfg = BenchmarkConfig(maps=("m",), planners=("p", "q"), runs=2)
    recs = [_rec(0, ((0.1, 1, 110.0), (0.3, 3, 100.0))), _rec(1, ((0.2, 2, 120.0), (0.4, 4, 102.0))),
            RunRecord.build(map="m", planner="q", run=0, seed=0, query=0, start=_Q.start, goal=_Q.goal, success=True,
                            status="exact", time_s=0.01, collision_checks=0, length_cm=108.0, first_solution_s=0.01)]
    ref = ReferenceResult(_Q, 100.0, 1, 1, 100.0, "", 0.0)
    res = BenchmarkResult(cfg, tuple(recs), (ref,), datetime.now(), 1.0)
    png = save_cost_over_time(res, tmp_path)
    assert png.read_bytes()[:4] == b"\x89PNG"
