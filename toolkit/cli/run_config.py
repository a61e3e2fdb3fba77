"""One override syntax and reproducible runs: ``--set section.key=value`` and ``--config FILE``.

``--set`` takes settings sections and plug-in options alike; the first dotted part names the section:

- ``mission.GROUP.FIELD=V``: the mission settings (`toolkit.mission.MissionConfig`, e.g.
  ``mission.drive.move_step_cm=20`` or ``mission.fix.rule=always``), through `toolkit.world.typed.with_sets`;
- ``robot.GROUP.FIELD=V`` and ``sonar.FIELD=V``: the robot model (`toolkit.world.RobotModel`: ``motion``,
  ``geometry``, ``timing``; the sonar's own parameters), through the same `with_sets` (`robot_model`). The
  shorthand flags (`SHORTHANDS`: ``--radius``, ``--noise``, ``--drive-speed``, ...) set the same fields;
  a flag and a ``--set`` of the same field on one command line are an error;
- ``PLUGIN.KEY=V`` or a bare ``KEY=V``: a chosen planner's or localiser's options
  (`toolkit.cli.set_options`, unchanged);
- ``challenge.KEY=V``: the challenge mission's settings (`toolkit.mission.challenge.ChallengeConfig`) on the
  commands that run it (`section_settings`).

Every command that runs something writes its effective configuration into its outputs
(`configuration`: the command, every option that shapes the result, the ``--set`` list and the
resulting mission settings). ``--config FILE`` reads such a file back (the JSON output itself, or the
``configuration`` part of it alone): its options become the command's defaults, so options given on the
command line win and ``--set`` values given there apply after the file's; the run is the same.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import typer

from ..world import ConfigError, NxtnavError
from ..world.bundled import data_path
from ..world.typed import with_sets
from ..world.yaml_text import YAMLError, load_yaml

if TYPE_CHECKING:
    from ..mission import MissionConfig
    from ..world import RobotModel

__all__ = ["SECTIONS", "SHORTHANDS", "add_configuration", "configuration", "dumps", "given_sets", "load_config",
           "mission_config", "mission_sets", "plugin_sets", "robot_model", "robot_sets", "section_settings",
           "split_sets"]

SECTIONS = ("mission", "robot", "sonar")
"""The settings sections ``--set`` knows besides the plug-ins' names."""

SHORTHANDS: dict[str, tuple[str, ...]] = {
    "--radius": ("robot.geometry.radius_cm",),
    "--noise": ("robot.sonar.noise_sd", "robot.motion.motion", "robot.motion.turn"),
    "--sensor-noise": ("robot.sonar.noise_sd",),
    "--noise-model": ("robot.motion.model",),
    "--motion-noise": ("robot.motion.motion",),
    "--turn-noise": ("robot.motion.turn",),
    "--drive-speed": ("robot.timing.drive_speed_cm_s",),
    "--turn-rate": ("robot.timing.turn_rate_deg_s",),
    "--stop-turn": ("robot.timing.stop_turn_s",),
}
"""The robot model's fields each shorthand flag sets (``--set sonar.KEY`` is ``robot.sonar.KEY``)."""

_NOT_CONFIGURATION = frozenset({
    "json_out", "plot", "animate", "record", "view", "view_save", "markdown", "pareto", "out", "output",
    "force", "config_file", "sets", "dask", "workers", "recordings"})
"""Parameters that say where results go or how they are computed, not what they are."""

_META = "nxtnav.config.sets"

M = TypeVar("M")
"""Where `load_config` leaves the ``--set`` list of the file in the click context."""


def split_sets(values: list[str]) -> tuple[dict[str, dict[str, str]], list[str]]:
    """``--set`` values of the settings sections (`SECTIONS`) by section, keys without the section; and the
    rest (plug-in options) as given."""
    sections: dict[str, dict[str, str]] = {}
    rest: list[str] = []
    for text in values:
        key, sep, raw = text.partition("=")
        section, dot, inner = key.strip().partition(".")
        if sep and dot and section in SECTIONS:
            if not inner:
                raise NxtnavError(f"--set: expected {section}.KEY=VALUE, got {text!r}")
            sections.setdefault(section, {})[inner] = raw
        elif sep and key.strip() in SECTIONS:
            raise NxtnavError(f"--set: {key.strip()} is a section; give {key.strip()}.KEY=VALUE, got {text!r}")
        else:
            rest.append(text)
    return sections, rest


def plugin_sets(ctx: typer.Context, sets: list[str], takes: tuple[str, ...]) -> list[str]:
    """The plug-in options among the ``--set`` values (`given_sets`) of the command `ctx` runs, which takes the
    settings sections `takes` (read elsewhere) and no other: a section it does not take is one line naming
    it, never silently ignored."""
    every = given_sets(ctx, sets)
    sections, plugins = split_sets(every)
    for section, keys in sections.items():
        if section not in takes:
            key = next(iter(keys))
            raise NxtnavError(f"--set {section}.{key}: nxtnav {_command(ctx)} takes no {section} settings"
                              f" (it takes {', '.join(f'{t}.' for t in takes)} and the plug-ins' options)")
    return plugins


def mission_sets(sets: list[str]) -> dict[str, str]:
    """The ``mission.`` settings of `sets` (dotted keys below the section, values as typed)."""
    return split_sets(sets)[0].get("mission", {})


def mission_config(sonar: str, sets: list[str], collision: str = "index", **fields: Any) -> MissionConfig:
    """The mission settings of a run on `sonar`: its tuning (`MissionConfig.for_sonar`), the backend and
    `fields`, then the ``mission.`` values of `sets`; a bad key or value is one line naming it."""
    from ..mission import MissionConfig

    base = MissionConfig.for_sonar(sonar, collision=collision).model_copy(update=fields)
    own = mission_sets(sets)
    try:
        return with_sets(base, own, "--set mission") if own else base
    except ConfigError as exc:
        raise NxtnavError(str(exc)) from None


def section_settings(model: M, sets: list[str], section: str, command: str) -> M:
    """`model` with the ``SECTION.KEY=VALUE`` values of `sets` applied (`with_sets`) for a command whose only
    settings are that section's; anything else in `sets` is one line naming the command and the section."""
    own: dict[str, str] = {}
    for text in sets:
        key, sep, raw = text.partition("=")
        head, dot, inner = key.strip().partition(".")
        if not (sep and dot and inner and head == section):
            raise NxtnavError(f"--set: nxtnav {command} takes {section} settings ({section}.KEY=VALUE), got {text!r}")
        own[inner] = raw
    try:
        return with_sets(model, own, f"--set {section}")
    except ConfigError as exc:
        raise NxtnavError(str(exc)) from None


def _field_of(section: str, key: str) -> str:
    """The robot model's field a ``robot.`` or ``sonar.`` key names, as ``robot.sonar.noise_sd``."""
    return f"robot.{key}" if section == "robot" else f"robot.sonar.{key}"


def _shorthand_clash(ctx: typer.Context | None, command_line: list[str]) -> None:
    """A one-line error when a shorthand flag given on the command line and a ``--set`` given there set
    the same field of the robot model."""
    if ctx is None:
        return
    given = {opt for p in ctx.command.params if p.name is not None  # typer has its own click: compare by name
             and getattr(ctx.get_parameter_source(p.name), "name", "") == "COMMANDLINE" for opt in p.opts}
    sections = split_sets(command_line)[0]
    keys = [(f"{section}.{key}", _field_of(section, key)) for section in ("robot", "sonar")
            for key in sections.get(section, {})]
    for flag, fields in SHORTHANDS.items():
        for typed, field in keys:
            hit = [f for f in fields if f == field or f.startswith(field + ".")]  # the field, or its group
            if flag in given and hit:
                raise NxtnavError(f"--set {typed} and {flag} both set {hit[0]}; give one of them")


def robot_model(base: RobotModel, sets: list[str], ctx: typer.Context | None = None,
                command_line: list[str] | None = None) -> RobotModel:
    """`base` (the robot the command's flags describe) with the ``robot.`` and ``sonar.`` settings of `sets`;
    a bad key or value is one line naming it (``--set: robot.timing.drive_speed_cm_s: -1 must be ...``).
    With `ctx`, a ``--set`` of `command_line` and a shorthand flag given there for the same field are an
    error."""
    from ..world.robot_model import with_robot_sets

    _shorthand_clash(ctx, command_line or [])
    try:
        return with_robot_sets(base, robot_sets(sets))
    except ConfigError as exc:
        raise NxtnavError(str(exc)) from None


def robot_sets(sets: list[str]) -> dict[str, str]:
    """The ``robot.`` and ``sonar.`` settings of `sets`, by their whole key (``robot.timing.drive_speed_cm_s``)."""
    sections = split_sets(sets)[0]
    return {f"{section}.{key}": text for section in ("robot", "sonar")
            for key, text in sections.get(section, {}).items()}


def given_sets(ctx: typer.Context, sets: list[str]) -> list[str]:
    """The ``--set`` values of the ``--config`` file (if one was given to the command of `ctx`), then those of
    the command line."""
    return list(ctx.meta.get(_META, [])) + list(sets)


def _plain(value: Any) -> Any:
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _command(ctx: typer.Context) -> str:
    """The command `ctx` runs, as typed after ``nxtnav`` (``run``, ``bench localisers``)."""
    return ctx.command_path.removeprefix(f"{ctx.find_root().info_name} ").strip()


def _flags(ctx: typer.Context) -> dict[str, str]:
    """Each option of the command `ctx` runs by its long name without dashes (``map``), to its parameter."""
    return {max(p.opts, key=len).lstrip("-"): p.name for p in ctx.command.params
            if p.name is not None and p.opts and p.name not in _NOT_CONFIGURATION}


def configuration(ctx: typer.Context, sets: list[str], **extra: Any) -> dict[str, Any]:
    """The effective configuration of the command `ctx` runs: its name, every option that shapes the result
    by its name on the command line (``map``, ``noise-model``; as typed, after the ``--config`` file's), the
    whole ``--set`` list and `extra` (the mission settings)."""
    options = {flag: _plain(ctx.params[name]) for flag, name in _flags(ctx).items()
               if ctx.params.get(name) is not None}
    return {"command": _command(ctx), "options": options, "set": given_sets(ctx, sets), **extra}


def _configuration_in(doc: Any, path: Path) -> dict[str, Any]:
    """The configuration a file holds: itself, its ``configuration`` part, or the first table's (paper)."""
    if isinstance(doc, list) and doc and isinstance(doc[0], dict):
        doc = doc[0]
    if isinstance(doc, dict) and isinstance(doc.get("configuration"), dict):
        doc = doc["configuration"]
    if not (isinstance(doc, dict) and isinstance(doc.get("command"), str) and isinstance(doc.get("options"), dict)):
        raise typer.BadParameter(f"{path} holds no run configuration (no 'command' and 'options'; give a "
                                 "configuration or the JSON output of a run)")
    return doc


def load_config(ctx: typer.Context, param: typer.CallbackParam, value: Any) -> Any:
    """Eager callback of ``--config FILE``: the file's options become the command's defaults (those given on
    the command line win) and its ``--set`` list goes before the command line's (`given_sets`)."""
    if value is None or ctx.resilient_parsing:
        return value
    path = data_path(value)
    try:
        doc = load_yaml(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, YAMLError) as exc:
        raise typer.BadParameter(f"cannot read {path}: {' '.join(str(exc).split())}") from None
    conf = _configuration_in(doc, Path(path))
    command = _command(ctx)
    if conf["command"] != command:
        raise typer.BadParameter(f"{path} configures 'nxtnav {conf['command']}', not 'nxtnav {command}'")
    flags = _flags(ctx)
    unknown = sorted(k for k in conf["options"] if k.lstrip("-") not in flags)
    if unknown:
        raise typer.BadParameter(f"{path}: options of no 'nxtnav {command}': {', '.join(unknown)}")
    sets = conf.get("set", [])
    if not (isinstance(sets, list) and all(isinstance(s, str) for s in sets)):
        raise typer.BadParameter(f"{path}: set must be a list of KEY=VALUE texts, got {sets!r}")
    ctx.default_map = {**(ctx.default_map or {}), **{flags[k.lstrip("-")]: v for k, v in conf["options"].items()}}
    ctx.meta[_META] = sets
    return value


def add_configuration(path: Path, conf: dict[str, Any]) -> None:
    """Put `conf` into the JSON object the file `path` holds (a benchmark's ``config.json``)."""
    doc = json.loads(path.read_text(encoding="utf-8"))
    path.write_text(json.dumps({**doc, "configuration": conf}, indent=1, default=str), encoding="utf-8")


def dumps(doc: Any) -> str:
    """`doc` as the JSON the outputs write (no NaN)."""
    from ..number_format import json_safe

    return json.dumps(json_safe(doc), indent=1, allow_nan=False)
