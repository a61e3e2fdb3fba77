"""The `nxtnav` command: the Typer application, its sub-groups and the error boundary."""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Sequence

import typer
from typer.exceptions import TyperException

from ..world import NxtnavError

__all__ = ["app", "bench_app", "brick_app", "fail", "main", "maps_app", "nxt_app"]

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
app.add_typer(maps_app, name="maps")
app.add_typer(bench_app, name="bench")
app.add_typer(nxt_app, name="nxt")
app.add_typer(brick_app, name="brick")


@app.callback()
def _root(
    verbose: int = typer.Option(0, "--verbose", "-v", count=True, help="More log output (-v info, -vv debug)."),
) -> None:
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")


def fail(message: str, code: int = 2) -> typer.Exit:
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


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of the console script; every `NxtnavError` becomes one line and exit code 2."""
    command = typer.main.get_command(app)
    code = 0
    try:
        rv = command.main(args=list(argv) if argv is not None else None, prog_name="nxtnav", standalone_mode=False)
        if isinstance(rv, int):  # click returns a command's typer.Exit code instead of raising it
            code = rv
    except NxtnavError as exc:
        typer.echo(f"nxtnav: error: {exc}", err=True)
        code = 2
    except typer.Exit as exc:
        code = exc.exit_code
    except typer.Abort:
        typer.echo("nxtnav: aborted", err=True)
        code = 130
    except TyperException as exc:  # usage errors and bad parameters: one line, exit 2
        message = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        typer.echo(f"nxtnav: error: {' '.join(str(message).split())}", err=True)
        code = 2
    except KeyboardInterrupt:
        typer.echo("nxtnav: interrupted", err=True)
        code = 130
    except (OSError, ValueError) as exc:
        typer.echo(f"nxtnav: error: {exc}", err=True)
        code = 2
    if argv is not None:  # called from Python (tests): return normally
        if code:
            raise SystemExit(code)
        return
    _quiet_exit(code)
