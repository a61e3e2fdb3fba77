"""`nxtnav planners list|show` and `nxtnav localisers list|show`: the plug-ins and their declared options."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.table import Table

from toolkit.world import NxtnavError, Params

from .app import localisers_app, planners_app
from .choices import one_of

__all__: list[str] = []


def _table(title: str, params: Params) -> Table:
    table = Table("option", "type", "default", "range", "unit", "description", title=title)
    for p in params:
        default = "null" if p.default is None else str(p.default).lower() if isinstance(p.default, bool) else str(
            p.default)
        table.add_row(p.name, p.type_name, default, p.range_text, p.unit,
                      p.description + (" [dim](from the robot model)[/dim]" if p.robot else ""))
    return table


@planners_app.command("list")
def planners_list() -> None:
    """The registered planners (and the OMPL family, ompl:NAME)."""
    from planners import PLANNERS
    from planners.ompl_planners import ompl_planner_names

    for name in PLANNERS.names():
        typer.echo(name)
    typer.echo(f"ompl:NAME for NAME in {', '.join(ompl_planner_names())}")


@planners_app.command("show")
def planners_show(name: str = typer.Argument(..., help="A planner " + one_of("planner") + ".")) -> None:
    """A planner's declared options: name, type, default, range, unit, description (`--set NAME.KEY=VALUE`)."""
    from planners import PLANNERS
    from planners.declarations import planner_params

    if name not in PLANNERS:
        raise NxtnavError(f"unknown planner {name!r}; known: {', '.join(PLANNERS.names())} and ompl:NAME")
    params = planner_params(name)
    if not params:
        typer.echo(f"{name} declares no options")
        return
    Console().print(_table(f"{name}: options (--set {name}.KEY=VALUE)", params))


@localisers_app.command("list")
def localisers_list() -> None:
    """The registered localisers."""
    from localisation import LOCALISERS

    for name in LOCALISERS.names():
        typer.echo(name)


@localisers_app.command("show")
def localisers_show(name: str = typer.Argument(..., help="A localiser " + one_of("localiser") + ".")) -> None:
    """A localiser's declared options and how it takes each facet of the robot model."""
    from localisation import LOCALISERS

    if name not in LOCALISERS:
        raise NxtnavError(f"unknown localiser {name!r}; known: {', '.join(LOCALISERS.names())}")
    cls = LOCALISERS.get(name)
    if cls.params:
        Console().print(_table(f"{name}: options (--set {name}.KEY=VALUE)", cls.params))
    else:
        typer.echo(f"{name} declares no options")
    mapping = cls.robot_options
    if mapping is None:
        typer.echo(f"{name} cannot be told a robot model")
        return
    robot = Table("robot model facet", "becomes", title=f"{name}: the robot model (the same for every localiser)")
    for facet, how in mapping.items():
        robot.add_row(facet, how if isinstance(how, str) else ", ".join(how))
    Console().print(robot)
