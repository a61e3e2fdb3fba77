"""Shared fixtures: the bundled maps and a small map with obstacles."""

from __future__ import annotations

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
