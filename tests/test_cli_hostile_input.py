"""Hostile input to the command line: every bad value is one line naming the option (or file, field),
exit code 2, found before any work; pictures are optional; ambiguous beliefs are said as such."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
from conftest import fails_cleanly, run_cli

from localisation.models import clear_range_table_cache, range_table
from toolkit.bench.executors import TasksInterrupted, collect_tasks
from toolkit.world import MapError, load_map, map_from_dict

POINT_SYMMETRIC = """name: twins
boundary: [[0, 0], [80, 0], [80, 20], [120, 20], [120, 60], [40, 60], [40, 40], [0, 40]]
"""
"""A room that looks the same from (x, y, h) and from (120 - x, 60 - y, h + 180 deg)."""


@pytest.mark.parametrize(("argv", "option"), [
    (["brick", "serve", "--port", "70000"], "--port"),
    (["brick", "serve", "--port", "-1"], "--port"),
    (["run", "--robot", "nxt", "--nxt-backend", "socket", "--server-port", "70000"], "--server-port"),
    (["nxt", "check", "--nxt-backend", "socket", "--server-port", "-1"], "--server-port"),
    (["nxt", "calibrate", "--nxt-backend", "socket", "--server-port", "0"], "--server-port"),
])
def test_ports_outside_their_range_are_refused(argv: list[str], option: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(argv, capsys, option, "TCP port")


@pytest.mark.parametrize(("argv", "option"), [
    (["bench", "world", "--repeats", "-1"], "--repeats"),
    (["bench", "world", "--poses", "0"], "--poses"),
    (["bench", "world", "--segments", "0"], "--segments"),
    (["bench", "world", "--poses", "100000000"], "--poses"),
    (["maps", "show", "map1", "--radius", "-5", "-o", "x.png"], "--radius"),
    (["scan", "--pose", "20,20,0", "--sensor-noise", "-1"], "--sensor-noise"),
    (["scan", "--pose", "20,20,0", "--sensor-noise", "nan"], "--sensor-noise"),
    (["brick", "serve", "--sensor-noise", "-1"], "--sensor-noise"),
    (["brick", "serve", "--time-factor", "0"], "--time-factor"),
    (["brick", "serve", "--wheel-diameter", "inf"], "--wheel-diameter"),
    (["run", "--seed", "-1"], "--seed"),
    (["plan", "--seed", "-1", "-o", "x.png"], "--seed"),
    (["plan", "--radius", "-0.5", "-o", "x.png"], "--radius"),
    (["plan", "--time-limit", "nan", "-o", "x.png"], "--time-limit"),
    (["plan", "--turn-noise", "-0.1", "-o", "x.png"], "--turn-noise"),
    (["paper", "--trials", "0"], "--trials"),
    (["paper", "--workers", "0"], "--workers"),
    (["bench", "localisers", "--trials", "0", "--out", "o"], "--trials"),
    (["bench", "localisers", "--tracking-steps", "0", "--out", "o"], "--tracking-steps"),
    (["bench", "planners", "--runs", "-3", "--out", "o"], "--runs"),
    (["bench", "planners", "--exec-repeats", "-1", "--out", "o"], "--exec-repeats"),
    (["localise", "--pose", "20,20,0", "--seed", "-5"], "--seed"),
    (["brick", "serve", "--reassembly-window", "0"], "--reassembly-window"),
    (["run", "--reconnect-timeout", "-1"], "--reconnect-timeout"),
    (["run", "--reply-timeout", "0"], "--reply-timeout"),
    (["bench", "faults", "--missions", "0"], "--missions"),
    (["bench", "faults", "--workers", "0"], "--workers"),
    (["bench", "faults", "--reconnect-timeout", "nan"], "--reconnect-timeout"),
])
def test_numbers_out_of_range_name_their_option(argv: list[str], option: str, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    fails_cleanly(argv, capsys, option)
    assert not any(tmp_path.iterdir())  # nothing was written


@pytest.mark.parametrize(("value", "needle"), [
    ("0:0:72", "STEP must be a number of degrees > 0"),
    ("0:-5:72", "STEP must be a number of degrees > 0"),
    ("0:nan:72", "STEP must be"),
    ("0:5:0", "COUNT must be a whole number from 1"),
    ("0:5:-3", "COUNT must be a whole number from 1"),
    ("0:5:2.5", "COUNT must be a whole number"),
    ("0:5:1e12", "COUNT must be a whole number from 1 to 100000"),
    ("inf:5:72", "START must be a finite angle"),
    ("north:5:72", "expected START:STEP:COUNT"),
    ("0:five:72", "expected START:STEP:COUNT"),
    ("0:5", "expected START:STEP:COUNT"),
    ("0:5:72:1", "expected START:STEP:COUNT"),
    ("", "expected START:STEP:COUNT"),
    ("0,5,72", "expected START:STEP:COUNT"),
])
def test_scan_angles_are_checked(value: str, needle: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    fails_cleanly(["scan", "--pose", "20,20,0", "--angles", value, "--json", "s.json", "-o", "s.png"], capsys,
                   "--angles", needle)
    assert not any(tmp_path.iterdir())  # refused before any work


@pytest.mark.parametrize(("argv", "needles"), [
    (["brick", "serve", "--port", "0", "--fault", "meteor:1:2"], ("--fault", "unknown kind 'meteor'")),
    (["brick", "serve", "--port", "0", "--fault", "drop-link:x:3"], ("--fault", "AT_S must be a number, got 'x'")),
    (["brick", "serve", "--port", "0", "--fault", "stall:5"], ("--fault", "expected stall:AT_S:DUR_S")),
    (["brick", "serve", "--port", "0", "--fault", "sonar-garbage:2"], ("--fault", "P must be a probability")),
    (["bench", "faults", "--faults", "drop-link,meteor"], ("--faults", "unknown meteor")),
    (["bench", "faults", "--maps", "nomap"], ("nomap",)),
])
def test_fault_options_are_checked_before_any_work(argv: list[str], needles: tuple[str, ...], tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    fails_cleanly(argv, capsys, *needles)
    assert not any(tmp_path.iterdir())


def test_scan_direction_is_cw_or_ccw(capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(["scan", "--pose", "20,20,0", "--angles", "0:1:360", "--direction", "clockwise"], capsys,
                   "--direction", "cw or ccw", "'clockwise'")


@pytest.mark.parametrize(("value", "needle"), [
    ("n_particles=abc", "expected an integer, got 'abc'"),
    ("n_particles=100.5", "expected an integer, got 100.5"),
    ("sensor.sensor_sigma_cm=wide", "expected a finite number"),
    ("ranges.use_table=maybe", "expected true or false"),
    ("n_particles=5", "out of its range [10, inf)"),
])
def test_set_values_are_checked_against_the_declarations(value: str, needle: str, tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b"
    fails_cleanly(["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf", "--trials", "1",
                    "--set", f"paper-pf.{value}", "--out", str(out)], capsys, needle)
    assert not out.exists()  # refused before any trial ran


def test_localise_set_is_typed_too(capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(["localise", "--pose", "20,20,0", "--set", "n_particles=abc"], capsys,
                   "--set paper-pf.n_particles")


@pytest.mark.parametrize(("value", "needle"), [
    ("model=sonar", "--set amcl.model: 'sonar' is not one of auto, beam, field, nxt-beam"),
    ("model=nxt-beam", "amcl: the NXT beam model needs a sonar_model"),
])
def test_an_amcl_model_is_a_registered_one_that_fits_the_sonar(value: str, needle: str,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(["localise", "--pose", "20,20,0", "--localiser", "amcl", "--set", value], capsys, needle)


def test_an_integer_where_a_float_is_annotated_is_accepted(tmp_path: Path) -> None:
    js = tmp_path / "l.json"
    assert run_cli(["localise", "--pose", "20,20,0", "--set", "sensor.sensor_sigma_cm=2", "--json", str(js)]) == 0
    assert json.loads(js.read_text())["localiser"] == "paper-pf"


def test_coordinates_are_bounded(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(MapError, match=r"boundary vertex 1\[0\]: coordinate 1e\+300 is outside"):
        map_from_dict({"boundary": [[0, 0], [1e300, 0], [1e300, 1e300], [0, 1e300]]})
    with pytest.raises(MapError, match="outside the supported range"):
        map_from_dict({"boundary": [[0, 0], [10, 0], [10, 10]], "start": [2e6, 1]})
    big = tmp_path / "big.yaml"
    big.write_text("boundary: [[0, 0], [1.0e+200, 0], [1.0e+200, 10], [0, 10]]\n")
    fails_cleanly(["maps", "show", str(big), "-o", str(tmp_path / "m.png")], capsys, "big.yaml", "boundary")
    fails_cleanly(["plan", "--start", "1e300,5", "-o", str(tmp_path / "p.png")], capsys, "--start", "within")


def test_a_bad_thin_wall_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    room = tmp_path / "stub.yaml"
    room.write_text("boundary: [[0, 0], [100, 0], [100, 60], [0, 60]]\n"
                    "walls: [[[50, 0], [50, 30]], [[20, 20], [20, 20]]]\n")
    fails_cleanly(["maps", "show", str(room), "-o", str(tmp_path / "m.png")], capsys, "stub.yaml",
                   "wall 1 vertex 1: zero-length segment")
    room.write_text("boundary: [[0, 0], [100, 0], [100, 60], [0, 60]]\nwalls: [[[50, 0], [50, 80]]]\n")
    fails_cleanly(["plan", "--map", str(room), "--start", "20,20", "--goal", "80,20", "-o", str(tmp_path / "p.png")],
                   capsys, "stub.yaml", "wall 0 vertex 1: [50.0, 80.0] is outside the free space")
    room.write_text("boundary: [[0, 0], [100, 0], [100, 60], [0, 60]]\nwalls: [[[50, 0], [50, .nan]]]\n")
    fails_cleanly(["scan", "--map", str(room), "--pose", "20,20,0"], capsys, "stub.yaml", "wall 0 vertex 1[1]",
                   "finite")
    assert not any(p.suffix == ".png" for p in tmp_path.iterdir())


def test_a_range_model_too_large_for_memory_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    huge = tmp_path / "huge.yaml"
    huge.write_text("name: huge\nboundary: [[0, 0], [900000, 0], [900000, 900000], [0, 900000]]\n")
    # the bounded range model refuses it up front, naming the budget and the option that raises it
    fails_cleanly(["localise", "--map", str(huge), "--pose", "50,50,0"], capsys, "huge", "budget",
                   "--range-memory-mb")
    # the mission builds its localiser on the way: still bad input (2), not a failed mission (1)
    fails_cleanly(["run", "--map", str(huge), "--start", "50,50", "--target", "100,100"], capsys, "huge",
                   "budget")


def test_memory_exhausted_anywhere_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    import toolkit.cli.plan_cmds as plan_cmds

    def exhausted(name: str) -> None:
        raise MemoryError("Unable to allocate 5.89 TiB for an array")

    monkeypatch.setattr(plan_cmds, "load_map", exhausted)
    fails_cleanly(["plan", "--exec-repeats", "0", "-o", "p.png"], capsys, "out of memory", "5.89 TiB")


@pytest.mark.parametrize("option", ["--json", "--plot"])
def test_unwritable_outputs_fail_before_the_run(option: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    target = blocker / "out.json"  # a folder that cannot be made: a file is in its place
    assert run_cli(["run", "--map", "map3", option, str(target)]) == 2
    captured = capsys.readouterr()
    assert "SUCCESS" not in captured.out and "FAILED" not in captured.out  # no mission ran
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and option in lines[0] and str(blocker) in lines[0]


def test_an_output_that_is_a_folder_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(["plan", "-o", str(tmp_path)], capsys, "--output", "is a folder")


def test_localise_and_scan_print_without_a_picture(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert run_cli(["localise", "--pose", "20,20,0"]) == 0
    assert "paper-pf: error" in capsys.readouterr().out
    assert run_cli(["scan", "--pose", "20,20,0"]) == 0
    assert "readings with an echo" in capsys.readouterr().out
    assert not any(tmp_path.iterdir())


def test_an_ambiguous_localisation_names_its_candidates(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    room = tmp_path / "twins.yaml"
    room.write_text(POINT_SYMMETRIC)
    js = tmp_path / "l.json"
    assert run_cli(["localise", "--map", str(room), "--pose", "20,15,30", "--seed", "0", "--json", str(js)]) == 0
    out = capsys.readouterr().out
    doc = json.loads(js.read_text())
    assert doc["converged"] is False and doc["ambiguous"] is True and len(doc["candidates"]) == 2
    assert "ambiguous: 2 candidate poses" in out
    a, b = np.array(doc["candidates"])
    assert np.allclose(a[:2] + b[:2], [120.0, 60.0], atol=3.0)  # the twins: mirror images through the centre
    assert abs(abs((a[2] - b[2] + 180.0) % 360.0 - 180.0) - 180.0) < 5.0


def test_a_mission_report_says_whether_it_was_ambiguous(tmp_path: Path) -> None:
    js = tmp_path / "m.json"
    run_cli(["run", "--json", str(js)])
    doc = json.loads(js.read_text())
    assert doc["ambiguous"] is False and doc["candidates"] == []


def test_a_range_table_cache_of_the_wrong_shape_is_rebuilt(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    m = load_map("map1")
    clear_range_table_cache()
    good = range_table(m, 2.0, 36, cache_dir=tmp_path)
    files = list(tmp_path.glob("*.npy"))
    assert len(files) == 1
    np.save(files[0], np.zeros((7, 5), dtype=np.float32))  # another grid's table under this name
    clear_range_table_cache()
    with caplog.at_level(logging.WARNING, logger="localisation.models"):
        again = range_table(m, 2.0, 36, cache_dir=tmp_path)
    assert np.array_equal(again.ranges, good.ranges)
    assert any(str(files[0]) in r.getMessage() and "rebuilding" in r.getMessage() for r in caplog.records)
    assert np.load(files[0]).shape == good.ranges.shape  # the cache holds the right table again
    clear_range_table_cache()


def _count_until_interrupt(i: int) -> int:
    if i == 3:
        raise KeyboardInterrupt
    return i * i


def test_collect_tasks_keeps_what_finished_before_ctrl_c() -> None:
    with pytest.raises(TasksInterrupted) as info:
        collect_tasks(_count_until_interrupt, list(range(6)))
    assert info.value.results == [0, 1, 4] and info.value.total == 6
    assert isinstance(info.value, KeyboardInterrupt)  # callers that do not care see a plain Ctrl-C


def _interrupt_after(n: int, func: object) -> object:
    """`func`, but Ctrl-C arrives while its call number `n` runs."""
    calls = [0]

    def wrapped(task: object) -> object:
        calls[0] += 1
        if calls[0] == n:
            raise KeyboardInterrupt
        return func(task)  # type: ignore[operator]

    return wrapped


def test_an_interrupted_planner_benchmark_writes_its_finished_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    import toolkit.bench.planners.runner as bp

    monkeypatch.setattr(bp, "run_task", _interrupt_after(4, bp.run_task))
    out = tmp_path / "b"
    assert run_cli(["bench", "planners", "--maps", "map1", "--planners", "min-turn,astar", "--runs", "3",
                    "--exec-repeats", "0", "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("nxtnav: interrupted: 3 planner runs done") and str(out) in err
    config = json.loads((out / "config.json").read_text())
    assert config["complete"] is False and config["runs_done"] == 3 and config["runs_planned"] == 6
    assert (out / "summary.md").read_text().startswith("**INCOMPLETE**")
    assert len((out / "runs.csv").read_text().strip().splitlines()) == 1 + 3


def test_an_interrupted_localiser_benchmark_writes_its_finished_trials(tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    import toolkit.bench.localisers as bl

    monkeypatch.setattr(bl, "run_trial", _interrupt_after(3, bl.run_trial))
    out = tmp_path / "b"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf", "--trials", "4",
                    "--out", str(out)]) == 130
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("nxtnav: interrupted: 2 of 4 trials done") and str(out) in err
    config = json.loads((out / "config.json").read_text())
    assert config["complete"] is False and config["trials_done"] == 2
    assert (out / "summary.md").read_text().startswith("**INCOMPLETE**")
    assert len((out / "runs.csv").read_text().strip().splitlines()) == 1 + 2


def test_a_preset_the_robot_does_not_fit_on_is_bad_input(capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(["plan", "--radius", "1000", "--exec-repeats", "0", "-o", "p.png"], capsys,
                   "--start (the map's preset)", "radius 1000")


def test_a_bug_is_not_passed_off_as_bad_input(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # a ValueError nxtnav did not raise on purpose is a bug: it keeps its traceback instead of exit 2
    import toolkit.cli.world_cmds as world_cmds

    def broken(*args: object, **kwargs: object) -> None:
        raise ValueError("an internal slip")

    monkeypatch.setattr(world_cmds, "load_map", broken)
    with pytest.raises(ValueError, match="an internal slip"):
        run_cli(["maps", "show", "map1", "-o", str(tmp_path / "m.png")])


def test_a_bad_option_value_is_a_config_error_with_exit_2(capsys: pytest.CaptureFixture[str]) -> None:
    from toolkit.mission import MissionConfig
    from toolkit.world import ConfigError, NxtnavError

    with pytest.raises(ConfigError) as err:
        MissionConfig().with_options(**{"planning.time_s": -1.0})
    assert isinstance(err.value, NxtnavError) and isinstance(err.value, ValueError)
    fails_cleanly(["localise", "--pose", "20,20,0", "--set", "n_particles=5"], capsys, "n_particles", "5")
