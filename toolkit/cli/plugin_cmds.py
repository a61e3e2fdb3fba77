"""`nxtnav planners list|show|check` and `nxtnav localisers list|show|check`: the plug-ins, their declared
options, and a check of a plug-in of your own against what the test suite demands; `nxtnav settings show`:
the fields of a settings section of ``--set`` (mission, challenge, robot, sonar)."""

from __future__ import annotations

import typer
from rich.table import Table

from toolkit.parameter_docs import SETTINGS_SECTIONS
from toolkit.world import NxtnavError
from toolkit.world.params import describe

from .app import localisers_app, planners_app, settings_app
from .choices import one_of
from .options import JsonFlag
from .tables import NEVER_CUT, print_json, print_table

__all__: list[str] = []


def _default_text(default: object) -> str:
    return "null" if default is None else str(default).lower() if isinstance(default, bool) else str(default)


def _params_doc(model: type | None, prefix: str = "", exclude: tuple[str, ...] = ()) -> list[dict[str, object]]:
    """The options as JSON-ready dicts: dotted name, type, default, range, unit, description, robot."""
    return [o.to_dict() for o in describe(model, prefix, exclude)] if model is not None else []


def _table(title: str, model: type, prefix: str = "", exclude: tuple[str, ...] = ()) -> Table:
    table = Table(title=title)
    table.add_column("option", **NEVER_CUT)  # type: ignore[arg-type]
    for column in ("type", "default", "range", "unit", "description"):
        table.add_column(column)
    for p in describe(model, prefix, exclude):
        default = _default_text(p.default)
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
def planners_show(name: str = typer.Argument(..., help="A planner " + one_of("planner") + "."),
                  as_json: JsonFlag = False) -> None:
    """A planner's declared options: name, type, default, range, unit, description (`--set NAME.KEY=VALUE`)."""
    from planners import PLANNERS
    from planners.declarations import planner_options

    if name not in PLANNERS:
        raise NxtnavError(f"unknown planner {name!r}; known: {', '.join(PLANNERS.names())} and ompl:NAME")
    params = planner_options(name)
    if as_json:
        print_json({"planner": name, "options": _params_doc(params)})
        return
    if params is None or not params.model_fields:
        typer.echo(f"{name} declares no options")
        return
    print_table(_table(f"{name}: options (--set {name}.PATH=VALUE)", params))


@localisers_app.command("list")
def localisers_list() -> None:
    """The registered localisers."""
    from localisation import LOCALISERS

    for name in LOCALISERS.names():
        typer.echo(name)


@localisers_app.command("show")
def localisers_show(name: str = typer.Argument(..., help="A localiser " + one_of("localiser") + "."),
                    as_json: JsonFlag = False) -> None:
    """A localiser's declared options and how it takes each facet of the robot model."""
    from localisation import LOCALISERS

    if name not in LOCALISERS:
        raise NxtnavError(f"unknown localiser {name!r}; known: {', '.join(LOCALISERS.names())}")
    cls = LOCALISERS.get(name)
    mapping = cls.robot_options
    if as_json:
        robot = None if mapping is None else {k: v if isinstance(v, str) else list(v) for k, v in mapping.items()}
        print_json({"localiser": name, "options": _params_doc(cls.options_model), "robot_model": robot})
        return
    if cls.options_model is not None and cls.options_model.model_fields:
        print_table(_table(f"{name}: options (--set {name}.PATH=VALUE)", cls.options_model))
    else:
        typer.echo(f"{name} declares no options")
    if mapping is None:
        typer.echo(f"{name} cannot be told a robot model")
        return
    robot_table = Table(title=f"{name}: the robot model (the same for every localiser)")
    robot_table.add_column("robot model facet", **NEVER_CUT)  # type: ignore[arg-type]
    robot_table.add_column("becomes")
    for facet, how in mapping.items():
        robot_table.add_row(facet, how if isinstance(how, str) else ", ".join(o or "not used" for o in how))
    print_table(robot_table)


@settings_app.command("show")
def settings_show(section: str = typer.Argument(..., help=f"A settings section {{{', '.join(SETTINGS_SECTIONS)}}}."),
                  sonar: str | None = typer.Option(None, "--sonar", help="With the sonar section: the sonar model "
                                                   "whose fields are shown " + one_of("sonar") + " (default ideal)."),
                  as_json: JsonFlag = False) -> None:
    """A settings section's fields, as --set SECTION.PATH=VALUE names them: type, default, range, unit,
    description (docs/parameters.md says which commands take each section)."""
    from toolkit.parameter_docs import settings_model

    if sonar is not None and section != "sonar":
        raise NxtnavError(f"--sonar: only with the sonar section, not {section}")
    sonar = sonar or "ideal"
    model, skipped = settings_model(section, sonar)
    if as_json:
        print_json({"section": section, **({"sonar": sonar} if section == "sonar" else {}),
                    "settings": _params_doc(model, f"{section}.", skipped)})
        return
    title = f"{section}{f' ({sonar})' if section == 'sonar' else ''}: settings (--set {section}.PATH=VALUE)"
    print_table(_table(title, model, f"{section}.", skipped))


def _load_plugin_class(spec: str, base: type, kind: str) -> type:
    """The class named by ``MODULE:CLASS`` (the current folder is searched first, as ``python -m`` does),
    which must subclass `base`; a bad spec, a module that cannot be imported or a missing class is a
    `NxtnavError` naming it."""
    import importlib
    import os
    import sys

    module_name, sep, class_name = spec.partition(":")
    if not sep or not module_name or not class_name or ":" in class_name:
        raise NxtnavError(f"expected MODULE:CLASS (e.g. my_{kind}s:My{kind.title()}), got {spec!r}")
    if os.getcwd() not in sys.path:
        sys.path.insert(0, os.getcwd())
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        raise NxtnavError(f"{spec}: no module named {exc.name!r} (run from the folder that holds "
                          f"{module_name.replace('.', '/')}.py, or install it)") from None
    except Exception as exc:  # the user's module failed while it was imported
        raise NxtnavError(f"{spec}: importing {module_name} raised {type(exc).__name__}: "
                          f"{' '.join(str(exc).split())}") from None
    cls = getattr(module, class_name, None)
    if cls is None:
        raise NxtnavError(f"{spec}: module {module_name} has no {class_name!r}")
    if not (isinstance(cls, type) and issubclass(cls, base)):
        raise NxtnavError(f"{spec}: {class_name} is not a {kind} class (a subclass of {base.__module__}."
                          f"{base.__qualname__})")
    return cls


def _report(spec: str, kind: str, problems: list[str]) -> None:
    """The problems one per line on stdout, exit 1; or one line saying the class passes."""
    for problem in problems:
        typer.echo(f"{spec}: {problem}")
    if problems:
        typer.echo(f"{spec}: {len(problems)} problem{'s' if len(problems) > 1 else ''}; see the how-to guide "
                   f"for a {kind} (docs/howto/{kind}.md)", err=True)
        raise typer.Exit(1)
    typer.echo(f"{spec}: passes the {kind} checks")


@planners_app.command("check")
def planners_check(spec: str = typer.Argument(..., metavar="MODULE:CLASS",
                                              help="Your planner class, e.g. detour:DetourPlanner")) -> None:
    """Check a planner plug-in as the test suite does: registered, declared options, a valid and seeded
    path on map1's preset query. One line per problem, exit 1 if any; exit 2 for a bad MODULE:CLASS."""
    from planners import Planner
    from planners.conformance import check_planner

    cls = _load_plugin_class(spec, Planner, "planner")
    _report(spec, "planner", check_planner(cls))


@localisers_app.command("check")
def localisers_check(spec: str = typer.Argument(..., metavar="MODULE:CLASS",
                                                help="Your localiser class, e.g. my_mcl:MclLocaliser")) -> None:
    """Check a localiser plug-in as the test suite does: registered, declared options, every facet of the
    robot model taken or refused with a reason, seeded tracking. One line per problem, exit 1 if any;
    exit 2 for a bad MODULE:CLASS."""
    from localisation import Localiser
    from localisation.conformance import check_localiser

    cls = _load_plugin_class(spec, Localiser, "localiser")
    _report(spec, "localiser", check_localiser(cls))
