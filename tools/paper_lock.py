"""Compare two `nxtnav paper --json` files, wall-clock timings aside (a behaviour lock).

    python tools/paper_lock.py BEFORE.json AFTER.json

Prints every deterministic field that differs (path, before, after) and exits 1 when any does, 0 when
the two runs agree. Wall-clock and CPU fields (`completion_*`, `cpu_*`) are skipped: they change from
run to run; robot time is simulated and is compared. Each table's ``configuration`` (the command that
made it) is skipped too.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

WALL_CLOCK = ("completion_s", "completion_median_s", "completion_max_s", "cpu_s", "cpu_median_s")
RECORD_OF_THE_RUN = "configuration"
"""Each table's record of the command that made it (`toolkit.cli.run_config`): how it ran, not what it found."""


def leaves(obj: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    """Every scalar of a JSON document with its path (``[0]/rows[1]/map``)."""
    if isinstance(obj, dict):
        for key, value in obj.items():
            yield from leaves(value, f"{path}/{key}")
    elif isinstance(obj, list):
        for i, value in enumerate(obj):
            yield from leaves(value, f"{path}[{i}]")
    else:
        yield path, obj


def differences(before: Any, after: Any) -> list[tuple[str, Any, Any]]:
    """The deterministic fields whose values differ (a field missing on one side counts)."""
    a, b = dict(leaves(before)), dict(leaves(after))
    out = []
    for key in sorted(a.keys() | b.keys()):
        if key.rsplit("/", 1)[-1] in WALL_CLOCK or f"/{RECORD_OF_THE_RUN}/" in f"{key}/":
            continue
        if a.get(key, "<missing>") != b.get(key, "<missing>"):
            out.append((key, a.get(key, "<missing>"), b.get(key, "<missing>")))
    return out


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print("usage: python tools/paper_lock.py BEFORE.json AFTER.json", file=sys.stderr)
        return 2
    docs = []
    for name in argv:
        try:
            docs.append(json.loads(Path(name).read_text()))
        except (OSError, ValueError) as exc:
            print(f"{name}: cannot read a paper JSON ({exc})", file=sys.stderr)
            return 2
    diff = differences(*docs)
    for key, a, b in diff:
        print(f"{key}: {a!r} -> {b!r}")
    print(f"{len(diff)} deterministic field(s) differ" if diff else "identical, wall-clock timings aside")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
