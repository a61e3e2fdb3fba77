"""Helpers the benchmarks share: a per-process map cache, the median of the finite values
(`toolkit.world.arrays.finite_median`, re-exported here), and which planners to run in worker processes."""

from __future__ import annotations

import csv
from collections.abc import Iterable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

from ..world import Map, load_map
from ..world.arrays import finite_median

__all__ = ["cached_map", "finite_median", "isolate_planners", "write_rows_csv"]


@lru_cache(maxsize=32)
def cached_map(name: str) -> Map:
    """`load_map(name)`, loaded once per process (benchmark tasks run many times on the same maps)."""
    return load_map(name)


def isolate_planners(names: Iterable[str]) -> bool:
    """Whether a batch running the planners `names` runs in worker processes even with one worker
    (`toolkit.bench.executors.run_tasks`'s ``isolate``): when one is named as ``ompl:NAME``. That
    reaches any of OMPL's planners, some of which crash their process now and then (AORRTC of OMPL
    2.0.1); the bundled ``rrtstar`` and ``prm`` (OMPL's RRT* and PRM) and the toolkit's own planners
    run in this process with one worker, where a debugger or a profiler sees them."""
    return any(name.startswith("ompl:") for name in names)


def write_rows_csv(rows: Iterable[Mapping[str, Any]], columns: Sequence[str], path: Path) -> Path:
    """`rows` as CSV with `columns`, written to a temporary file and then moved into place (a file cut
    short by an interrupt is never left under `path`)."""
    tmp = path.with_name(path.name + ".part")
    with tmp.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(columns))
        w.writeheader()
        w.writerows(rows)
    tmp.replace(path)
    return path
