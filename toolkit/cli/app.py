"""The `nxtnav` command: the Typer application, its sub-groups and the error boundary."""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Sequence
from typing import Any

import typer
from typer.exceptions import TyperException

from ..world import NxtnavError

__all__ = ["EXIT_BAD_INPUT", "EXIT_FAILED", "EXIT_INTERRUPTED", "EXIT_OK", "Interrupted", "app", "bench_app",
           "brick_app", "click_command", "fail", "import_app", "main", "maps_app", "nxt_app", "settings_app",
           "sonar_app"]

EXIT_OK = 0
"""The command did what was asked."""
EXIT_FAILED = 1
"""The command ran, but the plan or the mission failed (no path, target not reached)."""
EXIT_BAD_INPUT = 2
"""Bad input: an option, a file or a value is wrong (the one-line message says which)."""
EXIT_INTERRUPTED = 130
"""Interrupted (Ctrl-C); whatever was finished has been kept (the message says where)."""

_SETTINGS = {"help_option_names": ["-h", "--help"]}

app = typer.Typer(
    name="nxtnav",
    help="Localisation and navigation with one rotating ultrasonic sensor (LEGO NXT and simulation).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings=_SETTINGS,
)
maps_app = typer.Typer(help="List and draw maps.", no_args_is_help=True, context_settings=_SETTINGS)
bench_app = typer.Typer(help="Benchmarks (planners, localisers, world throughput).", no_args_is_help=True,
                        context_settings=_SETTINGS)
nxt_app = typer.Typer(help="A real LEGO NXT: check the link, calibrate.", no_args_is_help=True,
                      context_settings=_SETTINGS)
brick_app = typer.Typer(help="The virtual NXT brick (a simulated robot behind nxt-python's socket protocol).",
                        no_args_is_help=True, context_settings=_SETTINGS)
import_app = typer.Typer(help="Turn data taken elsewhere into recordings that nxtnav replay scores.",
                         no_args_is_help=True, context_settings=_SETTINGS)
sonar_app = typer.Typer(help="The nxt sonar model against real sweeps: fit a profile, score a model, leave one "
                             "source out.", no_args_is_help=True, context_settings=_SETTINGS)
planners_app = typer.Typer(help="The planners and their declared options.", no_args_is_help=True,
                           context_settings=_SETTINGS)
localisers_app = typer.Typer(help="The localisers, their declared options and how each takes the robot model.",
                             no_args_is_help=True, context_settings=_SETTINGS)
settings_app = typer.Typer(help="The settings sections of --set (mission, challenge, robot, sonar) and their fields.",
                           no_args_is_help=True, context_settings=_SETTINGS)
app.add_typer(maps_app, name="maps")
app.add_typer(planners_app, name="planners")
app.add_typer(localisers_app, name="localisers")
app.add_typer(settings_app, name="settings")
app.add_typer(bench_app, name="bench")
app.add_typer(nxt_app, name="nxt")
app.add_typer(brick_app, name="brick")
app.add_typer(import_app, name="import")
app.add_typer(sonar_app, name="sonar")


def _print_version(value: bool) -> None:
    if value:
        from .. import __version__

        typer.echo(f"nxtnav {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    verbose: int = typer.Option(0, "--verbose", "-v", count=True, help="More log output (-v info, -vv debug)."),
    version: bool = typer.Option(False, "--version", callback=_print_version, is_eager=True,
                                 help="Print the version and exit."),
) -> None:
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")


class Interrupted(Exception):
    """A command stopped by Ctrl-C after saving what it had finished; the message says what and where."""


def fail(message: str, code: int = EXIT_BAD_INPUT) -> typer.Exit:
    """Print `message` as one line on stderr and return the exit to raise."""
    typer.echo(f"nxtnav: error: {message}", err=True)
    return typer.Exit(code)


def _quiet_exit(code: int) -> None:
    """Leave without the interpreter's shutdown chatter.

    OMPL 2.0.1's nanobind bindings print "leaked ..." lines at interpreter exit (fixed upstream
    after 2.0.1); they are noise to a user, so the command flushes its output and exits directly.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    logging.shutdown()
    os._exit(code)


def click_command(with_choices: bool = True, args: Sequence[str] | None = None) -> Any:
    """The application as a click command; with `with_choices`, its help texts list the names of the
    registries they name (`toolkit.cli.choices`), as ``--help`` prints them (with `args`, those of the
    commands the command line names only)."""
    from .choices import fill_choices

    command = typer.main.get_command(app)
    return fill_choices(command, args) if with_choices else command


def _asks_for_help(args: Sequence[str]) -> bool:
    return any(a in _SETTINGS["help_option_names"] for a in args)


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of the console script: every failure becomes one line on stderr and an exit code.

    0 success; 1 the plan or mission failed; 2 bad input (`NxtnavError`, among them `ConfigError` for
    an option value, usage errors, unreadable or unwritable files, memory exhausted); 130 interrupted.
    Any other exception is a bug and keeps its traceback.
    """
    args = list(argv) if argv is not None else sys.argv[1:]
    # the registries behind the help texts' choice lists load only when help is printed
    command = click_command(with_choices=_asks_for_help(args), args=args)
    code = EXIT_OK
    try:
        # in this mode click returns the code of a `typer.Exit` (and 130 for a Ctrl-C it caught)
        rv = command.main(args=args, prog_name="nxtnav", standalone_mode=False)
        code = rv if isinstance(rv, int) else EXIT_OK
        if code == EXIT_INTERRUPTED:
            typer.echo("nxtnav: interrupted", err=True)
    except Interrupted as exc:
        typer.echo(f"nxtnav: interrupted: {exc}", err=True)
        code = EXIT_INTERRUPTED
    except NxtnavError as exc:
        typer.echo(f"nxtnav: error: {exc}", err=True)
        code = EXIT_BAD_INPUT
    except typer.Exit as exc:
        code = exc.exit_code
    except typer.Abort:
        typer.echo("nxtnav: aborted", err=True)
        code = EXIT_INTERRUPTED
    except TyperException as exc:  # usage errors and bad parameters (typer's click): one line, exit 2
        message = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        typer.echo(f"nxtnav: error: {' '.join(str(message).split())}", err=True)
        code = EXIT_BAD_INPUT
    except KeyboardInterrupt:
        typer.echo("nxtnav: interrupted", err=True)
        code = EXIT_INTERRUPTED
    except MemoryError as exc:
        detail = f" ({exc})" if str(exc) else ""
        typer.echo(f"nxtnav: error: out of memory{detail}; try a smaller map, problem or option value", err=True)
        code = EXIT_BAD_INPUT
    except (OSError, OverflowError) as exc:  # unreadable or unwritable files, numbers beyond a float
        typer.echo(f"nxtnav: error: {' '.join(str(exc).split())}", err=True)
        code = EXIT_BAD_INPUT
    from .options import remove_created_folders

    # on bad input, the folders made for outputs that were never written go again: nothing is left behind
    remove_created_folders(keep=code != EXIT_BAD_INPUT)
    if argv is not None:  # called from Python (tests): return normally
        if code:
            raise SystemExit(code)
        return
    _quiet_exit(code)
