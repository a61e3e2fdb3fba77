"""Would smoothing a localiser's estimates against the odometry lower its relative pose error?

Usage: ``python tools/estimate_smoothing.py REC.jsonl REPLAY.json [--localisers amcl,ekf]``

REPLAY.json is what ``nxtnav replay REC.jsonl ... --json REPLAY.json`` wrote. Each estimate after an
update is split into the recording's dead reckoning and a correction (estimate = correction o
odometry, the map-to-odom transform a ROS localiser publishes). The correction is then smoothed and
the estimates rebuilt from it: causally, each new correction moved into by a share GAIN (1 = the
estimates as they are), and, looking ahead, as the mean of the corrections of the updates within
WINDOW on either side (a fixed-lag smoother's best case). Each is scored by evo's relative pose error
over 1 m (`toolkit.recordings.trajectory_scores`), as `nxtnav replay` scores it. Two more columns say where the
error lies: the estimates with the truth's headings put in (what is left is position error), and the
scale of the best similarity alignment of the estimates onto the truth (1 when the two agree on
lengths, above 1 when the estimates make the path shorter). Prints one markdown row per localiser.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from truth_consistency import odometry_and_truth

from toolkit.recordings.trajectory_scores import relative_pose_error, similarity_scale
from toolkit.ros.bag_reader import se2_compose, se2_inverse
from toolkit.world import NxtnavError, angle_diff, circular_mean

GAINS = (1.0, 0.5, 0.2)
WINDOWS = (2, 8)


def load_report(replay_json: str) -> dict[str, Any]:
    """The report `nxtnav replay --json` wrote, checked for its localisers and steps."""
    try:
        report = json.loads(Path(replay_json).read_text())
        if not isinstance(report.get("localisers"), list) or not isinstance(report.get("steps"), list):
            raise ValueError("no 'localisers' or 'steps' list")
    except (ValueError, AttributeError) as exc:
        raise NxtnavError(f"{replay_json}: not a replay report written by `nxtnav replay --json`: {exc}") from None
    return report


def estimates_after_updates(report: dict[str, Any], replay_json: str, name: str) -> np.ndarray:
    """(n, 3) estimates of `name` (x cm, y cm, heading rad) after each update that has a true heading."""
    if name not in report["localisers"]:
        raise NxtnavError(f"{replay_json}: no localiser {name!r} (it has {', '.join(report['localisers'])})")
    out = []
    for k, s in enumerate(report["steps"]):
        try:
            if s["call"] != "update" or s["truth"] is None or s["truth"][2] is None:
                continue
            e = s["estimates"].get(name)
            if e is None:
                raise NxtnavError(f"{replay_json}: {name} has no estimate at step {k} (it failed)")
            x, y, h = (float(v) for v in e["pose"])
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise NxtnavError(f"{replay_json}: step {k} is not a replay step ({type(exc).__name__}: {exc})") from None
        out.append([x, y, math.radians(h)])
    return np.array(out).reshape(-1, 3)


def causal(corrections: np.ndarray, gain: float) -> np.ndarray:
    """Each correction moved into from the last smoothed one by the share `gain` (heading wrapped)."""
    out = np.empty_like(corrections)
    c = corrections[0].copy()
    for i, target in enumerate(corrections):
        step = target - c
        step[2] = angle_diff(target[2], c[2])
        c = c + gain * step
        out[i] = c
    return out


def centred(corrections: np.ndarray, window: int) -> np.ndarray:
    """The mean of the corrections within `window` updates on either side."""
    n = len(corrections)
    spans = [corrections[max(0, i - window):i + window + 1] for i in range(n)]
    return np.array([[*c[:, :2].mean(axis=0), circular_mean(c[:, 2])] for c in spans])


def row(odo: np.ndarray, truth: np.ndarray, est: np.ndarray) -> list[float]:
    corrections = se2_compose(est, se2_inverse(odo))

    def rebuilt(c: np.ndarray) -> float:
        return relative_pose_error(truth, se2_compose(c, odo))[0]

    true_heading = est.copy()
    true_heading[:, 2] = truth[:, 2]
    return ([rebuilt(causal(corrections, g)) for g in GAINS] + [rebuilt(centred(corrections, w)) for w in WINDOWS]
            + [relative_pose_error(truth, true_heading)[0], similarity_scale(truth, est)])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recording")
    parser.add_argument("replay_json")
    parser.add_argument("--localisers", default=None, help="comma-separated (default: every one in the report)")
    args = parser.parse_args(argv)
    try:
        odo, truth = odometry_and_truth(args.recording)
        report = load_report(args.replay_json)
        rows = []
        for name in args.localisers.split(",") if args.localisers else report["localisers"]:
            est = estimates_after_updates(report, args.replay_json, name)
            if est.shape != truth.shape:
                raise NxtnavError(f"{args.replay_json}: {len(est)} scored estimates of {name} against {len(truth)}"
                                  f" true poses in {args.recording}: not a replay of this recording")
            cells = row(odo, truth, est)
            rows.append(f"| {name} | " + " | ".join(f"{v:.2f}" for v in cells[:-1]) + f" | {cells[-1]:.4f} |")
    except (NxtnavError, OSError, ValueError) as exc:
        print(f"estimate_smoothing: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    heads = ([f"causal, gain {g:g}" for g in GAINS] + [f"centred, +-{w} updates" for w in WINDOWS]
             + ["truth's headings", "similarity scale"])
    print("| localiser | " + " | ".join(heads) + " |")
    print("|---|" + "---:|" * len(heads))
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
