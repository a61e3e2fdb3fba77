"""The `nxtnav` command line. Each command group lives in its own module and registers on import.

The command modules (and the numerical libraries behind them) load inside `main`, so that a Ctrl-C
while they load is the same clean exit 130 as a Ctrl-C during a command.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .app import app

__all__ = ["app", "main"]


def _load() -> ModuleType:
    # the app module (by path: its name is also the attribute `app`), then the command modules,
    # imported for their side effect: each adds its commands to the Typer app
    app_module = importlib.import_module(".app", __name__)
    for name in ("challenge_cmds", "export_cmds", "faults_cmds", "figures_cmds", "import_cmds", "localise_cmds",
                 "mission_cmds", "nxt_cmds", "plan_cmds", "plugin_cmds", "replay_cmds", "routes_cmds", "scen_cmds",
                 "sonar_cmds", "sweeps_cmds", "world_cmds"):
        importlib.import_module(f".{name}", __name__)
    # importing the submodule `app` set this package's attribute `app` to the module: the name means
    # the Typer application here
    globals()["app"] = app_module.app
    return app_module


def main(argv: Sequence[str] | None = None) -> None:
    """The console script: `toolkit.cli.app.main` once the commands have loaded.

    A Ctrl-C while they load (a second or two) is held until the imports are done, since an interrupt
    inside a compiled module's import surfaces as an unrelated ImportError, and then ends the command
    with exit code 130.
    """
    held: list[int] = []
    defer = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if defer:
        signal.signal(signal.SIGINT, lambda signum, frame: held.append(signum))
    try:
        app_module = _load()
    finally:
        if defer:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    if held:
        sys.stderr.write("nxtnav: interrupted\n")
        if argv is not None:
            raise SystemExit(130)
        sys.stderr.flush()
        os._exit(130)
    app_module.main(argv)


def __getattr__(name: str) -> Any:
    if name == "app":
        return _load().app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
