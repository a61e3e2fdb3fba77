"""The command-line reference page, generated from the `nxtnav` application itself.

Every command, its arguments and its options (type, default, help) come from the Typer application,
so the page cannot drift from the program: ``python tools/cli_docs.py > docs/reference/cli.md``
writes it and a test checks the file equals it.
"""

from __future__ import annotations

from typing import Any

import typer
import typer.core

__all__ = ["cli_markdown"]

_HEADER = """# Command-line reference

Generated from the `nxtnav` application (`python tools/cli_docs.py > docs/reference/cli.md`; a test
keeps this page equal to the program). `nxtnav COMMAND --help` prints the same in a terminal. Exit
codes: 0 done; 1 the command ran but the plan or mission failed; 2 bad input, one line
`nxtnav: error: ...` naming it; 130 interrupted (finished work is kept and marked incomplete).
Options of the plug-ins themselves (`--set NAME.KEY=VALUE`) are listed in
[the parameter reference](../parameters.md).
"""


def _one_line(text: str | None) -> str:
    """Help text as one Markdown table cell: whitespace folded, pipes escaped."""
    return " ".join((text or "").split()).replace("|", "\\|")


def _param_rows(command: Any) -> list[str]:
    """One table row per argument or option, as the command's own help prints it."""
    ctx = typer.Context(command, info_name=command.name)
    rows = []
    for param in command.params:
        if getattr(param, "hidden", False):
            continue
        record = param.get_help_record(ctx)
        if record is None:
            continue
        name, help_text = record
        rows.append(f"| `{name}` | {_one_line(help_text)} |")
    return rows


def _command_section(path: str, command: Any) -> list[str]:
    lines = [f"## `{path}`", "", _one_line(command.help or command.short_help), ""]
    rows = _param_rows(command)
    if rows:
        lines += ["| argument or option | meaning |", "|---|---|", *rows, ""]
    return lines


def _walk(path: str, command: Any) -> list[str]:
    if isinstance(command, typer.core.TyperGroup):
        lines = []
        for name in sorted(command.commands):
            sub = command.commands[name]
            if not getattr(sub, "hidden", False):
                lines += _walk(f"{path} {name}", sub)
        return lines
    return _command_section(path, command)


def cli_markdown() -> str:
    """The reference page of every `nxtnav` command, as Markdown."""
    from . import _load

    command = _load().click_command()  # every command registered, help texts with the registries' names
    return _HEADER + "\n" + "\n".join(_walk("nxtnav", command)).rstrip() + "\n"
