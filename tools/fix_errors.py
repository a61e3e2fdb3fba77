"""How far the fixes of paper missions lie from the truth, per kind of fix, and where the robot time goes.

Usage: ``python tools/fix_errors.py [--sonar nxt] [--trials 10] [--seed 4] [--noise-model botsim]
[--set mission.GROUP.FIELD=VALUE ...]`` (the mission settings `nxtnav paper --set` takes)

Runs the trials `nxtnav paper` runs (same seeds, `toolkit.bench.paper.paper_tasks`) on maps 1-3 and
reads each mission's trace against the simulator's truth. Prints, per map and kind of fix (global
look, tracking fix along a segment, at a waypoint, at the target, heading check, ...), how many
converged fixes there were and their heading error (median, 99th percentile and largest, degrees)
and position error (median and largest, cm); then, per map, the median robot time and the mean
robot time per mission each kind of step took (s), with how often it happened. The ``nxt`` tuning's
allowances (`toolkit.mission.MissionConfig.for_sonar`) rest on the errors this prints.
"""

from __future__ import annotations

import argparse
import math
import statistics
from collections import defaultdict

import numpy as np

from toolkit.bench.paper import paper_tasks
from toolkit.mission import MissionConfig, MissionReport, run_sim_mission
from toolkit.world.typed import parse_value

FIX_ACTIONS = ("localise", "relocalise", "check-heading")
MAPS = ("map1", "map2", "map3")


def kind_of(action: str, note: str) -> str:
    """A step's kind: its action and the reason its note starts with (``relocalise: along segment``)."""
    if action == "skip-fix":
        return action
    reason = note.split(":")[0].split("(")[0].strip()
    return f"{action}: {reason}" if reason else action


def fix_errors(report: MissionReport) -> list[tuple[str, float, float]]:
    """(kind, heading error in degrees, position error in cm) of every converged fix and heading check."""
    out = []
    for step in report.trace:
        if step.action.value not in FIX_ACTIONS or step.estimate is None or step.true_pose is None:
            continue
        if step.action.value != "check-heading" and "converged" not in step.note:
            continue
        heading = abs(math.degrees(math.remainder(step.estimate.theta - step.true_pose.theta, 2 * math.pi)))
        out.append((kind_of(step.action.value, step.note), heading, step.estimate.distance_to(step.true_pose)))
    return out


def time_by_kind(report: MissionReport) -> dict[str, tuple[float, int]]:
    """Robot time (s) and count of every kind of step of a mission."""
    spent: dict[str, list[float]] = defaultdict(list)
    before = 0.0
    for step in report.trace:
        spent[kind_of(step.action.value, step.note)].append(step.robot_time_s - before)
        before = step.robot_time_s
    return {k: (sum(v), len(v)) for k, v in spent.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sonar", default="nxt", choices=("ideal", "nxt"))
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--noise-model", default="botsim", choices=("botsim", "absolute"))
    ap.add_argument("--set", action="append", default=[], metavar="mission.GROUP.FIELD=VALUE",
                    help="a mission setting, as nxtnav paper --set takes it (values read as YAML)")
    args = ap.parse_args()
    options = dict(_setting(text) for text in args.set)
    config = MissionConfig.for_sonar(args.sonar, **options)
    tasks = paper_tasks(args.trials, args.seed, noise_models=(args.noise_model,), sonar=args.sonar)
    for name in MAPS:
        errors: dict[str, list[tuple[float, float]]] = defaultdict(list)
        times: dict[str, list[float]] = defaultdict(list)
        counts: dict[str, int] = defaultdict(int)
        robot_times = []
        runs = [t for t in tasks if t.map == name]
        for task in runs:
            report = run_sim_mission(name, seed=task.seed, sonar=args.sonar, noise_model=args.noise_model,
                                     config=config)
            robot_times.append(report.times.robot_time_s)
            for kind, heading, position in fix_errors(report):
                errors[kind].append((heading, position))
            for kind, (spent, n) in time_by_kind(report).items():
                times[kind].append(spent)
                counts[kind] += n
        print(f"## {name}: median robot time {statistics.median(robot_times):.1f} s over {len(runs)} missions")
        print("| fix | fixes | heading error median / p99 / max (deg) | position error median / max (cm) |")
        print("|---|---:|---:|---:|")
        for kind, values in sorted(errors.items()):
            a = np.array(values)
            print(f"| {kind} | {len(a)} | {np.median(a[:, 0]):.2f} / {np.percentile(a[:, 0], 99):.2f} / "
                  f"{a[:, 0].max():.2f} | {np.median(a[:, 1]):.2f} / {a[:, 1].max():.2f} |")
        print("\n| step | per mission | robot time per mission (s) |")
        print("|---|---:|---:|")
        for kind in sorted(times, key=lambda k: -sum(times[k])):
            total = sum(times[kind]) / len(runs)
            if total >= 0.5:
                print(f"| {kind} | {counts[kind] / len(runs):.1f} | {total:.1f} |")
        print()


def _setting(text: str) -> tuple[str, object]:
    key, sep, value = text.partition("=")
    if not sep or not key.startswith("mission."):
        raise SystemExit(f"fix_errors: error: --set {text!r}: give mission.GROUP.FIELD=VALUE")
    return key.removeprefix("mission."), parse_value(value)


if __name__ == "__main__":
    main()
