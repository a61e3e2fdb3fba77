"""``--set robot.GROUP.FIELD=V`` and ``--set sonar.FIELD=V``: the robot model through the one override syntax.

The user's path: a run with a faster robot takes less robot time, its configuration holds the robot
model, ``--config`` of its output runs the same mission again; a bad value, an unknown field, or a
shorthand flag with a ``--set`` of the same field is one line and exit 2; a profile file with a bad field
names the file, the field and the value.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from conftest import fails_cleanly, run_cli

from toolkit.robots.nxt_profile import NxtProfile, ProfileError
from toolkit.world import RobotModel
from toolkit.world.robot_model import with_robot_sets
from toolkit.world.typed import build


def _run(tmp_path: Path, name: str, *args: str) -> dict[str, Any]:
    out = tmp_path / f"{name}.json"
    assert run_cli(["run", "--map", "map1", "--seed", "1", *args, "--json", str(out)]) == 0
    return dict(json.loads(out.read_text()))


def test_a_faster_robot_takes_less_robot_time_and_runs_again_from_its_configuration(tmp_path: Path) -> None:
    base = _run(tmp_path, "base")
    fast = _run(tmp_path, "fast", "--set", "robot.timing.drive_speed_cm_s=30")
    # the same mission (the timing changes no draw), the drives in half the time
    assert fast["path_length_cm"] == base["path_length_cm"]
    assert fast["robot_time_split"]["drive_s"] == pytest.approx(base["robot_time_split"]["drive_s"] / 2)
    assert fast["robot_time_s"] < base["robot_time_s"]
    robot = fast["configuration"]["robot"]
    assert robot["timing"]["drive_speed_cm_s"] == 30.0 and base["configuration"]["robot"]["timing"][
        "drive_speed_cm_s"] == 15.0
    assert build(RobotModel, robot).timing.drive_speed_cm_s == 30.0  # the written model reads back
    again = tmp_path / "again.json"
    assert run_cli(["run", "--config", str(tmp_path / "fast.json"), "--json", str(again)]) == 0
    redo = json.loads(again.read_text())
    assert redo["robot_time_s"] == fast["robot_time_s"] and redo["configuration"] == fast["configuration"]


def test_a_sonar_setting_reaches_the_simulated_sonar(tmp_path: Path) -> None:
    doc = _run(tmp_path, "noisy", "--set", "sonar.noise_sd=2.5")
    assert doc["configuration"]["robot"]["sonar"] == {"name": "ideal", "noise_sd": 2.5}


@pytest.mark.parametrize(("argv", "words"), [
    (["--set", "robot.timing.drive_speed_cm_s=-5"],
     ["robot.timing.drive_speed_cm_s", "-5", "out of its range (0, inf)"]),
    (["--set", "robot.timing.drive_speed_cm_s=fast"], ["robot.timing.drive_speed_cm_s", "'fast'", "number"]),
    (["--set", "robot.timing.speed=3"], ["robot.timing.speed", "drive_speed_cm_s"]),
    (["--set", "sonar.beam_width_deg=20"], ["sonar.beam_width_deg", "noise_sd"]),
    (["--sonar", "nxt", "--set", "sonar.short_prob=0.9", "--set", "sonar.outlier_prob=0.5"],
     ["short_prob + outlier_prob", "1.4"]),
    (["--radius", "7", "--set", "robot.geometry.radius_cm=6"], ["--radius", "robot.geometry.radius_cm"]),
    (["--noise", "1,0.1,0.005", "--set", "sonar.noise_sd=2"], ["--noise", "sonar.noise_sd"]),
])
def test_a_bad_robot_setting_is_one_line(argv: list[str], words: list[str], tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.json"
    assert run_cli(["run", "--map", "map1", *argv, "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("nxtnav: error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert all(w in err for w in words), err
    assert not out.exists()


def test_paper_and_plan_take_the_same_settings(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    paper = tmp_path / "p.json"
    assert run_cli(["paper", "--trials", "1", "--maps", "map1", "--noise-model", "botsim",
                    "--set", "robot.timing.turn_rate_deg_s=45", "--json", str(paper)]) == 0
    table = json.loads(paper.read_text())[0]
    assert table["configuration"]["robot"]["ideal/botsim"]["timing"]["turn_rate_deg_s"] == 45.0
    assert run_cli(["plan", "-o", str(tmp_path / "p.png"), "--turn-rate", "60",
                    "--set", "robot.timing.turn_rate_deg_s=30"]) == 2
    assert "--turn-rate" in capsys.readouterr().err


def test_settings_apply_to_the_held_sonar_and_name_the_key() -> None:
    from toolkit.world import NxtSonar

    robot = with_robot_sets(RobotModel(NxtSonar()), {"sonar.beam_width_deg": "20", "robot.motion.turn": "0.01"})
    assert isinstance(robot.sonar, NxtSonar) and robot.sonar.beam_width_deg == 20.0 and robot.motion.turn == 0.01
    with pytest.raises(ValueError, match=r"robot\.sonar\.beam_rays must be a whole number, got 2\.5"):
        with_robot_sets(robot, {"robot.sonar.beam_rays": "2.5"})


def test_a_profile_file_with_a_bad_field_names_file_field_and_value(tmp_path: Path) -> None:
    path = tmp_path / "robot.yaml"
    path.write_text("drive_power: 150\nleft_port: A\n")
    with pytest.raises(ProfileError) as err:
        NxtProfile.load(path)
    assert str(err.value) == f"{path}: drive_power: 150 is out of its range [1, 100]"
    path.write_text("track_width_cm: wide\n")
    with pytest.raises(ProfileError, match=r"track_width_cm must be a number, got 'wide'"):
        NxtProfile.load(path)


def test_a_sonar_profile_with_a_bad_field_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "p.yaml"
    bad.write_text("kind: nxtnav-sonar-profile\nparams:\n  beam_width_deg: 200\n")
    assert run_cli(["scan", "--pose", "50,30,0", "--sonar", "nxt", "--sonar-profile", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(bad) in err and "params.beam_width_deg: 200" in err


@pytest.mark.parametrize("command", [
    ["plan", "--map", "map1", "-o", "OUT"],
    ["localise", "--map", "map1", "--pose", "20,20,0", "--json", "OUT"],
    ["bench", "localisers", "--maps", "map1", "--trials", "1", "--out", "OUT"],
])
def test_a_section_the_command_does_not_take_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                        command: list[str]) -> None:
    """``--set mission.KEY`` on a command without a mission (it took it and ignored it): one line naming the
    key and the sections the command takes, exit 2, nothing written."""
    out = tmp_path / "out"
    argv = [str(out) if a == "OUT" else a for a in command] + ["--set", "mission.drive.move_step_cm=20"]
    err = fails_cleanly(argv, capsys, "--set mission.drive.move_step_cm:", "takes no mission settings",
                        "robot., sonar.")
    assert f"nxtnav {' '.join(a for a in command[:2] if not a.startswith('-'))} takes" in err
    assert not out.exists()
