"""Every output option of every command is checked before any work: an output that cannot be written is
one line naming the option and the path, exit 2, at once, with nothing created (README, "Exit codes")."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import Any

import pytest
from conftest import nxtnav_exe, run_cli

from toolkit.cli import _load
from toolkit.cli.app import click_command
from toolkit.cli.options import writable_file, writable_folder

OUTPUT_NAMES = {"--json", "--plot", "--output", "--out", "--mcap", "--record", "--view-save", "--animate",
                "--markdown", "--pareto", "--log", "--recordings"}
"""Options that name a file or folder a command writes."""
ELSEWHERE = {("view", "--save"), ("sonar fit", "--output")}
"""Output options checked by their own command's code before any work (the Rerun view; sonar fit's -o, a
file or, with --per-source, a folder)."""


def _commands() -> list[tuple[tuple[str, ...], Any]]:
    _load()
    found: list[tuple[tuple[str, ...], Any]] = []

    def walk(command: Any, path: tuple[str, ...]) -> None:
        subs = getattr(command, "commands", {})
        for name, sub in subs.items():
            walk(sub, (*path, name))
        if not subs:
            found.append((path, command))

    walk(click_command(with_choices=False), ())
    return found


def _outputs() -> list[tuple[tuple[str, ...], str, bool, list[str]]]:
    """(command, option, whether it is a folder, filler for the other required parameters) per output option."""
    cases = []
    for path, command in _commands():
        for param in command.params:
            check = getattr(param.callback, "__wrapped__", param.callback)  # typer wraps callbacks
            if check not in (writable_file, writable_folder):
                continue
            option = max(param.opts, key=len)
            filler = []
            for other in command.params:
                if other is param or not other.required:
                    continue
                filler += ["x"] if other.param_type_name == "argument" else [max(other.opts, key=len), "x"]
            cases.append((path, option, check is writable_folder, filler))
    return cases


OUTPUTS = _outputs()


def test_every_output_option_is_checked() -> None:
    checked = {(path, option) for path, option, _, _ in OUTPUTS}
    for path, command in _commands():
        for param in command.params:
            names = set(getattr(param, "opts", ())) & OUTPUT_NAMES
            if getattr(param, "is_flag", False):  # `maps list --json` prints JSON on stdout: no file
                continue
            if names and (path, max(param.opts, key=len)) not in checked and (" ".join(path), *names) not in ELSEWHERE:
                pytest.fail(f"nxtnav {' '.join(path)} {param.opts}: an output option without the early check")
    assert len(OUTPUTS) >= 35  # run alone has six


def _refused(argv: list[str], cwd: Path) -> str:
    """`nxtnav ARGV` run as a user runs it (a process of its own, in `cwd`): exit 2, one line, no work.

    Whether any work began is told by its standard output, which stays empty; the subprocess timeout
    catches a command that would hang. Wall time is not asserted: it depends on the machine."""
    proc = subprocess.run([nxtnav_exe(), *argv], cwd=cwd, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "COLUMNS": "200"})
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith("nxtnav: error:"), proc.stderr
    assert proc.stdout == ""  # no work began: nothing was printed
    return lines[0]


def _refused_in_process(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """The same check through `run_cli` (this process: the command line is parsed exactly as in its own)."""
    assert run_cli(argv) == 2
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("nxtnav: error:"), err
    assert out == ""
    return lines[0]


@pytest.mark.parametrize(("path", "option", "folder", "filler"), OUTPUTS,
                         ids=[f"{' '.join(p)} {o}" for p, o, _, _ in OUTPUTS])
def test_an_unwritable_output_is_refused_before_any_work(path: tuple[str, ...], option: str, folder: bool,
                                                         filler: list[str], tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str],
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    blocker = tmp_path / "blocker"
    blocker.write_text("a file where a folder should be\n")
    target = blocker / ("out" if folder else "out.json")
    # the output option comes first, so it is looked at before the others (whose filler is no real value)
    monkeypatch.chdir(tmp_path)
    line = _refused_in_process([*path, option, str(target), *filler], capsys)
    assert option in line and str(blocker) in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]  # nothing created
    assert blocker.read_text() == "a file where a folder should be\n"


@pytest.mark.parametrize("argv", [
    ["run", "--plot", "/proc/nxtnav-x.png"],
    ["export", "run.jsonl", "--mcap", "/proc/nxtnav-x"],
    ["plan", "-o", "/proc/nxtnav-x.png"],
    ["bench", "planners", "--out", "/proc/nxtnav-x"],
])
def test_the_trials_unwritable_outputs(argv: list[str], tmp_path: Path) -> None:
    # /proc refuses every new file although its permission bits (and root) would allow it
    line = _refused(argv, tmp_path)
    assert "/proc" in line and "tmp" not in line.replace(str(tmp_path), "")  # no temporary name
    assert not any(tmp_path.iterdir())


def test_a_missing_folder_is_created_only_when_the_command_writes(tmp_path: Path) -> None:
    proc = subprocess.run([nxtnav_exe(), "maps", "show", "map1", "-o", "new/folder/m.png"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "new" / "folder" / "m.png").stat().st_size > 0
    proc = subprocess.run([nxtnav_exe(), "maps", "show", "nosuchmap", "-o", "other/m.png"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and not (tmp_path / "other").exists()  # a bad map: no folder made for nothing


@pytest.mark.parametrize("per_source", [[], ["--per-source"]], ids=["profile", "per-source folder"])
def test_sonar_fit_checks_its_output_before_fitting(per_source: list[str], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str],
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    # sonar fit's -o is a file, or with --per-source a folder: its own code checks it (ELSEWHERE)
    blocker = tmp_path / "blocker"
    blocker.write_text("a file where a folder should be\n")
    monkeypatch.chdir(tmp_path)
    line = _refused_in_process(["sonar", "fit", "maps/real-nxt", *per_source, "-o", str(blocker / "out")], capsys)
    assert "--output" in line and str(blocker) in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]
