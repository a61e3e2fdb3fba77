"""Tables on stdout that are never cut: as wide as a terminal allows there, whole when piped or saved.

Rich fits a table to the console's width, 80 columns when stdout is not a terminal, and shortens
what does not fit (``SampleReject...``): names people copy into ``--set`` or ``--map`` must come out
whole, so off a terminal the table takes the width it needs.
"""

from __future__ import annotations

import json
from typing import Any

from rich.console import Console
from rich.table import Table

__all__ = ["NEVER_CUT", "print_json", "print_table"]

NEVER_CUT = {"no_wrap": True, "overflow": "fold"}
"""Column settings for names: one line when there is room, folded (never shortened) when there is not."""

_PIPE_WIDTH = 100_000
"""Console width off a terminal: more than any table needs, so rich never shortens a cell."""


def print_table(table: Table) -> None:
    """Print `table` on stdout: fitted to a terminal, at its natural width otherwise."""
    console = Console()
    if not console.is_terminal:
        console = Console(width=_PIPE_WIDTH)
    console.print(table)


def print_json(doc: Any) -> None:
    """Print `doc` as indented JSON on stdout (values JSON has no type for as their text)."""
    print(json.dumps(doc, indent=1, default=str, allow_nan=False))
