"""The Table I runner's bookkeeping: task seeds, aggregation and the Markdown/JSON forms."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from toolkit.bench.paper import (
    PAPER_TABLE,
    PaperTrial,
    TrialResult,
    paper_tasks,
    summarise,
    tables_to_markdown,
    trial_seed,
)


def test_tasks_cover_every_model_stack_map_and_trial() -> None:
    tasks = paper_tasks(4, seed=9, stacks=[("min-turn", "paper-pf"), ("astar", "paper-pf")])
    assert len(tasks) == 2 * 2 * 3 * 4
    keys = {(t.noise_model, t.stack, t.map, t.trial) for t in tasks}
    assert len(keys) == len(tasks)
    # common random numbers: the same trial has the same seed under every noise model and stack
    by = {(t.noise_model, t.stack, t.map, t.trial): t.seed for t in tasks}
    assert by[("botsim", "min-turn/paper-pf", "map2", 3)] == by[("absolute", "astar/paper-pf", "map2", 3)]
    assert len({t.seed for t in tasks}) == 3 * 4  # distinct across maps and trials
    assert trial_seed(9, 1, 3) == by[("botsim", "min-turn/paper-pf", "map2", 3)]
    with pytest.raises(ValueError):
        paper_tasks(0)


def _result(task: PaperTrial, ok: bool, err: float, t: float, coll: int = 0) -> TrialResult:
    return TrialResult(task, ok, "reached target" if ok else "robot lost", t, err, 100.0 + err, coll, 50.0, 0, 3, 0)


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
    crashed = TrialResult(task[0], False, "crashed: RuntimeError: x", math.nan, math.nan, math.nan, 0, math.nan,
                          0, 0, 0)
    table = summarise([crashed, _result(task[1], True, 0.5, 0.2)])[0]
    row = table.rows[0]
    assert row.success_rate == 0.5 and row.final_error_cm == 0.5 and row.completion_s == pytest.approx(0.2)
