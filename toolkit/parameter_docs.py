"""docs/parameters.md and the plug-ins' JSON Schemas, made from their option models
(`toolkit.world.Options`), so the docs cannot drift.

Regenerate with ``python tools/parameter_docs.py > docs/parameters.md`` and ``python tools/parameter_docs.py
--schemas docs/reference/schemas``; a test checks the committed files equal what this module writes.
"""

from __future__ import annotations

__all__ = ["SCHEMA_FOLDER", "option_schemas", "parameters_markdown"]

SCHEMA_FOLDER = "reference/schemas"
"""Where the schemas live, relative to docs/."""

_HEAD = """# Parameters of the planners and localisers

Every option a planner or a localiser takes, as its options model declares it: type, default, range,
unit and a one-line description. `nxtnav planners show NAME` and `nxtnav localisers show NAME` print the
same; `--set NAME.PATH=VALUE` (`plan`, `localise`, `replay`, `bench localisers`) is checked against it,
and a value out of its range is refused with the range named. A localiser's options are grouped as nav2
groups its parameters (motion model, sensor model, recovery, convergence, ...): the dotted name is the
path, `--set amcl.sensor.z_hit=0.9`; an option given by its bare name when it sits in a group is refused
with its path named. In Python the same options are a model, `Amcl(m, AmclOptions(sensor=AmclSensor(
z_hit=0.9)))`, or keyword overrides, `make_localiser("amcl", m, **{"sensor.z_hit": 0.9})`. Each
plug-in's model is published as a JSON Schema (linked under its heading). This page and the schemas are
generated (`python tools/parameter_docs.py > docs/parameters.md`, `python tools/parameter_docs.py
--schemas docs/reference/schemas`); a test keeps them equal to the models.

Options marked *from the robot model* are set for each run from the one `RobotModel` every localiser is
told (`toolkit/world/robot_model.py`): motion noise, the sonar's sigma, lobe and range limit, the NXT's
beam mixture and the robot's radius. The last table of each localiser says which of its options each facet
of the model becomes, or why it does not use it.
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


def option_schemas() -> dict[str, str]:
    """The JSON Schema of every plug-in's options, by file name (``localiser-amcl.json``)."""
    from toolkit.world.params import json_schema

    return {_schema_file(kind, name): json_schema(model, f"nxtnav {kind} {name} options")
            for kind, name, model in _models()}


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
            parts += [f"| {facet} | {how if isinstance(how, str) else ', '.join(f'`{o}`' for o in how)} |"
                      for facet, how in cls.robot_options.items()]
            parts.append("")
    return "\n".join(parts)
