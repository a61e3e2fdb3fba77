"""docs/parameters.md and its JSON Schemas, made from the typed models that declare every option, so the
docs cannot drift: the plug-ins' options (`toolkit.world.Options`) and the settings sections of ``--set``
(the mission's, the challenge's, the robot model's and the sonar's).

Regenerate with ``python tools/parameter_docs.py > docs/parameters.md`` and ``python tools/parameter_docs.py
--schemas docs/reference/schemas``; a test checks the committed files equal what this module writes.
"""

from __future__ import annotations

from typing import Any

__all__ = ["SCHEMA_FOLDER", "SCHEMA_PATTERNS", "SETTINGS_SECTIONS", "option_schemas", "parameters_markdown",
           "settings_model"]

SCHEMA_FOLDER = "reference/schemas"
"""Where the schemas live, relative to docs/."""

SCHEMA_PATTERNS = ("planner-*.json", "localiser-*.json", "mission.json", "challenge.json")
"""The files of that folder `option_schemas` writes (the file formats' schemas there are `tools/schemas.py`'s)."""

_HEAD = """# Parameters

Every option a planner or a localiser takes, then every setting of the other `--set` sections
(`mission.`, `challenge.`, `robot.`, `sonar.`), as its typed model declares it: type, default, range,
unit and a one-line description. `--set` checks each key and value against the model: an unknown key
is refused with the fields of its group listed, a value out of its range with the range named. This
page and its JSON Schemas (linked under each heading) are generated (`python tools/parameter_docs.py >
docs/parameters.md`, `python tools/parameter_docs.py --schemas docs/reference/schemas`); a test keeps
them equal to the models.

`nxtnav planners show NAME` and `nxtnav localisers show NAME` print a plug-in's options, and
`--set NAME.PATH=VALUE` (`run`, `plan`, `localise`, `replay`, `bench planners`, `bench objectives`,
`bench localisers`) sets one. A localiser's options are grouped as nav2 groups its parameters (motion
model, sensor model, recovery, convergence, ...): the dotted name is the path, `--set
amcl.sensor.z_hit=0.9`; an option given by its bare name when it sits in a group is refused with its
path named. In Python the same options are a model, `Amcl(m, AmclOptions(sensor=AmclSensor(
z_hit=0.9)))`, or keyword overrides, `make_localiser("amcl", m, **{"sensor.z_hit": 0.9})`.

Options marked *from the robot model* are set for each run from the one `RobotModel` every localiser is
told (`toolkit/world/robot_model.py`; its own settings are the `robot.` and `sonar.` sections below):
motion noise, the sonar's sigma, lobe and range limit, the NXT's beam mixture and the robot's radius.
The last table of each localiser says which of its options each facet of the model becomes, or why it
does not use it.
"""


def _schema_file(kind: str, name: str) -> str:
    return f"{kind}-{name.replace(':', '-')}.json"


def _models() -> list[tuple[str, str, type]]:
    """(kind, name, options model) of every bundled plug-in that declares options, and the OMPL wrapper's."""
    from localisation import LOCALISERS
    from planners import PLANNERS
    from planners.declarations import OmplOptions, planner_options

    out: list[tuple[str, str, type]] = []
    for name in PLANNERS.names():
        model = planner_options(name)
        if model is not None:
            out.append(("planner", name, model))
    out.append(("planner", "ompl:NAME", OmplOptions))
    for name in LOCALISERS.names():
        model = LOCALISERS.get(name).options_model
        if model is not None:
            out.append(("localiser", name, model))
    return out


SETTINGS_SECTIONS = ("mission", "challenge", "robot", "sonar")
"""The settings sections of ``--set`` besides the plug-ins' names (``--set SECTION.PATH=VALUE``)."""


def settings_model(section: str, sonar: str = "ideal") -> tuple[type, tuple[str, ...]]:
    """The typed model of a settings section (for ``sonar``, of the sonar model named `sonar`) and the dotted
    fields of it that another section sets (the robot model's ``sonar``: the ``sonar`` section)."""
    from toolkit.mission import MissionConfig
    from toolkit.mission.challenge import ChallengeConfig
    from toolkit.world import ConfigError
    from toolkit.world.robot_model import RobotModel
    from toolkit.world.sonar import SONAR_MODELS

    models: dict[str, tuple[type, tuple[str, ...]]] = {
        "mission": (MissionConfig, ()), "challenge": (ChallengeConfig, ()), "robot": (RobotModel, ("sonar",))}
    if section == "sonar":
        return SONAR_MODELS.get(sonar), ()
    if section not in models:
        raise ConfigError(f"no settings section {section!r}; sections: {', '.join(SETTINGS_SECTIONS)}")
    return models[section]


def _settings_models() -> dict[str, type]:
    """The models of the settings sections that have a schema of their own here, by schema file name."""
    return {"mission.json": settings_model("mission")[0], "challenge.json": settings_model("challenge")[0]}


_SETTINGS_TITLES = {"mission.json": "nxtnav mission settings (--set mission.GROUP.FIELD=VALUE)",
                    "challenge.json": "nxtnav challenge settings (--set challenge.KEY=VALUE)"}


def option_schemas() -> dict[str, str]:
    """The JSON Schema of every plug-in's options and of the mission's and the challenge's settings, by
    file name (``localiser-amcl.json``, ``mission.json``)."""
    from toolkit.world.params import json_schema

    plugins = {_schema_file(kind, name): json_schema(model, f"nxtnav {kind} {name} options")
               for kind, name, model in _models()}
    return {**plugins, **{name: json_schema(model, _SETTINGS_TITLES[name])
                          for name, model in _settings_models().items()}}


def _link(name: str) -> str:
    return f"[{name}]({SCHEMA_FOLDER}/{name})"


def _value_text(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else "null" if value is None else str(value)


def _nxt_tuning() -> str:
    """The mission settings the ``nxt`` sonar's tuning (`MissionConfig.for_sonar`) changes, as ``--set`` texts."""
    from functools import reduce

    from toolkit.mission import MissionConfig
    from toolkit.world.typed import fields_of

    base, nxt = MissionConfig(), MissionConfig.for_sonar("nxt")
    changed = []
    for path, _ in fields_of(MissionConfig):
        value = reduce(getattr, path.split("."), nxt)
        if value != reduce(getattr, path.split("."), base):
            changed.append(f"`mission.{path}={_value_text(value)}`")
    return ", ".join(changed)


def _shorthands() -> str:
    """The shorthand flags of the robot model's fields, as ``--radius`` (``robot.geometry.radius_cm``)."""
    from toolkit.cli.run_config import SHORTHANDS

    return ", ".join(f"`{flag}` ({', '.join(f'`{path}`' for path in paths)})" for flag, paths in SHORTHANDS.items())


def _settings_parts() -> list[str]:
    """The settings sections of ``--set``: what each sets, the commands that take it, its fields."""
    from toolkit.world.params import markdown
    from toolkit.world.sonar import SONAR_MODELS

    def table(section: str, sonar: str = "ideal") -> str:
        model, skipped = settings_model(section, sonar)
        return markdown(model, f"{section}.", skipped)

    parts = [
        "## Settings sections of `--set`", "",
        "The first dotted part of a `--set` key names its section; a key whose first part is no section is "
        "a plug-in's option (above). Each section below names the commands that take it; `nxtnav settings "
        "show SECTION` prints its table (`--sonar NAME` for a sonar model's, `--json` for scripts). `--set` "
        "values are read as YAML (`3`, `0.5`, `true`, `null`, a text) and may also come from a `--config` "
        "file.", "",
        "### `mission.`: how a mission runs", "",
        "`--set mission.GROUP.FIELD=VALUE` on `nxtnav run` (a simulated robot or a real NXT; not with "
        "`--sonar sweeps:DIR`, which runs the challenge) and `nxtnav paper` (every mission it runs). The "
        "defaults below are the ideal sonar's; with the nxt sonar (`--sonar nxt`, or `--robot nxt`) a "
        f"mission starts from its tuning (`MissionConfig.for_sonar`): {_nxt_tuning()}. In Python: "
        "`MissionConfig().with_options(**{\"fix.rule\": \"always\"})`.", "",
        f"JSON Schema: {_link('mission.json')}", "", table("mission"), "",
        "### `challenge.`: the challenge mission", "",
        "`--set challenge.KEY=VALUE` (groups `challenge.fix.KEY`, `challenge.sonar.KEY`) on `nxtnav run "
        "--sonar sweeps:DIR` and `nxtnav bench challenge`, which take no other section "
        "(`toolkit.mission.challenge`, [real sweeps](real-sonar.md)).", "",
        f"JSON Schema: {_link('challenge.json')}", "", table("challenge"), "",
        "### `robot.`: the robot model", "",
        "`--set robot.GROUP.FIELD=VALUE` on `nxtnav run` (a simulated robot: a real NXT's build comes from "
        "its `--profile`), `paper`, `plan`, `localise` and `bench localisers` (`toolkit.world.RobotModel`: "
        "what the simulator, the localisers and the robot-time objective are told). Shorthand flags set the "
        f"same fields: {_shorthands()}; a flag and a `--set` of the same field "
        "on one command line are an error. The sonar is chosen by `--sonar` and its fields are the `sonar.` "
        f"section below. JSON Schema: {_link('robot-model.json')} (the `robot` part of a run's "
        "configuration).", "", table("robot"), "",
        "### `sonar.`: the sonar model", "",
        "`--set sonar.FIELD=VALUE` on `nxtnav run` (a real NXT's too), `paper`, `plan`, `localise` and "
        "`bench localisers`, for the sonar `--sonar` chooses (`ideal` unless given, and on `plan`, which has "
        "no `--sonar`; `paper` sets each of its sonars), and on `nxtnav bench sweeps`, where it sets "
        "the nxt model its localisers are told (the only section that command takes). The fields are the "
        f"sonar model's: the nxt model's are also what a sonar profile holds ({_link('sonar-profile.json')}).", ""]
    for name in SONAR_MODELS.names():
        parts += [f"#### `{name}`", "", table("sonar", name), ""]
    return parts


def _becomes(how: tuple[str | None, ...] | str) -> str:
    """A robot model facet's options as a table cell (a value not used says so), or the reason it is not used."""
    return how if isinstance(how, str) else ", ".join(f"`{o}`" if o else "not used" for o in how)


def parameters_markdown() -> str:
    """The whole page."""
    from localisation import LOCALISERS
    from toolkit.world.params import markdown

    models = {(kind, name): model for kind, name, model in _models()}
    parts = [_HEAD, "## Planners", ""]
    for kind, name in models:
        if kind != "planner" or name == "ompl:NAME":
            continue
        parts += [f"### `{name}`", "", f"JSON Schema: [{_schema_file(kind, name)}]({SCHEMA_FOLDER}/"
                  f"{_schema_file(kind, name)})", "", markdown(models[kind, name]), ""]
    parts += ["### `ompl:NAME` (any OMPL geometric planner)", "",
              "The wrapper's options below, and OMPL's own parameters of planner NAME (every setter with a getter, "
              "named as in OMPL: `--set ompl:RRTstar.GoalBias=0.1`; `nxtnav planners show ompl:NAME` lists them "
              f"with their defaults). JSON Schema of the wrapper's: [{_schema_file('planner', 'ompl:NAME')}]"
              f"({SCHEMA_FOLDER}/{_schema_file('planner', 'ompl:NAME')})", "",
              markdown(models["planner", "ompl:NAME"]), "", "## Localisers", ""]
    for name in LOCALISERS.names():
        cls = LOCALISERS.get(name)
        if ("localiser", name) in models:
            parts += [f"### `{name}`", "", f"JSON Schema: [{_schema_file('localiser', name)}]({SCHEMA_FOLDER}/"
                      f"{_schema_file('localiser', name)})", "", markdown(models["localiser", name]), ""]
        else:
            parts += [f"### `{name}`", "", "No options.", ""]
        if cls.robot_options is not None:
            parts += ["| robot model facet | becomes |", "|---|---|"]
            parts += [f"| {facet} | {_becomes(how)} |" for facet, how in cls.robot_options.items()]
            parts.append("")
    return "\n".join(parts + _settings_parts())
