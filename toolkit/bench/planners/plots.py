"""Figures of the planner benchmark: box plots per metric and map, paths side by side, error vs turns.

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

from ...plotting import draw_cspace, draw_map, draw_path, save_figure
from ...world import ConfigError, load_map
from .records import BenchmarkResult, RunRecord

__all__ = ["BOXPLOT_METRICS", "draw_exec_vs_turns", "draw_metric_boxplot", "draw_paths_grid", "save_boxplots",
           "save_plots"]

#: Box-plot metrics: record attribute -> (axis label, file stem, log scale).
BOXPLOT_METRICS: dict[str, tuple[str, str, bool]] = {
    "time_s": ("planning time (s)", "time", True),
    "length_ratio": ("length / shortest", "length_ratio", False),
    "turns": ("turns", "turns", False),
    "exec_error_cm": ("execution error (cm)", "exec_error", False),
}

_COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


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


def draw_exec_vs_turns(result: BenchmarkResult, ax: Axes) -> list[Any]:
    """Execution error against the number of turns of every successful run, coloured by planner."""
    artists: list[Any] = []
    for j, p in enumerate(result.config.planners):
        rs = [r for r in result.records if r.planner == p and r.success and math.isfinite(r.exec_error_cm)]
        if not rs:
            continue
        x = np.array([r.turns for r in rs]) + np.random.default_rng(j).uniform(-0.15, 0.15, len(rs))
        artists.append(ax.scatter(x, [r.exec_error_cm for r in rs], s=10, alpha=0.6,
                                  color=_COLORS[j % len(_COLORS)], label=p))
    nz = result.config.noise
    ax.set_xlabel("turns in the path")
    ax.set_ylabel("mean execution error (cm)")
    ax.set_title(f"open-loop execution error vs turns ({nz.model} noise: motion {nz.motion:g}, turn {nz.turn:g})")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return artists


def save_plots(result: BenchmarkResult, out: str | Path) -> dict[str, Path]:
    """Write every figure of ``nxtnav bench planners`` into `out` and return the files.

    The box plots (`save_boxplots`), ``exec_vs_turns.png`` (`draw_exec_vs_turns`, when the
    execution error was measured) and ``paths.png`` (`draw_paths_grid` of run 0).
    """
    files = save_boxplots(result, out)
    if result.config.exec_repeats > 0:
        fig, ax = plt.subplots(figsize=(7.0, 4.2))
        draw_exec_vs_turns(result, ax)
        files["exec_vs_turns"] = save_figure(fig, Path(out) / "exec_vs_turns.png")
    files["paths"] = save_figure(draw_paths_grid(result, size=2.9), Path(out) / "paths.png")
    return files
