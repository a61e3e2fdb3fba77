"""Compiled kernels before timed work: a word when numba really compiles, and planning times without it.

The collision checks and the grid and visibility searches are numba kernels cached on disk
(``cache=True``). The first run after an install compiles them, which takes tens of seconds; later
runs load them in a fraction of a second. `compile_note` says so once on stderr, only when a kernel is
really compiled (numba's ``numba:compile`` event fires on a cache miss alone) and stderr is a terminal
(a person waits there; a script reading stderr keeps its one line per failure), and `warm_up_planner`
compiles or loads a planner's kernels on a small room before the timed call, so that the planning time
a command reports never holds compilation.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

__all__ = ["compile_note", "warm_up_planner"]

_SAID: list[bool] = [False]
"""Whether this process has said that it compiles (it says so once)."""


@contextmanager
def compile_note(what: str) -> Iterator[None]:
    """While the block runs, the first kernel numba compiles (not one it loads from its cache) writes one
    line on stderr saying that `what` compiles, once per process, when stderr is a terminal."""
    from numba.core import event

    if not sys.stderr.isatty():
        yield
        return

    class _Note(event.Listener):
        def on_start(self, ev: Any) -> None:
            if not _SAID[0]:
                _SAID[0] = True
                print(f"nxtnav: compiling {what} (the first run only: numba keeps them in its cache) ...",
                      file=sys.stderr, flush=True)

        def on_end(self, ev: Any) -> None:
            pass

    note = _Note()
    event.register("numba:compile", note)
    try:
        yield
    finally:
        event.unregister("numba:compile", note)


def _room(scale: float) -> Any:
    """A square room with a pillar between its two presets, `scale` times 100 cm a side."""
    from ..world import map_from_dict

    s = scale
    return map_from_dict({"name": "warm-up", "boundary": [[0, 0], [100 * s, 0], [100 * s, 100 * s], [0, 100 * s]],
                          "obstacles": [[[45 * s, 30 * s], [55 * s, 30 * s], [55 * s, 70 * s], [45 * s, 70 * s]]]})


def warm_up_planner(name: str, options: dict[str, Any], checker: Any, radius: float, collision: str,
                    start: np.ndarray, goal: np.ndarray) -> float:
    """Compile (or load from numba's cache) what planning with `name` runs, untimed; seconds it took.

    The query's own `checker` answers a point and a segment check (its kernels, with its map's types);
    then `name` with `options` plans across a small room scaled to the robot's `radius` (cm), with the
    same `collision` backend, and so do the references the plan command draws beside it.
    """
    from planners import PlanningProblem

    from ..bench.planners import REFERENCE_PLANNERS, planner_for
    from ..world import make_checker

    t0 = time.perf_counter()
    checker.point_free(start)
    checker.segments_free(start[None], goal[None])
    room = _room(max(1.0, radius / 6.0))
    room_checker = make_checker(room, radius, collision)
    a, b = np.array(room.bounds[2:]) * [0.15, 0.5], np.array(room.bounds[2:]) * [0.85, 0.5]
    for planner_name, opts in ((name, options), *((ref, {}) for ref in REFERENCE_PLANNERS)):
        planner = planner_for(planner_name, room, opts)
        if planner is not None:
            planner.plan(PlanningProblem(room, room_checker, a, b, 0.05, np.random.default_rng(0)))
    return time.perf_counter() - t0
