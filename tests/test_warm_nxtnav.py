"""The warm `nxtnav` the documented blocks run (tools/warm_nxtnav.py): a forked command behaves as the
console script does: the same output, exit code and files; signals reach it; it dies with its stand-in."""

from __future__ import annotations

import socket
import sys
from pathlib import Path

import pytest
from conftest import load_tool, wait_until

docs_commands = load_tool("docs_commands")
REAL = Path(sys.executable).parent / "nxtnav"


def _both(script: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple:
    """The outcome of `script` with the warm stand-in, then with the real console script."""
    (tmp_path / "warm").mkdir()
    (tmp_path / "real").mkdir()
    monkeypatch.setenv("NXTNAV_DOCS_WARM", "1")
    warm = docs_commands.run_script(script, tmp_path / "warm")
    monkeypatch.setenv("NXTNAV_DOCS_WARM", "0")
    real = docs_commands.run_script(script, tmp_path / "real")
    return warm, real


def test_a_warm_command_prints_exits_and_writes_as_the_console_script(tmp_path: Path,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    script = ("command -v nxtnav\n"
              "nxtnav --version\n"
              "nxtnav run --map map2 --target 150,10 > /dev/null 2> err.txt || echo exit=$?\n"
              "nxtnav plan --map map1 --planner astar --exec-repeats 0 --json p.json -o p.png > /dev/null\n"
              "python -c \"import json; print(json.load(open('p.json'))['length_cm'])\"\n"
              "echo 'not json' > bad.json; nxtnav run --config bad.json || echo exit=$?\n")
    warm, real = _both(script, tmp_path, monkeypatch)
    assert warm.failure is None and real.failure is None, (warm.output, real.output)
    warm_lines, real_lines = warm.output.splitlines(), real.output.splitlines()
    assert Path(real_lines[0]) == REAL
    stand_in = Path(warm_lines[0])
    assert stand_in != REAL and str(REAL) in stand_in.read_text()  # a stand-in that falls back to the real one
    assert warm_lines[1:] == real_lines[1:]
    assert warm_lines.count("exit=2") == 2
    assert (tmp_path / "warm" / "err.txt").read_bytes() == (tmp_path / "real" / "err.txt").read_bytes()
    assert (tmp_path / "warm" / "p.png").stat().st_size > 0


def test_a_signal_reaches_the_warm_command_and_a_dead_stand_in_takes_it_along(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # SIGTERM to the stand-in (kill %1) reaches the brick, which says it stopped and exits as it does alone
    script = ("nxtnav brick serve --port 2741 --time-factor 1000 &\n"
              "for try in $(seq 100); do (exec 3<>/dev/tcp/127.0.0.1/2741) 2>/dev/null && break; sleep 0.1; done\n"
              "kill %1; wait %1 && echo brick=0 || echo brick=$?\n")
    warm, real = _both(script, tmp_path, monkeypatch)
    assert warm.failure is None, warm.output
    for outcome in (warm, real):
        assert "stopped:" in outcome.output, outcome.output
    assert [x for x in warm.output.splitlines() if x.startswith("brick=")] == \
        [x for x in real.output.splitlines() if x.startswith("brick=")]
    monkeypatch.setenv("NXTNAV_DOCS_WARM", "1")
    # SIGKILL to the stand-in (nothing to forward): the server ends its command, the port is free again
    script = ("nxtnav brick serve --port 2742 --time-factor 1000 &\n"
              "for try in $(seq 100); do (exec 3<>/dev/tcp/127.0.0.1/2742) 2>/dev/null && break; sleep 0.1; done\n"
              "kill -KILL %1\n")
    assert docs_commands.run_script(script, tmp_path).failure is None

    def refused() -> bool:
        with socket.socket() as probe:
            return probe.connect_ex(("127.0.0.1", 2742)) != 0

    wait_until(refused, 10.0, "the brick of a stand-in killed with SIGKILL still listens")
