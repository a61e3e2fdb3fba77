"""The Table I runner's bookkeeping: task seeds, aggregation and the Markdown/JSON forms."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from toolkit.bench.paper import (
    PAPER_TABLE,
    PaperResult,
    PaperTrial,
    paper_tasks,
    summarise,
    tables_to_markdown,
)
from toolkit.seeds import derive_seed


def test_tasks_cover_every_model_stack_map_and_trial() -> None:
    tasks = paper_tasks(4, seed=9, stacks=[("min-turn", "paper-pf"), ("astar", "paper-pf")])
    assert len(tasks) == 2 * 2 * 3 * 4
    keys = {(t.noise_model, t.stack, t.map, t.trial) for t in tasks}
    assert len(keys) == len(tasks)
    # common random numbers: the same trial has the same seed under every noise model and stack
    by = {(t.noise_model, t.stack, t.map, t.trial): t.seed for t in tasks}
    assert by[("botsim", "min-turn/paper-pf", "map2", 3)] == by[("absolute", "astar/paper-pf", "map2", 3)]
    assert len({t.seed for t in tasks}) == 3 * 4  # distinct across maps and trials
    assert derive_seed(9, 1, 3) == by[("botsim", "min-turn/paper-pf", "map2", 3)]
    with pytest.raises(ValueError):
        paper_tasks(0)


def _result(task: PaperTrial, ok: bool, err: float, t: float, coll: int = 0) -> PaperResult:
    return PaperResult(task, ok, "reached target" if ok else "robot lost", t, err, 100.0 + err, coll, 50.0, 0, 3, 0)


def test_summarise_means_totals_and_order() -> None:
    tasks = paper_tasks(3, seed=1, maps=("map3", "map1"))
    rng = np.random.default_rng(0)
    results = []
    expected: dict[tuple[str, str], list[float]] = {}
    times: dict[tuple[str, str], list[float]] = {}
    for i, task in enumerate(tasks):
        err = float(rng.uniform(0, 2))
        ok = i % 5 != 0
        t = 0.1 * (i + 1) + (5.0 if task.trial == 0 else 0.0)  # a slow first trial (table precomputation)
        results.append(_result(task, ok, err, t, coll=1 if i == 4 else 0))
        expected.setdefault((task.noise_model, task.map), []).append(err)
        times.setdefault((task.noise_model, task.map), []).append(t)
    rng.shuffle(results)  # results arrive in any order
    tables = summarise(results)
    assert [t.noise_model for t in tables] == ["botsim", "absolute"]
    for table in tables:
        assert [r.map for r in table.rows] == ["map1", "map3"]  # the paper's order
        for row in table.rows:
            errs = expected[(table.noise_model, row.map)]
            assert row.trials == 3
            assert row.final_error_cm == pytest.approx(np.mean(errs))
            assert row.path_length_cm == pytest.approx(100.0 + np.mean(errs))
            assert row.final_error_max_cm == pytest.approx(max(errs))
            ts = times[(table.noise_model, row.map)]
            assert row.completion_s == pytest.approx(np.mean(ts))
            assert row.completion_median_s == pytest.approx(np.median(ts)) and row.completion_median_s < 5.0
            assert len(row.failures) == round(3 * (1 - row.success_rate))
    assert sum(r.collisions for t in tables for r in t.rows) == 1
    doc = json.loads(json.dumps([t.to_dict() for t in tables]))
    assert doc[0]["rows"][0]["paper"] == PAPER_TABLE["map1"]
    md = tables_to_markdown(tables)
    assert md.count("| map1 |") == 2 and "(1.79)" in md and "(276.2)" in md


def test_nan_results_do_not_poison_means() -> None:
    task = paper_tasks(2, maps=("map1",), noise_models=("botsim",))
    crashed = PaperResult(task[0], False, "crashed: RuntimeError: x", math.nan, math.nan, math.nan, 0, math.nan,
                          0, 0, 0)
    table = summarise([crashed, _result(task[1], True, 0.5, 0.2)])[0]
    row = table.rows[0]
    assert row.success_rate == 0.5 and row.final_error_cm == 0.5 and row.completion_s == pytest.approx(0.2)


def test_rows_carry_the_median_robot_time_and_the_mean_split() -> None:
    from toolkit.mission import RobotTimeSplit

    tasks = paper_tasks(3, maps=("map2",), noise_models=("botsim",))
    times = [30.0, 90.0, 40.0]
    results = [PaperResult(t, True, "reached target", 0.1, 0.3, 100.0, 0, rt, 0, 2, 0,
                           RobotTimeSplit(0.6 * rt, 0.2 * rt, 0.1 * rt, 0.1 * rt, int(10 * rt)))
               for t, rt in zip(tasks, times, strict=True)]
    row = summarise(results)[0].rows[0]
    assert row.robot_time_s == pytest.approx(np.mean(times))
    assert row.robot_time_median_s == pytest.approx(40.0)
    assert row.time_split is not None
    assert row.time_split.sweep_s == pytest.approx(0.6 * np.mean(times))
    assert row.time_split.readings == round(10 * np.mean(times))
    doc = json.loads(json.dumps(summarise(results)[0].to_dict()))
    assert doc["rows"][0]["robot_time_median_s"] == pytest.approx(40.0)
    assert doc["rows"][0]["robot_time_split"]["turn_s"] == pytest.approx(0.1 * np.mean(times))
    md = tables_to_markdown(summarise(results))
    assert "| 40.0 |" in md and "Sweeping / turret back / driving / turning" in md


def test_options_make_their_own_tables() -> None:
    plain = paper_tasks(1, maps=("map1",), noise_models=("botsim",))
    always = paper_tasks(1, maps=("map1",), noise_models=("botsim",), options={"fix.rule": "always"})
    assert always[0].config().fix.rule == "always" and plain[0].config().fix.rule == "spread"
    assert always[0].seed == plain[0].seed  # common random numbers across settings
    tables = summarise([_result(plain[0], True, 0.3, 0.1), _result(always[0], True, 0.2, 0.1)])
    assert len(tables) == 2
    assert "`fix.rule=always`" in tables_to_markdown(tables)
    with pytest.raises(ValueError, match=r"fix\.rule"):
        paper_tasks(1, options={"fix.rule": "never"})
    with pytest.raises(ValueError, match="'fix_rule'"):  # an unknown key is named
        paper_tasks(1, options={"fix_rule": "always"})


def test_pareto_front_and_points() -> None:
    from toolkit.bench.paper_pareto import MISSION_SETTINGS, pareto_front, pareto_points, pareto_tasks

    assert pareto_front([(10.0, 1.0), (20.0, 0.5), (30.0, 0.5), (5.0, 2.0), (float("nan"), 0.1)]) == [
        True, True, False, True, False]
    tasks = pareto_tasks(2, settings=("paper-habit", "default", "lean"), sonars=("ideal",), maps=("map1",))
    assert len(tasks) == 3 * 2
    by = {(t.options, t.trial): t for t in tasks}
    assert by[(tuple(sorted(MISSION_SETTINGS["lean"].items())), 1)].seed == by[((), 1)].seed
    cost = {"paper-habit": (200.0, 0.30), "default": (50.0, 0.35), "lean": (40.0, 0.60)}
    results = []
    for t in tasks:
        name = next(k for k, v in MISSION_SETTINGS.items() if tuple(sorted(v.items())) == t.options)
        rt, err = cost[name]
        coll = 1 if name == "lean" and t.trial == 0 else 0  # a setting that collides is no choice
        results.append(PaperResult(t, True, "reached target", 0.2, err, 100.0, coll, rt, 0, 2, 0))
    points = {p.setting: p for p in pareto_points(results)}
    assert points["default"].on_front and points["paper-habit"].on_front
    assert not points["lean"].on_front and points["lean"].collisions == 1
    assert points["default"].robot_time_median_s == pytest.approx(50.0)
    with pytest.raises(ValueError, match="unknown mission setting"):
        pareto_tasks(1, settings=("nope",))


def test_rows_carry_the_median_cpu_time_per_mission() -> None:
    tasks = paper_tasks(3, maps=("map1",), noise_models=("botsim",))
    cpus = [0.4, 2.5, 0.3]  # the slow one: the worker's first mission (range table precomputation)
    results = [replace(_result(t, True, 0.3, 1.0), cpu_s=c) for t, c in zip(tasks, cpus, strict=True)]
    row = summarise(results)[0].rows[0]
    assert row.cpu_median_s == pytest.approx(0.4)
    doc = json.loads(json.dumps(summarise(results)[0].to_dict()))
    assert doc["rows"][0]["cpu_median_s"] == pytest.approx(0.4)
    md = tables_to_markdown(summarise(results))
    assert "Median CPU (s)" in md and "| 0.400 |" in md
