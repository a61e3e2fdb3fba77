"""Build a sweep set from a clone of kentheo/Robotics_CO333: real sweeps of the CO333 arena.

That repository (no licence: study it, never copy its files into this one) holds 129 usable 360-degree
sweeps of a LEGO ultrasonic sensor taken at the five waypoints of its ``Challenge.py``, by a robot
none of the toolkit's sonar profiles was fitted on. This script reads them out of a clone the user
made and writes a sweep set (``sweeps.csv`` and the raw files) into a folder of the user's, for
``nxtnav bench sweeps`` and ``nxtnav sonar score``::

    git clone https://github.com/kentheo/Robotics_CO333 /tmp/Robotics_CO333
    python tools/kentheo_sweep_set.py /tmp/Robotics_CO333 -o /tmp/kentheo
    nxtnav bench sweeps /tmp/kentheo --map co333-arena --seeds 0,1,2 --workers 2

How each file's waypoint is known (docs/real-sonar.md gives the evidence):

* ``loc_00..04.dat`` at the top of the master branch: the code reads ``loc_0i`` as ``waypoints[i]``;
* ``database/batch2/loc_70..74.dat`` (branch ``working_challenge``): the same bytes as that branch's
  top-level ``loc_00..04.dat``, so the same rule;
* the other ``database/batch*/loc_NN.dat``: taken in rounds of the five waypoints in order, so
  ``waypoints[NN % 5]`` (inferred; ``--certain-only`` leaves them out). An empty file is skipped.

Every sweep: 360 readings, 1 degree apart, the turret turning counter-clockwise from looking
backwards (``start_deg`` 180), 255 = no echo.
"""

from __future__ import annotations

import argparse
import csv
import shutil
import subprocess
import sys
from pathlib import Path

REPO = "kentheo/Robotics_CO333"
MASTER = "54d4ce677c94cdef16d86538e0954a8e9a91be93"
WORKING = "d4aaa8b7c5f06eff2894c510a0c6cbd027cae103"  # branch working_challenge
WAYPOINTS = [(84, 30), (180, 30), (180, 54), (138, 54), (138, 168)]  # Challenge.py, in order
BATCHES = {"database/batch1": 50, "database/batch2": 75}  # files loc_00 .. loc_(n-1)
CERTAIN_FROM = {"database/batch2": 70}  # copies of the branch's top-level loc_00..04
COLUMNS = ["repo", "commit", "file", "raw", "x_cm", "y_cm", "n_bins", "step_deg", "direction", "start_deg",
           "licence", "invalid_values", "assignment"]


class BuildError(Exception):
    pass


def candidates(certain_only: bool, commits: tuple[str, str] = (MASTER, WORKING)) -> list[tuple[str, str, int, str]]:
    """(commit, path, waypoint index, how the waypoint is known) of every sweep file."""
    master, working = commits
    rows = [(master, f"loc_{i:02d}.dat", i, "read as waypoints[i] by the code") for i in range(5)]
    for folder, count in BATCHES.items():
        for n in range(count):
            certain = n >= CERTAIN_FROM.get(folder, count)
            if certain_only and not certain:
                continue
            how = ("same bytes as the branch's loc_0i, read as waypoints[i]" if certain
                   else "taken in rounds of the five waypoints: waypoints[NN % 5]")
            rows.append((working, f"{folder}/loc_{n:02d}.dat", n % 5, how))
    return rows


def git_show(clone: Path, commit: str, path: str) -> bytes:
    done = subprocess.run(["git", "-C", str(clone), "show", f"{commit}:{path}"], capture_output=True)
    if done.returncode != 0:
        message = done.stderr.decode(errors="replace").strip().splitlines()
        raise BuildError(f"{clone}: cannot read {commit[:7]}:{path} ({message[-1] if message else 'git failed'}); "
                         f"is it a full clone of {REPO}?")
    return done.stdout


def build(clone: Path, out: Path, certain_only: bool = False,
          commits: tuple[str, str] = (MASTER, WORKING)) -> tuple[int, int]:
    """Write the sweep set; returns (sweeps written, empty files skipped). `commits`: (master, the
    branch working_challenge)."""
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise BuildError(f"{out}: exists and is not an empty folder; give a new folder")
    part = out.with_name(out.name + ".partial")
    shutil.rmtree(part, ignore_errors=True)
    part.mkdir(parents=True)
    try:
        written, skipped = _write(clone, part, certain_only, commits)
    except BaseException:
        shutil.rmtree(part, ignore_errors=True)
        raise
    part.rename(out)  # all or nothing: the folder appears complete
    return written, skipped


def _write(clone: Path, out: Path, certain_only: bool, commits: tuple[str, str]) -> tuple[int, int]:
    rows, skipped = [], 0
    for commit, path, index, how in candidates(certain_only, commits):
        data = git_show(clone, commit, path)
        if not data.strip():
            skipped += 1
            continue
        raw = Path("raw") / path
        (out / raw).parent.mkdir(parents=True, exist_ok=True)
        (out / raw).write_bytes(data)
        x, y = WAYPOINTS[index]
        rows.append({"repo": REPO, "commit": commit, "file": path, "raw": raw.as_posix(), "x_cm": x, "y_cm": y,
                     "n_bins": 360, "step_deg": 1.0, "direction": "ccw", "start_deg": 180.0, "licence": "none",
                     "invalid_values": 255, "assignment": how})
    with open(out / "sweeps.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows(rows)
    return len(rows), skipped


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clone", type=Path, help=f"a git clone of {REPO} (both branches)")
    parser.add_argument("-o", "--out", type=Path, required=True, help="a new folder for the sweep set")
    parser.add_argument("--certain-only", action="store_true",
                        help="only the 10 sweeps whose waypoint the code states")
    args = parser.parse_args(argv)
    try:
        written, skipped = build(args.clone, args.out, args.certain_only)
    except BuildError as error:
        print(f"kentheo_sweep_set: error: {error}", file=sys.stderr)
        return 2
    print(f"wrote {args.out / 'sweeps.csv'}: {written} sweeps ({skipped} empty files skipped); "
          f"nxtnav bench sweeps {args.out} --map co333-arena")
    return 0


if __name__ == "__main__":
    sys.exit(main())
