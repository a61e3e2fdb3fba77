"""docs/parameters.md made from the plug-ins' declarations (`toolkit.world.Params`), so the docs cannot drift.

Regenerate with ``python tools/parameter_docs.py > docs/parameters.md``; a test checks the file equals
what this module writes.
"""

from __future__ import annotations

__all__ = ["parameters_markdown"]

_HEAD = """# Parameters of the planners and localisers

Every option a planner or a localiser takes, as it declares it: type, default, range, unit and a
one-line description. `nxtnav planners show NAME` and `nxtnav localisers show NAME` print the same;
`--set NAME.KEY=VALUE` (`plan`, `localise`, `bench localisers`) is checked against it, and a value out of
its range is refused with the range named. This page is generated (`python tools/parameter_docs.py >
docs/parameters.md`); a test keeps it equal to the declarations.

Options marked *from the robot model* are set for each run from the one `RobotModel` every localiser is
told (`toolkit/world/robot_model.py`): motion noise, the sonar's sigma, lobe and range limit, the NXT's
beam mixture and the robot's radius. The last table of each localiser says which of its options each facet
of the model becomes, or why it does not use it.
"""


def parameters_markdown() -> str:
    """The whole page."""
    from localisation import LOCALISERS
    from planners import PLANNERS
    from planners.declarations import OMPL_PARAMS, planner_params

    parts = [_HEAD, "## Planners", ""]
    for name in PLANNERS.names():
        params = planner_params(name)
        parts += [f"### `{name}`", "", params.markdown() if params else "No options.", ""]
    parts += ["### `ompl:NAME` (any OMPL geometric planner)", "",
              "The wrapper's options below, and OMPL's own parameters of planner NAME (every setter with a getter, "
              "named as in OMPL: `--set ompl:RRTstar.GoalBias=0.1`; `nxtnav planners show ompl:NAME` lists them "
              "with their defaults).", "", OMPL_PARAMS.markdown(), "", "## Localisers", ""]
    for name in LOCALISERS.names():
        cls = LOCALISERS.get(name)
        parts += [f"### `{name}`", "", cls.params.markdown() if cls.params else "No options.", ""]
        if cls.robot_options is not None:
            parts += ["| robot model facet | becomes |", "|---|---|"]
            parts += [f"| {facet} | {how if isinstance(how, str) else ', '.join(f'`{o}`' for o in how)} |"
                      for facet, how in cls.robot_options.items()]
            parts.append("")
    return "\n".join(parts)
