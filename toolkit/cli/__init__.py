"""The `nxtnav` command line. Each command group lives in its own module and registers on import."""

from . import localise_cmds  # noqa: F401  (registers localise/bench localisers)
from . import mission_cmds  # noqa: F401  (registers run/paper)
from . import nxt_cmds  # noqa: F401  (registers brick serve, nxt check/calibrate)
from . import plan_cmds  # noqa: F401  (registers plan and bench planners)
from . import world_cmds  # noqa: F401  (registers maps/scan/bench world)
from .app import app, main

__all__ = ["app", "main"]
