"""The first `nxtnav plan` after an install: it says once that it compiles, and the planning time it
reports holds no compilation (the kernels are compiled, or loaded from numba's cache, before the timer)."""

from __future__ import annotations

import json
import os
import pty
import subprocess
from pathlib import Path

import pytest
from conftest import nxtnav_exe

NOTE = "nxtnav: compiling the collision checks and planners"


def _plan_on_a_terminal(cwd: Path, cache: Path) -> tuple[dict[str, float], str]:
    """`nxtnav plan --planner astar` with stderr on a pseudo-terminal (a person waiting) and numba's cache
    in `cache`; the JSON report and what stderr showed."""
    controller, terminal = pty.openpty()
    try:
        proc = subprocess.run([nxtnav_exe(), "plan", "--planner", "astar", "--exec-repeats", "0", "-o", "p.png",
                               "--json", "p.json"], cwd=cwd, stdout=subprocess.PIPE, stderr=terminal, text=True,
                              env={**os.environ, "NUMBA_CACHE_DIR": str(cache)}, timeout=900)
        os.set_blocking(controller, False)
        try:
            shown = os.read(controller, 1 << 16).decode(errors="replace")
        except BlockingIOError:
            shown = ""
    finally:
        os.close(terminal)
        os.close(controller)
    assert proc.returncode == 0, shown
    return json.loads((cwd / "p.json").read_text()), shown


@pytest.mark.slow
def test_a_fresh_install_compiles_before_the_timer_and_says_so_once(tmp_path: Path) -> None:
    cache = tmp_path / "numba-cache"  # empty, as after an install: every kernel compiles
    first, shown = _plan_on_a_terminal(tmp_path, cache)
    assert shown.count(NOTE) == 1, shown
    # the compile step's own timing holds the compilation; the reported planning time does not
    assert first["warm_up_s"] > 0 and first["time_s"] < first["warm_up_s"] / 5, first
    again, shown = _plan_on_a_terminal(tmp_path, cache)
    assert NOTE not in shown  # loaded from numba's cache: nothing compiles, nothing said
    assert again["warm_up_s"] < first["warm_up_s"] / 5
