"""Matplotlib drawing of maps, c-space, poses, paths, particles and scans.

Every function takes an optional ``ax`` and returns the artists it drew; nothing here opens a
window. `save_figure` writes a figure to a file and closes it.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import matplotlib.ticker as mticker
import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle, PathPatch
from matplotlib.path import Path as MplPath
from numpy.typing import ArrayLike
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient

from .world import Map, Pose, Scan, ray_cast

__all__ = [
    "draw_cspace",
    "draw_map",
    "draw_particles",
    "draw_path",
    "draw_pose",
    "draw_radar",
    "draw_scan_rays",
    "new_axes",
    "plain_log_axis",
    "save_figure",
]


def new_axes(ncols: int = 1, size: float = 5.0, polar: bool = False) -> tuple[Figure, Any]:
    """A figure with `ncols` axes side by side."""
    subplot_kw = {"projection": "polar"} if polar else None
    fig, axes = plt.subplots(1, ncols, figsize=(size * ncols, size), squeeze=True, subplot_kw=subplot_kw)
    return fig, axes


def save_figure(fig: Figure, path: str | Path, dpi: int = 120) -> Path:
    """Save `fig` to `path` (parent folders created) and close it."""
    p = Path(path)
    if p.parent and not p.parent.exists():
        p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return p


def plain_log_axis(axis: Any) -> None:
    """Log axis with plain numbers (1, 2, 5, 10, ... or 1, 10, 100 over a wide range), not powers of ten."""
    lo, hi = sorted(axis.get_view_interval())
    decades = math.log10(hi / lo) if lo > 0 and hi > lo else 1.0
    axis.set_major_locator(mticker.LogLocator(base=10, subs=(1.0, 2.0, 5.0) if decades <= 3.0 else (1.0,)))
    axis.set_major_formatter(mticker.FuncFormatter(lambda v, _pos: f"{v:g}"))
    axis.set_minor_formatter(mticker.NullFormatter())


def _ax(ax: Axes | None) -> Axes:
    return ax if ax is not None else plt.subplots(figsize=(6, 6))[1]


def _geometry_patch(geom: BaseGeometry, **kw: Any) -> list[PathPatch]:
    patches = []
    polys = getattr(geom, "geoms", [geom])
    for poly in polys:
        if poly.is_empty or poly.geom_type != "Polygon":
            continue
        poly = orient(poly, 1.0)  # exterior counter-clockwise, holes clockwise: holes stay unfilled
        verts: list[Any] = []
        codes: list[Any] = []
        for ring in (poly.exterior, *poly.interiors):
            xy = np.asarray(ring.coords)
            verts.extend(xy)
            codes.extend([MplPath.MOVETO] + [MplPath.LINETO] * (len(xy) - 2) + [MplPath.CLOSEPOLY])
        patches.append(PathPatch(MplPath(verts, codes), **kw))
        kw.pop("label", None)  # one legend entry for a geometry of many parts
    return patches


def draw_map(m: Map, ax: Axes | None = None, presets: bool = True, title: bool = True) -> list[Any]:
    """The walls (black), the free area (white on grey), the thin walls (thick dark lines, labelled)
    and the start/target presets."""
    ax = _ax(ax)
    artists: list[Any] = []
    xmin, ymin, xmax, ymax = m.bounds
    pad = 0.04 * max(xmax - xmin, ymax - ymin)
    ax.set_facecolor("0.85")
    for patch in _geometry_patch(m.polygon, facecolor="white", edgecolor="none", zorder=0):
        artists.append(ax.add_patch(patch))
    # one collection for all walls (a real map has thousands); thinner lines as the map grows
    lw = float(np.clip(2.0 * math.sqrt(60.0 / max(len(m.walls), 1)), 0.3, 2.0))
    edges = np.asarray(m.walls)[:len(m.walls) - len(m.thin_segments)]
    artists.append(ax.add_collection(LineCollection(list(edges.reshape(-1, 2, 2)), colors="black",
                                                    linewidths=lw, zorder=3)))
    if m.thin_walls:  # zero thickness in the map: drawn thick so that they show at any size
        artists.append(ax.add_collection(LineCollection(list(m.thin_walls), colors="0.15", linewidths=max(3.0, 2 * lw),
                                                        capstyle="round", zorder=4, label="thin wall")))
    if presets:
        if m.start is not None:
            artists.extend(ax.plot(*m.start, marker="o", color="tab:green", ms=9, ls="", label="start", zorder=6))
        if m.target is not None:
            artists.extend(ax.plot(*m.target, marker="*", color="tab:red", ms=14, ls="", label="target",
                                   zorder=6))
    ax.set_xlim(xmin - pad, xmax + pad)
    ax.set_ylim(ymin - pad, ymax + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (cm)")
    ax.set_ylabel("y (cm)")
    if title:
        ax.set_title(m.name)
    return artists


def draw_cspace(m: Map, radius: float, ax: Axes | None = None) -> list[Any]:
    """The configuration space of a disc of `radius` cm (light blue, dashed outline)."""
    ax = _ax(ax)
    patches = _geometry_patch(m.free_space(radius), facecolor="#d6e9f8", edgecolor="#3b7dbf", ls="--",
                              lw=1, zorder=1, label=f"c-space (r = {radius:g} cm)")
    return [ax.add_patch(p) for p in patches]


def draw_pose(pose: Pose, ax: Axes | None = None, radius: float | None = None, color: str = "tab:blue",
              label: str | None = None, length: float = 8.0) -> list[Any]:
    """A pose as an arrow (and the robot disc when `radius` is given)."""
    ax = _ax(ax)
    out: list[Any] = []
    if radius:
        out.append(ax.add_patch(Circle((pose.x, pose.y), radius, fill=False, ec=color, lw=1.2, zorder=7)))
    out.append(ax.annotate("", xy=(pose.x + length * math.cos(pose.theta), pose.y + length * math.sin(pose.theta)),
                           xytext=(pose.x, pose.y),
                           arrowprops={"arrowstyle": "->", "color": color, "lw": 2}, zorder=8))
    out.extend(ax.plot(pose.x, pose.y, "o", color=color, ms=5, label=label, zorder=8))
    return out


def draw_path(path: ArrayLike, ax: Axes | None = None, color: str = "tab:red", label: str | None = None,
              **kw: Any) -> list[Any]:
    """A polyline path with its waypoints."""
    ax = _ax(ax)
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    return list(ax.plot(p[:, 0], p[:, 1], "-o", color=color, ms=4, lw=2, label=label, zorder=5, **kw))


def draw_particles(particles: ArrayLike, ax: Axes | None = None, color: str = "tab:orange", alpha: float = 0.4,
                   size: float = 4.0, label: str | None = None) -> list[Any]:
    """Particles (n, 2 or 3) as dots."""
    ax = _ax(ax)
    p = np.asarray(particles, dtype=float)
    return [ax.scatter(p[:, 0], p[:, 1], s=size, c=color, alpha=alpha, lw=0, label=label, zorder=4)]


def draw_scan_rays(pose: Pose, scan: Scan, ax: Axes | None = None, color: str = "tab:orange",
                   every: int = 5) -> list[Any]:
    """Every `every`-th valid reading of `scan` as a ray from `pose` to its end point."""
    ax = _ax(ax)
    out: list[Any] = []
    idx = np.flatnonzero(scan.valid)[::every]
    a = pose.theta + scan.angles[idx]
    ends = pose.xy + scan.ranges[idx, None] * np.column_stack([np.cos(a), np.sin(a)])
    for e in ends:
        out.extend(ax.plot([pose.x, e[0]], [pose.y, e[1]], color=color, lw=0.5, alpha=0.6, zorder=2))
    out.append(ax.scatter(ends[:, 0], ends[:, 1], s=6, c=color, zorder=4))
    return out


def draw_radar(scan: Scan, ax: Any, expected: ArrayLike | None = None, max_range: float | None = None,
               label: str = "measured", expected_label: str = "simulated") -> list[Any]:
    """The paper's radar chart (Fig. 3): readings against sensor angle on polar axes.

    `ax` must be polar. `expected` (same length as the scan) draws the noise-free readings too.
    """
    out: list[Any] = []
    ang = np.append(scan.angles, scan.angles[:1])
    if expected is not None:
        e = np.asarray(expected, dtype=float)
        out.extend(ax.plot(ang, np.append(e, e[:1]), color="tab:red", lw=1.2, label=expected_label))
    r = np.where(scan.valid, scan.ranges, np.nan)
    out.extend(ax.plot(ang, np.append(r, r[:1]), color="tab:blue", lw=1.0, label=label))
    lost = ~scan.valid
    if lost.any():
        top = max_range or float(np.nanmax(r)) if np.isfinite(np.nanmax(r)) else 1.0
        out.append(ax.scatter(scan.angles[lost], np.full(lost.sum(), top), marker="x", s=10, c="0.4",
                              label="no echo"))
    ax.set_theta_zero_location("E")
    return out


def expected_ranges(m: Map, pose: Pose, scan: Scan) -> np.ndarray:
    """Noise-free readings at the scan's angles from `pose` (for radar charts)."""
    return np.asarray(ray_cast(m.walls, pose.xy, pose.theta + scan.angles))
