"""Running independent benchmark tasks: in-process, over a process pool, or on a Dask cluster.

Results come back as they finish (not in task order); each task should carry its own identifiers.
Progress is reported through a callback so that the CLI owns the progress bar.

Ctrl-C: worker processes ignore SIGINT (the terminal sends it to the whole process group), so only
this process sees it; it then terminates the workers at once (no task is waited for) and
`collect_tasks` raises `TasksInterrupted` carrying the results that had finished. On a Dask cluster
the tasks not yet finished are cancelled instead (the cluster's workers stay up for the next client;
a task already running on one finishes there and its result is dropped).

What travels to a Dask cluster: each task description and a reference to `func` (its module and
name), pickled; the workers import the function from their own installed nxtnav, so they need the
same version of nxtnav (and of dask) as this process, and every file a task names (a map by path,
a sonar profile) at the same path. Maps named by name (``map1``) resolve on the worker from its
installed data and ``$NXTNAV_MAPS``.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.context import BaseContext
from typing import Any, Generic, TypeVar, cast

from toolkit.world import ConfigError, NxtnavError

__all__ = ["TasksInterrupted", "WorkerDied", "collect_tasks", "default_workers", "quiet_logger", "run_tasks"]

T = TypeVar("T")
R = TypeVar("R")


class TasksInterrupted(KeyboardInterrupt, Generic[R]):
    """Ctrl-C during `collect_tasks`: `results` holds the tasks that had finished, of `total`."""

    def __init__(self, results: list[R], total: int) -> None:
        super().__init__(f"interrupted after {len(results)} of {total} tasks")
        self.results = results
        self.total = total


class WorkerDied(NxtnavError):
    """A worker process of the pool ended without a result (a crash in a compiled library, the
    kernel's out-of-memory killer): the run stops with this instead of waiting for it forever."""


@contextlib.contextmanager
def quiet_logger(name: str) -> Iterator[None]:
    """Logger `name` says only its errors while the block runs (a batch whose report counts what the
    logger would say each time), its level restored after."""
    logger = logging.getLogger(name)
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def collect_tasks(
    func: Callable[[T], R],
    tasks: Sequence[T],
    *,
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[R], None] | None = None,
) -> list[R]:
    """`run_tasks` into a list (in finishing order); Ctrl-C raises `TasksInterrupted` with the
    results finished so far, after the workers have been ended."""
    results: list[R] = []
    try:
        for r in run_tasks(func, tasks, workers=workers, dask_address=dask_address, on_done=on_done):
            results.append(r)
    except KeyboardInterrupt as exc:
        if isinstance(exc, TasksInterrupted):
            raise
        raise TasksInterrupted(results, len(tasks)) from None
    return results


def default_workers() -> int:
    """Worker processes by default: the usable cores."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def run_tasks(
    func: Callable[[T], R],
    tasks: Sequence[T],
    *,
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[R], None] | None = None,
) -> Iterator[R]:
    """Yield ``func(task)`` for every task, as each finishes.

    Parameters
    ----------
    func : callable
        A picklable top-level function.
    tasks : sequence
        Picklable task descriptions.
    workers : int
        1 runs in this process (simplest to debug); more uses a process pool of that size.
    dask_address : str or None
        Scheduler address (``tcp://host:8786``) of a Dask cluster, or ``"local"`` for a local
        cluster of `workers` processes; needs the ``cluster`` extra.
    on_done : callable or None
        Called with each result as it arrives (progress bars).
    """
    if workers < 1:
        raise ConfigError(f"workers must be >= 1, got {workers}")
    if dask_address is not None:
        yield from _run_dask(func, tasks, workers, dask_address, on_done)
        return
    if workers == 1 or len(tasks) <= 1:
        for t in tasks:
            r = func(t)
            if on_done:
                on_done(r)
            yield r
        return
    yield from _run_pool(func, tasks, min(workers, len(tasks)), on_done)


def _run_pool(func: Callable[[T], R], tasks: Sequence[T], workers: int,
              on_done: Callable[[R], None] | None) -> Iterator[R]:
    """The tasks over a pool of `workers` processes, one task at a time each; a worker that dies
    raises `WorkerDied`, Ctrl-C or a task's exception ends every worker at once."""
    context = _TrackedContext(multiprocessing.get_context())
    # the wrapper lends the wrapped context's every other attribute: a context in all but its class
    pool = ProcessPoolExecutor(workers, mp_context=cast(BaseContext, context), initializer=_ignore_sigint)
    finished = False
    try:
        pending: set[Future[R]] = {pool.submit(func, t) for t in tasks}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                r = future.result()
                if on_done:
                    on_done(r)
                yield r
        finished = True
    except BrokenProcessPool:
        # the pool ends its other workers with SIGTERM once one has died: those codes say nothing
        codes = sorted({p.exitcode for p in context.processes if p.exitcode not in (None, 0, -signal.SIGTERM)})
        seen = ", ".join(f"killed by signal {-c}" if c < 0 else f"exit {c}" for c in codes)
        how = f" ({seen})" if seen else ""
        raise WorkerDied(f"a worker process died while running a task{how}; rerun with --workers 1 "
                         "to see which task and why") from None
    finally:
        if not finished:  # Ctrl-C, a task that raised, a dead worker, or the caller stopped early
            for process in context.processes:
                if process.exitcode is None:
                    process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)


class _TrackedContext:
    """A multiprocessing context that keeps a handle on every worker process it starts.

    `ProcessPoolExecutor` starts its workers with its ``mp_context``'s ``Process``; this context lends
    everything else to the one it wraps. `processes` lets the caller end the workers at once (Ctrl-C)
    and read the exit codes of those that died.
    """

    def __init__(self, base: Any) -> None:
        self._base = base
        self.processes: list[Any] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._base, name)

    def Process(self, *args: Any, **kwargs: Any) -> Any:
        process = self._base.Process(*args, **kwargs)
        self.processes.append(process)
        return process


def _run_dask(
    func: Callable[[T], R], tasks: Sequence[T], workers: int, address: str, on_done: Callable[[R], None] | None
) -> Iterator[R]:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:  # pragma: no cover - depends on the extra
        from ..world import NxtnavError

        raise NxtnavError("--dask needs the 'cluster' extra: pip install 'nxtnav[cluster]'") from exc
    cluster: Any = None
    if address == "local":
        # the scheduler's HTTP server on a free port: without an address it takes 8787, and a second run on
        # the same machine (another benchmark, another clone's tests) finds it taken and fails to start
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0")
        client = Client(cluster)
    else:
        try:
            client = Client(address)
        except (OSError, ValueError, TypeError) as exc:  # unreachable, or not an address
            from ..world import NxtnavError

            raise NxtnavError(f"--dask {address}: cannot reach a Dask scheduler there: "
                              f"{' '.join(str(exc).split()) or type(exc).__name__}") from None
    futures: list[Any] = []
    finished = False
    try:
        futures = client.map(func, list(tasks), pure=False)
        for f in as_completed(futures):
            r = f.result()
            if on_done:
                on_done(r)
            yield r
        finished = True
    finally:
        if not finished and futures:  # Ctrl-C, a task that raised, or the caller stopped early
            client.cancel(futures)
        client.close()
        if cluster is not None:
            cluster.close()
