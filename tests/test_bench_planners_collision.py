"""The planner benchmark on either collision backend: the same runs, apart from the times.

FCL and the indexed checker answer every check alike (FCL's tolerance band decided exactly), so
with the same seed every planner takes the same decisions: `runs.csv` must be equal cell for cell
except the wall-clock columns (planning, first-solution and simplification times) and the column
that names the backend. The budget is one every planner here meets on either backend (min-turn
counts rounds; the OMPL planners count iterations).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from conftest import run_cli

from toolkit.bench.planners import runner
from toolkit.bench.planners.records import TIMING_COLUMNS

PLANNERS = "min-turn,rrtstar,prm,astar,shortest,min-link"


def _bench(out: Path, backend: str, map_name: str) -> list[dict[str, str]]:
    runner._planner.cache_clear()  # both runs start from the same empty caches (graphs, lattices, checkers)
    runner._checker.cache_clear()
    code = run_cli(["bench", "planners", "--maps", map_name, "--planners", PLANNERS, "--runs", "1",
                    "--time-limit", "0.2", "--exec-repeats", "3", "--seed", "5", "--no-plots",
                    "--collision", backend, "--out", str(out)])
    assert code == 0
    with (out / "runs.csv").open(newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow
@pytest.mark.parametrize("map_name", ["map1", "map2", "map3", "pillars"])
def test_index_and_fcl_give_the_same_runs(map_name: str, tmp_path: Path) -> None:
    index = _bench(tmp_path / "index", "index", map_name)
    fcl = _bench(tmp_path / "fcl", "fcl", map_name)
    assert {r["collision"] for r in index} == {"index"} and {r["collision"] for r in fcl} == {"fcl"}
    assert len(index) == len(PLANNERS.split(",")) and all(r["success"] == "true" for r in index)
    for a, b in zip(index, fcl, strict=True):
        for column in a:
            if column not in TIMING_COLUMNS | {"collision"}:
                assert a[column] == b[column], (a["planner"], column, a[column], b[column])
    config = json.loads((tmp_path / "fcl" / "config.json").read_text())
    assert config["config"]["collision"] == "fcl"
    assert "collision checks: fcl" in (tmp_path / "fcl" / "summary.md").read_text()
    assert all(json.loads(line)["collision"] == "fcl"
               for line in (tmp_path / "fcl" / "paths.jsonl").read_text().splitlines())
