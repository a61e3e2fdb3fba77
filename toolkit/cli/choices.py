"""Choice lists in help texts, built from the registries they name so that they cannot drift.

A help text says ``"Simulated sonar " + one_of("sonar")``; when help is printed, `fill_choices`
replaces the placeholder with the registry's names as ``{ideal, laser, nxt}``. The registries of the
plug-ins (planners, localisers) load in half a second, so they are read only when help is asked
for, not on every command.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["CHOICE_SETS", "choice_names", "fill_choices", "one_of"]


def _sonars() -> list[str]:
    from ..world import SONAR_MODELS

    return SONAR_MODELS.names()


def _noise_models() -> list[str]:
    from localisation.models import NOISE_MODELS

    return list(NOISE_MODELS)


def _planners() -> list[str]:
    from planners import PLANNERS

    return [*PLANNERS.names(), *(f"{prefix}:NAME" for prefix in PLANNERS.family_prefixes())]


def _localisers() -> list[str]:
    from localisation import LOCALISERS

    return LOCALISERS.names()


def _collision() -> list[str]:
    from ..world import CHECKER_BACKENDS

    return list(CHECKER_BACKENDS)


def _nxt_backends() -> list[str]:
    from ..robots.nxt import BACKENDS

    return list(BACKENDS)


def _tracker_priors() -> list[str]:
    from ..bench.localisers import TRACKER_PRIORS

    return list(TRACKER_PRIORS)


def _scenarios() -> list[str]:
    from ..bench.localisers import SCENARIOS

    return list(SCENARIOS)


def _simplify() -> list[str]:
    from ..bench.planners.simplify import SIMPLIFY_METHODS

    return list(SIMPLIFY_METHODS)


def _fault_kinds() -> list[str]:
    from ..robots.brick_faults import FAULT_KINDS

    return list(FAULT_KINDS)


def _explorations() -> list[str]:
    from localisation.global_localisation import EXPLORATIONS

    return list(EXPLORATIONS)


def _scen_kinds() -> list[str]:
    from ..bench.scen import EXACT_PLANNER

    return list(EXACT_PLANNER)


def _peers() -> list[str]:
    from ..bench.peers import PEERS

    return list(PEERS)


def _mission_settings() -> list[str]:
    from ..bench.paper_pareto import MISSION_SETTINGS

    return list(MISSION_SETTINGS)


def _figure_jobs() -> list[str]:
    from .figure_jobs import FIGURE_JOBS

    return [job.name for job in FIGURE_JOBS]


def _sonar_baselines() -> list[str]:
    from ..sonar_fit import BASELINES

    return list(BASELINES)


CHOICE_SETS: dict[str, Callable[[], list[str]]] = {
    "sonar": _sonars,
    "noise model": _noise_models,
    "planner": _planners,
    "localiser": _localisers,
    "collision": _collision,
    "nxt backend": _nxt_backends,
    "tracker prior": _tracker_priors,
    "scenario": _scenarios,
    "simplify": _simplify,
    "fault kind": _fault_kinds,
    "exploration": _explorations,
    "scen kind": _scen_kinds,
    "peer": _peers,
    "mission setting": _mission_settings,
    "figure job": _figure_jobs,
    "sonar baseline": _sonar_baselines,
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
