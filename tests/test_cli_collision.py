"""`--collision index|fcl` on every command that checks collisions: refused when unknown, recorded in
every result file, and the same answers either way (a mission, a single plan)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from conftest import run_cli

EXTERNAL = Path(__file__).resolve().parents[1] / "maps" / "external"


@pytest.mark.parametrize("command", [
    ["plan", "-o", "{tmp}/p.png"],
    ["run"],
    ["paper", "--trials", "1"],
    ["bench", "planners", "--out", "{tmp}/b"],
    ["bench", "scen", str(EXTERNAL / "arena2.map.scen"), "--kind", "octile"],
    ["bench", "world"],
])
def test_an_unknown_backend_is_one_line_and_exit_2(command: list[str], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    argv = [a.replace("{tmp}", str(tmp_path)) for a in command] + ["--collision", "ode"]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nxtnav: error:"), err
    assert "--collision" in err[0] and "'ode'" in err[0] and "index, fcl" in err[0]
    assert not any(tmp_path.iterdir()), "nothing is written before the options are checked"


def test_plan_records_the_backend_and_finds_the_same_path(tmp_path: Path) -> None:
    docs = {}
    for backend in ("index", "fcl"):
        out = tmp_path / backend
        assert run_cli(["plan", "--map", "map2", "--planner", "min-link", "--exec-repeats", "3", "--collision",
                        backend, "-o", str(out / "p.png"), "--json", str(out / "p.json")]) == 0
        docs[backend] = json.loads((out / "p.json").read_text())
    assert docs["index"]["collision"] == "index" and docs["fcl"]["collision"] == "fcl"
    for key in ("path", "metrics", "execution", "collision_checks"):
        assert docs["index"][key] == docs["fcl"][key], key


def test_bench_world_and_scen_record_the_backend(tmp_path: Path) -> None:
    assert run_cli(["bench", "world", "--map", "map1", "--poses", "20", "--segments", "200", "--repeats", "1",
                    "--no-range-model", "--no-peer", "--collision", "fcl", "--json", str(tmp_path / "w.json")]) == 0
    fig = json.loads((tmp_path / "w.json").read_text())
    assert fig["collision"] == "fcl" and fig["segment_checks_per_s"] > 0 and fig["index_bytes"] is None
    out = tmp_path / "scen"
    assert run_cli(["bench", "scen", str(EXTERNAL / "arena2.map.scen"), "--kind", "octile", "--planners", "astar",
                    "--limit", "3", "--radius", "0.4", "--collision", "fcl", "--out", str(out)]) == 0
    with (out / "scen.csv").open(newline="") as fh:
        assert {r["collision"] for r in csv.DictReader(fh)} == {"fcl"}
    assert "collision checks: fcl" in (out / "summary.md").read_text()
    assert "collision checks fcl" in (out / "scen.log").read_text()


def test_a_point_robot_says_which_checker_answered(tmp_path: Path) -> None:
    out = tmp_path / "scen"
    assert run_cli(["bench", "scen", str(EXTERNAL / "arena2.map.scen"), "--kind", "octile", "--planners", "astar",
                    "--limit", "2", "--collision", "fcl", "--out", str(out)]) == 0
    with (out / "scen.csv").open(newline="") as fh:
        assert {r["collision"] for r in csv.DictReader(fh)} == {"point"}
    assert "point (exact; --collision fcl applies to a robot of radius > 0)" in (out / "summary.md").read_text()


@pytest.mark.slow
def test_a_mission_is_the_same_on_either_backend(tmp_path: Path) -> None:
    reports = {}
    for backend in ("index", "fcl"):
        path = tmp_path / f"{backend}.json"
        assert run_cli(["run", "--map", "map1", "--seed", "3", "--collision", backend, "--json", str(path),
                        "--record", str(tmp_path / f"{backend}.jsonl")]) == 0
        reports[backend] = json.loads(path.read_text())
        header = json.loads((tmp_path / f"{backend}.jsonl").read_text().splitlines()[0])
        assert header["collision"] == backend
    assert reports["fcl"]["collision"] == "fcl"
    same = ("success", "status", "final_error_cm", "path_length_cm", "turns", "collisions", "watchdog_stops",
            "relocalisations", "replans", "robot_time_s", "plans", "final_pose")
    for key in same:
        assert reports["index"][key] == reports["fcl"][key], key
