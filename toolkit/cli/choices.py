"""Choice lists in help texts, built from the registries they name so that they cannot drift.

A help text says ``"Simulated sonar " + one_of("sonar")``; when help is printed, `fill_choices`
replaces the placeholder with the registry's names as ``{ideal, laser, nxt}``. The registries of the
plug-ins (planners, localisers) load in half a second, so they are read only when help is asked
for, not on every command.
"""

from __future__ import annotations

import functools
import importlib
import re
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["CHOICE_SETS", "choice_names", "fill_choices", "one_of"]


_TABLES: dict[str, tuple[str, str]] = {
    "sonar": ("toolkit.world", "SONAR_MODELS"),
    "noise model": ("localisation.models", "NOISE_MODELS"),
    "localiser": ("localisation", "LOCALISERS"),
    "collision": ("toolkit.world", "CHECKER_BACKENDS"),
    "nxt backend": ("toolkit.robots.nxt", "BACKENDS"),
    "tracker prior": ("toolkit.bench.localisers", "TRACKER_PRIORS"),
    "scenario": ("toolkit.bench.localisers", "SCENARIOS"),
    "simplify": ("toolkit.bench.planners.simplify", "SIMPLIFY_METHODS"),
    "fault kind": ("toolkit.robots.brick_faults", "FAULT_KINDS"),
    "exploration": ("localisation.global_localisation", "EXPLORATIONS"),
    "scen kind": ("toolkit.bench.scen", "EXACT_PLANNER"),
    "peer": ("toolkit.bench.peers", "PEERS"),
    "mission setting": ("toolkit.bench.paper_pareto", "MISSION_SETTINGS"),
    "sonar baseline": ("toolkit.real_sonar.fit", "BASELINES"),
}
"""Kind -> (module, name) of the registry or table whose names a help text lists (imported when help
is printed)."""


def _table_names(module: str, name: str) -> list[str]:
    """The names of a registry (its ``names()``) or of a table (its keys or items), imported now."""
    table = getattr(importlib.import_module(module), name)
    return list(table.names()) if hasattr(table, "names") else list(table)


def _planners() -> list[str]:
    from planners import PLANNERS

    return [*PLANNERS.names(), *(f"{prefix}:NAME" for prefix in PLANNERS.family_prefixes())]


def _figure_jobs() -> list[str]:
    from .figure_jobs import FIGURE_JOBS

    return [job.name for job in FIGURE_JOBS]


CHOICE_SETS: dict[str, Callable[[], list[str]]] = {
    **{kind: functools.partial(_table_names, *where) for kind, where in _TABLES.items()},
    "planner": _planners,
    "figure job": _figure_jobs,
}
"""Kind -> the names a help text lists for it, read from the registry or table that defines them."""

_PLACEHOLDER = re.compile(r"<<choices:([a-z ]+)>>")


def one_of(kind: str) -> str:
    """The placeholder for the names of `kind` (a key of `CHOICE_SETS`) in a help text.

    >>> one_of("sonar")
    '<<choices:sonar>>'
    """
    if kind not in CHOICE_SETS:
        raise KeyError(f"no choice set {kind!r}; known: {', '.join(CHOICE_SETS)}")
    return f"<<choices:{kind}>>"


def choice_names(kind: str) -> list[str]:
    """The names of `kind` as help prints them."""
    return CHOICE_SETS[kind]()


def _filled(text: str | None) -> str | None:
    if not text or "<<choices:" not in text:
        return text
    return _PLACEHOLDER.sub(lambda m: "{" + ", ".join(choice_names(m.group(1))) + "}", text)


def fill_choices(command: Any, args: Sequence[str] | None = None) -> Any:
    """Replace every placeholder in the help of `command` (a click command of the application) and of
    its sub-commands, arguments and options by the names it stands for; returns `command`.

    With `args` (the command line), only the commands it names are filled, so that ``nxtnav --help``
    loads no plug-in registry.
    """
    command.help = _filled(command.help)
    for param in command.params:
        if getattr(param, "help", None):
            param.help = _filled(param.help)
    subs = getattr(command, "commands", {})
    if args is None:
        for sub in subs.values():
            fill_choices(sub)
        return command
    named = next((i for i, a in enumerate(args) if a in subs), None)
    if named is not None:
        fill_choices(subs[args[named]], args[named + 1:])
    return command
