"""Ctrl-C during a batch of tasks, written once: keep what finished, mark every output incomplete, say where.

`run_batch` runs the tasks under a progress bar (`toolkit.bench.executors.collect_tasks`: in this process,
over a pool, or on a Dask cluster). On Ctrl-C it returns the finished tasks as a `Batch` that knows it is
incomplete (or, for a command that cannot use part of its tasks, ends the command saying nothing was
written). The command writes its outputs from the batch, puts `Batch.banner` on top of its tables, and
ends with `Batch.finish`: nothing when every task finished, else `Interrupted` (exit 130) naming where the
partial results are.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from .app import Interrupted
from .progress import progress

__all__ = ["Batch", "run_batch"]

R = TypeVar("R")


@dataclass(frozen=True)
class Batch(Generic[R]):
    """The results of a batch of tasks (as they finished) and how many were planned; `what` names the tasks
    in the plural (``missions``, ``trials``, ``runs``)."""

    results: list[R]
    planned: int
    what: str

    @property
    def done(self) -> int:
        return len(self.results)

    @property
    def complete(self) -> bool:
        return self.done == self.planned

    def banner(self) -> str:
        """The line that heads a partial table (empty when the batch is complete)."""
        if self.complete:
            return ""
        return (f"**INCOMPLETE**: interrupted after {self.done} of {self.planned} {self.what}; the tables below "
                f"cover only the finished {self.what}.\n\n")

    def finish(self, where: str) -> None:
        """End the command after its outputs are written: `Interrupted` naming `where` the partial results
        are, when the batch is incomplete."""
        if not self.complete:
            raise Interrupted(f"{self.done} of {self.planned} {self.what} done; {where}")


def run_batch(function: Callable[[Any], R], tasks: Sequence[Any], what: str, *, label: str | None = None,
              workers: int = 1, dask: str | None = None, keep_partial: bool = True,
              transient: bool = False, crashed: Callable[[Any, str], R] | None = None,
              isolate: bool = False) -> Batch[R]:
    """Run `function` on every task (`toolkit.bench.executors.collect_tasks`, with its `crashed` and
    `isolate`) under a progress bar (`label`, default `what`). On Ctrl-C: the finished ones as an incomplete
    batch with `keep_partial`, else `Interrupted` saying nothing was written; none finished is `Interrupted`
    either way."""
    from ..bench.executors import TasksInterrupted, collect_tasks

    with progress(label or what, len(tasks), transient=transient) as advance:
        try:
            results = collect_tasks(function, list(tasks), workers=workers, dask_address=dask, on_done=advance,
                                    crashed=crashed, isolate=isolate)
        except TasksInterrupted as exc:
            finished = list(exc.results)
            if not keep_partial:
                raise Interrupted(f"after {len(finished)} of {len(tasks)} {what}; nothing written") from None
            if not finished:
                raise Interrupted(f"none of the {len(tasks)} {what} had finished; nothing written") from None
            return Batch(finished, len(tasks), what)
    return Batch(list(results), len(tasks), what)
