"""Compile numba's kernels once, before pytest-xdist starts its workers (`tests/conftest.py` runs this file).

The collision checks, the searches and the beam model are numba kernels cached on disk (``cache=True``,
in ``__pycache__`` beside their modules). On a fresh clone, as in CI, that cache is empty, and every
process that needs a kernel compiles it until one of them has written it: at the start of a parallel run
the two workers, their process pools, the Dask cluster's workers and the documented commands compile the
same kernels at once, each for itself. Run first, this process compiles them once: it imports every
module (the kernels with a signature compile then) and runs a few small commands that call the others.
On a sample of the suite (the Dask cluster, the collision backends, scen, sweeps and fault benchmarks on
two workers) the cold run took 179 s of CPU without it and 141 s with it, this compilation included.

With a warm cache it stops after one probe (about a second): the kernels of
`toolkit.world.grid_visibility` compile when imported, and numba says when it compiles rather than loads.
It asserts nothing and prints nothing; the tests find whatever it did not compile, as before.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import pkgutil
import tempfile
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("toolkit", "planners", "localisation")


def _compiles_on_import(module: str) -> bool:
    """Whether importing `module` made numba compile a kernel (a cache miss) rather than load it."""
    from numba.core import event

    compiled: list[bool] = []

    class _Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            compiled.append(True)

        def on_end(self, ev: Any) -> None:
            pass

    listener = _Listener()
    event.register("numba:compile", listener)
    try:
        importlib.import_module(module)
    finally:
        event.unregister("numba:compile", listener)
    return bool(compiled)


def _import_everything() -> None:
    for name in PACKAGES:
        package = importlib.import_module(name)
        for found in pkgutil.walk_packages(package.__path__, name + "."):
            if found.name.endswith("__main__"):
                continue
            with contextlib.suppress(Exception):  # an optional extra that is not installed
                importlib.import_module(found.name)


def _commands(folder: str) -> list[list[str]]:
    """Small commands whose kernels compile on their first call: the planners' searches and collision
    checks (the plan command's warm-up runs the references too), a mission's localiser and ray casts,
    and the grid visibility of an any-angle search."""
    plan = ["plan", "--map", "map1", "--exec-repeats", "0"]
    return [
        [*plan, "--planner", "astar", "--exec-repeats", "1", "-o", f"{folder}/astar.png"],
        [*plan, "--planner", "min-turn", "-o", f"{folder}/min-turn.png"],
        [*plan, "--planner", "min-link", "-o", f"{folder}/min-link.png"],
        [*plan, "--planner", "shortest", "-o", f"{folder}/shortest.png"],
        ["run", "--map", "map1", "--sonar", "nxt", "--json", f"{folder}/run.json"],
        ["bench", "scen", str(REPO / "maps" / "external" / "arena2.map.scen"), "--kind", "octile", "--planners",
         "astar,shortest", "--limit", "1", "--out", f"{folder}/scen"],
    ]


def main() -> None:
    if not _compiles_on_import("toolkit.world.grid_visibility"):
        return  # numba's cache is warm
    _import_everything()
    from toolkit.cli import main as nxtnav

    with tempfile.TemporaryDirectory(prefix="numba-warm-up-") as folder:
        for argv in _commands(folder):
            with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()), \
                    contextlib.suppress(SystemExit, Exception):
                nxtnav(argv)


if __name__ == "__main__":
    main()
