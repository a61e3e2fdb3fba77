"""The `nxtnav` command line. Each command group lives in its own module and registers on import."""

# imported for their side effect: each module adds its commands to the Typer app
from . import (  # noqa: F401
    figures_cmds,
    localise_cmds,
    mission_cmds,
    nxt_cmds,
    plan_cmds,
    replay_cmds,
    scen_cmds,
    world_cmds,
)
from .app import app, main

__all__ = ["app", "main"]
