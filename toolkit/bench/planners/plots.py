"""Figures of the planner benchmark: box plots per metric and map, paths side by side, error vs turns,
and the best cost over time of the anytime planners.

Drawing functions take an ``ax`` (or a figure) and return the artists; nothing here opens a
window. `save_plots` writes the PNGs of ``nxtnav bench planners``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from planners.base import status_message

from ...plotting import draw_cspace, draw_map, draw_path, plain_log_axis, save_figure
from ...world import OBJECTIVE_UNITS, ConfigError, load_map
from .anytime import WITHIN, cost_band, has_curve, reference_lengths
from .records import BenchmarkResult, RunRecord

__all__ = ["BOXPLOT_METRICS", "cost_axis_label", "draw_cost_over_time", "draw_exec_vs_turns", "draw_metric_boxplot",
           "draw_paths_grid", "planner_color", "save_boxplots", "save_cost_over_time", "save_plots"]

#: Box-plot metrics: record attribute -> (axis label, file stem, log scale).
BOXPLOT_METRICS: dict[str, tuple[str, str, bool]] = {
    "time_s": ("planning time (s)", "time", True),
    "length_ratio": ("length / shortest", "length_ratio", False),
    "turns": ("turns", "turns", False),
    "exec_error_cm": ("execution error (cm)", "exec_error", False),
}

_COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def planner_color(result: BenchmarkResult, planner: str) -> Any:
    """The colour of `planner` in every figure of a benchmark (its place in the planner list)."""
    return _COLORS[list(result.config.planners).index(planner) % len(_COLORS)]


def _values(records: Sequence[RunRecord], map_name: str, planner: str, metric: str) -> np.ndarray:
    v = [getattr(r, metric) for r in records if r.map == map_name and r.planner == planner and r.success]
    a = np.array([x for x in v if x is not None and math.isfinite(x)], dtype=float)
    return a


def draw_metric_boxplot(result: BenchmarkResult, metric: str, map_name: str, ax: Axes) -> list[Any]:
    """One box per planner of `metric` over the successful runs on `map_name` (with the points jittered)."""
    if metric not in BOXPLOT_METRICS:
        raise ConfigError(f"unknown metric {metric!r}; known: {', '.join(BOXPLOT_METRICS)}")
    label, _, log_scale = BOXPLOT_METRICS[metric]
    planners = list(result.config.planners)
    data = [_values(result.records, map_name, p, metric) for p in planners]
    artists: list[Any] = []
    positions = np.arange(1, len(planners) + 1)
    has = [i for i, d in enumerate(data) if len(d)]
    if has:
        bp = ax.boxplot([data[i] for i in has], positions=positions[has], widths=0.6, showfliers=False)
        artists.extend(a for group in bp.values() for a in group)
    rng = np.random.default_rng(0)
    for i, d in enumerate(data):
        if len(d):
            x = positions[i] + rng.uniform(-0.18, 0.18, len(d))
            artists.append(ax.scatter(x, d, s=6, alpha=0.5, color=_COLORS[i % len(_COLORS)], zorder=3))
    ax.set_xticks(positions, planners, rotation=20)
    ax.set_xlim(0.4, len(planners) + 0.6)
    ax.set_ylabel(label)
    ax.set_title(map_name)
    if log_scale and any(len(d) and np.all(d > 0) for d in data):
        ax.set_yscale("log")
    ax.grid(axis="y", alpha=0.3)
    return artists


def save_boxplots(result: BenchmarkResult, out: str | Path) -> dict[str, Path]:
    """Write ``boxplot_<metric>.png`` into `out` (one panel per map) and return the files."""
    files = {}
    maps = list(result.config.maps)
    for metric, (label, stem, _) in BOXPLOT_METRICS.items():
        fig, axes = plt.subplots(1, len(maps), figsize=(3.8 * len(maps), 3.6), squeeze=False)
        for ax, m in zip(axes[0], maps, strict=True):
            draw_metric_boxplot(result, metric, m, ax)
        fig.suptitle(f"{label}: {result.config.runs} runs, {result.config.time_limit:g} s budget, "
                     f"{result.config.queries} queries, {result.config.collision} collision checks")
        fig.tight_layout()
        files[f"boxplot_{stem}"] = save_figure(fig, Path(out) / f"boxplot_{stem}.png")
    return files


def draw_paths_grid(result: BenchmarkResult, run: int = 0, size: float = 3.6) -> Figure:
    """A figure with one row per map and one column per planner, showing the path of run `run`."""
    maps, planners = list(result.config.maps), list(result.config.planners)
    worlds = [load_map(m) for m in maps]
    # each row as tall as its map's aspect ratio needs (plus room for the titles)
    heights = [max(0.3, (b[3] - b[1]) / (b[2] - b[0])) + 0.25 for b in (w.bounds for w in worlds)]
    fig, axes = plt.subplots(len(maps), len(planners), figsize=(size * len(planners), size * sum(heights)),
                             squeeze=False, gridspec_kw={"height_ratios": heights})
    for i, m in enumerate(maps):
        world = worlds[i]
        for j, p in enumerate(planners):
            ax = axes[i][j]
            draw_map(world, ax, presets=False, title=False)
            draw_cspace(world, result.config.robot_radius, ax)
            rec = next((r for r in result.records if r.map == m and r.planner == p and r.run == run), None)
            if rec is None:
                continue
            ax.plot(*rec.start, "o", color="tab:green", ms=7, zorder=6)
            ax.plot(*rec.goal, "*", color="tab:red", ms=11, zorder=6)
            if rec.success:
                draw_path(np.array(rec.path), ax, color=_COLORS[j % len(_COLORS)])
                ax.set_title(f"{m} / {p}\n{rec.length_cm:.0f} cm, {int(rec.turns)} turns, "
                             f"{1e3 * rec.time_s:.1f} ms", fontsize=9)
            else:
                ax.set_title(f"{m} / {p}\nfailed: {status_message(rec.status, rec.detail)}", fontsize=9)
            ax.set_xlabel("")
            ax.set_ylabel("")
    fig.tight_layout()
    return fig


def draw_exec_vs_turns(result: BenchmarkResult, ax: Axes, simplified: bool = False) -> list[Any]:
    """Execution error against the number of turns of every successful run, coloured by planner
    (of the simplified paths with `simplified`)."""
    turns, error = ("simplified_turns", "simplified_exec_error_cm") if simplified else ("turns", "exec_error_cm")
    artists: list[Any] = []
    for j, p in enumerate(result.config.planners):
        rs = [r for r in result.records if r.planner == p and r.success and math.isfinite(getattr(r, error))]
        if not rs:
            continue
        x = np.array([getattr(r, turns) for r in rs]) + np.random.default_rng(j).uniform(-0.15, 0.15, len(rs))
        artists.append(ax.scatter(x, [getattr(r, error) for r in rs], s=10, alpha=0.6,
                                  color=_COLORS[j % len(_COLORS)], label=p))
    nz = result.config.noise
    ax.set_xlabel("turns in the path")
    ax.set_ylabel("mean execution error (cm)")
    what = f"simplified ({result.config.simplify}) paths" if simplified else "raw paths"
    ax.set_title(f"{what}: open-loop execution error vs turns\n({nz.model} noise: motion {nz.motion:g}, "
                 f"turn {nz.turn:g})", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return artists


def _time_grid(records: Sequence[RunRecord]) -> np.ndarray:
    times = [t for r in records for t, _, _ in r.progress if t > 0]
    times += [r.time_s for r in records if r.success and r.time_s > 0]
    if not times:
        return np.geomspace(1e-4, 1.0, 200)
    return np.geomspace(max(min(times), 1e-5), max(times), 300)


_COST_NAMES = {"length": ("length", "shortest"), "turns": ("turns", "min-link"),
               "robot-time": ("robot time", "fastest")}


def _cost_ratio(record: RunRecord, objective: str, shortest_cm: float) -> float:
    """A run's cost over the reference under `objective` (its length over `shortest_cm` under length)."""
    if objective == "length":
        return record.length_cm / shortest_cm
    return record.objective_cost / record.reference_cost if record.reference_cost > 0 else math.nan


def cost_axis_label(objective: str | None) -> str:
    """The cost-over-time axis under `objective` (None: each planner's default, drawn as length), with its unit."""
    name, reference = _COST_NAMES[objective or "length"]
    unit = OBJECTIVE_UNITS[objective or "length"]
    return f"best {name} ({unit}) / {reference}'s ({unit})"


def draw_cost_over_time(result: BenchmarkResult, map_name: str, ax: Axes, within: float = WITHIN) -> list[Any]:
    """Best cost over the reference against time on one map: per anytime planner the median over its
    runs (line) and the interquartile range (band); planners with one solution per run (min-turn,
    A*, RRTConnect) as a point at their median time and cost ratio with interquartile bars. The cost
    is the benchmark's objective's (length over `shortest` when each planner ran its default, robot
    time over ``fastest`` under ``robot-time``), named with its unit on the axis."""
    refs = reference_lengths(result)
    records = [r for r in result.records if r.map == map_name]
    grid = _time_grid(records)
    artists: list[Any] = []
    top = 1.0 + 2 * within
    for p in result.config.planners:
        rs = [r for r in records if r.planner == p]
        color = planner_color(result, p)
        if any(has_curve(r) for r in rs):
            band = cost_band(rs, refs, grid)
            if band is None:
                continue
            med = np.isfinite(band.median)
            artists += ax.plot(grid[med], band.median[med], color=color, lw=1.6, label=p)
            both = np.isfinite(band.q75)  # where three quarters of the runs have a solution
            artists.append(ax.fill_between(grid[both], band.q25[both], band.q75[both], color=color, alpha=0.18,
                                           lw=0))
            top = max(top, float(np.max(band.median[med], initial=top)))
        else:
            ok = [r for r in rs if r.success and math.isfinite(refs.get((r.map, r.query), math.nan))]
            if not ok:
                continue
            t = np.array([r.first_solution_s for r in ok], dtype=float)
            y = np.array([_cost_ratio(r, result.config.objective or "length", refs[(r.map, r.query)]) for r in ok])
            (tq25, tm, tq75), (yq25, ym, yq75) = np.quantile(t, [0.25, 0.5, 0.75]), np.quantile(y, [0.25, 0.5, 0.75])
            artists.append(ax.errorbar([tm], [ym], xerr=[[tm - tq25], [tq75 - tm]], yerr=[[ym - yq25], [yq75 - ym]],
                                       fmt="o", ms=6, color=color, capsize=2, label=p))
            top = max(top, float(yq75))
    if not any(np.size(line.get_xdata()) for line in ax.get_lines()):  # no median anywhere (runs failed, crashed):
        ax.set_xlim(grid[0], grid[-1])  # limits of its own for the log axis, which has no data to fit
    artists.append(ax.axhline(1.0 + within, ls="--", lw=0.8, color="0.4"))
    ax.set_xscale("log")
    plain_log_axis(ax.xaxis)
    ax.set_ylim(0.995, min(top * 1.02, 2.0))
    ax.set_xlabel("time (s)")
    ax.set_ylabel(cost_axis_label(result.config.objective))
    ax.set_title(f"{map_name}: dashed {100 * within:g} % above the reference", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    return artists


def save_cost_over_time(result: BenchmarkResult, out: str | Path) -> Path:
    """Write ``cost_over_time.png`` (one panel per map, a shared legend) into `out`."""
    maps = list(result.config.maps)
    fig, axes = plt.subplots(1, len(maps), figsize=(4.6 * len(maps), 4.2), squeeze=False)
    for ax, m in zip(axes[0], maps, strict=True):
        draw_cost_over_time(result, m, ax)
    legend: dict[str, Any] = {}  # every planner drawn on some map (on the first, all of them unless runs failed)
    for ax in axes[0]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    labels = list(legend)
    if labels:
        fig.legend(list(legend.values()), labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8,
                   frameon=False)
    c = result.config
    what = "path length" if c.objective in (None, "length") else c.objective
    fig.suptitle(f"best {what} over time: median and interquartile range of {c.runs} runs, "
                 f"{c.time_limit:g} s budget", fontsize=11)
    fig.tight_layout(rect=(0, 0.1 if len(labels) > 5 else 0.06, 1, 1))
    return save_figure(fig, Path(out) / "cost_over_time.png")


def save_plots(result: BenchmarkResult, out: str | Path) -> dict[str, Path]:
    """Write every figure of ``nxtnav bench planners`` into `out` and return the files.

    The box plots (`save_boxplots`), ``exec_vs_turns.png`` (`draw_exec_vs_turns` of the raw and the
    simplified paths, when the execution error was measured), ``paths.png`` (`draw_paths_grid` of
    run 0) and ``cost_over_time.png`` (`draw_cost_over_time` per map).
    """
    files = save_boxplots(result, out)
    if result.config.exec_repeats > 0:
        panels = [False, True] if result.config.simplify != "none" else [False]
        fig, axes = plt.subplots(1, len(panels), figsize=(7.0 * len(panels), 4.4), squeeze=False, sharey=True)
        for ax, simplified in zip(axes[0], panels, strict=True):
            draw_exec_vs_turns(result, ax, simplified)
        fig.tight_layout()
        files["exec_vs_turns"] = save_figure(fig, Path(out) / "exec_vs_turns.png")
    size = min(2.9, 19.0 / max(len(result.config.planners), 1))  # many planners: narrower panels, one page wide
    files["paths"] = save_figure(draw_paths_grid(result, size=size), Path(out) / "paths.png")
    files["cost_over_time"] = save_cost_over_time(result, out)
    return files
