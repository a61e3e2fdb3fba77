"""The process pool of the benchmarks: results as they finish, a dead worker is an error, not a hang."""

from __future__ import annotations

import faulthandler
import os
import re
import signal
import threading

import pytest

from toolkit.bench.executors import WorkerDied, collect_tasks


def _square(x: int) -> int:
    return x * x


def _crash_on_three(x: int) -> int:
    if x == 3:
        faulthandler.disable()  # (pytest's dump of the crash would only clutter the output)
        os.kill(os.getpid(), signal.SIGSEGV)  # what a crash inside a compiled library looks like
    return x


def _raise_on_two(x: int) -> int:
    if x == 2:
        raise ArithmeticError("task 2 failed")
    return x


def test_the_pool_returns_every_result() -> None:
    seen: list[int] = []
    results = collect_tasks(_square, list(range(12)), workers=2, on_done=seen.append)
    assert sorted(results) == [x * x for x in range(12)] and sorted(seen) == sorted(results)


def test_a_worker_killed_by_a_signal_stops_the_run_with_one_error() -> None:
    raised: list[BaseException] = []

    def run() -> None:
        try:
            collect_tasks(_crash_on_three, list(range(8)), workers=2)
        except BaseException as exc:  # handed to the test's thread
            raised.append(exc)

    runner = threading.Thread(target=run, daemon=True)  # a hang fails the test instead of the suite
    runner.start()
    runner.join(60.0)
    assert not runner.is_alive(), "the pool hangs on a dead worker"
    assert len(raised) == 1 and isinstance(raised[0], WorkerDied), raised
    # the signal is named when the dead worker is still in the pool's books (not always: the pool may
    # have dropped it before the error reaches the caller)
    assert re.fullmatch(r"a worker process died while running a task( \(killed by signal 11\))?; rerun with "
                        r"--workers 1 to see which task and why", str(raised[0])), str(raised[0])


def test_a_task_that_raises_passes_its_exception_on() -> None:
    with pytest.raises(ArithmeticError, match="task 2 failed"):
        collect_tasks(_raise_on_two, list(range(6)), workers=2)
