"""The budget sweep: the same benchmark at several planning budgets, and what each budget buys.

Every budget runs the whole benchmark with the same seed, so run ``r`` of a planner on a map plans
the same query with the same random numbers at every budget; with the iteration-counted budget of
OMPL's planners a longer budget continues the shorter one. The sweep reports, per map, planner and
budget, the medians of length over `shortest`, turns and execution error, raw and simplified; and
per run the smallest budget at which its path came within 5 % of `shortest` (`within_rows`): the
planning time that took (plus the simplification time for the simplified path), and the turns and
execution error of that path.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from ...number_format import cell, csv_cell, percent
from ...plotting import save_figure
from ...world import PlanningError
from ..common import finite_median
from .anytime import WITHIN, reference_lengths
from .records import BenchmarkConfig, BenchmarkResult, RunRecord
from .report import write_results
from .runner import run_benchmark

__all__ = ["BUDGET_COLUMNS", "BudgetSweep", "budget_rows", "check_budgets", "draw_budget_sweep", "format_budget_sweep",
           "run_budget_sweep", "within_rows", "write_budget_sweep"]

#: Columns of ``budgets.csv``: medians over the successful runs of one planner on one map at one budget.
BUDGET_COLUMNS = ("map", "planner", "budget_s", "runs", "success_rate", "median_time_s", "median_length_ratio",
                  "median_turns", "median_exec_error_cm", "median_simplified_length_ratio",
                  "median_simplified_turns", "median_simplified_exec_error_cm")


def check_budgets(budgets: Sequence[float]) -> tuple[float, ...]:
    """The budgets in increasing order; `PlanningError` for none, a repeated one or one that is not
    a positive number of seconds."""
    if not budgets:
        raise PlanningError("no budgets to sweep")
    for b in budgets:
        if not (isinstance(b, int | float) and math.isfinite(b) and b > 0):
            raise PlanningError(f"a budget must be a positive number of seconds, got {b!r}")
    if len(set(budgets)) != len(budgets):
        raise PlanningError(f"budget listed twice in {', '.join(f'{b:g}' for b in budgets)}")
    return tuple(sorted(float(b) for b in budgets))


@dataclass(frozen=True, eq=False)
class BudgetSweep:
    """The benchmark results of each budget (seconds), in increasing order of budget."""

    budgets: tuple[float, ...]
    results: tuple[BenchmarkResult, ...]

    @property
    def complete(self) -> bool:
        """False when Ctrl-C ended the sweep early (the last result holds the runs that had finished)."""
        return len(self.results) == len(self.budgets) and all(r.complete for r in self.results)


def run_budget_sweep(config: BenchmarkConfig, budgets: Sequence[float], *, workers: int = 1,
                     dask_address: str | None = None, on_done: Callable[[Any], None] | None = None) -> BudgetSweep:
    """Run `config` once per budget (its ``time_limit`` replaced); see `run_benchmark` for the rest.

    ``config.n_tasks() * len(budgets)`` tasks report to `on_done`. Ctrl-C keeps the budgets done.
    """
    chosen = check_budgets(budgets)
    results: list[BenchmarkResult] = []
    for b in chosen:
        try:
            res = run_benchmark(replace(config, time_limit=b), workers=workers, dask_address=dask_address,
                                on_done=on_done)
        except KeyboardInterrupt:
            break
        results.append(res)
        if not res.complete:
            break
    if not results:
        raise KeyboardInterrupt
    return BudgetSweep(chosen, tuple(results))


def _medians(records: Sequence[RunRecord]) -> dict[str, float]:
    ok = [r for r in records if r.success]
    return {
        "runs": len(records),
        "success_rate": len(ok) / len(records) if records else math.nan,
        "median_time_s": finite_median(r.time_s for r in ok),
        "median_length_ratio": finite_median(r.length_ratio for r in ok),
        "median_turns": finite_median(r.turns for r in ok),
        "median_exec_error_cm": finite_median(r.exec_error_cm for r in ok),
        "median_simplified_length_ratio": finite_median(r.simplified_length_ratio for r in ok),
        "median_simplified_turns": finite_median(r.simplified_turns for r in ok),
        "median_simplified_exec_error_cm": finite_median(r.simplified_exec_error_cm for r in ok),
    }


def budget_rows(sweep: BudgetSweep) -> list[dict[str, Any]]:
    """One row per map, planner and budget (`BUDGET_COLUMNS`)."""
    rows = []
    config = sweep.results[0].config
    for m in config.maps:
        for p in config.planners:
            for b, res in zip(sweep.budgets, sweep.results, strict=False):
                recs = [r for r in res.records if r.map == m and r.planner == p]
                rows.append({"map": m, "planner": p, "budget_s": b, **_medians(recs)})
    return rows


def _first_within(runs: Sequence[tuple[float, RunRecord]], refs: dict[tuple[str, int], float], simplified: bool,
                  within: float) -> tuple[float, RunRecord] | None:
    """The (budget, run) at the smallest budget whose (simplified) path is within `within` of `shortest`."""
    for b, r in runs:
        ref = refs.get((r.map, r.query), math.nan)
        length = r.simplified_length_cm if simplified else r.length_cm
        if r.success and math.isfinite(ref) and length <= (1.0 + within) * ref:
            return b, r
    return None


def within_rows(sweep: BudgetSweep, within: float = WITHIN) -> list[dict[str, Any]]:
    """Per map and planner, raw and simplified: how many runs came within `within` of `shortest` at
    some budget, and over those the median time it took (the planning time at that budget, plus the
    simplification time for the simplified path), the budget, and the turns and execution error of
    that path."""
    config = sweep.results[0].config
    refs: dict[tuple[str, int], float] = {}
    for res in sweep.results:
        refs.update(reference_lengths(res))
    rows = []
    for m in config.maps:
        for p in config.planners:
            by_run: dict[int, list[tuple[float, RunRecord]]] = {}
            for b, res in zip(sweep.budgets, sweep.results, strict=False):  # increasing budgets
                for r in res.records:
                    if r.map == m and r.planner == p:
                        by_run.setdefault(r.run, []).append((b, r))
            row: dict[str, Any] = {"map": m, "planner": p, "runs": len(by_run)}
            for label, simplified in (("raw", False), ("simplified", True)):
                hits = [h for h in (_first_within(rs, refs, simplified, within) for rs in by_run.values()) if h]
                row[f"{label}_reached"] = len(hits)
                row[f"{label}_time_s"] = finite_median(
                    r.time_s + (r.simplify_time_s if simplified else 0.0) for _, r in hits)
                row[f"{label}_budget_s"] = finite_median(b for b, _ in hits)
                row[f"{label}_turns"] = finite_median(r.simplified_turns if simplified else r.turns for _, r in hits)
                row[f"{label}_exec_error_cm"] = finite_median(
                    r.simplified_exec_error_cm if simplified else r.exec_error_cm for _, r in hits)
            rows.append(row)
    return rows


def format_budget_sweep(sweep: BudgetSweep, within: float = WITHIN) -> str:
    """``budgets.md``: per map, the medians at every budget, then the time to within `within` of `shortest`."""
    c = sweep.results[0].config
    done = sweep.budgets[:len(sweep.results)]
    lines = ["# Planner budget sweep", "",
             f"- maps: {', '.join(c.maps)}; planners: {', '.join(c.planners)}",
             f"- budgets (s): {', '.join(f'{b:g}' for b in done)}; {c.runs} runs per planner, map and budget, "
             f"seed {c.seed}, queries: {c.queries}; paths simplified with `{c.simplify}`",
             "", "Medians over the successful runs; raw / simplified.", ""]
    if not sweep.complete:
        lines[1:1] = ["", f"**INCOMPLETE**: interrupted; budgets done: {', '.join(f'{b:g}' for b in done)}."]
    rows = budget_rows(sweep)
    for m in c.maps:
        lines += [f"## {m}", "", "| planner | budget (s) | success | time (ms) | length ratio | turns | "
                  "exec error (cm) |", "|---|---:|---:|---:|---:|---:|---:|"]
        for r in (r for r in rows if r["map"] == m):
            lines.append(
                f"| {r['planner']} | {r['budget_s']:g} | {percent(r['success_rate'])} | "
                f"{cell(1e3 * r['median_time_s'], '.1f')} | {cell(r['median_length_ratio'], '.3f')} / "
                f"{cell(r['median_simplified_length_ratio'], '.3f')} | {cell(r['median_turns'], 'g')} / "
                f"{cell(r['median_simplified_turns'], 'g')} | {cell(r['median_exec_error_cm'], '.1f')} / "
                f"{cell(r['median_simplified_exec_error_cm'], '.1f')} |")
        lines.append("")
    lines += [f"## Time to within {100 * within:g} % of the shortest path", "",
              "Per run, the smallest budget whose path is at most "
              f"{100 * within:g} % longer than the shortest; medians over the runs that got there (reached: "
              "how many of them), of the planning time at that budget (simplified: plus the simplification "
              "time), the budget, and the turns and execution error of that path.", "",
              "| map | planner | raw: reached | time (ms) | budget (s) | turns | exec error (cm) | simplified: "
              "reached | time (ms) | budget (s) | turns | exec error (cm) |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in within_rows(sweep, within):
        cells = []
        for label in ("raw", "simplified"):
            cells += [f"{r[f'{label}_reached']}/{r['runs']}", cell(1e3 * r[f"{label}_time_s"], ".1f"),
                      cell(r[f"{label}_budget_s"], "g"), cell(r[f"{label}_turns"], "g"),
                      cell(r[f"{label}_exec_error_cm"], ".1f")]
        lines.append(f"| {r['map']} | {r['planner']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _write_csv(path: Path, columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> Path:
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for row in rows:
            w.writerow([csv_cell(row[c]) for c in columns])
    return path


def draw_budget_sweep(sweep: BudgetSweep) -> Figure:
    """Length over `shortest`, turns and execution error (rows) against the budget per map (columns):
    the median of each planner, raw (solid) and simplified (dashed)."""
    c = sweep.results[0].config
    rows = budget_rows(sweep)
    metrics = (("length_ratio", "length / shortest"), ("turns", "turns"), ("exec_error_cm", "exec error (cm)"))
    fig, axes = plt.subplots(len(metrics), len(c.maps), figsize=(4.4 * len(c.maps), 2.9 * len(metrics)),
                             squeeze=False, sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, m in enumerate(c.maps):
        for i, (key, label) in enumerate(metrics):
            ax = axes[i][j]
            for k, p in enumerate(c.planners):
                pr = [r for r in rows if r["map"] == m and r["planner"] == p]
                x = np.array([r["budget_s"] for r in pr])
                color = colors[k % len(colors)]
                ax.plot(x, [r[f"median_{key}"] for r in pr], "o-", ms=3, color=color, label=p)
                if c.simplify != "none":
                    ax.plot(x, [r[f"median_simplified_{key}"] for r in pr], "s--", ms=3, lw=1, color=color,
                            alpha=0.7)
            ax.set_xscale("log")
            ax.set_xticks(list(sweep.budgets), [f"{b:g}" for b in sweep.budgets])
            ax.minorticks_off()
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel(label)
            if i == 0:
                ax.set_title(m)
            if i == len(metrics) - 1:
                ax.set_xlabel("budget (s)")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8, frameon=False)
    what = f"solid raw, dashed simplified ({c.simplify})" if c.simplify != "none" else "raw paths"
    fig.suptitle(f"what a budget buys: medians of {c.runs} runs; {what}", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return fig


def write_budget_sweep(sweep: BudgetSweep, out: str | Path, *, plots: bool = True) -> dict[str, Path]:
    """Write each budget's results into ``budget-<B>s/`` (the files of `write_results`, without its
    plots) and ``budgets.csv``, ``within.csv``, ``budgets.md`` and ``budget_sweep.png`` into `out`."""
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    for b, res in zip(sweep.budgets, sweep.results, strict=False):
        for key, path in write_results(res, d / f"budget-{b:g}s", plots=False).items():
            files[f"{b:g}s/{key}"] = path
    files["budgets"] = _write_csv(d / "budgets.csv", BUDGET_COLUMNS, budget_rows(sweep))
    wrows = within_rows(sweep)
    files["within"] = _write_csv(d / "within.csv", list(wrows[0]), wrows)
    files["summary"] = d / "budgets.md"
    files["summary"].write_text(format_budget_sweep(sweep), encoding="utf-8")
    if plots:
        files["budget_sweep"] = save_figure(draw_budget_sweep(sweep), d / "budget_sweep.png")
    return files
