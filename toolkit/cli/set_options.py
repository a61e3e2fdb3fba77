"""``--set [NAME.]PATH=VALUE``: plug-in options checked against their models (`toolkit.world.Options`).

A key with a plug-in name (``amcl.min_particles=50``, ``amcl.sensor.z_hit=0.9``: the option's dotted
path in its groups) applies to that plug-in; a bare path applies to every chosen plug-in that has it.
Each value is read as YAML (``3``, ``0.5``, ``true``, ``null``, a text) and checked against the option's
type and range; an unknown plug-in or key, a grouped option given by its bare name, or a bad value is
one line naming it (exit 2). A plug-in that declares no options takes none.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from toolkit.world import ConfigError, NxtnavError, Options
from toolkit.world.params import grouped_paths, groups, option_names, resolve
from toolkit.world.params import parse_sets as parse_option_texts

__all__ = ["checked_sets", "localiser_sets", "parse_sets"]


def parse_sets(values: list[str], option: str = "--set") -> dict[str, dict[str, str]]:
    """``NAME.PATH=VALUE`` texts by plug-in name (the text before the first dot; ``*`` for a bare
    ``KEY=VALUE``), values as given."""
    out: dict[str, dict[str, str]] = {}
    for text in values:
        key, sep, raw = text.partition("=")
        if not sep or not key.strip():
            raise NxtnavError(f"{option}: expected KEY=VALUE or NAME.KEY=VALUE, got {text!r}")
        name, dot, path = key.strip().partition(".")
        out.setdefault(name if dot else "*", {})[path if dot else name] = raw
    return out


def _declares(model: type[Options] | None, key: str) -> bool:
    try:
        return model is not None and bool(resolve(model, key, bare=False))
    except ConfigError:
        return False


def _key_problem(n: str, model: type[Options], keys: list[str], option: str) -> NxtnavError:
    """The error for keys of plug-in `n` its model does not have: the dotted path of a grouped option
    given by its bare name, else the options it has."""
    for key in keys:
        paths = grouped_paths(model, key)
        if paths:
            return NxtnavError(f"{option} {n}.{key}: the options are grouped: use "
                               f"{' or '.join(f'{n}.{p}' for p in paths)}")
    return NxtnavError(f"{option}: {n} has no option {', '.join(keys)}; its options: {option_names(model)}")


def checked_sets(sets: dict[str, dict[str, str]], names: list[str], declared: Callable[[str], type[Options] | None],
                 kind: str = "plug-in", option: str = "--set") -> dict[str, dict[str, Any]]:
    """Per chosen plug-in (`names`), its options from `sets` by dotted path, parsed and checked against
    the model `declared(name)`."""
    models = {n: declared(n) for n in names}
    sets = dict(sets)
    for n in [n for n in sets if n != "*" and n not in names]:  # a bare dotted path: group.key
        if any(m is not None and n in groups(m) for m in models.values()):
            sets["*"] = {**sets.get("*", {}), **{f"{n}.{k}": v for k, v in sets.pop(n).items()}}
    unknown = [n for n in sets if n != "*" and n not in names]
    if unknown:
        raise NxtnavError(f"{option}: options for {', '.join(unknown)}, which is not among {', '.join(names)}")
    bare = sets.get("*", {})
    out: dict[str, dict[str, Any]] = {}
    for n, model in models.items():
        own = sets.get(n, {})
        if model is None:
            if own:
                raise NxtnavError(f"{option}: {n} has no option {', '.join(own)}; its options: none")
            continue
        stray = [k for k in own if not _declares(model, k)]
        if stray:
            raise _key_problem(n, model, stray, option)
        try:
            opts = parse_option_texts(model, {**{k: v for k, v in bare.items() if _declares(model, k)}, **own})
        except ConfigError as exc:
            raise NxtnavError(f"{option} {n}.{exc}") from None
        if opts:
            out[n] = opts
    for k in bare:
        if not any(_declares(m, k) for m in models.values()):
            grouped = [p for m in models.values() if m is not None for p in grouped_paths(m, k)]
            if grouped:
                raise NxtnavError(f"{option} {k}: the options are grouped: use {' or '.join(sorted(set(grouped)))}")
            raise NxtnavError(f"{option}: no chosen {kind} has an option {k}")
    return out


def localiser_sets(sets: list[str], names: list[str]) -> dict[str, dict[str, Any]]:
    """Per chosen localiser (registry names), its ``--set`` options checked against its options model."""
    from localisation.base import LOCALISERS

    return checked_sets(parse_sets(sets), names, lambda n: LOCALISERS.get(n).options_model, "localiser")
