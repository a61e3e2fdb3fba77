"""Progress lines for stderr that is not a terminal (logs, CI): how often and what they say."""

from __future__ import annotations

import io
import re
import subprocess
import time
from pathlib import Path

import pytest
from conftest import nxtnav_exe

from toolkit.cli.progress import LineProgress


def _counts(text: str, total: int) -> list[int]:
    lines = text.splitlines()
    assert all(re.fullmatch(rf"missions: \d+/{total} \(\d+ %\), \d+ s", ln) for ln in lines), lines
    return [int(ln.split()[1].split("/")[0]) for ln in lines]


def test_first_every_tenth_and_last() -> None:
    out = io.StringIO()
    bar = LineProgress("missions", 200, out)
    for _ in range(200):
        bar.advance("a result")
    assert _counts(out.getvalue(), 200) == [1, *range(20, 201, 20)]


def test_a_quiet_spell_longer_than_every_s_gets_a_line() -> None:
    out = io.StringIO()
    bar = LineProgress("missions", 1000, out, every_s=0.0)
    for _ in range(5):
        bar.advance()
    assert _counts(out.getvalue(), 1000) == [1, 2, 3, 4, 5]


def test_fewer_tasks_than_tenths() -> None:
    out = io.StringIO()
    bar = LineProgress("missions", 3, out)
    for _ in range(3):
        bar.advance()
    assert _counts(out.getvalue(), 3) == [1, 2, 3]


def test_announce_writes_a_line_before_the_first_task_ends() -> None:
    out = io.StringIO()
    bar = LineProgress("missions", 3, out, announce=True)
    assert _counts(out.getvalue(), 3) == [0]
    for _ in range(3):
        bar.advance()
    assert _counts(out.getvalue(), 3) == [0, 1, 2, 3]


@pytest.mark.slow
@pytest.mark.parametrize(("argv", "label"), [
    (["sonar", "score", "maps/real-nxt"], "sweeps scored"),
    (["sonar", "plot", "maps/real-nxt", "--out", "figures"], "figures"),
])
def test_long_sonar_commands_say_how_far_they_are(argv: list[str], label: str, tmp_path: Path) -> None:
    # stderr is a pipe here, as in a log or CI: plain lines, the first at once, one per finished step
    proc = subprocess.run([nxtnav_exe(), *argv], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    steps = [ln for ln in proc.stderr.splitlines() if ln.startswith(label + ":")]
    assert steps, proc.stderr
    total = int(steps[0].split("/")[1].split()[0])
    assert total >= 3
    assert [int(ln.split(": ")[1].split("/")[0]) for ln in steps] == list(range(total + 1))


def test_a_late_bar_counts_the_time_since_the_work_began() -> None:
    # progress_after shows its lines only after a while: their clock starts when the work did, not then
    out = io.StringIO()
    bar = LineProgress("steps", 4, out, done=2, started=time.monotonic() - 10.0)
    bar.advance()
    seconds = int(out.getvalue().split(", ")[-1].split()[0])
    assert out.getvalue().startswith("steps: 3/4 (75 %)") and seconds >= 10
