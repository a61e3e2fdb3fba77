"""Help texts that list choices list exactly the registry's names: `nxtnav COMMAND --help`, as printed."""

from __future__ import annotations

import os
import re
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from conftest import nxtnav_exe, run_cli

from toolkit.cli import _load
from toolkit.cli.app import click_command

_PLACEHOLDER = re.compile(r"<<choices:([a-z ]+)>>")


def _registry(kind: str) -> list[str]:
    """The names of `kind`, read from the registry or table that defines them (not from the help code)."""
    from localisation import LOCALISERS
    from localisation.global_localisation import EXPLORATIONS
    from localisation.models import NOISE_MODELS
    from planners import PLANNERS
    from planners.ompl_planners import ompl_planner_names
    from toolkit.bench.localisers import SCENARIOS, TRACKER_PRIORS
    from toolkit.bench.paper_pareto import MISSION_SETTINGS
    from toolkit.bench.peers import PEERS
    from toolkit.bench.planners.simplify import SIMPLIFY_METHODS
    from toolkit.bench.scen import EXACT_PLANNER
    from toolkit.cli.figure_jobs import FIGURE_JOBS
    from toolkit.real_sonar.fit import BASELINES
    from toolkit.robots.brick_faults import FAULT_KINDS
    from toolkit.robots.nxt import BACKENDS
    from toolkit.world import CHECKER_BACKENDS, SONAR_MODELS

    assert "ompl:" + ompl_planner_names()[0] in PLANNERS  # the family the help writes as ompl:NAME
    sets: dict[str, Callable[[], list[str]]] = {
        "sonar": SONAR_MODELS.names, "noise model": lambda: list(NOISE_MODELS),
        "planner": lambda: [*PLANNERS.names(), "ompl:NAME"], "localiser": LOCALISERS.names,
        "collision": lambda: list(CHECKER_BACKENDS), "nxt backend": lambda: list(BACKENDS),
        "tracker prior": lambda: list(TRACKER_PRIORS), "scenario": lambda: list(SCENARIOS),
        "simplify": lambda: list(SIMPLIFY_METHODS), "fault kind": lambda: list(FAULT_KINDS),
        "exploration": lambda: list(EXPLORATIONS), "scen kind": lambda: list(EXACT_PLANNER),
        "peer": lambda: list(PEERS), "mission setting": lambda: list(MISSION_SETTINGS),
        "figure job": lambda: [j.name for j in FIGURE_JOBS], "sonar baseline": lambda: list(BASELINES),
    }
    return sets[kind]()


def _listed_choices() -> dict[tuple[str, ...], list[tuple[str, list[str]]]]:
    """Command path -> (option or argument, the kinds its help lists, in order), from the application."""
    _load()
    found: dict[tuple[str, ...], list[tuple[str, list[str]]]] = {}

    def walk(command: Any, path: tuple[str, ...]) -> None:
        for name, sub in getattr(command, "commands", {}).items():
            walk(sub, (*path, name))
        for param in command.params:
            kinds = _PLACEHOLDER.findall(getattr(param, "help", None) or "")
            if kinds:
                label = max(param.opts, key=len) if param.param_type_name == "option" else param.name
                found.setdefault(path, []).append((label, kinds))

    walk(click_command(with_choices=False), ())
    return found


LISTED = _listed_choices()


def test_the_help_texts_that_list_choices_are_many() -> None:
    # sonar, planner, localiser, noise model, collision, backend... on every command that takes them
    assert len(LISTED) >= 15 and sum(len(v) for v in LISTED.values()) >= 35
    assert ("--sonar", ["sonar"]) in LISTED[("localise",)]
    assert ("--sonar", ["sonar"]) in LISTED[("bench", "localisers")]


@pytest.mark.parametrize("path", sorted(LISTED), ids=" ".join)
def test_help_lists_the_registry_names(path: tuple[str, ...], capsys: pytest.CaptureFixture[str],
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    # the command's own entry point, in this process (its help is filled in by `main` as for the console
    # script; `test_the_installed_command_lists_them_too` runs the script itself once)
    monkeypatch.setenv("COLUMNS", "1000")  # one line per option, as wide as it needs
    assert run_cli([*path, "--help"]) == 0
    out = capsys.readouterr().out
    assert "<<" not in out
    lines = out.splitlines()
    for label, kinds in LISTED[path]:
        # the option's own row: its names come first (`*` marks a required one)
        line = next((ln for ln in lines if ln.startswith("│") and label in ln.replace("│", " ").split()[:3]), None)
        assert line is not None, f"{label} not in the help of nxtnav {' '.join(path)}"
        listed = [group.split(", ") for group in re.findall(r"\{([^{}]*)\}", line)]
        assert listed == [_registry(kind) for kind in kinds], line


def test_the_installed_command_lists_them_too(tmp_path: Path) -> None:
    env = {**os.environ, "COLUMNS": "1000"}
    proc = subprocess.run([nxtnav_exe(), "localise", "--help"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "{" + ", ".join(_registry("sonar")) + "}" in proc.stdout and "<<" not in proc.stdout
