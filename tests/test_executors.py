"""The process pool of the benchmarks: results as they finish; a dead worker is a crashed task of the run
(or, without a `crashed` factory, an error naming it), never a hang."""

from __future__ import annotations

import csv
import faulthandler
import json
import logging
import os
import re
import signal
import threading
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import run_cli

from planners import PLANNERS, PlanningProblem, PlanResult, PlanStatus, ShortestPathPlanner
from toolkit.bench.executors import WorkerDied, collect_tasks
from toolkit.bench.planners import BenchmarkConfig, run_benchmark
from toolkit.bench.planners.plots import save_cost_over_time

CRASHES = 3
"""The task that kills its own process."""


def _square(x: int) -> int:
    return x * x


def _crash_on_three(x: int) -> int:
    if x == CRASHES:
        faulthandler.disable()  # (pytest's dump of the crash would only clutter the output)
        os.kill(os.getpid(), signal.SIGSEGV)  # what a crash inside a compiled library looks like
    return x


def _crash_on_odd(x: int) -> int:
    if x % 2:
        faulthandler.disable()
        os.kill(os.getpid(), signal.SIGKILL if x == 5 else signal.SIGSEGV)
    return x


def _raise_on_two(x: int) -> int:
    if x == 2:
        raise ArithmeticError("task 2 failed")
    return x


def test_the_pool_returns_every_result() -> None:
    seen: list[int] = []
    results = collect_tasks(_square, list(range(12)), workers=2, on_done=seen.append)
    assert sorted(results) == [x * x for x in range(12)] and sorted(seen) == sorted(results)


def _crashed(x: int, reason: str) -> str:
    return f"task {x} crashed: {reason}"


def _in_a_thread(run: Callable[[], list[object]]) -> list[object]:
    """`run()`'s result, or its exception as the one item; a hang fails the test instead of the suite."""
    out: list[object] = []

    def target() -> None:
        try:
            out.append(run())
        except BaseException as exc:  # handed to the test's thread
            out.append(exc)

    runner = threading.Thread(target=target, daemon=True)
    runner.start()
    runner.join(60.0)
    assert not runner.is_alive(), "the pool hangs on a dead worker"
    return out


def test_a_worker_killed_by_a_signal_without_a_factory_stops_the_run_naming_the_task() -> None:
    raised = _in_a_thread(lambda: list(collect_tasks(_crash_on_three, list(range(8)), workers=2)))
    assert len(raised) == 1 and isinstance(raised[0], WorkerDied), raised
    assert str(raised[0]) == ("the worker process running task 4 of 8 died (killed by signal 11 (SIGSEGV)); a task "
                              "that crashes its process ends this run"), str(raised[0])


@pytest.mark.parametrize("workers", [1, 2, 3])
def test_a_crashed_task_is_a_result_and_every_other_task_comes_back(
        workers: int, caplog: pytest.LogCaptureFixture) -> None:
    seen: list[object] = []
    with caplog.at_level(logging.WARNING, logger="toolkit.bench.executors"):
        (results,) = _in_a_thread(lambda: list(collect_tasks(
            _crash_on_three, list(range(8)), workers=workers, on_done=seen.append, crashed=_crashed, isolate=True)))
    assert isinstance(results, list), results
    expected = [x for x in range(8) if x != CRASHES]
    assert sorted(r for r in results if isinstance(r, int)) == expected
    assert [r for r in results if isinstance(r, str)] == ["task 3 crashed: killed by signal 11 (SIGSEGV)"]
    assert sorted(seen, key=str) == sorted(results, key=str)  # the progress saw the crashed one too
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == ["task 4 of 8 crashed: its worker process was killed by signal 11 (SIGSEGV); recorded as "
                        "crashed, the run goes on"], warnings


def test_each_of_several_crashed_tasks_is_named_with_its_own_signal() -> None:
    (results,) = _in_a_thread(lambda: list(collect_tasks(_crash_on_odd, list(range(8)), workers=2, crashed=_crashed)))
    assert isinstance(results, list), results
    assert sorted(r for r in results if isinstance(r, int)) == [0, 2, 4, 6]
    assert sorted(r for r in results if isinstance(r, str)) == [
        "task 1 crashed: killed by signal 11 (SIGSEGV)", "task 3 crashed: killed by signal 11 (SIGSEGV)",
        "task 5 crashed: killed by signal 9 (SIGKILL)", "task 7 crashed: killed by signal 11 (SIGSEGV)"]


def test_without_isolate_one_worker_runs_the_tasks_in_this_process() -> None:
    assert collect_tasks(_pid, [0, 1], workers=1, crashed=_crashed) == [os.getpid()] * 2
    (pids,) = collect_tasks(_pid, [0], workers=1, crashed=_crashed, isolate=True)
    assert pids != os.getpid()


def _pid(_: int) -> int:
    return os.getpid()


def test_a_task_that_raises_passes_its_exception_on() -> None:
    with pytest.raises(ArithmeticError, match="task 2 failed"):
        collect_tasks(_raise_on_two, list(range(6)), workers=2)


class _CrashesOnMap2(ShortestPathPlanner):
    """The shortest path, except on map2, where it kills its own process (a crash in compiled code)."""

    def plan(self, problem: PlanningProblem) -> PlanResult:
        if problem.map.name == "map2":
            faulthandler.disable()
            os.kill(os.getpid(), signal.SIGSEGV)
        return super().plan(problem)


def test_bench_planners_records_the_crashed_runs_and_writes_the_others(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture) -> None:
    out = tmp_path / "bench"
    with PLANNERS.added({"crashes-on-map2": _CrashesOnMap2}):  # the forked workers inherit it
        code = run_cli(["bench", "planners", "--maps", "map1,map2", "--planners", "crashes-on-map2", "--runs", "1",
                        "--workers", "2", "--exec-repeats", "0", "--no-plots", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    with (out / "runs.csv").open() as fh:
        success = {(r["map"], r["run"]): r["success"] for r in csv.DictReader(fh)}
    assert success == {("map1", "0"): "true", ("map2", "0"): "false"}
    runs = [json.loads(line) for line in (out / "paths.jsonl").read_text().splitlines()]  # strict JSON: no NaN
    crashed = sorted((r["map"], r["run"], r["status"], r["detail"], r["time_s"]) for r in runs if not r["success"])
    assert crashed == [("map2", 0, "error", "crashed: killed by signal 11 (SIGSEGV)", None)]
    warned = sorted(r.getMessage() for r in caplog.records if "crashed: its worker process" in r.getMessage())
    assert len(warned) == 1 and "(map map2, planner crashes-on-map2, run 0, seed " in warned[0], warned
    # the success share counts the crashed run as a failure: map1's table, then map2's
    shares = re.findall(r"^\| crashes-on-map2 \| (\d+) % \|", (out / "summary.md").read_text(), re.MULTILINE)
    assert shares == ["100", "0"], shares


def test_the_cost_plot_of_a_map_whose_runs_all_crashed_has_its_panel(tmp_path: Path) -> None:
    with PLANNERS.added({"crashes-on-map2": _CrashesOnMap2}):
        result = run_benchmark(BenchmarkConfig(maps=("map2",), planners=("crashes-on-map2",), runs=2, exec_repeats=0),
                               workers=2)  # two runs: one task alone would run in this process
    assert [(r.success, r.detail) for r in result.records] == [(False, "crashed: killed by signal 11 (SIGSEGV)")] * 2
    assert save_cost_over_time(result, tmp_path).is_file()  # no median to draw: the log axis has limits of its own


def test_the_cost_plot_of_a_map_where_most_runs_of_an_anytime_planner_crashed(tmp_path: Path) -> None:
    result = run_benchmark(BenchmarkConfig(maps=("map1",), planners=("rrtstar",), runs=1, exec_repeats=0,
                                           time_limit=0.05))
    (solved,) = result.records
    assert solved.success and solved.progress  # a best-cost curve: the band's median is drawn from the runs'
    crashed = replace(solved, success=False, status=PlanStatus.ERROR, progress=(), detail="crashed")
    # two of three runs crashed: the median has no finite value anywhere, nothing is drawn on the panel
    assert save_cost_over_time(replace(result, records=(solved, crashed, crashed)), tmp_path).is_file()


def _mmap_threshold(_: int) -> str | None:
    return os.environ.get("MALLOC_MMAP_THRESHOLD_")


def test_a_local_dask_clusters_workers_keep_glibcs_mmap_threshold_fixed() -> None:
    """A nanny sets MALLOC_TRIM_THRESHOLD_, which pins glibc's mmap threshold at 128 KiB and doubled the
    localisers' CPU time on Dask; ``--dask local`` starts its workers with the threshold fixed at 64 MiB."""
    pytest.importorskip("distributed")
    assert collect_tasks(_mmap_threshold, [0, 1], workers=1, dask_address="local") == [str(64 << 20)] * 2
