"""The OMPL benchmark log writer, read back by OMPL's own parser."""

from __future__ import annotations

import math
import sqlite3
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import pytest

from planners import PlanStatus
from toolkit.bench.ompl_log import (
    OMPL_STATUS,
    OmplExperiment,
    OmplPlannerData,
    format_ompl_log,
    ompl_status,
    write_ompl_log,
)

PROPS = [("time", "REAL"), ("solved", "BOOLEAN"), ("status", "ENUM"), ("solution length", "REAL"),
         ("solution turns", "INTEGER")]


def experiment(**kw: object) -> OmplExperiment:
    planners = [
        OmplPlannerData("min-turn", PROPS, [[0.002, True, 6, 120.5, 2], [0.003, False, 4, math.nan, None]],
                        {"points": 30}),
        OmplPlannerData("rrtstar", PROPS, [[1.0, True, 6, 118.25, 5]]),
    ]
    args: dict[str, object] = {"name": "map1 presets", "planners": planners, "time_limit_s": 1.0,
                               "total_time_s": 2.5, "seed": 7, "run_count": 2, "setup": "map1\nstart (20, 20)",
                               "properties": {"robot_radius_cm": ("REAL", 8.0)},
                               "date": datetime(2026, 1, 2, 3, 4, 5), "hostname": "lab pc"}
    args.update(kw)
    return OmplExperiment(**args)  # type: ignore[arg-type]


def test_format_follows_the_grammar() -> None:
    text = format_ompl_log(experiment())
    lines = text.splitlines()
    assert lines[0] == "nxtnav version 0.1.0"
    assert lines[1] == "Experiment map1_presets"  # one word: the parser keeps only the last one
    assert "Running on lab_pc" in lines
    assert "Starting at 2026-01-02 03:04:05" in lines
    assert "7 is the random seed" in lines and "1.0 seconds per run" in lines
    assert "2 runs per planner" in lines and "2.5 seconds spent to collect the data" in lines
    assert "1 enum types" in lines and lines[lines.index("1 enum types") + 1] == "status|" + "|".join(OMPL_STATUS)
    assert "0.002; 1; 6; 120.5; 2; " in lines
    assert "0.003; 0; 4; ; ; " in lines  # NaN and None are empty values
    assert lines.count(".") == 2 and text.endswith(".\n")


def test_ompl_parser_reads_it(tmp_path: Path) -> None:
    exe = Path(sys.executable).with_name("ompl_benchmark_statistics")
    assert exe.exists(), "ompl_benchmark_statistics (OMPL's wheel) is not installed next to this Python"
    log = write_ompl_log(tmp_path / "sub" / "b.log", experiment())
    db = tmp_path / "b.db"
    proc = subprocess.run([str(exe), str(log), "-d", str(db)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    con = sqlite3.connect(db)
    try:
        (name, timelimit, runcount, seed, host, radius), = con.execute(
            "SELECT name, timelimit, runcount, seed, hostname, robot_radius_cm FROM experiments").fetchall()
        assert (name, timelimit, runcount, seed, host, radius) == ("map1_presets", 1.0, 2, "7", "lab_pc", 8.0)
        rows = con.execute("SELECT p.name, r.time, r.solved, r.status, r.solution_length, r.solution_turns "
                           "FROM runs r JOIN plannerConfigs p ON p.id = r.plannerid ORDER BY r.id").fetchall()
        assert rows == [("min-turn", 0.002, 1, 6, 120.5, 2), ("min-turn", 0.003, 0, 4, None, None),
                        ("rrtstar", 1.0, 1, 6, 118.25, 5)]
        settings = con.execute("SELECT settings FROM plannerConfigs WHERE name = 'min-turn'").fetchone()[0]
        assert "points = 30" in settings
        labels = [d for (d,) in con.execute("SELECT description FROM enums WHERE name = 'status' ORDER BY value")]
        assert labels == list(OMPL_STATUS)
    finally:
        con.close()


PROGRESS = [("time", "REAL"), ("iterations", "INTEGER"), ("best cost", "REAL")]


def test_progress_properties_reach_the_progress_table(tmp_path: Path) -> None:
    samples = [[[0.01, 50, math.inf], [0.02, 80, 130.5], [0.03, 100, 121.25]], [], [[0.005, 9, 140.0]]]
    anytime = OmplPlannerData("rrtstar", PROPS, [[0.03, True, 6, 121.25, 4], [0.03, False, 4, math.nan, None],
                                                 [0.01, True, 6, 140.0, 2]], {}, PROGRESS, samples)
    text = format_ompl_log(experiment(planners=[anytime], run_count=3))
    lines = text.splitlines()
    at = lines.index("3 progress properties for each run")
    assert lines[at + 1:at + 5] == ["time REAL", "iterations INTEGER", "best cost REAL", "3 runs"]
    assert lines[at + 5] == "0.01,50,,;0.02,80,130.5,;0.03,100,121.25,;"  # inf (no solution yet): empty
    assert lines[at + 6] == "" and lines[at + 7] == "0.005,9,140.0,;" and lines[at + 8] == "."
    log = write_ompl_log(tmp_path / "p.log", experiment(planners=[anytime], run_count=3))
    db = tmp_path / "p.db"
    exe = Path(sys.executable).with_name("ompl_benchmark_statistics")
    proc = subprocess.run([str(exe), str(log), "-d", str(db)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    con = sqlite3.connect(db)
    try:
        rows = con.execute("SELECT r.solution_length, p.time, p.iterations, p.best_cost FROM progress p "
                           "JOIN runs r ON r.id = p.runid ORDER BY r.id, p.time").fetchall()
    finally:
        con.close()
    assert rows == [(121.25, 0.01, 50, None), (121.25, 0.02, 80, 130.5), (121.25, 0.03, 100, 121.25),
                    (140.0, 0.005, 9, 140.0)]


@pytest.mark.parametrize(
    "bad",
    [
        lambda: OmplPlannerData("p", PROPS, [], {}, [("iterations", "INTEGER")], []),  # no time
        lambda: OmplPlannerData("p", PROPS, [[1.0, True, 6, 1.0, 0]], {}, PROGRESS, []),  # runs without samples
        lambda: OmplPlannerData("p", PROPS, [[1.0, True, 6, 1.0, 0]], {}, PROGRESS, [[[0.1, 2]]]),  # short sample
        lambda: OmplPlannerData("p", PROPS, [[1.0, True, 6, 1.0, 0]], {}, [("time", "ENUM")], [[[0.1]]]),
        lambda: OmplPlannerData("p", PROPS, [[1.0, True, 6, 1.0, 0]], {}, (), [[[0.1]]]),  # samples, no properties
        lambda: format_ompl_log(experiment(planners=[
            OmplPlannerData("p", PROPS, [[1.0, True, 6, 1.0, 0]], {}, [("time", "REAL"), ("note", "REAL")],
                            [[[0.1, "a,b"]]])])),
    ],
)
def test_rejects_progress_the_parser_would_misread(bad: object) -> None:
    with pytest.raises(ValueError):
        bad()  # type: ignore[operator]


def test_status_mapping() -> None:
    assert OMPL_STATUS[ompl_status(True, PlanStatus.EXACT)] == "Exact solution"
    assert OMPL_STATUS[ompl_status(False, PlanStatus.TIMEOUT)] == "Timeout"
    assert OMPL_STATUS[ompl_status(False, PlanStatus.START_IN_COLLISION)] == "Invalid start"
    assert OMPL_STATUS[ompl_status(False, PlanStatus.GOAL_IN_COLLISION)] == "Invalid goal"
    assert OMPL_STATUS[ompl_status(False, PlanStatus.ERROR)] == "Crash"
    assert OMPL_STATUS[ompl_status(False, "something else")] == "Unknown status"


@pytest.mark.parametrize(
    "bad",
    [
        lambda: OmplPlannerData("p", [("time-s", "REAL")], []),
        lambda: OmplPlannerData("p", [("time", "FLOAT")], []),
        lambda: OmplPlannerData("p", [("time", "REAL")], [[1.0, 2.0]]),
        lambda: OmplPlannerData("two\nlines", [], []),
        lambda: format_ompl_log(experiment(properties={"bad name": ("REAL", 1.0)})),
        lambda: format_ompl_log(experiment(enums={"map": ["a|b"]})),
        lambda: format_ompl_log(experiment(planners=[OmplPlannerData("p", [("s", "INTEGER")], [["1; 2"]])])),
    ],
)
def test_rejects_what_the_parser_would_misread(bad: object) -> None:
    with pytest.raises(ValueError):
        bad()  # type: ignore[operator]
