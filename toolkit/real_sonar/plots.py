"""Figures of real sweeps against the `nxt` sonar model: radar charts, no-echo probability curves, and
where in the map one sweep puts the robot.

Every sweep is drawn where the model finds it most likely (`toolkit.real_sonar.fit.align_sweeps`: heading
and a few cm of position around its waypoint), so real and model are compared reading for reading.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from localisation.base import HeadingPrior

from ..plotting import draw_map
from ..world import NO_ECHO, Map, NxtSonar, ray_cast
from ..world.arrays import FloatArray
from .fit import AlignedSweep, align_sweeps
from .margins import LATTICE_STEP_CM, place_costs
from .sweeps import Sweep, SweepSet

__all__ = ["draw_incidence_curves", "draw_places", "draw_sweep_radar", "real_sonar_figures"]

PLACES_FLOOR_NATS = 15.0
"""The place map's colour scale: from the best place down to this many nats below it."""


def draw_sweep_radar(ax: Any, a: AlignedSweep, model: NxtSonar, *, rng: int = 0) -> None:
    """One sweep on polar axes: the real readings, the model's noise-free echo and one draw of the
    model at the same angles (no-echo readings as crosses on the rim)."""
    theta = a.heading_rad + a.angles  # map frame: the chart is oriented like the map
    real = a.readings
    echo = np.where(np.isfinite(a.echo), a.echo + model.bias_cm, np.nan)
    draw = model.sample(a.echo, rng)
    rim = 1.08 * max(np.nanmax(np.where(real < NO_ECHO, real, np.nan), initial=50.0),
                     np.nanmax(np.where(draw < NO_ECHO, draw, np.nan), initial=50.0))
    order = np.argsort(theta % (2 * math.pi))
    t = theta[order] % (2 * math.pi)
    ax.plot(t, echo[order], color="0.55", lw=1.0, label="model, noise-free echo")
    for values, colour, label, marker in ((real, "tab:blue", "real", "o"), (draw, "tab:orange", "model draw", ".")):
        v = values[order]
        heard = v < NO_ECHO
        ax.scatter(t[heard], v[heard], s=6, color=colour, marker=marker, label=label)
        ax.scatter(t[~heard], np.full(int((~heard).sum()), rim), s=10, color=colour, marker="x")
    ax.set_ylim(0, rim * 1.04)
    ax.set_title(f"({a.sweep.x_cm:g}, {a.sweep.y_cm:g}) {a.sweep.file}", fontsize=9)


def incidence_deg(a: AlignedSweep) -> FloatArray:
    """Angle (degrees) between each reading's axis and the normal of the wall the axis meets (nan: none)."""
    absolute = a.heading_rad + a.angles
    walls = a.walls
    t, w = ray_cast(walls, np.array([a.x_cm, a.y_cm]), absolute, return_wall=True)
    seg = walls[np.maximum(w, 0)]
    ex, ey = seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]
    cos_inc = np.abs(np.cos(absolute) * ey - np.sin(absolute) * ex) / np.hypot(ex, ey)
    return np.where((w >= 0) & np.isfinite(t), np.degrees(np.arccos(np.clip(cos_inc, 0.0, 1.0))), np.nan)


def draw_incidence_curves(ax_inc: Any, ax_range: Any, aligned: Sequence[AlignedSweep],
                          model: NxtSonar) -> None:
    """No-echo share against the axis's incidence on its wall and against the axis's range: real (points
    with binomial error bars) and the model's mean probability over the same readings (line)."""
    inc = np.concatenate([incidence_deg(a) for a in aligned])
    rng_axis = np.concatenate([np.asarray(ray_cast(a.walls, np.array([a.x_cm, a.y_cm]), a.heading_rad + a.angles))
                               for a in aligned])
    silent = np.concatenate([a.readings >= NO_ECHO for a in aligned])
    p_model = np.concatenate([np.exp(model.log_pmf(a.echo, np.full(a.echo.shape, NO_ECHO))) for a in aligned])
    for ax_, x, edges, label in ((ax_inc, inc, np.arange(0.0, 91.0, 10.0), "incidence of the axis on its wall (deg)"),
                                 (ax_range, rng_axis, np.array([0, 30, 45, 60, 80, 100, 130, 160, 200, 260.0]),
                                  "range along the axis (cm)")):
        centres, real, err, mod = [], [], [], []
        for lo, hi in itertools.pairwise(edges):
            sel = (x >= lo) & (x < hi)
            n = int(sel.sum())
            if n < 10:
                continue
            share = float(silent[sel].mean())
            centres.append(0.5 * (lo + hi))
            real.append(share)
            err.append(math.sqrt(max(share * (1 - share), 1e-4) / n))
            mod.append(float(p_model[sel].mean()))
        ax_.errorbar(centres, real, yerr=err, fmt="o", color="tab:blue", label="real")
        ax_.plot(centres, mod, "-", color="tab:orange", label="model")
        ax_.set_xlabel(label)
        ax_.set_ylabel("share of no-echo readings (255)")
        ax_.set_ylim(0, 1)
        ax_.grid(alpha=0.3)
        ax_.legend(fontsize=8)


def draw_places(ax: Any, m: Map, xy: FloatArray, costs: FloatArray, sweep: Sweep, title: str) -> Any:
    """Where one sweep puts the robot: per lattice cell, the log-likelihood of its best heading (nats
    below the best cell, down to `PLACES_FLOOR_NATS`), the waypoint (red star) and the best pose
    (white arrow). Returns the image (for a colour bar)."""
    best_h = costs.min(axis=1)
    ll = np.maximum(-0.5 * (best_h - best_h.min()), -PLACES_FLOOR_NATS)
    step = float(LATTICE_STEP_CM)
    ij = np.rint((xy - xy.min(axis=0)) / step).astype(np.int64)
    grid = np.full((ij[:, 1].max() + 1, ij[:, 0].max() + 1), np.nan)
    grid[ij[:, 1], ij[:, 0]] = ll
    x0, y0 = xy.min(axis=0) - step / 2.0
    draw_map(m, ax, presets=False, title=False)
    im = ax.imshow(grid, origin="lower", extent=(x0, x0 + grid.shape[1] * step, y0, y0 + grid.shape[0] * step),
                   cmap="magma", vmin=-PLACES_FLOOR_NATS, vmax=0.0, interpolation="nearest", zorder=1)
    c, h = np.unravel_index(int(np.argmin(costs)), costs.shape)
    th = 2.0 * math.pi * h / costs.shape[1]
    ax.annotate("", xy=(xy[c, 0] + 14 * math.cos(th), xy[c, 1] + 14 * math.sin(th)), xytext=tuple(xy[c]),
                arrowprops={"arrowstyle": "->", "color": "white", "lw": 2}, zorder=6)
    ax.plot(sweep.x_cm, sweep.y_cm, marker="*", color="tab:red", ms=15, mec="white", ls="", zorder=7,
            label="waypoint")
    ax.set_title(title, fontsize=9)
    return im


def real_sonar_figures(sets: Sequence[SweepSet], model: NxtSonar, out: Path, *, radar_sweeps: int = 3,
                       rng: int = 0, heading_prior: HeadingPrior | None = None,
                       on_figure: Callable[[Path], None] | None = None) -> list[Path]:
    """``real_sonar_radar.png`` (the first `radar_sweeps` sweeps at distinct waypoints, real against
    model), ``real_sonar_no_echo.png`` (no-echo share against incidence and range) and
    ``real_sonar_places.png`` (where the first sweep puts the robot, alone and, with `heading_prior`,
    with the heading known roughly) in `out`; `on_figure` is called with each file as it is written
    (a progress display)."""
    done = on_figure or (lambda path: None)
    out.mkdir(parents=True, exist_ok=True)
    aligned = [x for s in sets for x in align_sweeps(model, s)]
    seen: set[tuple[float, float]] = set()
    picks = []
    for a in aligned:
        key = (a.sweep.x_cm, a.sweep.y_cm)
        if key not in seen:
            seen.add(key)
            picks.append(a)
    picks = picks[:radar_sweeps]
    fig = Figure(figsize=(4.2 * len(picks), 4.6))
    for i, a in enumerate(picks):
        ax = fig.add_subplot(1, len(picks), i + 1, projection="polar")
        draw_sweep_radar(ax, a, model, rng=rng + i)
        if i == 0:
            ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(-0.15, -0.2))
    fig.suptitle("real NXT sweeps (blue; stuck runs left out) against the nxt sonar model (orange: one draw; "
                 "grey: noise-free echo), map frame; x on the rim: no echo", fontsize=9)
    radar = out / "real_sonar_radar.png"
    fig.savefig(radar, dpi=110, bbox_inches="tight")
    done(radar)
    fig2 = Figure(figsize=(10, 4))
    draw_incidence_curves(fig2.add_subplot(1, 2, 1), fig2.add_subplot(1, 2, 2), aligned, model)
    fig2.suptitle(f"no-echo readings of {len(aligned)} real sweeps against the model", fontsize=10)
    curves = out / "real_sonar_no_echo.png"
    fig2.savefig(curves, dpi=110, bbox_inches="tight")
    done(curves)
    places = _places_figure(sets[0], model, out / "real_sonar_places.png", heading_prior)
    done(places)
    return [radar, curves, places]


def _places_figure(sweeps: SweepSet, model: NxtSonar, path: Path, heading_prior: HeadingPrior | None) -> Path:
    first = SweepSet(sweeps.folder, sweeps.map, sweeps.sweeps[:1])
    sw = first.sweeps[0]
    panels: list[tuple[HeadingPrior | None, str]] = [(None, "one sweep alone (global)")]
    if heading_prior is not None:
        panels.append((heading_prior, f"heading known: {math.degrees(heading_prior.heading_rad):g} +- "
                                      f"{math.degrees(heading_prior.sd_rad):g} deg"))
    fig = Figure(figsize=(4.6 * len(panels) + 0.8, 4.4))
    axes = [fig.add_subplot(1, len(panels), i + 1) for i in range(len(panels))]
    im = None
    for ax, (prior, title) in zip(axes, panels, strict=True):
        xy, costs = place_costs(model, first, prior)
        im = draw_places(ax, sweeps.map, xy, next(costs), sw, title)
    axes[0].legend(fontsize=8, loc="lower left")
    assert im is not None
    fig.colorbar(im, ax=axes, shrink=0.8, label="best heading's log-likelihood (nats below the best place)")
    fig.suptitle(f"where one real sweep puts the robot: {sw.label} at ({sw.x_cm:g}, {sw.y_cm:g});\n"
                 "arrow: the most likely pose", fontsize=9)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path
