"""One override syntax and reproducible runs: ``--set mission.GROUP.FIELD=V`` reaches the mission, every run
writes its effective configuration (JSON report, recording header, paper tables), and ``--config FILE``
reads it back to run the same mission again."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from conftest import run_cli


def _deterministic(doc: dict[str, Any]) -> dict[str, Any]:
    """A run report without its wall-clock measurements (the planner's note carries its time)."""
    trace = [{k: v for k, v in step.items() if k != "note"} for step in doc["trace"]]
    return {**{k: v for k, v in doc.items() if k not in ("completion_s", "cpu_s", "trace")}, "trace": trace}


def test_a_run_written_with_its_configuration_runs_again_from_it(tmp_path: Path) -> None:
    first, again, rec = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "a.jsonl"
    assert run_cli(["run", "--map", "map1", "--seed", "4", "--set", "mission.drive.move_step_cm=25",
                    "--set", "mission.fix.rule=always", "--set", "paper-pf.n_particles=400",
                    "--json", str(first), "--record", str(rec)]) == 0
    doc = json.loads(first.read_text())
    conf = doc["configuration"]
    assert conf["command"] == "run" and conf["options"]["seed"] == 4 and conf["options"]["map"] == "map1"
    assert conf["mission"]["drive"]["move_step_cm"] == 25.0 and conf["mission"]["fix"]["rule"] == "always"
    assert conf["mission"]["localiser_options"] == {"n_particles": 400}
    assert "json" not in conf["options"] and "record" not in conf["options"]
    header = json.loads(rec.read_text().splitlines()[0])
    assert header["configuration"] == conf
    # the same mission from the file alone; a setting read from the file is really applied
    assert run_cli(["run", "--config", str(first), "--json", str(again)]) == 0
    assert _deterministic(json.loads(again.read_text())) == _deterministic(doc)
    # the setting reached the mission: moves longer than the default step (10 cm)
    assert max(step["distance_cm"] or 0.0 for step in doc["trace"]) > 10.0


def test_the_command_line_wins_over_the_file(tmp_path: Path) -> None:
    first, second = tmp_path / "a.json", tmp_path / "b.json"
    assert run_cli(["run", "--seed", "2", "--set", "mission.drive.move_step_cm=25", "--json", str(first)]) == 0
    assert run_cli(["run", "--config", str(first), "--seed", "3", "--set", "mission.drive.move_step_cm=15",
                    "--json", str(second)]) == 0
    conf = json.loads(second.read_text())["configuration"]
    assert conf["options"]["seed"] == 3 and conf["mission"]["drive"]["move_step_cm"] == 15.0
    assert conf["set"] == ["mission.drive.move_step_cm=25", "mission.drive.move_step_cm=15"]
    assert json.loads(second.read_text())["seed"] == 3


def test_paper_tables_carry_the_configuration_and_run_again_from_it(tmp_path: Path) -> None:
    first, again = tmp_path / "t.json", tmp_path / "u.json"
    argv = ["paper", "--trials", "1", "--maps", "map1", "--noise-model", "botsim", "--seed", "7",
            "--set", "mission.sweeps.track_scan_step_deg=3"]
    assert run_cli([*argv, "--json", str(first)]) == 0
    (table,) = json.loads(first.read_text())
    conf = table["configuration"]
    assert conf["command"] == "paper" and conf["set"] == ["mission.sweeps.track_scan_step_deg=3"]
    assert conf["mission"]["ideal"]["sweeps"]["track_scan_step_deg"] == 3.0
    assert table["options"] == {"sweeps.track_scan_step_deg": 3}
    assert run_cli(["paper", "--config", str(first), "--json", str(again)]) == 0
    (same,) = json.loads(again.read_text())
    keep = ("map", "trials", "success_rate", "final_error_cm", "path_length_cm", "collisions", "robot_time_s")
    assert [{k: r[k] for k in keep} for r in same["rows"]] == [{k: r[k] for k in keep} for r in table["rows"]]
    assert same["configuration"] == conf


@pytest.mark.parametrize(("argv", "words"), [
    (["paper", "--option", "fix.rule=always"], "--set mission."),
    (["run", "--set", "mission.drive.speed=3"], "no option 'drive.speed'"),
    (["run", "--set", "mission.drive.move_step_cm=-1"], "drive.move_step_cm: -1"),
    (["paper", "--set", "amcl.min_particles=5"], "mission settings"),
])
def test_bad_settings_are_one_line(argv: list[str], words: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nxtnav: error:") and words in err[0], err


@pytest.mark.parametrize(("content", "words"), [
    ('{"x": 1}', "holds no run configuration"),
    ('{"configuration": {"command": "paper", "options": {}}}', "configures 'nxtnav paper', not 'nxtnav run'"),
    ('{"configuration": {"command": "run", "options": {"speed": 3}}}', "options of no 'nxtnav run': speed"),
    ('{"configuration": {"command": "run", "options": {}, "set": 3}}', "set must be a list"),
    ("[unclosed", "cannot read"),
])
def test_a_file_that_is_no_configuration_is_one_line(content: str, words: str, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "c.json"
    bad.write_text(content)
    assert run_cli(["run", "--config", str(bad), "--json", str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--config" in err[0] and words in err[0], err
    assert not (tmp_path / "out.json").exists()


def test_plan_and_the_localiser_benchmark_run_again_from_their_outputs(tmp_path: Path) -> None:
    first, again = tmp_path / "p.json", tmp_path / "q.json"
    assert run_cli(["plan", "--planner", "rrtstar", "--time-limit", "0.2", "--seed", "3", "--set", "rrtstar.range=20",
                    "--exec-repeats", "0", "-o", str(tmp_path / "p.png"), "--json", str(first)]) == 0
    assert run_cli(["plan", "--config", str(first), "-o", str(tmp_path / "q.png"), "--json", str(again)]) == 0
    a, b = json.loads(first.read_text()), json.loads(again.read_text())
    assert a["configuration"]["set"] == ["rrtstar.range=20"] and a["configuration"]["options"]["seed"] == 3
    assert b["configuration"] == a["configuration"] and b["path"] == a["path"]
    bench, bench_again = tmp_path / "b", tmp_path / "c"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf", "--trials", "1",
                    "--set", "n_particles=300", "--out", str(bench)]) == 0
    conf = json.loads((bench / "config.json").read_text())["configuration"]
    assert conf["command"] == "bench localisers" and conf["set"] == ["n_particles=300"]
    assert run_cli(["bench", "localisers", "--config", str(bench / "config.json"), "--out", str(bench_again)]) == 0
    columns = ("map", "localiser", "trial", "seed", "success", "error_cm", "heading_error_deg")

    def rows(folder: Path) -> list[tuple[str, ...]]:
        lines = [line.split(",") for line in (folder / "runs.csv").read_text().splitlines()]
        keep = [lines[0].index(c) for c in columns]
        return [tuple(line[i] for i in keep) for line in lines[1:]]

    assert rows(bench_again) == rows(bench) and len(rows(bench)) == 1


def test_a_hand_written_configuration_names_options_as_the_command_line_does(tmp_path: Path) -> None:
    conf, out = tmp_path / "mission.yaml", tmp_path / "m.json"
    conf.write_text("command: run\noptions:\n  map: map2\n  seed: 5\n  noise-model: absolute\n"
                    "set: [mission.fix.rule=always]\n")
    assert run_cli(["run", "--config", str(conf), "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert (doc["map"], doc["seed"]) == ("map2", 5)
    assert doc["configuration"]["options"]["noise-model"] == "absolute"
    assert doc["configuration"]["mission"]["fix"]["rule"] == "always"
