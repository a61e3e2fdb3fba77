"""How well a recording's ground truth agrees with its own odometry over short stretches.

Usage: ``python tools/truth_consistency.py REC.jsonl [REC.jsonl ...] [--deltas 0.1,0.25,0.5,1]``

Dead reckoning from the recording's motions (its ``predict`` events, each a turn then a drive) is
compared with its true poses at every scan that has one, by evo's relative pose error over pairs of
poses DELTA metres apart (`toolkit.recordings.trajectory_scores.relative_pose_error`). Over 10 cm, wheel odometry
drifts by a millimetre or so, so what the comparison finds there is mostly the truth's own jitter, or
a time offset between the truth's stamps and the odometry's: the floor under any localiser's relative
pose error against that truth. Run it on imports of one bag with different ``--truth-delay`` values to
see which offset the two clocks agree on. Prints one row per recording.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from toolkit.recordings.replay import read_recording
from toolkit.recordings.trajectory_scores import relative_pose_error
from toolkit.world import NxtnavError


def odometry_and_truth(path: str) -> tuple[np.ndarray, np.ndarray]:
    """(n, 3) dead-reckoned poses and (n, 3) true poses (x cm, y cm, heading rad) at the scans with a truth."""
    rec = read_recording(path)
    x = y = h = 0.0
    odo, truth = [], []
    for _, e in rec.events:
        if e["type"] == "predict":
            h += float(e.get("turn_rad", 0.0))
            d = float(e.get("distance_cm", 0.0))
            x, y = x + d * math.cos(h), y + d * math.sin(h)
        elif e["type"] == "scan" and e.get("true_pose") is not None and e["true_pose"][2] is not None:
            truth.append([float(v) for v in e["true_pose"]])
            odo.append([x, y, h])
    return np.array(odo).reshape(-1, 3), np.array(truth).reshape(-1, 3)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+")
    parser.add_argument("--deltas", default="0.1,0.25,0.5,1", help="pair distances (m), comma-separated")
    args = parser.parse_args(argv)
    try:
        deltas = [float(v) for v in args.deltas.split(",")]
    except ValueError:
        deltas = []
    if not deltas or not all(math.isfinite(d) and d > 0 for d in deltas):
        print(f"truth_consistency: --deltas must be positive numbers (m), got {args.deltas!r}", file=sys.stderr)
        return 2
    rows = []
    for path in args.recordings:
        try:
            odo, truth = odometry_and_truth(path)
        except (NxtnavError, OSError) as exc:
            print(f"truth_consistency: {' '.join(str(exc).split())}", file=sys.stderr)
            return 2
        if len(truth) < 2:
            print(f"truth_consistency: {path}: fewer than two true poses with a heading", file=sys.stderr)
            return 2
        cells = [relative_pose_error(truth, odo, d) for d in deltas]
        rows.append(f"| {path} | {len(truth)} | " + " | ".join(f"{t:.2f}, {r:.2f}" for t, r in cells) + " |")
    print("| recording | poses | " + " | ".join(f"RPE over {d:g} m (cm, deg)" for d in deltas) + " |")
    print("|---|---:|" + "---:|" * len(deltas))
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
