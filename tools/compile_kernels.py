"""Fill numba's cache before the suite runs: a few small commands that compile the toolkit's kernels.

On a fresh clone numba's cache is empty, and every test process that starts before a kernel is cached
compiles it again (tens of seconds each). `make test` runs this once, beside mypy, so that the tests
load the kernels instead. Nothing it writes is kept but the cache.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMANDS = [
    ["plan", "--map", "map1", "--planner", "astar", "--exec-repeats", "0", "-o", "astar.png"],
    ["plan", "--map", "map1", "--planner", "min-turn", "--exec-repeats", "0", "-o", "min-turn.png"],
    ["run", "--map", "map1", "--json", "paper-pf.json"],
    ["run", "--map", "map1", "--sonar", "nxt", "--localiser", "amcl", "--json", "amcl.json"],
]
"""What compiles the kernels most tests use: the swept-disc index, the grid and visibility searches,
the range tables, the beam model's lattice and the stuck-run test."""


def main() -> int:
    exe = Path(sys.executable).with_name("nxtnav")
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        for args in COMMANDS:
            proc = subprocess.run([str(exe), *args], cwd=tmp, capture_output=True, text=True)
            if proc.returncode != 0:
                print(f"compile_kernels: nxtnav {' '.join(args)} exited {proc.returncode}:\n{proc.stderr}",
                      file=sys.stderr)
                return proc.returncode
    print(f"compile_kernels: numba's cache filled in {time.monotonic() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
