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

A worker process that dies (a crash in a compiled library, the kernel's out-of-memory killer) breaks
the pool. With a `crashed` factory the run goes on: every result finished so far is kept, the task
that the dead process was running (each worker marks the task it starts in memory shared with this
process) becomes ``crashed(task, "killed by signal 11 (SIGSEGV)")`` with one warning line naming it,
and the tasks that were pending or running on the pool's other workers (which the broken pool ends)
run again in a fresh pool. The crashed task is not run again: a crash that comes now and then would
otherwise count as a success on its second try. Without a factory the run ends with `WorkerDied`
naming the task. Tasks run in this process (one worker without ``isolate``, or a single task) have no
such guard: a crash ends this process too. On a Dask cluster the scheduler itself moves the tasks of
a dead worker to others and gives up on a task whose workers died more than its allowed failures
(``KilledWorker``): that task becomes ``crashed(task, ...)`` likewise.
"""

from __future__ import annotations

import contextlib
import gc
import logging
import multiprocessing
import os
import signal
from collections.abc import Callable, Generator, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing.context import BaseContext
from typing import Any, Generic, TypeVar, cast

from toolkit.world import ConfigError, NxtnavError

__all__ = ["TasksInterrupted", "WorkerDied", "collect_tasks", "default_workers", "exit_reason", "quiet_logger",
           "run_tasks", "task_label"]

T = TypeVar("T")
R = TypeVar("R")
MMAP_THRESHOLD = 64 << 20
"""glibc's mmap threshold (bytes) in the workers of ``--dask local`` (`_run_dask`); for workers started by hand,
``export MALLOC_MMAP_THRESHOLD_=67108864`` before ``dask worker`` (docs/cluster.md)."""

log = logging.getLogger(__name__)

_LABEL_FIELDS = ("map", "planner", "localiser", "scenario", "sweep", "route", "run", "trial", "seed")
"""The task attributes that `task_label` names a task by, when it has them."""


class TasksInterrupted(KeyboardInterrupt, Generic[R]):
    """Ctrl-C during `collect_tasks`: `results` holds the tasks that had finished, of `total`."""

    def __init__(self, results: list[R], total: int) -> None:
        super().__init__(f"interrupted after {len(results)} of {total} tasks")
        self.results = results
        self.total = total


class WorkerDied(NxtnavError):
    """A worker process of the pool ended without a result (a crash in a compiled library, the
    kernel's out-of-memory killer) and the caller gave no `crashed` factory: the run stops with this,
    naming the task, instead of waiting for it forever."""


def task_label(task: Any, index: int, total: int) -> str:
    """How the warnings and errors name task `index` (from 0) of `total`: its place and the fields of
    `_LABEL_FIELDS` it has and the index of its ``query`` when it has no run (``task 4 of 20 (map map1,
    planner ompl:AORRTC, run 3, seed 17)``)."""
    fields = [f"{name} {getattr(task, name)}" for name in _LABEL_FIELDS if hasattr(task, name)]
    query: Any = getattr(task, "query", None)
    if not hasattr(task, "run") and hasattr(query, "index"):  # a query's planning: which query
        fields.append(f"query {query.index}")
    return f"task {index + 1} of {total}" + (f" ({', '.join(fields)})" if fields else "")


def exit_reason(exitcode: int) -> str:
    """What a process's exit code says of its end: ``killed by signal 11 (SIGSEGV)``, ``exit 3``."""
    if exitcode < 0:
        try:
            return f"killed by signal {-exitcode} ({signal.Signals(-exitcode).name})"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit {exitcode}"


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
    crashed: Callable[[T, str], R] | None = None,
    isolate: bool = False,
) -> list[R]:
    """`run_tasks` into a list (in finishing order); Ctrl-C raises `TasksInterrupted` with the
    results finished so far, after the workers have been ended."""
    results: list[R] = []
    try:
        for r in run_tasks(func, tasks, workers=workers, dask_address=dask_address, on_done=on_done,
                           crashed=crashed, isolate=isolate):
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
    crashed: Callable[[T, str], R] | None = None,
    isolate: bool = False,
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
    crashed : callable or None
        ``crashed(task, reason)``: the result of a task whose worker process died while running it
        (`reason` as ``killed by signal 11 (SIGSEGV)``); None ends the run with `WorkerDied` instead.
    isolate : bool
        Run the tasks in worker processes even when `workers` is 1 or there is one task (one worker
        process then), so that a task that crashes its process does not end this one: for tasks that
        run compiled code known to crash now and then.
    """
    if workers < 1:
        raise ConfigError(f"workers must be >= 1, got {workers}")
    if dask_address is not None:
        yield from _run_dask(func, tasks, workers, dask_address, on_done, crashed)
        return
    if not isolate and (workers == 1 or len(tasks) <= 1):
        for t in tasks:
            r = func(t)
            if on_done:
                on_done(r)
            yield r
        return
    yield from _run_pool(func, tasks, max(1, min(workers, len(tasks))), on_done, crashed)


def _run_pool(func: Callable[[T], R], tasks: Sequence[T], workers: int, on_done: Callable[[R], None] | None,
              crashed: Callable[[T, str], R] | None) -> Iterator[R]:
    """The tasks over a pool of `workers` processes, one task at a time each; a pool broken by a dead
    worker is replaced by a fresh one for the tasks left, the dead worker's task `_crashed`. A pool
    that breaks twice in a row with no task to blame ends the run with `WorkerDied`."""
    remaining = dict(enumerate(tasks))
    unblamed = 0
    while remaining:
        blame = yield from _pool_round(func, remaining, min(workers, len(remaining)), on_done)
        if blame is None:
            return
        unblamed = 0 if blame.culprits else unblamed + 1
        if unblamed == 2:
            how = f" ({', '.join(blame.codes)})" if blame.codes else ""
            raise WorkerDied(f"worker processes died twice with no task of this run on them{how}")
        for index, reason in sorted(blame.culprits.items()):
            r = _crashed(remaining.pop(index), index, len(tasks), reason, crashed)
            if on_done:
                on_done(r)
            yield r


def _crashed(task: T, index: int, total: int, reason: str, crashed: Callable[[T, str], R] | None) -> R:
    """The result of `task` whose worker died of `reason`, with one warning line; `WorkerDied` without
    a factory."""
    label = task_label(task, index, total)
    if crashed is None:
        raise WorkerDied(f"the worker process running {label} died ({reason}); a task that crashes its "
                         "process ends this run")
    log.warning("%s crashed: its worker process was %s; recorded as crashed, the run goes on", label, reason)
    return crashed(task, reason)


class _Blame:
    """Why a pool broke: `culprits` maps the index of each task a dead worker was running to how that
    worker ended; `codes` are the ends of the dead workers (the pool's own SIGTERMs left out)."""

    def __init__(self, culprits: dict[int, str], codes: list[str]) -> None:
        self.culprits = culprits
        self.codes = codes


_started: Any = None
"""In a worker process: the shared array in which it marks each task it starts with its process id."""


def _start_worker(started: Any) -> None:
    global _started
    _ignore_sigint()
    _started = started


def _run_marked(func: Callable[[T], R], index: int, task: T) -> R:
    """``func(task)`` in a worker process, after marking task `index` as started by this process."""
    _started[index] = os.getpid()
    return func(task)


def _pool_round(func: Callable[[T], R], remaining: dict[int, T], workers: int,
                on_done: Callable[[R], None] | None) -> Generator[R, None, _Blame | None]:
    """The `remaining` tasks (by index) over one pool, each finished one yielded and taken out of
    `remaining`; returns None when they all finished, else the `_Blame` of the broken pool (Ctrl-C or a
    task's exception end every worker at once)."""
    context = _TrackedContext(multiprocessing.get_context())
    started = context.RawArray("q", max(remaining) + 1)
    # the wrapper lends the wrapped context's every other attribute: a context in all but its class
    pool = ProcessPoolExecutor(workers, mp_context=cast(BaseContext, context), initializer=_start_worker,
                               initargs=(started,))
    finished = False
    try:
        index_of = {pool.submit(_run_marked, func, i, t): i for i, t in remaining.items()}
        pending, broken = set(index_of), False
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                if isinstance(future.exception(), BrokenProcessPool):
                    broken = True
                    continue
                r = future.result()
                del remaining[index_of[future]]
                if on_done:
                    on_done(r)
                yield r
        finished = True
        if not broken:
            return None
        pool.shutdown(wait=True)  # the pool's own thread reaps the dead: their exit codes are known after
        return _blame(context.processes, started, remaining)
    finally:
        if not finished:  # Ctrl-C, a task that raised, or the caller stopped early
            for process in context.processes:
                if process.exitcode is None:
                    process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)


def _blame(processes: list[Any], started: Any, remaining: dict[int, T]) -> _Blame:
    """The unfinished tasks that the dead `processes` had started (the pool ends its other workers with
    SIGTERM once one has died: those say nothing)."""
    died = {p.pid: p.exitcode for p in processes if p.exitcode not in (None, 0, -signal.SIGTERM)}
    culprits = {i: exit_reason(died[started[i]]) for i in remaining if started[i] in died}
    return _Blame(culprits, [exit_reason(c) for c in sorted(set(died.values()))])


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
    func: Callable[[T], R], tasks: Sequence[T], workers: int, address: str, on_done: Callable[[R], None] | None,
    crashed: Callable[[T, str], R] | None = None,
) -> Iterator[R]:
    try:
        import dask
        from dask.distributed import Client, LocalCluster, as_completed
        from distributed.scheduler import KilledWorker
    except ImportError as exc:  # pragma: no cover - depends on the extra
        from ..world import NxtnavError

        raise NxtnavError("--dask needs the 'cluster' extra: pip install 'nxtnav[cluster]'") from exc
    cluster: Any = None
    # an earlier run's Client, closed but held in a reference cycle, is finalised now: collected later, while
    # the new cluster's IO loop starts under distributed's LoopRunner lock, its __del__ (which closes its
    # own loop runner under the same lock) would wait on that lock for ever (seen once in a test run)
    gc.collect()
    if address == "local":
        # one task at a time on each worker, none queued behind it: a worker that dies then takes only the
        # task it ran into the scheduler's count of suspects (KilledWorker), not an innocent one waiting
        # and glibc's mmap threshold fixed at 64 MiB in each worker: a nanny sets MALLOC_TRIM_THRESHOLD_
        # (distributed.nanny.pre-spawn-environ), which also pins that threshold at 128 KiB, and every larger
        # array is then mapped afresh: the localisers' tasks took twice the CPU they take in a local pool
        with dask.config.set({"distributed.scheduler.worker-saturation": 1.0,
                              "distributed.nanny.pre-spawn-environ.MALLOC_MMAP_THRESHOLD_": MMAP_THRESHOLD}):
            # the scheduler's HTTP server on a free port: without an address it takes 8787, and a second run
            # on the same machine (another benchmark, another clone's tests) finds it taken and fails to start
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
        index_of = {f.key: i for i, f in enumerate(futures)}
        for f in as_completed(futures):
            try:
                r = f.result()
            except KilledWorker:  # the scheduler gave up on it: every worker that ran it died
                i = index_of[f.key]
                r = _crashed(tasks[i], i, len(tasks), "its Dask workers died while running it (KilledWorker)",
                             crashed)
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
