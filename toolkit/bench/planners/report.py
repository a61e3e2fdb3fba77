"""The planner benchmark's outputs: summary tables, CSV/JSONL files, OMPL logs and plots."""

from __future__ import annotations

import csv
import json
import math
import platform
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...number_format import cell, csv_cell, percent
from ...world import NxtnavError
from ..common import finite_median
from ..ompl_log import OmplExperiment, OmplPlannerData, ompl_status, write_ompl_log
from .anytime import WITHIN, reference_lengths, time_within_median
from .records import PROGRESS_COLUMNS, RUN_COLUMNS, BenchmarkResult, RunRecord


# -- summaries -----------------------------------------------------------------------------------
def summarise(result: BenchmarkResult) -> dict[str, list[dict[str, Any]]]:
    """Per map, one row per planner: runs, success rate and medians over the successful runs.

    ``median_within_s`` is the median time to a path at most 5 % longer than `shortest` over the runs
    that got there (``within_runs`` of them; from the best-cost samples of the anytime planners).
    """
    refs = reference_lengths(result)
    out: dict[str, list[dict[str, Any]]] = {}
    for m in result.config.maps:
        rows = []
        for p in result.config.planners:
            rs = [r for r in result.records if r.map == m and r.planner == p]
            ok = [r for r in rs if r.success]
            within_s, within_runs = time_within_median(ok, refs)
            rows.append({
                "planner": p,
                "runs": len(rs),
                "success_rate": len(ok) / len(rs) if rs else math.nan,
                "median_time_s": finite_median(r.time_s for r in ok),
                "median_first_solution_s": finite_median(r.first_solution_s for r in ok),
                "median_first_solution_ratio": finite_median(
                    r.first_solution_length_cm / refs.get((r.map, r.query), math.nan) for r in ok),
                "median_within_s": within_s,
                "within_runs": within_runs,
                "median_length_cm": finite_median(r.length_cm for r in ok),
                "median_length_ratio": finite_median(r.length_ratio for r in ok),
                "median_turns": finite_median(r.turns for r in ok),
                "median_turn_ratio": finite_median(r.turn_ratio for r in ok),
                "median_min_clearance_cm": finite_median(r.min_clearance_cm for r in ok),
                "median_exec_error_cm": finite_median(r.exec_error_cm for r in ok),
                "median_exec_collision_fraction": finite_median(r.exec_collision_fraction for r in ok),
                "median_collision_checks": finite_median(float(r.collision_checks) for r in ok),
                "median_simplify_time_s": finite_median(r.simplify_time_s for r in ok),
                "median_simplified_length_ratio": finite_median(r.simplified_length_ratio for r in ok),
                "median_simplified_turns": finite_median(r.simplified_turns for r in ok),
                "median_simplified_min_clearance_cm": finite_median(r.simplified_min_clearance_cm for r in ok),
                "median_simplified_exec_error_cm": finite_median(r.simplified_exec_error_cm for r in ok),
                "median_simplified_exec_collision_fraction": finite_median(
                    r.simplified_exec_collision_fraction for r in ok),
                "objective": ", ".join(sorted({r.objective for r in rs})) or "-",
                "median_robot_time_s": finite_median(r.robot_time_s for r in ok),
                "median_predicted_error_cm": finite_median(r.predicted_error_cm for r in ok),
                "median_objective_ratio": finite_median(r.objective_cost / r.reference_cost for r in ok
                                                        if r.reference_cost > 0),
                "below_reference": sum(1 for r in ok if below_reference(r)),
            })
        out[m] = rows
    return out


def _query_line(result: BenchmarkResult, m: str) -> list[str]:
    refs = [r for r in result.references if r.query.map == m]
    if result.config.queries == "presets" and refs:
        r = refs[0]
        return [f"Query: start ({r.query.start[0]:g}, {r.query.start[1]:g}), goal ({r.query.goal[0]:g}, "
                f"{r.query.goal[1]:g}); shortest {cell(r.shortest_length_cm, '.1f')} cm, min-link "
                f"{'–' if r.min_link_turns is None else r.min_link_turns} turns."]
    if refs:
        ml_turns = finite_median(float(r.min_link_turns) for r in refs if r.min_link_turns is not None)
        return [f"{len(refs)} random queries; median shortest path "
                f"{cell(finite_median(r.shortest_length_cm for r in refs), '.1f')} cm, median min-link turns "
                f"{cell(ml_turns, 'g')}."]
    return []


def _raw_table(rows: list[dict[str, Any]]) -> list[str]:
    lines = ["| planner | success | median time (ms) | first solution (ms) | first / shortest | "
             f"within {100 * WITHIN:g} % (ms) | length ratio | turns | exec error (cm) | exec collisions | "
             "collision checks | objective | objective / reference | robot time (s) | predicted error (cm) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|"]
    for row in rows:
        within = cell(1e3 * row["median_within_s"], ".2f")
        if row["within_runs"] and row["within_runs"] < row["runs"]:
            within += f" ({row['within_runs']}/{row['runs']})"
        lines.append(
            f"| {row['planner']} | {percent(row['success_rate'])} | "
            f"{cell(1e3 * row['median_time_s'], '.2f')} | {cell(1e3 * row['median_first_solution_s'], '.2f')} | "
            f"{cell(row['median_first_solution_ratio'], '.3f')} | {within} | "
            f"{cell(row['median_length_ratio'], '.3f')} | "
            f"{cell(row['median_turns'], 'g')} | {cell(row['median_exec_error_cm'], '.2f')} | "
            f"{percent(row['median_exec_collision_fraction'])} | "
            f"{cell(row['median_collision_checks'], '.0f')} | {row['objective']} | "
            f"{cell(row['median_objective_ratio'], '.3f')} | {cell(row['median_robot_time_s'], '.2f')} | "
            f"{cell(row['median_predicted_error_cm'], '.2f')} |")
    return lines


BELOW_REFERENCE_RTOL = 1e-3
"""A path whose cost is below its query's reference by more than this fraction (and the reference's own
length tolerance, 1 cm of driving) is a bug of the planner or of the reference."""


def below_reference(r: RunRecord) -> bool:
    """Whether a successful run's path costs less than the reference optimum of its query (a bug)."""
    if not (r.success and math.isfinite(r.reference_cost) and math.isfinite(r.objective_cost)):
        return False
    slack = {"length": 1.0, "turns": 0.0}.get(r.objective, 1.0 / 15.0)  # about 1 cm of driving
    return bool(r.objective_cost < r.reference_cost * (1 - BELOW_REFERENCE_RTOL) - slack)


def _below_lines(rows: list[dict[str, Any]]) -> list[str]:
    """A line per planner whose paths cost less than the reference optimum (a bug), none otherwise."""
    return [f"BUG: {row['below_reference']} run(s) of {row['planner']} cost less under {row['objective']} than the "
            "reference optimum of their query." for row in rows if row["below_reference"]]


def _simplified_table(rows: list[dict[str, Any]], method: str) -> list[str]:
    lines = [f"Simplified (`{method}`):", "",
             "| planner | simplification (ms) | length ratio | turns | min clearance (cm) | exec error (cm) | "
             "exec collisions |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for row in rows:
        lines.append(
            f"| {row['planner']} | {cell(1e3 * row['median_simplify_time_s'], '.2f')} | "
            f"{cell(row['median_simplified_length_ratio'], '.3f')} | {cell(row['median_simplified_turns'], 'g')} | "
            f"{cell(row['median_simplified_min_clearance_cm'], '.2f')} | "
            f"{cell(row['median_simplified_exec_error_cm'], '.2f')} | "
            f"{percent(row['median_simplified_exec_collision_fraction'])} |")
    return lines


def format_summary(result: BenchmarkResult) -> str:
    """``summary.md``: the settings, then per map a table of the raw paths and one of the simplified."""
    c = result.config
    nz = c.noise
    lines = [
        "# Planner benchmark",
        "",
        f"- maps: {', '.join(c.maps)}; planners: {', '.join(c.planners)}",
        f"- {c.runs} runs per planner and map, {c.time_limit:g} s budget, seed {c.seed}, queries: {c.queries}",
        f"- robot radius {c.robot_radius:g} cm, collision checks: {_backend(result)}; execution error: mean final "
        f"distance to the goal over "
        f"{c.exec_repeats} open-loop drives, noise {nz.model} (motion {nz.motion:g}, turn {nz.turn:g})",
        f"- objective: {c.objective or 'each planner its own'}; robot time at {c.timing.drive_speed_cm_s:g} cm/s, "
        f"{c.timing.turn_rate_deg_s:g} deg/s, {c.timing.stop_turn_s:g} s per stop-and-turn",
        f"- paths simplified with `{c.simplify}`; anytime progress sampled every {1e3 * c.progress_interval:g} ms "
        "of budget and at every improvement",
        f"- started {result.started.isoformat(timespec='seconds')}, total {result.total_time_s:.1f} s",
        "",
        "Medians over the successful runs. Time is the planning time (anytime planners use the whole budget); "
        "first solution is the time to their first path and first / shortest its length over the shortest "
        f"path's; within {100 * WITHIN:g} % is the time to a path at most {100 * WITHIN:g} % longer than the "
        "shortest (median over the runs that got there, their count in brackets when not all did). Length "
        "ratio = length / shortest path; turns are heading changes above 1 degree; exec error = mean distance "
        "(cm) from the goal after driving the path open-loop; exec collisions = share of those drives that "
        "touched a wall; objective / reference = the path's cost under the objective its planner minimised over "
        "the query's reference optimum under it (shortest, min-link, fastest); robot time and predicted error "
        "(closed form, root mean square, no walls) are the robot model's cost of the path. The simplified table "
        "measures the same paths after simplification (its time is not part of the planning time).",
    ]
    summary = summarise(result)
    for m in c.maps:
        lines += ["", f"## {m}", "", *_query_line(result, m), "", *_raw_table(summary[m])]
        if _below_lines(summary[m]):
            lines += ["", *_below_lines(summary[m])]
        if c.simplify != "none":
            lines += ["", *_simplified_table(summary[m], c.simplify)]
        rho, n = turns_error_correlation(result, m)
        if math.isfinite(rho):
            lines += ["", f"Execution error vs turns over all successful runs: Spearman rank correlation "
                          f"{rho:+.2f} (n = {n})."]
    return "\n".join(lines) + "\n"


def _backend(result: BenchmarkResult) -> str:
    """The checker that answered the runs (``index``, ``fcl``; ``point`` for a point robot, whatever was asked)."""
    used = sorted({r.collision for r in result.records}) or [result.config.collision]
    return ", ".join(used) + ("" if used == [result.config.collision] else f" (asked: {result.config.collision})")


def turns_error_correlation(result: BenchmarkResult, map_name: str) -> tuple[float, int]:
    """Spearman rank correlation of execution error with turns over the successful runs on a map.

    Returns ``(rho, n)``; rho is NaN with fewer than 3 runs or when either quantity is constant.
    """
    from scipy.stats import spearmanr

    pts = [(r.turns, r.exec_error_cm) for r in result.records
           if r.map == map_name and r.success and math.isfinite(r.turns) and math.isfinite(r.exec_error_cm)]
    if len(pts) < 3:
        return math.nan, len(pts)
    t, e = np.array(pts).T
    if np.ptp(t) == 0 or np.ptp(e) == 0:
        return math.nan, len(pts)
    return float(spearmanr(t, e).statistic), len(pts)


# -- writers -------------------------------------------------------------------------------------
def check_out_dir(out: str | Path, force: bool = False) -> Path:
    """The output folder, created; a non-empty existing folder is refused unless `force`."""
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise NxtnavError(f"--out {str(p)!r} exists and is not a folder")
    if p.is_dir() and any(p.iterdir()) and not force:
        raise NxtnavError(f"--out {str(p)!r} is not empty; choose another folder or pass --force to overwrite")
    p.mkdir(parents=True, exist_ok=True)
    return p


def write_runs_csv(result: BenchmarkResult, path: Path) -> None:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(RUN_COLUMNS)
        for r in result.records:
            row = []
            for col in RUN_COLUMNS:
                v = getattr(r, col)
                if col in ("turns", "simplified_turns") and isinstance(v, float) and math.isfinite(v):
                    v = int(v)
                row.append(csv_cell(v))
            w.writerow(row)


def write_progress_csv(result: BenchmarkResult, path: Path) -> None:
    """``progress.csv``: every best-cost sample of every run that reported them (inf cost: empty)."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(PROGRESS_COLUMNS)
        for r in result.records:
            for t, it, cost in r.progress:
                w.writerow([csv_cell(v) for v in (r.map, r.planner, r.run, r.seed, t, int(it), cost)])


def write_paths_jsonl(result: BenchmarkResult, path: Path) -> None:
    with path.open("w", encoding="utf-8") as fh:
        for r in result.records:
            doc = {"map": r.map, "planner": r.planner, "run": r.run, "seed": r.seed, "success": r.success,
                   "path": [list(p) for p in r.path], "status": str(r.status), "detail": r.detail, "query": r.query,
                   "start": list(r.start), "goal": list(r.goal),
                   "time_s": r.time_s if math.isfinite(r.time_s) else None, "collision": r.collision,
                   "first_solution_s": r.first_solution_s if math.isfinite(r.first_solution_s) else None,
                   "first_solution_length_cm": (r.first_solution_length_cm
                                                if math.isfinite(r.first_solution_length_cm) else None),
                   "simplify": r.simplify, "simplified_path": [list(p) for p in r.simplified_path]}
            fh.write(json.dumps(doc) + "\n")


def write_references_csv(result: BenchmarkResult, path: Path) -> None:
    cols = ("map", "query", "start_x", "start_y", "goal_x", "goal_y", "shortest_length_cm", "min_link_turns",
            "min_link_length_cm", "status", "collision")
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in result.references:
            q = r.query
            w.writerow([csv_cell(v) for v in (q.map, q.index, q.start[0], q.start[1], q.goal[0], q.goal[1],
                                                r.shortest_length_cm, r.min_link_turns, r.min_link_length_cm,
                                                r.status, _backend(result))])


_OMPL_PROPERTIES = (
    ("time", "REAL"),
    ("first solution time", "REAL"),
    ("first solution length", "REAL"),
    ("solved", "BOOLEAN"),
    ("status", "ENUM"),
    ("approximate solution", "BOOLEAN"),
    ("correct solution", "BOOLEAN"),
    ("solution length", "REAL"),
    ("solution clearance", "REAL"),
    ("solution segments", "INTEGER"),
    ("solution turns", "INTEGER"),
    ("solution turn angle", "REAL"),
    ("length ratio", "REAL"),
    ("turn ratio", "REAL"),
    ("execution error", "REAL"),
    ("execution error median", "REAL"),
    ("execution collision fraction", "REAL"),
    ("simplification time", "REAL"),
    ("simplified solution length", "REAL"),
    ("simplified solution clearance", "REAL"),
    ("simplified solution segments", "INTEGER"),
    ("simplified correct solution", "BOOLEAN"),
    ("simplified solution turns", "INTEGER"),
    ("simplified length ratio", "REAL"),
    ("simplified execution error", "REAL"),
    ("collision checks", "INTEGER"),
    ("run", "INTEGER"),
    ("seed", "INTEGER"),
    ("query", "INTEGER"),
)

#: Progress properties of the anytime planners (OMPL's names: ``best cost`` as RRT* reports it).
_OMPL_PROGRESS = (("time", "REAL"), ("iterations", "INTEGER"), ("best cost", "REAL"))


def _ompl_row(r: RunRecord) -> list[Any]:
    ok = r.success
    simplified = ok and bool(r.simplified_path)
    segments = max(len(r.path) - 1, 0) if ok else None
    s_segments = max(len(r.simplified_path) - 1, 0) if simplified else None
    return [r.time_s, r.first_solution_s, r.first_solution_length_cm, ok, ompl_status(ok, r.status),
            False if ok else None, True if ok else None, r.length_cm, r.min_clearance_cm, segments,
            int(r.turns) if ok else None, r.turn_angle_rad, r.length_ratio, r.turn_ratio, r.exec_error_cm,
            r.exec_median_cm, r.exec_collision_fraction,
            r.simplify_time_s, r.simplified_length_cm, r.simplified_min_clearance_cm, s_segments,
            True if simplified else None, int(r.simplified_turns) if simplified else None,
            r.simplified_length_ratio, r.simplified_exec_error_cm,
            r.collision_checks, r.run, r.seed, r.query]


def _common(result: BenchmarkResult, planner: str, records: Sequence[RunRecord]) -> dict[str, Any]:
    """A planner block's common properties: the benchmark's settings and the planner's declared
    parameters (a parameter whose value differs between maps, such as OMPL's default range, lists
    the value of each)."""
    c = result.config
    common: dict[str, Any] = {"planner": planner, "time_limit": c.time_limit, "simplify": c.simplify,
                              "progress_interval": c.progress_interval}
    per_map: dict[str, dict[str, Any]] = {}
    for r in records:
        if r.params and r.map not in per_map:
            per_map[r.map] = dict(r.params)
    for key in sorted({k for d in per_map.values() for k in d}):
        values = {m: d.get(key) for m, d in per_map.items()}
        if len({repr(v) for v in values.values()}) == 1:
            common[key] = next(iter(values.values()))
        else:
            common[key] = ", ".join(f"{Path(m).stem}: {v}" for m, v in values.items())
    return common


def _ompl_experiment(result: BenchmarkResult, maps: Sequence[str], name: str) -> OmplExperiment:
    c = result.config
    multi = len(maps) > 1
    props = list(_OMPL_PROPERTIES) + ([("map", "ENUM")] if multi else [])
    planners = []
    for p in c.planners:
        rows, progress = [], []
        records = [r for r in result.records if r.planner == p and r.map in maps]
        for r in records:
            row = _ompl_row(r)
            if multi:
                row.append(list(maps).index(r.map))
            rows.append(row)
            progress.append([[t, int(it), cost] for t, it, cost in r.progress])
        anytime = any(progress)
        planners.append(OmplPlannerData(p, props, rows, _common(result, p, records),
                                        _OMPL_PROGRESS if anytime else (), progress if anytime else ()))
    setup = [f"nxtnav planner benchmark: maps {', '.join(maps)}; queries {c.queries}",
             f"robot radius {c.robot_radius:g} cm; planners validated by the shared collision checker "
             f"({_backend(result)})",
             f"execution error: {c.exec_repeats} open-loop drives, noise {json.dumps(c.noise.to_dict())}",
             f"paths simplified with {c.simplify}; progress every {c.progress_interval:g} s of budget"]
    for ref in result.references:
        if ref.query.map in maps:
            q = ref.query
            setup.append(f"{q.map} query {q.index}: start {q.start} goal {q.goal} shortest "
                         f"{cell(ref.shortest_length_cm, '.3f')} cm min-link turns {ref.min_link_turns}")
    return OmplExperiment(
        name=name,
        planners=planners,
        time_limit_s=c.time_limit,
        total_time_s=result.total_time_s,
        seed=c.seed,
        run_count=c.runs,
        setup="\n".join(setup),
        properties={"robot_radius_cm": ("REAL", c.robot_radius), "exec_repeats": ("INTEGER", c.exec_repeats),
                    "motion_noise": ("REAL", c.noise.motion), "turn_noise": ("REAL", c.noise.turn)},
        enums={"map": list(maps)} if multi else {},
        date=result.started,
        cpuinfo=platform.processor() or platform.machine(),
    )


def write_results(result: BenchmarkResult, out: str | Path, *, plots: bool = True) -> dict[str, Path]:
    """Write every output file of `result` into folder `out` (see the module docstring)."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    files = {"runs": d / "runs.csv", "paths": d / "paths.jsonl", "references": d / "references.csv",
             "summary": d / "summary.md", "ompl_log": d / "benchmark.log", "config": d / "config.json",
             "progress": d / "progress.csv"}
    write_runs_csv(result, files["runs"])
    write_progress_csv(result, files["progress"])
    write_paths_jsonl(result, files["paths"])
    write_references_csv(result, files["references"])
    c = result.config
    planned = c.runs * len(c.maps) * len(c.planners)
    note = "" if result.complete else (f"**INCOMPLETE**: interrupted after {len(result.records)} of {planned} "
                                       "planner runs; the tables cover only the finished runs.\n\n")
    files["summary"].write_text(note + format_summary(result), encoding="utf-8")
    files["config"].write_text(json.dumps({"config": c.to_dict(), "started": result.started.isoformat(),
                                           "total_time_s": result.total_time_s, "complete": result.complete,
                                           "runs_done": len(result.records), "runs_planned": planned},
                                          indent=1), encoding="utf-8")
    write_ompl_log(files["ompl_log"], _ompl_experiment(result, c.maps, f"nxtnav-planners-{c.queries}"))
    for stale in (d / "ompl").glob("*.log"):  # per-map logs of an earlier benchmark (--force) would mix in
        if stale.stem.endswith(("-presets", "-random")):
            stale.unlink()
    for m in c.maps:
        key = f"ompl_{m}"
        files[key] = write_ompl_log(d / "ompl" / f"{Path(m).stem}-{c.queries}.log",
                                    _ompl_experiment(result, [m], f"{Path(m).stem}-{c.queries}"))
    if plots:
        from .plots import save_plots

        files.update(save_plots(result, d))
    return files
