"""`nxtnav bench planners` and `nxtnav plan`: output files, independent checks, OMPL's own converter."""

from __future__ import annotations

import csv
import json
import math
import sqlite3
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
import shapely
from conftest import built_once, nxtnav_exe, run_cli

from planners import PLANNERS, Planner, PlanningProblem, PlanStatus
from planners.base import Solution
from toolkit.bench.planners import (
    LARGE_MAP_WALLS,
    RUN_COLUMNS,
    BenchmarkConfig,
    known_planners,
    make_queries,
    planner_for,
)
from toolkit.seeds import derive_seed
from toolkit.world import CollisionChecker, RegistryError, load_map

pytestmark = pytest.mark.xdist_group("bench-planners")  # one worker: `bench_dir` built once, none waiting on its lock

MAPS = ("map1", "map2", "map3")
WANTED = ("min-turn", "rrtstar", "prm", "astar")
RADIUS = 8.0
RUNS = 3


def planners_under_test() -> list[str]:
    known = known_planners()
    assert set(WANTED) <= set(known), f"not registered: {sorted(set(WANTED) - set(known))}"
    return list(WANTED)


def ompl_statistics() -> str:
    exe = Path(sys.executable).with_name("ompl_benchmark_statistics")
    assert exe.exists(), "ompl_benchmark_statistics (OMPL's wheel) is not installed next to this Python"
    return str(exe)


def path_is_free(m_name: str, path: np.ndarray, radius: float) -> bool:
    """Independent check with shapely: every segment inside the map and >= radius from every wall."""
    m = load_map(m_name)
    line = shapely.LineString(path) if len(path) > 1 else shapely.Point(path[0])
    return bool(m.polygon.covers(line)) and float(line.distance(m.wall_lines)) >= radius - 1e-6


@pytest.fixture(scope="session")
def bench_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    def build(folder: Path) -> None:
        code = run_cli(["bench", "planners", "--maps", ",".join(MAPS), "--planners", ",".join(planners_under_test()),
                        "--runs", str(RUNS), "--time-limit", "0.2", "--seed", "4", "--out", str(folder / "presets"),
                        "--exec-repeats", "20"])
        assert code == 0

    return built_once(tmp_path_factory, "bench_planners", build) / "presets"


def read_runs(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def test_runs_csv_columns_and_rows(bench_dir: Path) -> None:
    with (bench_dir / "runs.csv").open(newline="") as fh:
        header = next(csv.reader(fh))
    assert tuple(header) == RUN_COLUMNS
    rows = read_runs(bench_dir / "runs.csv")
    names = planners_under_test()
    assert len(rows) == len(MAPS) * len(names) * RUNS
    assert {(r["map"], r["planner"], int(r["run"])) for r in rows} == {
        (m, p, i) for m in MAPS for p in names for i in range(RUNS)}
    for r in rows:
        assert r["seed"] == str(derive_seed(4, r["map"], int(r["run"])))
        if r["success"] == "true":
            assert float(r["length_cm"]) > 0
            assert float(r["length_ratio"]) >= 1.0 - 1e-6  # no planner beats the shortest path
            assert int(r["turns"]) >= 0
            assert float(r["exec_error_cm"]) > 0
            assert float(r["min_clearance_cm"]) >= -1e-3  # FCL distance, to its tolerance
    # the paper's planner solves the preset queries
    assert all(r["success"] == "true" for r in rows if r["planner"] == "min-turn")


def test_paths_jsonl_are_collision_free_per_shapely(bench_dir: Path) -> None:
    lines = (bench_dir / "paths.jsonl").read_text().splitlines()
    assert len(lines) == len(MAPS) * len(planners_under_test()) * RUNS
    runs = {(r["map"], r["planner"], r["run"]): r for r in read_runs(bench_dir / "runs.csv")}
    for line in lines:
        doc = json.loads(line)
        assert {"map", "planner", "run", "seed", "success", "path"} <= set(doc)
        row = runs[(doc["map"], doc["planner"], str(doc["run"]))]
        assert (row["success"] == "true") == doc["success"]
        if not doc["success"]:
            continue
        if doc["first_solution_s"] is not None:
            assert 0 < doc["first_solution_s"] <= doc["time_s"] + 1e-9
        p = np.array(doc["path"], float)
        m = load_map(doc["map"])
        np.testing.assert_allclose(p[0], m.start)
        np.testing.assert_allclose(p[-1], m.target)
        assert path_is_free(doc["map"], p, RADIUS), (doc["map"], doc["planner"], doc["run"])
        length = float(np.sum(np.hypot(*np.diff(p, axis=0).T)))
        assert length == pytest.approx(float(row["length_cm"]), rel=1e-6)


def test_summary_has_one_table_per_map(bench_dir: Path) -> None:
    text = (bench_dir / "summary.md").read_text()
    for m in MAPS:
        assert f"## {m}" in text
    assert text.count("| planner | success |") == len(MAPS)
    assert text.count("| planner | simplification (ms) |") == len(MAPS)  # the paths simplified (default: ompl)
    for p in planners_under_test():
        assert text.count(f"| {p} |") == 2 * len(MAPS)
    for stem in ("time", "length_ratio", "turns", "exec_error"):
        assert (bench_dir / f"boxplot_{stem}.png").read_bytes()[:4] == b"\x89PNG"
    for name in ("exec_vs_turns", "paths", "cost_over_time"):
        assert (bench_dir / f"{name}.png").read_bytes()[:4] == b"\x89PNG"


def test_ompl_log_converts_to_a_database_with_every_planner(bench_dir: Path, tmp_path: Path) -> None:
    exe = ompl_statistics()
    names = planners_under_test()
    db = tmp_path / "out.db"
    proc = subprocess.run([exe, str(bench_dir / "benchmark.log"), "-d", str(db)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    con = sqlite3.connect(db)
    try:
        counts = dict(con.execute("SELECT p.name, COUNT(*) FROM runs r JOIN plannerConfigs p ON r.plannerid = p.id "
                                  "GROUP BY p.name").fetchall())
        assert counts == {p: len(MAPS) * RUNS for p in names}
        solved = con.execute("SELECT COUNT(*) FROM runs r JOIN plannerConfigs p ON r.plannerid = p.id "
                             "WHERE p.name = 'min-turn' AND r.solved = 1").fetchone()[0]
        assert solved == len(MAPS) * RUNS
        # the map enum keeps the runs of each map apart
        per_map = con.execute("SELECT e.description, COUNT(*) FROM runs r JOIN enums e "
                              "ON e.name = 'map' AND e.value = r.map GROUP BY e.description").fetchall()
        assert dict(per_map) == {m: len(names) * RUNS for m in MAPS}
        times = [t for (t,) in con.execute("SELECT time FROM runs")]
        assert all(t is not None and t >= 0 for t in times)
    finally:
        con.close()
    # one experiment per map and query set, for Planner Arena
    db2 = tmp_path / "maps.db"
    logs = sorted(str(p) for p in (bench_dir / "ompl").glob("*.log"))
    assert len(logs) == len(MAPS)
    proc = subprocess.run([exe, *logs, "-d", str(db2)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    con = sqlite3.connect(db2)
    try:
        exps = sorted(n for (n,) in con.execute("SELECT name FROM experiments"))
        assert exps == sorted(f"{m}-presets" for m in MAPS)
        rows = con.execute("SELECT e.name, p.name, COUNT(*) FROM runs r JOIN experiments e ON r.experimentid = e.id "
                           "JOIN plannerConfigs p ON r.plannerid = p.id GROUP BY e.name, p.name").fetchall()
        assert {(e, p): n for e, p, n in rows} == {(f"{m}-presets", p): RUNS for m in MAPS for p in names}
    finally:
        con.close()


def test_refuses_a_non_empty_out_folder(bench_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = (bench_dir / "runs.csv").read_bytes()
    code = run_cli(["bench", "planners", "--maps", "map1", "--planners", "min-turn", "--runs", "1",
                "--out", str(bench_dir)])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "--force" in err
    assert (bench_dir / "runs.csv").read_bytes() == before


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--planners", "min-turn,no-such-planner"], "no-such-planner"),
        (["--planners", "ompl:NoSuchPlanner"], "NoSuchPlanner"),
        (["--maps", "map1,nowhere"], "nowhere"),
        (["--queries", "sometimes"], "--queries"),
        (["--time-limit", "0"], "time limit"),
        (["--noise-model", "gaussian"], "noise"),
        (["--simplify", "smooth"], "--simplify"),
        (["--simplify", ""], "--simplify"),
        (["--progress-interval", "0"], "--progress-interval"),
        (["--progress-interval", "-0.01"], "--progress-interval"),
        (["--budgets", ""], "--budgets"),
        (["--budgets", ",,"], "--budgets"),
        (["--budgets", "0.1,-1"], "--budgets"),
        (["--budgets", "0.1,0"], "--budgets"),
        (["--budgets", "0.1,nan"], "--budgets"),
        (["--budgets", "0.1,fast"], "--budgets"),
        (["--budgets", "0.1,0.1"], "--budgets"),
        (["--budgets", "0.1", "--time-limit", "1"], "--budgets"),
    ],
)
def test_bench_bad_inputs_exit_2_with_one_line(args: list[str], needle: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    base = {"--maps": "map1", "--planners": "min-turn", "--runs": "1"}
    for i in range(0, len(args), 2):
        base[args[i]] = args[i + 1]
    argv = ["bench", "planners", "--out", str(tmp_path / "o")]
    for k, v in base.items():
        argv += [k, v]
    code = run_cli(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and needle in err, err
    assert not (tmp_path / "o").exists()


def test_random_queries_are_free_connected_and_seeded() -> None:
    for name in MAPS:
        m = load_map(name)
        qs = make_queries(m, "random", 6, 9, RADIUS)
        again = make_queries(m, "random", 6, 9, RADIUS)
        assert [q.to_dict() for q in qs] == [q.to_dict() for q in again]
        assert len({q.start for q in qs}) == 6
        cspace = m.free_space(RADIUS)
        parts = list(getattr(cspace, "geoms", [cspace]))
        cc = CollisionChecker(m, RADIUS)
        for q in qs:
            for p in (q.start, q.goal):
                assert m.wall_distance(np.array(p)) >= RADIUS and m.contains(np.array(p))
                assert cc.point_free(np.array(p))
            assert any(part.covers(shapely.Point(q.start)) and part.covers(shapely.Point(q.goal)) for part in parts)


def test_random_queries_seeded_and_same_on_every_executor(tmp_path: Path) -> None:
    """Same seed, same runs: in-process vs a local Dask cluster, with random queries."""
    args = ["bench", "planners", "--maps", "map1", "--planners", "min-turn", "--runs", "2", "--time-limit", "0.2",
            "--seed", "12", "--queries", "random", "--exec-repeats", "10", "--no-plots"]
    assert run_cli([*args, "--out", str(tmp_path / "a")]) == 0
    assert run_cli([*args, "--out", str(tmp_path / "b"), "--dask", "local", "--workers", "1"]) == 0
    untimed = lambda d: {k: v for k, v in d.items() if k not in ("time_s", "first_solution_s")}  # noqa: E731
    pa = [untimed(json.loads(x)) for x in (tmp_path / "a" / "paths.jsonl").read_text().splitlines()]
    pb = [untimed(json.loads(x)) for x in (tmp_path / "b" / "paths.jsonl").read_text().splitlines()]
    assert pa == pb
    ra, rb = read_runs(tmp_path / "a" / "runs.csv"), read_runs(tmp_path / "b" / "runs.csv")
    for x, y in zip(ra, rb, strict=True):
        for col in ("map", "planner", "run", "seed", "success", "length_cm", "turns", "exec_error_cm"):
            assert x[col] == y[col]
    assert pa[0]["start"] != pa[1]["start"]  # one random query per run


def test_force_overwrites(tmp_path: Path) -> None:
    out = tmp_path / "o"
    out.mkdir()
    (out / "old.txt").write_text("x")
    (out / "ompl").mkdir()
    (out / "ompl" / "map1-presets.log").write_text("an earlier benchmark")
    assert run_cli(["bench", "planners", "--maps", "map2", "--planners", "min-turn", "--runs", "1", "--out", str(out),
                "--force", "--exec-repeats", "0", "--no-plots"]) == 0
    rows = read_runs(out / "runs.csv")
    assert len(rows) == 1 and rows[0]["exec_error_cm"] == ""
    assert (out / "old.txt").read_text() == "x"  # not ours: left alone
    assert sorted(p.name for p in (out / "ompl").iterdir()) == ["map2-presets.log"]


def test_turns_error_correlation_is_a_rank_correlation() -> None:
    from datetime import datetime

    from toolkit.bench.planners import BenchmarkResult, Query, RunRecord, turns_error_correlation

    q = Query("map1", 0, (20.0, 20.0), (80.0, 80.0))

    def rec(i: int, turns: float, err: float, success: bool = True) -> RunRecord:
        return RunRecord.build(map="map1", planner="min-turn", run=i, seed=0, query=0, start=q.start, goal=q.goal,
                               success=success, status="exact", time_s=0.01, collision_checks=1, turns=turns,
                               exec_error_cm=err)

    cfg = BenchmarkConfig(maps=("map1",), planners=("min-turn",), runs=5)
    up = [rec(0, 0, 1.0), rec(1, 1, 5.0), rec(2, 2, 5.5), rec(3, 5, 40.0), rec(4, 9, 1e9, success=False)]
    res = BenchmarkResult(cfg, tuple(up), (), datetime.now(), 1.0)
    assert turns_error_correlation(res, "map1") == (pytest.approx(1.0), 4)
    down = [rec(i, t, -e) for i, t, e in ((0, 0, 1.0), (1, 1, 5.0), (2, 2, 5.5))]
    assert turns_error_correlation(BenchmarkResult(cfg, tuple(down), (), datetime.now(), 1.0), "map1")[0] == \
        pytest.approx(-1.0)
    flat = [rec(i, 2, float(i)) for i in range(4)]
    assert math.isnan(turns_error_correlation(BenchmarkResult(cfg, tuple(flat), (), datetime.now(), 1.0), "map1")[0])


def test_config_validation() -> None:
    from toolkit.world import NxtnavError

    with pytest.raises(NxtnavError):
        BenchmarkConfig(maps=("map1", "map1"), planners=("min-turn",))
    with pytest.raises(NxtnavError):
        BenchmarkConfig(maps=("map1",), planners=("min-turn",), runs=0)
    c = BenchmarkConfig(maps=("map1", "map2"), planners=("min-turn", "astar"), runs=5, queries="random")
    assert c.n_tasks() == 2 * 5 + 2 * 2 * 5


# -- nxtnav plan ---------------------------------------------------------------------------------
def test_plan_writes_figure_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png, js = tmp_path / "p.png", tmp_path / "p.json"
    assert run_cli(["plan", "--map", "map3", "--planner", "min-turn", "--seed", "2", "--time-limit", "0.5",
                "-o", str(png), "--json", str(js), "--exec-repeats", "30"]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    doc = json.loads(js.read_text())
    assert doc["success"] is True and doc["status"]
    p = np.array(doc["path"], float)
    np.testing.assert_allclose(p[0], [50, 70])
    np.testing.assert_allclose(p[-1], [230, 70])
    assert path_is_free("map3", p, RADIUS)
    met = doc["metrics"]
    assert met["length_cm"] == pytest.approx(float(np.sum(np.hypot(*np.diff(p, axis=0).T))))
    assert met["turns"] >= 1
    assert doc["execution"]["repeats"] == 30 and doc["execution"]["mean_cm"] > 0
    if "shortest" in doc["references"]:
        assert met["length_ratio"] >= 1.0 - 1e-9
    out = capsys.readouterr().out
    assert "min-turn on map3" in out


def test_plan_custom_query(tmp_path: Path) -> None:
    js = tmp_path / "p.json"
    assert run_cli(["plan", "--map", "map1", "--planner", "min-turn", "--start", "20,80", "--goal", "90,70",
                "-o", str(tmp_path / "p.png"), "--json", str(js), "--exec-repeats", "0"]) == 0
    doc = json.loads(js.read_text())
    assert doc["start"] == [20.0, 80.0] and doc["goal"] == [90.0, 70.0]
    assert "execution" not in doc
    assert all(math.isfinite(v) for v in np.ravel(doc["path"]))


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--planner", "warp-drive"], "warp-drive"),
        (["--start", "1,1"], "--start"),
        (["--goal", "58,50"], "--goal"),
        (["--start", "20,twenty"], "--start"),
        (["--map", "atlantis"], "atlantis"),
    ],
)
def test_plan_bad_inputs_exit_2_with_one_line(args: list[str], needle: str, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "p.png"
    code = run_cli(["plan", "--map", "map1", "--planner", "min-turn", "-o", str(png), *args])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and needle in err, err
    assert not png.exists()


def test_console_script_keeps_stderr_to_one_line(tmp_path: Path) -> None:
    exe = nxtnav_exe()
    proc = subprocess.run([exe, "plan", "--map", "map1", "--planner", "min-turn", "--start", "3,3",
                           "-o", str(tmp_path / "p.png")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1


def test_point_robot_on_a_grid_map_file(tmp_path: Path) -> None:
    """Radius 0 on a Moving AI file: every path is free for the exact point checker, none beats `shortest`."""
    from toolkit.world import import_map, make_checker

    grid = tmp_path / "g.map"
    assert run_cli(["maps", "random", "40", "-o", str(grid), "--density", "0.2", "--seed", "2"]) == 0
    out = tmp_path / "b"
    assert run_cli(["bench", "planners", "--maps", str(grid), "--planners", "shortest,astar", "--radius", "0",
                "--queries", "random", "--runs", "4", "--exec-repeats", "0", "--no-plots", "--out", str(out)]) == 0
    checker = make_checker(import_map(grid), 0.0)
    best: dict[int, float] = {}
    lengths: dict[tuple[str, int], float] = {}
    for line in (out / "paths.jsonl").read_text().splitlines():
        doc = json.loads(line)
        assert doc["success"], doc["planner"]
        p = np.array(doc["path"], float)
        assert checker.segments_free(p[:-1], p[1:]).all(), (doc["planner"], doc["run"])
        lengths[(doc["planner"], doc["run"])] = float(np.sum(np.hypot(*np.diff(p, axis=0).T)))
    for (planner, run_no), length in lengths.items():
        best[run_no] = lengths[("shortest", run_no)]
        assert length >= best[run_no] - 1e-9, planner
    assert len(best) == 4
    assert run_cli(["bench", "planners", "--maps", str(grid), "--radius", "-1", "--out", str(tmp_path / "c")]) == 2


# -- what the bench gives a planner is the planner class's declaration ---------------------------------------
class _Declared(Planner):
    """A planner of one's own that declares what the bench gives it (it plans nothing)."""

    grid_map_options: ClassVar[Mapping[str, Any]] = {"cells": True}
    large_map_options = None
    reports_progress = True

    def __init__(self, cells: bool = False, progress_interval: float | None = None) -> None:
        self.cells, self.progress_interval = cells, progress_interval

    def _solve(self, problem: PlanningProblem) -> Solution:
        return Solution(None, PlanStatus.TIMEOUT)


def test_the_bench_gives_a_planner_what_its_class_declares() -> None:
    small, grid, large = load_map("map1"), load_map("i-108_10mm"), load_map("turtlebot3_world")
    assert grid.grid is not None and len(grid.walls) <= LARGE_MAP_WALLS < len(large.walls)
    with PLANNERS.added({"declared": _Declared}):
        built = planner_for("declared", small, progress_interval=0.5)
        assert (built.cells, built.progress_interval) == (False, 0.5)
        assert planner_for("declared", grid, {"cells": False}).cells is False  # the user's option wins
        assert planner_for("declared", grid).cells is True and planner_for("declared", large) is None
    assert planner_for("astar", grid).resolution is None and planner_for("astar", small).resolution == 2.0
    assert planner_for("shortest", large).n_sides == 16 and planner_for("shortest", grid).n_sides == 64
    assert planner_for("min-link", large) is None and planner_for("min-link", grid) is not None
    assert planner_for("ompl:RRTConnect", small, progress_interval=0.5).progress_interval == 0.5
    assert planner_for("min-turn", small, progress_interval=0.5) is not None  # declares none: given none
    with pytest.raises(RegistryError,
                       match=r"unknown planner 'declared'; known: astar, fastest, min-link, .*ompl:NAME"):
        planner_for("declared", small)  # gone with its block
