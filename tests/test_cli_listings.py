"""`maps list`, `planners show` and `localisers show` piped or saved: every name whole (the ones `--map`
and `--set` need), and `--json` lists every registered map, option and facet.

The tables are read through a pipe from the console script (their width is the pipe's); the JSON of
each plug-in, which no terminal shapes, from the command run in this process (`run_cli`)."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import pytest
from conftest import nxtnav_exe, run_cli

from localisation import LOCALISERS
from planners import PLANNERS
from planners.declarations import planner_options
from toolkit.world import list_maps
from toolkit.world.params import OptionInfo, describe


def _piped(tmp_path: Path, *args: str) -> str:
    """stdout of `nxtnav ARGS` read through a pipe (not a terminal: rich's 80 columns by default)."""
    proc = subprocess.run([nxtnav_exe(), *args], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          env={k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")})
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def _json(capsys: pytest.CaptureFixture[str], *args: str) -> Any:
    """The JSON document `nxtnav ARGS` prints, the command run in this process."""
    capsys.readouterr()
    assert run_cli(list(args)) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def _cells(text: str) -> set[str]:
    """Every table cell of `text`, stripped."""
    return {cell.strip() for line in text.splitlines() for cell in line.split("│")}


def test_maps_list_piped_keeps_every_name_and_file(tmp_path: Path) -> None:
    cells = _cells(_piped(tmp_path, "maps", "list"))
    maps = list_maps()
    assert len(maps) >= 10
    for name, path in maps.items():
        assert name in cells and str(path) in cells, name


def test_maps_list_json_lists_every_map(tmp_path: Path) -> None:
    rows = json.loads(_piped(tmp_path, "maps", "list", "--json"))
    assert [r["name"] for r in rows] == list(list_maps())
    map1 = next(r for r in rows if r["name"] == "map1")
    assert map1["start"] == [20, 20] and map1["walls"] == 8 and map1["file"].endswith("map1.yaml")


def _options(model: type | None) -> list[OptionInfo]:
    """The options of a plug-in's model as `show` lists them (none without a model)."""
    return describe(model) if model is not None else []


def test_planners_show_piped_keeps_the_option_names(tmp_path: Path) -> None:
    cells = _cells(_piped(tmp_path, "planners", "show", "ompl:BITstar"))
    names = [p.name for p in _options(planner_options("ompl:BITstar"))]
    assert "DelayRewiringUntilInitialSolution" in names
    assert set(names) <= cells


@pytest.mark.slow
@pytest.mark.parametrize("name", [*PLANNERS.names(), "ompl:InformedRRTstar"])
def test_planners_show_json_lists_every_option(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(capsys, "planners", "show", name, "--json")
    declared = _options(planner_options(name))
    assert doc["planner"] == name
    assert [o["name"] for o in doc["options"]] == [p.name for p in declared]
    assert [o["default"] for o in doc["options"]] == [p.default for p in declared]


def test_localisers_show_piped_keeps_the_option_names(tmp_path: Path) -> None:
    cells = _cells(_piped(tmp_path, "localisers", "show", "amcl"))
    cls = LOCALISERS.get("amcl")
    assert {p.name for p in _options(cls.options_model)} <= cells
    assert set(cls.robot_options or {}) <= cells


@pytest.mark.slow
@pytest.mark.parametrize("name", LOCALISERS.names())
def test_localisers_show_json_lists_every_option_and_facet(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(capsys, "localisers", "show", name, "--json")
    cls = LOCALISERS.get(name)
    assert doc["localiser"] == name
    assert [o["name"] for o in doc["options"]] == [p.name for p in _options(cls.options_model)]
    robot = cls.robot_options
    assert doc["robot_model"] == (None if robot is None else {k: v if isinstance(v, str) else list(v)
                                                              for k, v in robot.items()})
