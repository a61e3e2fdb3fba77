"""A mission over the socket link whose brick drops the link, through the installed `nxtnav` command.

Run from the repository root (a few minutes)::

    .venv/bin/python docs/link_loss_targets.py --seeds 0,1,2,3,4

For each seed, two runs, each against its own `nxtnav brick serve --time-factor 1000 --max-step 0.01`
(map1, its start with heading 30 degrees):

* ``--fault drop-link:20:3``: the link drops at brick time 20 s for 3 s; prints the mission's exit code
  and the robot's true distance from the target at the end (the brick's truth log);
* ``--fault drop-link:20:1000`` with ``nxtnav run --reconnect-timeout 10``: prints the exit code, the
  lines on stderr, and the wall-clock seconds from the moment the brick says the fault fired to the
  moment the mission's process has exited.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

NXTNAV = shutil.which("nxtnav", path=str(Path(sys.executable).parent)) or "nxtnav"
TARGET = (80.0, 80.0)


class Brick:
    """`nxtnav brick serve` in a subprocess; the wall time at which each line of its output came."""

    def __init__(self, fault: str, seed: int, log: Path) -> None:
        self.proc = subprocess.Popen(
            [NXTNAV, "brick", "serve", "--port", "0", "--pose", "20,20,30", "--time-factor", "1000", "--max-step",
             "0.01", "--seed", str(seed), "--fault", fault, "--log", str(log)],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, bufsize=1)
        self.lines: list[tuple[float, str]] = []
        self._port = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()
        if not self._port.wait(60):
            raise RuntimeError("the brick did not start")

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append((time.monotonic(), line.strip()))
            self._port.set()

    @property
    def port(self) -> int:
        found = re.search(r"127\.0\.0\.1:(\d+)", self.lines[0][1])
        assert found, self.lines[0][1]
        return int(found.group(1))

    def fired_at(self) -> float | None:
        return next((t for t, line in self.lines if " fired at brick time " in line), None)

    def stop(self) -> None:
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(30)


def run(brick: Brick, seed: int, *extra: str) -> tuple[int, list[str], float]:
    """`nxtnav run` against `brick`: exit code, stderr lines, and the wall clock when it exited."""
    done = subprocess.run([NXTNAV, "run", "--robot", "nxt", "--nxt-backend", "socket", "--server-host", "127.0.0.1",
                           "--server-port", str(brick.port), "--seed", str(seed), *extra],
                          capture_output=True, text=True, timeout=900)
    return done.returncode, [ln for ln in done.stderr.splitlines() if ln.strip()], time.monotonic()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", default="0,1,2,3,4")
    seeds = [int(s) for s in ap.parse_args().seeds.split(",")]
    gaps: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            log = Path(tmp) / f"truth-{seed}.jsonl"
            brick = Brick("drop-link:20:3", seed, log)
            try:
                code, err, _ = run(brick, seed)
            finally:
                brick.stop()
            final = json.loads(log.read_text().splitlines()[-1])
            error = math.hypot(final["pose"][0] - TARGET[0], final["pose"][1] - TARGET[1])
            print(f"seed {seed} drop-link:20:3: exit {code}, true error {error:.2f} cm, "
                  f"{final['collisions']} collision(s), fired {brick.fired_at() is not None}", flush=True)
            brick = Brick("drop-link:20:1000", seed, Path(tmp) / f"lost-{seed}.jsonl")
            try:
                code, err, exited = run(brick, seed, "--reconnect-timeout", "10")
            finally:
                brick.stop()
            fired = brick.fired_at()
            gap = math.nan if fired is None else exited - fired
            gaps.append(gap)
            print(f"seed {seed} drop-link:20:1000 --reconnect-timeout 10: exit {code}, {gap:.2f} s from the drop "
                  f"to the exit, stderr {len(err)} line(s): {err[0] if err else ''}", flush=True)
    print(f"median seconds from the drop to the exit: {statistics.median(gaps):.2f} (max {max(gaps):.2f})")


if __name__ == "__main__":
    main()
