"""``--set [NAME.]KEY=VALUE``: plug-in options checked against their declarations (`toolkit.world.Params`).

A key with a plug-in name (``amcl.min_particles=50``) applies to that plug-in; a bare key applies to every
chosen plug-in that declares it. Each value is read as YAML (``3``, ``0.5``, ``true``, ``null``, a text) and
checked against the option's declared type and range; an unknown plug-in or key, or a bad value, is one
line naming it (exit 2). A plug-in that declares no options takes none.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from toolkit.world import ConfigError, NxtnavError, Params

__all__ = ["checked_sets", "localiser_sets", "parse_sets"]


def parse_sets(values: list[str], option: str = "--set") -> dict[str, dict[str, str]]:
    """``NAME.KEY=VALUE`` texts by plug-in name (``*`` for a bare ``KEY=VALUE``), values as given."""
    out: dict[str, dict[str, str]] = {}
    for text in values:
        key, sep, raw = text.partition("=")
        if not sep or not key.strip():
            raise NxtnavError(f"{option}: expected KEY=VALUE or NAME.KEY=VALUE, got {text!r}")
        name, dot, k = key.strip().rpartition(".")
        out.setdefault(name if dot else "*", {})[k] = raw
    return out


def checked_sets(sets: dict[str, dict[str, str]], names: list[str], declared: Callable[[str], Params | None],
                 kind: str = "plug-in", option: str = "--set") -> dict[str, dict[str, Any]]:
    """Per chosen plug-in (`names`), its options from `sets`, parsed and checked against `declared(name)`."""
    unknown = [n for n in sets if n != "*" and n not in names]
    if unknown:
        raise NxtnavError(f"{option}: options for {', '.join(unknown)}, which is not among {', '.join(names)}")
    out: dict[str, dict[str, Any]] = {}
    for n in names:
        params = declared(n) or Params()
        own = sets.get(n, {})
        bad = [k for k in own if k not in params]
        if bad:
            raise NxtnavError(f"{option}: {n} has no option {', '.join(bad)}; its options: "
                              f"{', '.join(params.names) or 'none'}")
        texts = {**{k: v for k, v in sets.get("*", {}).items() if k in params}, **own}
        try:
            opts = {k: params.parse(k, v) for k, v in texts.items()}
        except ConfigError as exc:
            raise NxtnavError(f"{option} {n}.{exc}") from None
        if opts:
            out[n] = opts
    stray = [k for k in sets.get("*", {}) if not any(k in out.get(n, {}) for n in names)]
    if stray:
        raise NxtnavError(f"{option}: no chosen {kind} has an option {', '.join(stray)}")
    return out


def localiser_sets(sets: list[str], names: list[str]) -> dict[str, dict[str, Any]]:
    """Per chosen localiser (registry names), its ``--set`` options checked against its declarations."""
    from localisation.base import LOCALISERS

    return checked_sets(parse_sets(sets), names, lambda n: LOCALISERS.get(n).params, "localiser")
