"""``--config FILE`` on the benchmarks of real sweeps, faults, scenario files and the world, and on replay: each
command writes its effective configuration into its outputs, and a second run from that file alone gives
the same results (wall-clock measurements aside)."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from conftest import REAL_NXT, fails_cleanly, run_cli

DATA = Path(__file__).parent / "data"
SCEN = Path(__file__).parents[1] / "maps" / "external" / "arena2.map.scen"


def _two_sweeps(tmp_path: Path) -> Path:
    """The real sweep set cut to its first two sweeps: one source at two waypoints (the cheapest routes)."""
    folder = tmp_path / "set"
    shutil.copytree(REAL_NXT, folder)
    lines = (folder / "sweeps.csv").read_text().splitlines()
    (folder / "sweeps.csv").write_text("\n".join(lines[:3]) + "\n")
    return folder


WALL_CLOCK = ("time_s", "preprocess_s")
"""The columns that measure wall-clock time."""


def _rows(path: Path) -> list[dict[str, str]]:
    """A CSV's rows without its wall-clock columns."""
    with path.open(newline="") as fh:
        return [{k: v for k, v in row.items() if k not in WALL_CLOCK} for row in csv.DictReader(fh)]


@pytest.mark.parametrize(("command", "args", "written", "results"), [
    ("sweeps", ["--localisers", "paper-pf", "--seeds", "1", "--set", "sonar.noise_sd=4"], "config.json",
     "sweeps.csv"),
    ("routes", ["--localisers", "paper-pf", "--seeds", "1", "--set", "paper-pf.n_particles=300"], "summary.json",
     "routes.csv"),
    ("challenge", ["--localisers", "paper-pf", "--seeds", "1", "--set", "challenge.move_step_cm=15"], "summary.json",
     "challenge.csv"),
])
def test_a_real_sweep_benchmark_runs_again_from_its_output(tmp_path: Path, command: str, args: list[str],
                                                           written: str, results: str) -> None:
    folder, first, again = _two_sweeps(tmp_path), tmp_path / "a", tmp_path / "b"
    assert run_cli(["bench", command, str(folder), *args, "--out", str(first)]) == 0
    conf = json.loads((first / written).read_text())["configuration"]
    assert conf["command"] == f"bench {command}" and conf["options"]["seeds"] == "1"
    assert conf["options"]["folder"] == str(folder) and conf["set"] == args[5:]
    assert run_cli(["bench", command, "--config", str(first / written), "--out", str(again)]) == 0
    assert _rows(again / results) == _rows(first / results) and len(_rows(first / results)) >= 2
    assert json.loads((again / written).read_text())["configuration"] == conf


def test_a_sweep_benchmark_tells_the_localisers_the_sonar_it_is_set(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    folder, out = _two_sweeps(tmp_path), tmp_path / "a"
    argv = ["bench", "sweeps", str(folder), "--localisers", "paper-pf", "--seeds", "1", "--out", str(out)]
    assert run_cli([*argv, "--set", "sonar.noise_sd=4", "--set", "sonar.beam_width_deg=30"]) == 0
    told = json.loads((out / "config.json").read_text())["sonar"]
    assert told["noise_sd"] == 4.0 and told["beam_width_deg"] == 30.0
    capsys.readouterr()
    for bad, words in (("sonar.noise_sd=-1", "sonar: noise_sd: -1"),
                       ("robot.timing.drive_speed_cm_s=20", "nxtnav bench sweeps takes sonar settings")):
        fails_cleanly([*argv[:-1], str(tmp_path / "c"), "--set", bad], capsys, words)
        assert not (tmp_path / "c").exists()


def test_a_challenge_setting_is_applied_and_a_wrong_one_is_one_line(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    folder, out = _two_sweeps(tmp_path), tmp_path / "a"
    argv = ["bench", "challenge", str(folder), "--localisers", "paper-pf", "--seeds", "1", "--out", str(out)]
    assert run_cli([*argv, "--set", "challenge.reach_cm=0.001"]) == 0
    conf = json.loads((out / "summary.json").read_text())["configuration"]
    assert conf["challenge"]["reach_cm"] == 0.001
    assert {row["reached"] for row in _rows(out / "challenge.csv")} == {"False"}  # no robot ends 0.01 mm close
    capsys.readouterr()
    for bad, words in (("challenge.reach_cm=-1", "--set challenge: reach_cm: -1"),
                       ("paper-pf.n_particles=300", "nxtnav bench challenge takes challenge settings")):
        fails_cleanly([*argv[:-1], str(tmp_path / "c"), "--set", bad], capsys, words)
        assert not (tmp_path / "c").exists()


def _deterministic(mission: dict[str, Any]) -> dict[str, Any]:
    """A fault mission without its wall-clock measurements (the run's and each outage's)."""
    noticed = [{k: v for k, v in n.items() if k != "outage_s"} for n in mission["noticed"]]
    return {**{k: v for k, v in mission.items() if k not in ("wall_s", "noticed")}, "noticed": noticed}


@pytest.mark.slow
def test_the_fault_benchmark_runs_again_from_its_json(tmp_path: Path) -> None:
    first, again = tmp_path / "a.json", tmp_path / "b.json"
    assert run_cli(["bench", "faults", "--missions", "1", "--seed", "4", "--faults", "sonar-garbage", "--maps",
                    "map1", "--reply-timeout", "2", "--json", str(first)]) == 0
    doc = json.loads(first.read_text())
    conf = doc["configuration"]
    assert conf["command"] == "bench faults" and conf["options"]["reply-timeout"] == 2.0
    assert run_cli(["bench", "faults", "--config", str(first), "--json", str(again)]) == 0
    same = json.loads(again.read_text())
    assert [_deterministic(m) for m in same["missions"]] == [_deterministic(m) for m in doc["missions"]]
    assert same["missions"][0]["faults"] and same["configuration"] == conf


def test_the_scenario_benchmark_runs_again_from_its_config(tmp_path: Path) -> None:
    first, again = tmp_path / "a", tmp_path / "b"
    assert run_cli(["bench", "scen", str(SCEN), "--kind", "octile", "--planners", "astar", "--limit", "3",
                    "--out", str(first)]) == 0
    conf = json.loads((first / "config.json").read_text())["configuration"]
    assert conf["command"] == "bench scen" and conf["options"]["limit"] == 3
    assert run_cli(["bench", "scen", "--config", str(first / "config.json"), "--out", str(again)]) == 0
    assert _rows(again / "scen.csv") == _rows(first / "scen.csv") and len(_rows(first / "scen.csv")) == 3


def test_the_world_benchmark_runs_again_from_its_json(tmp_path: Path) -> None:
    first, again = tmp_path / "a.json", tmp_path / "b.json"
    assert run_cli(["bench", "world", "--map", "map3", "--poses", "20", "--repeats", "1", "--segments", "100",
                    "--no-range-model", "--no-peer", "--seed", "5", "--json", str(first)]) == 0
    doc = json.loads(first.read_text())
    assert doc["configuration"]["options"]["map"] == "map3" and doc["configuration"]["options"]["seed"] == 5
    assert run_cli(["bench", "world", "--config", str(first), "--json", str(again)]) == 0
    same = json.loads(again.read_text())
    keep = ("edges", "collision", "mean_segment_cm", "mean_long_segment_cm", "configuration")
    assert {k: same[k] for k in keep} == {k: doc[k] for k in keep}


def test_replay_runs_again_from_its_json(tmp_path: Path) -> None:
    first, again = tmp_path / "a.json", tmp_path / "b.json"
    assert run_cli(["replay", str(DATA / "recording_map1_nxt.jsonl"), "--localisers", "pf-systematic", "--seed", "4",
                    "--set", "pf-systematic.n_particles=150", "--json", str(first)]) == 0
    doc = json.loads(first.read_text())
    assert doc["configuration"]["set"] == ["pf-systematic.n_particles=150"]
    assert run_cli(["replay", "--config", str(first), "--json", str(again)]) == 0
    same = json.loads(again.read_text())
    poses = [[s["estimates"][n]["pose"] for n in s["estimates"]] for s in doc["steps"]]
    assert [[s["estimates"][n]["pose"] for n in s["estimates"]] for s in same["steps"]] == poses
    assert same["configuration"] == doc["configuration"]
