"""Progress of long commands on stderr: a live bar on a terminal, a plain line now and then otherwise.

Benchmarks and paper tables often run for hours under ``nohup``, in CI or with stderr sent to a
file, where a live bar shows nothing until it ends. There `progress` writes a line such as
``missions: 12/200 (6 %), 31 s`` when the first task finishes, then at every further tenth of the
work or half a minute, whichever comes first, and when all are done.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import TextIO

__all__ = ["LineProgress", "progress", "progress_after"]

Advance = Callable[..., None]
"""Called once per finished task (any arguments are ignored, so it can be an ``on_done`` callback)."""


class LineProgress:
    """Plain progress lines for a stream that is not a terminal.

    Parameters
    ----------
    label : str
        What is counted, e.g. ``"missions"``.
    total : int
        How many tasks there are.
    stream : TextIO
        Where the lines go.
    every_s : float
        Longest quiet spell between two lines while tasks finish (s).
    done : int
        Tasks already finished when the count starts.
    started : float, optional
        When the work began (`time.monotonic`), if before the count starts: the lines give the time since.
    announce : bool
        Also write a line when the work starts (for a few long tasks: the first may take a while).
    """

    def __init__(self, label: str, total: int, stream: TextIO, every_s: float = 30.0, done: int = 0,
                 announce: bool = False, started: float | None = None) -> None:
        self.label, self.total, self.stream, self.every_s = label, total, stream, every_s
        self.done = done
        self._last_t = time.monotonic()
        self._t0 = self._last_t if started is None else started
        self._last_tenth = -1
        if announce:  # a line at once, before the first task ends
            print(f"{self.label}: 0/{self.total} (0 %), 0 s", file=self.stream, flush=True)

    def advance(self, *_: object) -> None:
        self.done += 1
        now = time.monotonic()
        tenth = 10 * self.done // max(self.total, 1)
        if self.done in (1, self.total) or tenth > self._last_tenth or now - self._last_t >= self.every_s:
            self._last_t, self._last_tenth = now, tenth
            pct = 100.0 * self.done / max(self.total, 1)
            print(f"{self.label}: {self.done}/{self.total} ({pct:.0f} %), {now - self._t0:.0f} s",
                  file=self.stream, flush=True)


@contextmanager
def progress(label: str, total: int, *, transient: bool = False, done: int = 0,
             announce: bool = False, started: float | None = None) -> Iterator[Advance]:
    """Report the progress of `total` tasks on stderr, `done` of them already finished; yields the
    function to call as each finishes.

    On a terminal a live bar (removed at the end when `transient`); otherwise `LineProgress` (with
    `announce`, its first line comes at once).

    >>> import io, contextlib
    >>> err = io.StringIO()
    >>> with contextlib.redirect_stderr(err), progress("trials", 3) as advance:
    ...     for _ in range(3):
    ...         advance()
    >>> err.getvalue().splitlines()[-1].startswith("trials: 3/3 (100 %)")
    True
    """
    from rich.console import Console

    console = Console(file=sys.stderr)
    if not console.is_terminal:
        yield LineProgress(label, total, sys.stderr, done=done, announce=announce, started=started).advance
        return
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("eta"), TimeRemainingColumn(), console=console, transient=transient) as bar:
        task = bar.add_task(label, total=total, completed=done)
        yield lambda *_: bar.advance(task)


PROGRESS_AFTER_S = 2.0
"""How long work runs before `progress_after` shows its progress (s)."""


@contextmanager
def progress_after(label: str, total: int, after_s: float | None = None) -> Iterator[Advance]:
    """`progress` (transient) that appears only once the work has run `after_s` seconds (default
    `PROGRESS_AFTER_S`), counting the tasks finished so far: a command that ends sooner prints nothing.

    >>> import io, contextlib
    >>> err = io.StringIO()
    >>> with contextlib.redirect_stderr(err), progress_after("steps", 3, after_s=0.0) as advance:
    ...     for _ in range(3):
    ...         advance()
    >>> err.getvalue().splitlines()[-1].startswith("steps: 3/3 (100 %)")
    True
    """
    wait_s = PROGRESS_AFTER_S if after_s is None else after_s
    started = time.monotonic()
    done = 0
    with ExitStack() as stack:
        shown: list[Advance] = []

        def advance(*_: object) -> None:
            nonlocal done
            done += 1
            if shown:
                shown[0]()
            elif time.monotonic() - started >= wait_s:
                shown.append(stack.enter_context(progress(label, total, transient=True, done=done - 1,
                                                          started=started)))
                shown[0]()

        yield advance
