"""Every planner under every objective it can minimise: the robot's cost of their paths, side by side.

``nxtnav bench objectives`` runs the planner benchmark once per objective (``length``, ``turns``,
``robot-time``) with the planners that can minimise it (`planners.Planner.objectives`) and writes

- ``objectives.csv``: one row per run (map, planner, objective, robot time, predicted and measured
  open-loop error, turns, length, planning time, the path's cost under its objective and the query's
  reference optimum under it);
- ``objectives.md``: per map, the medians per planner and objective, robot time over the ``fastest``
  reference, and the issue's targets checked (RRT*'s robot time under ``robot-time`` within 10 % of
  the reference; every OMPL planner's robot time under ``robot-time`` no worse than under ``length``);
- ``pareto_<map>.png``: median robot time against median open-loop error per planner and objective;
- ``cost_over_time.png``: the best robot time over ``fastest``'s against planning time, per map, of the
  planners under ``robot-time`` (anytime planners as curves, the others as points).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from planners import PLANNERS, can_minimise

from ...number_format import cell, csv_cell
from ...world import OBJECTIVES
from .records import BenchmarkConfig, BenchmarkResult, RunRecord
from .report import below_reference
from .runner import run_benchmark

__all__ = ["OBJECTIVE_COLUMNS", "ObjectiveSweep", "run_objectives", "write_objectives"]

OBJECTIVE_COLUMNS = ("map", "planner", "objective", "run", "success", "time_s", "robot_time_s",
                     "predicted_error_cm", "exec_error_cm", "turns", "length_cm", "objective_cost", "reference_cost",
                     "fastest_time_s", "collision_checks")
RRTSTAR_WITHIN = 0.10
"""Target: RRT*'s median robot time under ``robot-time`` at most this much above the reference."""


@dataclass(frozen=True, eq=False)
class ObjectiveSweep:
    """One benchmark result per objective (planners that cannot minimise an objective are left out of it)."""

    results: dict[str, BenchmarkResult]

    def records(self) -> list[RunRecord]:
        return [r for res in self.results.values() for r in res.records]

    def fastest(self) -> dict[tuple[str, int], float]:
        """The ``fastest`` reference's robot time (s) per (map, query)."""
        out: dict[tuple[str, int], float] = {}
        for res in self.results.values():
            out.update({(r.query.map, r.query.index): r.fastest_time_s for r in res.references})
        return out


def run_objectives(config: BenchmarkConfig, *, workers: int = 1,
                   on_done: Callable[[Any], None] | None = None) -> ObjectiveSweep:
    """`config`'s benchmark once per objective, with the planners that can minimise it (its own
    ``objective`` option, if any, is replaced)."""
    results = {}
    for objective in OBJECTIVES:
        able = tuple(p for p in config.planners if can_minimise(p, objective))
        if not able:
            continue
        options = {p: {**_polished(p), **{k: v for k, v in config.planner_options.get(p, {}).items()
                                          if k != "objective"}} for p in able}
        cfg = replace(config, planners=able, objective=objective, planner_options=options)
        results[objective] = run_benchmark(cfg, workers=workers, on_done=on_done)
    return ObjectiveSweep(results)


def _polished(planner: str) -> dict[str, Any]:
    """``polish=true`` for a planner that can polish its path (OMPL's): the same post-processing under every
    objective, so that no objective wins by it (`planners.ompl_polish`); the user's setting wins."""
    model = PLANNERS.class_of(planner).options_model
    return {"polish": True} if model is not None and "polish" in model.model_fields else {}


def _median(values: Sequence[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan


def _rows(sweep: ObjectiveSweep, map_name: str) -> list[dict[str, Any]]:
    """Medians per (planner, objective) on one map over the successful runs."""
    fastest = sweep.fastest()
    out = []
    for objective, res in sweep.results.items():
        for planner in res.config.planners:
            rs = [r for r in res.records if r.map == map_name and r.planner == planner]
            ok = [r for r in rs if r.success]
            out.append({"planner": planner, "objective": objective, "runs": len(rs), "ok": len(ok),
                        "robot_time_s": _median([r.robot_time_s for r in ok]),
                        "time_ratio": _median([r.robot_time_s / fastest.get((r.map, r.query), math.nan) for r in ok]),
                        "predicted_error_cm": _median([r.predicted_error_cm for r in ok]),
                        "exec_error_cm": _median([r.exec_error_cm for r in ok]),
                        "turns": _median([r.turns for r in ok]), "length_cm": _median([r.length_cm for r in ok]),
                        "time_s": _median([r.time_s for r in ok]),
                        "check_us": _median([1e6 * r.time_s / r.collision_checks for r in ok if r.collision_checks])})
    return out


def _targets(rows: list[dict[str, Any]]) -> list[str]:
    """The issue's targets on one map, each said met or not with the numbers."""
    by = {(r["planner"], r["objective"]): r for r in rows}
    lines = []
    rrt = by.get(("rrtstar", "robot-time"))
    if rrt is not None and math.isfinite(rrt["time_ratio"]):
        met = rrt["time_ratio"] <= 1 + RRTSTAR_WITHIN
        lines.append(f"- RRT* under robot-time: median robot time x{rrt['time_ratio']:.3f} the reference "
                     f"(target <= x{1 + RRTSTAR_WITHIN:.2f}): {'met' if met else 'NOT met'}")
    for (planner, objective), row in sorted(by.items()):
        cls = PLANNERS.class_of(planner)
        if objective != "robot-time" or "length" not in cls.objectives_for(planner) or planner in ("astar",):
            continue
        base = by.get((planner, "length"))
        if base is None or not math.isfinite(base["robot_time_s"]):
            continue
        met = row["robot_time_s"] <= base["robot_time_s"]
        lines.append(f"- {planner}: median robot time {row['robot_time_s']:.2f} s under robot-time, "
                     f"{base['robot_time_s']:.2f} s under length: {'met' if met else 'NOT met'} (no worse)")
    return lines


def _below_line(sweep: ObjectiveSweep, map_name: str) -> str:
    """Whether a run on `map_name` cost less than its query's reference optimum under its objective (a bug
    of the planner or of the reference; within the reference's tolerance it is not)."""
    below = [r for r in sweep.records() if r.map == map_name and below_reference(r)]
    if not below:
        return "No run costs less than the reference optimum of its query under its objective."
    who = ", ".join(sorted({f"{r.planner} under {r.objective}" for r in below}))
    return f"BUG: {len(below)} run(s) cost less than the reference optimum of their query: {who}."


def format_objectives(sweep: ObjectiveSweep) -> str:
    """``objectives.md``: the settings, then per map the medians per planner and objective and the targets."""
    first = next(iter(sweep.results.values()))
    c = first.config
    t = c.timing
    lines = ["# Planners under every objective", "",
             f"- maps: {', '.join(c.maps)}; {c.runs} runs per planner, objective and map; {c.time_limit:g} s budget; "
             f"seed {c.seed}; queries: {c.queries}",
             f"- robot time at {t.drive_speed_cm_s:g} cm/s, {t.turn_rate_deg_s:g} deg/s, {t.stop_turn_s:g} s per "
             f"stop-and-turn; open-loop error: {c.noise.model} noise (motion {c.noise.motion:g}, turn "
             f"{c.noise.turn:g}), predicted (closed form, root mean square) and measured (mean over "
             f"{c.exec_repeats} drives)",
             "", "Medians over the successful runs; robot time / fastest = over the least robot time of the query "
             "(`fastest`); per check = planning time over collision checks (the cost of the objective's evaluations "
             "shows there: compare a planner under robot-time with itself under length)."]
    for m in c.maps:
        rows = _rows(sweep, m)
        lines += ["", f"## {m}", "",
                  "| planner | objective | success | robot time (s) | / fastest | predicted error (cm) | "
                  "measured error (cm) | turns | length (cm) | planning time (s) | per check (us) |",
                  "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in rows:
            values = (cell(r["robot_time_s"], ".2f"), cell(r["time_ratio"], ".3f"),
                      cell(r["predicted_error_cm"], ".2f"), cell(r["exec_error_cm"], ".2f"), cell(r["turns"], "g"),
                      cell(r["length_cm"], ".1f"), cell(r["time_s"], ".3f"), cell(r["check_us"], ".0f"))
            lines.append(f"| {r['planner']} | {r['objective']} | {r['ok']}/{r['runs']} | " + " | ".join(values) + " |")
        targets = _targets(rows)
        if targets:
            lines += ["", "Targets:", "", *targets]
        lines += ["", _below_line(sweep, m)]
    return "\n".join(lines) + "\n"


def _save_pareto(sweep: ObjectiveSweep, m: str, path: Path) -> Path:
    """Median robot time against median measured open-loop error (predicted where not driven) per map."""
    import matplotlib.pyplot as plt

    from ...plotting import save_figure

    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    markers = {"length": "o", "turns": "s", "robot-time": "^"}
    planners = list(dict.fromkeys(r.planner for r in sweep.records()))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for r in _rows(sweep, m):
        err = r["exec_error_cm"] if math.isfinite(r["exec_error_cm"]) else r["predicted_error_cm"]
        if not (math.isfinite(err) and math.isfinite(r["robot_time_s"])):
            continue
        ax.scatter(r["robot_time_s"], err, marker=markers[r["objective"]], s=60,
                   color=colors[planners.index(r["planner"]) % len(colors)], label=f"{r['planner']} / {r['objective']}")
    ax.set_xlabel("median robot time (s)")
    ax.set_ylabel("open-loop final error (cm): median over runs of the mean")
    ax.set_title(f"{m}: robot time against error, every planner under every objective", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    save_figure(fig, path)
    return path


def write_objectives(sweep: ObjectiveSweep, out: Path, plots: bool = True) -> dict[str, Path]:
    """Write ``objectives.csv``, ``objectives.md`` and (with `plots`) a Pareto figure per map into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    files = {"runs": out / "objectives.csv", "summary": out / "objectives.md"}
    fastest = sweep.fastest()
    with files["runs"].open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(OBJECTIVE_COLUMNS)
        for r in sweep.records():
            w.writerow([csv_cell(v) for v in (r.map, r.planner, r.objective, r.run, r.success, r.time_s,
                                               r.robot_time_s, r.predicted_error_cm, r.exec_error_cm, r.turns,
                                               r.length_cm, r.objective_cost, r.reference_cost,
                                               fastest.get((r.map, r.query), math.nan), r.collision_checks)])
    files["summary"].write_text(format_objectives(sweep), encoding="utf-8")
    if plots:
        first = next(iter(sweep.results.values()))
        for m in first.config.maps:
            files[f"pareto_{m}"] = _save_pareto(sweep, m, out / f"pareto_{Path(m).stem}.png")
        if "robot-time" in sweep.results:
            from .plots import save_cost_over_time

            files["cost_over_time"] = save_cost_over_time(sweep.results["robot-time"], out)
    return files
