"""The command-line reference page is generated from the application and kept equal to it."""

from __future__ import annotations

from pathlib import Path

import typer

from toolkit.cli import _load
from toolkit.cli.reference import cli_markdown

PAGE = Path(__file__).resolve().parents[1] / "docs" / "reference" / "cli.md"


def _leaf_commands(group: typer.core.TyperGroup, prefix: str = "nxtnav") -> list[str]:
    names = []
    for name, command in group.commands.items():
        if isinstance(command, typer.core.TyperGroup):
            names += _leaf_commands(command, f"{prefix} {name}")
        elif not command.hidden:
            names.append(f"{prefix} {name}")
    return names


def test_page_equals_the_generated_reference() -> None:
    assert PAGE.read_text(encoding="utf-8") == cli_markdown(), "python tools/cli_docs.py > docs/reference/cli.md"


def test_every_command_and_option_is_on_the_page() -> None:
    text = cli_markdown()
    root = _load().click_command()
    commands = _leaf_commands(root)
    assert len(commands) > 20
    for name in commands:
        assert f"## `{name}`" in text, name
    assert "<<" not in text, "a help text's choice list was not filled in"
    plan = root.commands["plan"]
    for param in plan.params:
        for opt in param.opts:
            assert opt in text, opt
