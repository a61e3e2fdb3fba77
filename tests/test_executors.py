"""The process pool of the benchmarks: results as they finish; a dead worker is a crashed task of the run
(or, without a `crashed` factory, an error naming it), never a hang."""

from __future__ import annotations

import faulthandler
import logging
import os
import signal
import threading
from collections.abc import Callable

import pytest

from toolkit.bench.executors import WorkerDied, collect_tasks

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
