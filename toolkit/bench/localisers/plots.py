"""Figures of the localiser benchmark and of single localisations.

Every ``plot_*`` function takes the trial results (or one outcome) and an optional axes, and returns
the artists it drew; `write_plots` saves the standard set into a folder. Nothing opens a window.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from localisation.procedure import LocalisationResult
from toolkit.plotting import draw_map, draw_particles, draw_pose, plain_log_axis, save_figure
from toolkit.world import Map, Pose, RobotGeometry

from ...world.arrays import FloatArray
from .records import SUCCESS_CM, SUCCESS_DEG, GlobalRun, KidnappedRun, LocalisationOutcome, TrackingRun, TrialResult

__all__ = [
    "draw_localisation",
    "iteration_snapshots",
    "plot_error_ecdf",
    "plot_kidnapped",
    "plot_success",
    "plot_times",
    "plot_tracking",
    "write_plots",
]


def _ax(ax: Axes | None, size: tuple[float, float] = (6.0, 4.0)) -> Axes:
    return ax if ax is not None else plt.subplots(figsize=size)[1]


def _colours(names: Sequence[str]) -> dict[str, Any]:
    cmap = plt.get_cmap("tab10")
    return {n: cmap(i % 10) for i, n in enumerate(names)}


def _of(results: Sequence[TrialResult], kind: type, map_name: str | None = None) -> list[Any]:
    return [r for r in results if isinstance(r, kind) and (map_name is None or r.map == map_name)]


def plot_error_ecdf(results: Sequence[TrialResult], map_name: str, localisers: Sequence[str],
                    ax: Axes | None = None, quantity: str = "position") -> list[Any]:
    """Empirical CDF of the final error per localiser on one map (log axis).

    `quantity` is ``position`` (cm) or ``heading`` (absolute, degrees); the success threshold is
    drawn dashed. Trials that raised (NaN errors) keep their curve below 1.
    """
    ax = _ax(ax)
    rs = _of(results, GlobalRun, map_name)
    col = _colours(localisers)
    heading = quantity == "heading"
    artists: list[Any] = []
    for n in localisers:
        sel = [r for r in rs if r.localiser == n]
        if not sel:
            continue
        e = np.sort([abs(r.heading_error_deg) if heading else r.error_cm for r in sel])
        y = np.arange(1, e.size + 1) / e.size
        artists.extend(ax.step(np.maximum(e, 1e-2), y, where="post", color=col[n], label=n))
    limit = SUCCESS_DEG if heading else SUCCESS_CM
    unit = "°" if heading else " cm"
    artists.append(ax.axvline(limit, color="0.3", ls="--", lw=1, label=f"{limit:g}{unit}"))
    ax.set_xscale("log")
    plain_log_axis(ax.xaxis)
    ax.set_xlabel("final heading error (degrees)" if heading else "final position error (cm)")
    ax.set_ylabel("fraction of trials")
    ax.set_ylim(0, 1.02)
    ax.set_title(f"{map_name}: {'heading' if heading else 'position'} error distribution")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower right")
    return artists


def plot_times(results: Sequence[TrialResult], map_name: str, localisers: Sequence[str],
               ax: Axes | None = None) -> list[Any]:
    """Box plot of the localisation time (ms, log axis) per localiser on one map."""
    ax = _ax(ax)
    rs = _of(results, GlobalRun, map_name)
    names = [n for n in localisers if any(r.localiser == n for r in rs)]
    data = [[1e3 * r.time_s for r in rs if r.localiser == n and np.isfinite(r.time_s)] for n in names]
    if not data:
        return []
    bp = ax.boxplot(data, showfliers=True, flierprops={"markersize": 2})
    ax.set_xticks(range(1, len(names) + 1), names, rotation=30, ha="right", fontsize=8)
    ax.set_yscale("log")
    plain_log_axis(ax.yaxis)
    ax.set_ylabel("localisation time (ms)")
    ax.set_title(f"{map_name}: time per localisation")
    ax.grid(alpha=0.3, axis="y", which="both")
    return [bp]


def _rate_bars(ax: Axes, maps: Sequence[str], localisers: Sequence[str],
               rate: Callable[[str, str], float], ylabel: str, title: str) -> list[Any]:
    """Grouped bars of `rate(map, localiser)` (%), each labelled with its value (so 0 % shows)."""
    col = _colours(localisers)
    width = 0.8 / max(len(localisers), 1)
    artists: list[Any] = []
    for j, n in enumerate(localisers):
        bars = ax.bar(np.arange(len(maps)) + j * width - 0.4 + width / 2, [rate(m, n) for m in maps], width,
                      color=col[n], label=n)
        artists.append(bars)
        artists.extend(ax.bar_label(bars, fmt="%.0f", fontsize=7, padding=1))
    ax.set_xticks(range(len(maps)), list(maps))
    ax.set_ylabel(ylabel)
    ax.set_ylim(0, 125)
    ax.set_yticks(range(0, 101, 20))
    ax.set_title(title)
    ax.legend(fontsize=7, ncol=min(len(localisers), 4), loc="upper center")
    return artists


def plot_success(results: Sequence[TrialResult], maps: Sequence[str], localisers: Sequence[str],
                 ax: Axes | None = None) -> list[Any]:
    """Grouped bars: success rate (%) per map and localiser."""

    def rate(m: str, n: str) -> float:
        rs = [r for r in _of(results, GlobalRun, m) if r.localiser == n]
        return 100.0 * float(np.mean([r.success for r in rs])) if rs else np.nan

    return _rate_bars(_ax(ax, (7.0, 4.0)), maps, localisers, rate, "success rate (%)",
                      f"success (within {SUCCESS_CM:g} cm and 3 degrees)")


def plot_tracking(results: Sequence[TrialResult], map_name: str, localisers: Sequence[str],
                  ax: Axes | None = None) -> list[Any]:
    """Median (line) and 90th percentile (band) of the tracking error after each action, per localiser."""
    ax = _ax(ax)
    rs = _of(results, TrackingRun, map_name)
    col = _colours(localisers)
    artists: list[Any] = []
    for n in localisers:
        e = [r.errors_cm for r in rs if r.localiser == n and r.errors_cm]
        if not e:
            continue
        k = min(len(x) for x in e)
        a = np.array([x[:k] for x in e])
        steps = np.arange(1, k + 1)
        artists.extend(ax.plot(steps, np.median(a, axis=0), color=col[n], label=n))
        artists.append(ax.fill_between(steps, np.percentile(a, 10, axis=0), np.percentile(a, 90, axis=0),
                                       color=col[n], alpha=0.15))
    ax.set_yscale("log")
    plain_log_axis(ax.yaxis)
    ax.set_xlabel("action")
    ax.set_ylabel("position error (cm)")
    ax.set_title(f"{map_name}: tracking error (median, 10-90 %)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    return artists


def plot_kidnapped(results: Sequence[TrialResult], maps: Sequence[str], localisers: Sequence[str],
                   ax: Axes | None = None) -> list[Any]:
    """Grouped bars: kidnapped-robot recovery rate (%) per map and localiser."""

    def rate(m: str, n: str) -> float:
        rs = [r for r in _of(results, KidnappedRun, m) if r.localiser == n and r.localised]
        return 100.0 * float(np.mean([r.recovered for r in rs])) if rs else np.nan

    return _rate_bars(_ax(ax, (7.0, 4.0)), maps, localisers, rate, "recovered (%)",
                      "kidnapped robot: recovery without reset")


def write_plots(results: Sequence[TrialResult], out_dir: str | Path, maps: Sequence[str],
                localisers: Sequence[str]) -> list[Path]:
    """Save the standard figures of whichever scenarios `results` holds; returns the files."""
    out = Path(out_dir)
    files: list[Path] = []
    if _of(results, GlobalRun):
        fig, axes = plt.subplots(2, len(maps), figsize=(4.2 * len(maps), 7.6), squeeze=False,
                                 layout="constrained")
        for m, ax, ax2 in zip(maps, axes[0], axes[1], strict=True):
            plot_error_ecdf(results, m, localisers, ax)
            plot_error_ecdf(results, m, localisers, ax2, quantity="heading")
        files.append(save_figure(fig, out / "errors.png"))
        fig, axes = plt.subplots(1, len(maps), figsize=(4.2 * len(maps), 3.8), squeeze=False,
                                 layout="constrained")
        for m, ax in zip(maps, axes[0], strict=True):
            plot_times(results, m, localisers, ax)
        files.append(save_figure(fig, out / "times.png"))
        fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
        plot_success(results, maps, localisers, ax)
        files.append(save_figure(fig, out / "success.png"))
    if _of(results, TrackingRun):
        fig, axes = plt.subplots(1, len(maps), figsize=(4.2 * len(maps), 3.8), squeeze=False,
                                 layout="constrained")
        for m, ax in zip(maps, axes[0], strict=True):
            plot_tracking(results, m, localisers, ax)
        files.append(save_figure(fig, out / "tracking.png"))
    if _of(results, KidnappedRun):
        fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
        plot_kidnapped(results, maps, localisers, ax)
        files.append(save_figure(fig, out / "kidnapped.png"))
    return files


# -- one localisation ------------------------------------------------------------------------------


def iteration_snapshots(result: LocalisationResult) -> list[tuple[str, FloatArray | None, Pose]]:
    """(label, particles or None, mean pose) per filter iteration of a procedure's trace.

    A `localisation.procedure.LocalisationResult` holds one `TraceStep` per procedure iteration
    (scan, update), each with the particle filter's snapshots of that update (one per annealed
    filter iteration: ``particles`` and ``estimate``); Kalman filters have none, and their step's
    estimate stands for the iteration.
    """
    out: list[tuple[str, FloatArray | None, Pose]] = []
    for step in result.trace:
        if not step.snapshots:
            out.append((f"scan {step.iteration}", None, step.estimate.pose))
            continue
        for j, sn in enumerate(step.snapshots, 1):
            out.append((f"scan {step.iteration}, filter iteration {j}/{len(step.snapshots)}",
                        np.asarray(sn.particles, dtype=float), sn.estimate.pose))
    return out


def draw_localisation(m: Map, outcome: LocalisationOutcome, title: str = "", max_panels: int = 6) -> Figure:
    """Small multiples of a localisation: particles and mean at chosen iterations, then the final estimate.

    Each panel shows one filter iteration of the procedure's trace (the first, the last and evenly
    spaced ones between, at most `max_panels` - 1) with its particles (orange) and mean pose (blue);
    the last panel shows the final estimate against the simulator's true pose (green). The robot
    turns and may drive during the procedure, so earlier panels show the belief about earlier poses.
    """
    snaps = iteration_snapshots(outcome.result)
    k = max_panels - 1
    idx = sorted({round(i) for i in np.linspace(0, len(snaps) - 1, min(k, len(snaps)))}) if snaps else []
    n = len(idx) + 1
    xmin, ymin, xmax, ymax = m.bounds
    aspect = min(max((ymax - ymin) / max(xmax - xmin, 1e-9), 0.25), 2.0)
    width = 4.2 if aspect >= 0.6 else 5.5
    cols = min(n, 3 if aspect >= 0.6 else 2)  # wide maps: two columns, so the panels stay legible
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, (width * aspect + 1.2) * rows), squeeze=False)
    flat = list(axes.ravel())
    radius = RobotGeometry().radius_cm
    for ax, i in zip(flat, idx, strict=False):
        label, parts, pose = snaps[i]
        draw_map(m, ax, presets=False, title=False)
        if parts is not None and len(parts):
            draw_particles(parts[:, :2], ax, size=5.0, alpha=0.45)
        if pose is not None:
            draw_pose(pose, ax, color="tab:blue")
        ax.set_title(label + ("" if parts is None else f" ({len(parts)} particles shown)"), fontsize=9)
    ax = flat[len(idx)]
    draw_map(m, ax, presets=False, title=False)
    draw_pose(outcome.truth, ax, radius=radius, color="tab:green", label="truth", length=14.0)
    draw_pose(outcome.estimate, ax, color="tab:blue", label="estimate")
    ax.set_title(f"final: error {outcome.error_cm:.2f} cm, {outcome.heading_error_deg:+.2f}°", fontsize=9)
    ax.legend(fontsize=7, loc="best")
    for extra in flat[n:]:
        extra.set_visible(False)
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return fig
