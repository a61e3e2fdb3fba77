"""Bad inputs tried on the `nxtnav` command, as a new user (or a hostile one) would type them.

Run from the repository root::

    .venv/bin/python docs/hostile_inputs.py             # every case, 2 at a time; prints the table
    .venv/bin/python docs/hostile_inputs.py --jobs 1 --markdown cases.md

The cases live in the test suite (``tests/hostile_cases.py``; ``tests/test_cli_hostile_cases.py`` runs
every one of them). This script runs each through the installed console script in a scratch folder
that holds the files the cases name (broken maps, a map cut in two, a huge map, ...) and prints the
table. A case is handled cleanly when the exit code is the expected one (2 bad input, 1 plan or
mission failed, 0 where the input is odd but usable) and, for a failure, stderr is exactly one line
``nxtnav: ...`` with no traceback. The script exits 0 when every case is handled cleanly.
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

TESTS = Path(__file__).resolve().parents[1] / "tests"
"""Where the case list lives (tests/hostile_cases.py): the suite runs the same cases."""


@dataclass
class Outcome:
    case: Any  # a hostile_cases.Case
    code: int
    stderr: str
    seconds: float

    @property
    def clean(self) -> bool:
        if self.code != self.case.expect or "Traceback" in self.stderr:
            return False
        lines = [ln for ln in self.stderr.splitlines() if ln.strip()]
        if self.case.expect == 0:
            return len(lines) <= 1  # at most one warning
        return len(lines) == 1 and lines[0].startswith("nxtnav: ")

    @property
    def said(self) -> str:
        lines = [ln for ln in self.stderr.splitlines() if ln.strip()]
        text = lines[0] if len(lines) == 1 else f"({len(lines)} lines) " + " | ".join(lines[:2])
        return text[:160]


def _run(case: Any, folder: Path, exe: str, timeout: float) -> Outcome:
    env = {**os.environ, **{k: str(folder / v) for k, v in case.env.items()}}
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([exe, *shlex.split(case.command)], cwd=folder, env=env, capture_output=True,
                              text=True, timeout=timeout)
        return Outcome(case, proc.returncode, proc.stderr, time.perf_counter() - t0)
    except subprocess.TimeoutExpired:
        return Outcome(case, -1, f"timed out after {timeout:g} s", time.perf_counter() - t0)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=2, help="cases run at once")
    parser.add_argument("--timeout", type=float, default=180.0, help="seconds per case")
    parser.add_argument("--markdown", type=Path, help="also write the table to this file")
    parser.add_argument("--only", help="run only the cases whose group contains this text")
    args = parser.parse_args()
    exe = shutil.which("nxtnav", path=str(Path(sys.executable).parent)) or shutil.which("nxtnav")
    if exe is None:
        print("the nxtnav console script is not installed", file=sys.stderr)
        return 2
    sys.path.insert(0, str(TESTS))
    from hostile_cases import cases, prepare

    chosen = [c for c in cases() if args.only is None or args.only in c.group]
    with tempfile.TemporaryDirectory(prefix="nxtnav-hostile-") as tmp:
        folder = Path(tmp)
        prepare(folder, exe)
        with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            outcomes = []
            for o in pool.map(lambda c: _run(c, folder, exe, args.timeout), chosen):
                outcomes.append(o)  # progress on stderr, the table on stdout at the end
                print(f"{len(outcomes)}/{len(chosen)} {'ok ' if o.clean else 'BAD'} {o.seconds:5.1f} s "
                      f"nxtnav {o.case.command}: {o.said}", file=sys.stderr, flush=True)
    rows = ["| # | group | command | expected | exit | clean | what it said |", "|---:|---|---|---:|---:|---|---|"]
    for i, o in enumerate(outcomes, 1):
        env = " ".join(f"{k}={v}" for k, v in o.case.env.items())
        cmd = f"{env + ' ' if env else ''}nxtnav {o.case.command}".replace("|", "\\|")
        rows.append(f"| {i} | {o.case.group} | `{cmd}` | {o.case.expect} | {o.code} | "
                    f"{'yes' if o.clean else '**no**'} | {o.said.replace('|', '/')} |")
    clean = sum(o.clean for o in outcomes)
    rows.append("")
    rows.append(f"{clean} / {len(outcomes)} handled cleanly")
    text = "\n".join(rows)
    print(text)
    if args.markdown:
        args.markdown.write_text(text + "\n")
    return 0 if clean == len(outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
