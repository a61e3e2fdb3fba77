"""Same seed, same path, for every planner: in one process whatever ran before, across processes, and
across benchmark worker counts; and a query no path can solve fails at once."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli

from planners import PLANNERS, PlanningProblem, PlanStatus, make_planner
from toolkit.world import load_map, map_from_dict

OMPL_PLANNERS = ["rrtstar", "prm", "ompl:RRTConnect", "ompl:PRMstar", "ompl:BITstar"]
BUDGET_S = 0.1


def _plan(name: str, seed: int, map_name: str = "map2") -> tuple[bool, list[list[float]]]:
    m = load_map(map_name)
    r = make_planner(name).plan(PlanningProblem.create(m, 8.0, m.start, m.target, BUDGET_S, rng=seed))
    return r.success, np.round(r.path, 9).tolist()


@pytest.mark.parametrize("name", OMPL_PLANNERS)
def test_a_seeded_call_does_not_depend_on_what_ran_before(name: str) -> None:
    first = _plan(name, 11)
    for other in (3, 4):  # other seeds and other planners in between
        _plan(name, other)
        _plan("ompl:RRT", other, "map1")
    again = _plan(name, 11)
    assert first[0] and first == again
    assert _plan(name, 12) != first  # and the seed matters


_CHILD = """
import json, sys
import numpy as np
from planners import PlanningProblem, make_planner
from toolkit.world import load_map
m = load_map("map2")
out = {}
for name in sys.argv[1].split(","):
    r = make_planner(name).plan(PlanningProblem.create(m, 8.0, m.start, m.target, float(sys.argv[2]), rng=11))
    out[name] = np.round(r.path, 9).tolist()
print(json.dumps(out))
"""


def test_the_same_seed_gives_the_same_path_in_a_fresh_process() -> None:
    proc = subprocess.run([sys.executable, "-c", _CHILD, ",".join(OMPL_PLANNERS), str(BUDGET_S)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    there = json.loads(proc.stdout.strip().splitlines()[-1])
    for name in OMPL_PLANNERS:
        assert there[name] == _plan(name, 11)[1], name


def _bench_rows(out: Path, workers: int) -> list[tuple[str, ...]]:
    code = run_cli(["bench", "planners", "--maps", "map1,map2", "--planners", "rrtstar,prm,ompl:RRTConnect",
                 "--runs", "2", "--time-limit", str(BUDGET_S), "--exec-repeats", "0", "--no-plots",
                 "--workers", str(workers), "--out", str(out)])
    assert code == 0
    with (out / "runs.csv").open() as f:
        rows = list(csv.DictReader(f))
    paths = [json.loads(line) for line in (out / "paths.jsonl").read_text().splitlines()]
    keep = ("map", "planner", "run", "seed", "success", "length_cm", "turns")
    table = sorted(tuple(r[k] for k in keep if k in r) for r in rows)
    return table + sorted((p["map"], p["planner"], str(p["run"]), json.dumps(p["path"])) for p in paths)


def test_benchmark_rows_repeat_across_runs_and_worker_counts(tmp_path: Path) -> None:
    one = _bench_rows(tmp_path / "w1", 1)
    assert one == _bench_rows(tmp_path / "w1-again", 1)
    assert one == _bench_rows(tmp_path / "w2", 2)


SPLIT = {"name": "split", "boundary": [[0, 0], [100, 0], [100, 60], [0, 60]],
         "obstacles": [[[45, 2], [55, 2], [55, 58], [45, 58]]]}


@pytest.mark.parametrize("name", sorted(PLANNERS.names()))
def test_start_and_goal_in_different_free_regions_fail_at_once(name: str) -> None:
    m = map_from_dict(SPLIT)
    r = make_planner(name).plan(PlanningProblem.create(m, 8.0, (20, 30), (80, 30), 5.0, rng=0))
    assert not r.success and r.status is PlanStatus.UNREACHABLE
    assert r.collision_checks == 2  # the start and goal checks: no search was made
