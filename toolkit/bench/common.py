"""Helpers the benchmarks share: a per-process map cache, and the median of the finite values
(`toolkit.world.arrays.finite_median`, re-exported here)."""

from __future__ import annotations

import csv
from collections.abc import Iterable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

from ..world import Map, load_map
from ..world.arrays import finite_median

__all__ = ["cached_map", "finite_median", "write_rows_csv"]


@lru_cache(maxsize=32)
def cached_map(name: str) -> Map:
    """`load_map(name)`, loaded once per process (benchmark tasks run many times on the same maps)."""
    return load_map(name)


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
