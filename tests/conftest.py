"""Shared fixtures and helpers: the bundled maps, the command line in this process and as a console script."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest

from toolkit.world import Map, load_map

BOTSIM_MAPS = ("map1", "map2", "map3")
ALL_MAPS = (*BOTSIM_MAPS, "pillars")


@pytest.fixture(params=ALL_MAPS)
def any_map(request: pytest.FixtureRequest) -> Map:
    return load_map(request.param)


@pytest.fixture(params=BOTSIM_MAPS)
def botsim_map(request: pytest.FixtureRequest) -> Map:
    return load_map(request.param)


def run_cli(argv: list[str]) -> int:
    """Run the `nxtnav` command in this process; its exit code."""
    from toolkit.cli import main

    try:
        main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def nxtnav_exe() -> str:
    """The `nxtnav` console script next to this Python (`make install` puts it there)."""
    exe = shutil.which("nxtnav", path=str(Path(sys.executable).parent))
    assert exe is not None, "the nxtnav console script is not installed next to this Python: run make install"
    return exe
