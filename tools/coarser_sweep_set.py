"""Write a coarser copy of a sweep set: every K-th reading of each sweep, as a robot whose turret steps K
times farther would have read the same place.

A new robot's sweeps are often coarser than the development set's (5 or 10 degrees a step where two of
its sources have 1). This script makes such a set from one at hand, to measure what the coarser steps
cost (``nxtnav bench challenge OUT``, ``nxtnav bench routes OUT``)::

    python tools/coarser_sweep_set.py ../shared/data/real-nxt -o /tmp/every5 --every 5 \\
        --repos ellasurobot/ella,andrei-alpha/robotics

Each kept sweep keeps its row of ``sweeps.csv`` (its waypoint, heading, licence and the rest) with
``n_bins`` divided and ``step_deg`` multiplied by K, and its readings 0, K, 2K, ... written to
``raw/sNNN.dat``; the arena file is copied. A sweep whose number of readings K does not divide is left
out and named. The source set is only read. A licence travels with the readings: a copy of sweeps whose
licence forbids sharing stays where it was made, outside any repository.
"""

from __future__ import annotations

import argparse
import csv
import shutil
import sys
from pathlib import Path


def _rows(folder: Path) -> tuple[list[str], list[dict[str, str]]]:
    with (folder / "sweeps.csv").open(newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        return list(reader.fieldnames or []), list(reader)


def _readings(folder: Path, row: dict[str, str]) -> list[str]:
    raw = row.get("raw") or row["file"]
    return [line.strip() for line in (folder / raw).read_text().splitlines() if line.strip()]


def coarser(source: Path, out: Path, every: int, repos: set[str] | None) -> tuple[int, list[str]]:
    """Write the coarser set of `source` into `out` (which must not exist): the sweeps written and the
    labels of those left out."""
    columns, rows = _rows(source)
    columns = columns if "raw" in columns else [*columns, "raw"]
    (out / "raw").mkdir(parents=True)
    kept: list[dict[str, str]] = []
    left: list[str] = []
    for row in rows:
        if repos is not None and row["repo"] not in repos:
            continue
        values = _readings(source, row)
        if len(values) % every:
            left.append(f"{row['repo']}/{row['file']} ({len(values)} readings)")
            continue
        raw = f"raw/s{len(kept):03d}.dat"
        (out / raw).write_text("\n".join(values[::every]) + "\n")
        kept.append({**row, "raw": raw, "n_bins": str(len(values) // every),
                     "step_deg": f"{float(row['step_deg']) * every:g}"})
    with (out / "sweeps.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(kept)
    for arena in source.glob("arena.yaml"):
        shutil.copy(arena, out / arena.name)
    return len(kept), left


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source", type=Path, help="a sweep set's folder (sweeps.csv, the raw files)")
    parser.add_argument("-o", "--out", type=Path, required=True, help="a new folder for the coarser set")
    parser.add_argument("--every", type=int, required=True, help="keep every K-th reading (K >= 2)")
    parser.add_argument("--repos", help="only these sources, comma-separated (default: every source)")
    args = parser.parse_args(argv)
    if args.every < 2:
        parser.error(f"--every {args.every}: keep every K-th reading with K at least 2")
    if not (args.source / "sweeps.csv").is_file():
        parser.error(f"{args.source}: no sweeps.csv")
    if args.out.exists():
        parser.error(f"{args.out}: already exists; give a new folder")
    repos = None if args.repos is None else {r.strip() for r in args.repos.split(",") if r.strip()}
    written, left = coarser(args.source, args.out, args.every, repos)
    for label in left:
        print(f"left out: {label}: not a multiple of {args.every}", file=sys.stderr)
    if not written:
        shutil.rmtree(args.out)
        parser.error(f"{args.source}: no sweep to write" + (f" of {args.repos}" if repos else ""))
    print(f"wrote {written} sweeps every {args.every} readings to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
