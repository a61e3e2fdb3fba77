"""Drawing missions like the paper's figures: map, c-space, planned path(s), estimates, true trajectory.

Functions take an optional ``ax`` and return the artists they drew (nothing opens a window);
`animate_mission` writes a GIF with matplotlib's Pillow writer.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..mission import Action, MissionReport
from ..plotting import draw_cspace, draw_map, draw_path, draw_pose, plain_log_axis
from ..world import Map, RobotGeometry
from .paper import PAPER_TABLE, PaperResult
from .paper_pareto import ParetoPoint

__all__ = ["animate_mission", "draw_error_spread", "draw_mission", "draw_paper_table", "draw_pareto"]


def _ax(ax: Axes | None) -> Axes:
    return ax if ax is not None else plt.subplots(figsize=(6, 6))[1]


def draw_mission(report: MissionReport, m: Map, ax: Axes | None = None, radius: float | None = None,
                 legend: bool = True) -> list[Any]:
    """The whole mission on its map.

    Draws the walls, the c-space of the robot disc, every planned path (the first solid, re-plans
    dashed), the estimates after each action (small dots), the true trajectory (when known), the
    true start and end poses and the target.
    """
    ax = _ax(ax)
    r = RobotGeometry().radius_cm if radius is None else radius
    out: list[Any] = []
    out.extend(draw_map(m, ax, presets=False, title=False))
    out.extend(draw_cspace(m, r, ax))
    for i, path in enumerate(report.plans):
        if i == 0:
            out.extend(draw_path(path, ax, color="tab:red", label="planned path"))
        else:
            out.extend(ax.plot(path[:, 0], path[:, 1], "--", color="tab:red", lw=1, alpha=0.6,
                               label="re-planned" if i == 1 else None, zorder=5))
    est = report.confident_estimates()
    if len(est):
        out.append(ax.scatter(est[:, 0], est[:, 1], s=10, c="tab:purple", zorder=6, label="estimates"))
    traj = report.true_trajectory
    if len(traj):
        out.extend(ax.plot(traj[:, 0], traj[:, 1], "-", color="tab:blue", lw=1.5, label="true trajectory",
                           zorder=6))
    if report.poses.start is not None:
        out.extend(draw_pose(report.poses.start, ax, radius=r, color="tab:green", label="start"))
    if report.poses.final_pose is not None:
        out.extend(draw_pose(report.poses.final_pose, ax, radius=r, color="tab:blue", label="end"))
    out.extend(ax.plot(*report.poses.target, marker="*", color="tab:red", ms=15, ls="", label="target", zorder=9))
    err = "?" if report.final_error_cm is None else f"{report.final_error_cm:.2f} cm"
    ax.set_title(f"{report.map}: {report.planner}/{report.localiser}, seed {report.seed}\n"
                 f"{'reached' if report.success else 'failed'}, final error {err}, "
                 f"{report.path_length_cm:.0f} cm driven, {report.collisions} collisions", fontsize=9)
    if legend:
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.26), ncol=4, fontsize=7, frameon=False)
    return out


def draw_error_spread(errors: dict[str, Sequence[float]], ax: Axes | None = None,
                      paper: dict[str, float] | None = None) -> list[Any]:
    """Box plots (with the points) of final errors per label, with the paper's means as stars."""
    ax = _ax(ax)
    labels = list(errors)
    data = [np.asarray(errors[k], dtype=float) for k in labels]
    out: list[Any] = [ax.boxplot(data, tick_labels=labels, showmeans=True)]
    rng = np.random.default_rng(0)
    for i, d in enumerate(data, start=1):
        out.append(ax.scatter(i + rng.uniform(-0.12, 0.12, d.size), d, s=6, alpha=0.5, c="tab:blue"))
    if paper:
        xs = [i for i, k in enumerate(labels, start=1) if k in paper]
        out.append(ax.scatter(xs, [paper[labels[i - 1]] for i in xs], marker="*", s=120, c="tab:red", zorder=5,
                              label="paper (mean)"))
        ax.legend(fontsize=8)
    ax.set_ylabel("final distance from target (cm)")
    return out


def draw_paper_table(results: Sequence[PaperResult], size: float = 4.2) -> Figure:
    """Table I as a figure: final error and driven path length per map, the paper's means as stars.

    One box per map (and per noise model, stack, sonar and start kind when `results` mixes them), over
    the trials that succeeded; the title of each panel counts the successes.
    """
    groups: dict[str, list[PaperResult]] = {}
    keys = ("noise_model", "stack", "sonar", "random_start")
    varying = [k for k in keys if len({getattr(r.task, k) for r in results}) > 1]
    for r in results:
        extra = [str(getattr(r.task, k)) if k != "random_start" else ("random" if r.task.random_start else "preset")
                 for k in varying]
        groups.setdefault("\n".join([r.task.map, *extra]), []).append(r)
    fig, axes = plt.subplots(1, 2, figsize=(2 * size + 0.4 * len(groups), size), layout="constrained")
    ok = {k: [r for r in v if r.success] for k, v in groups.items()}
    for ax, attr, field, label in ((axes[0], "final_error_cm", "final_error_cm", "final distance from target (cm)"),
                                   (axes[1], "path_length_cm", "path_length_cm", "driven path length (cm)")):
        paper = {k: PAPER_TABLE[v[0].task.map][field] for k, v in groups.items() if v[0].task.map in PAPER_TABLE}
        draw_error_spread({k: [getattr(r, attr) for r in v] for k, v in ok.items() if v}, ax, paper=paper)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    n_ok, n = sum(len(v) for v in ok.values()), len(results)
    fixed = [f"{getattr(results[0].task, k)} {k.replace('_', ' ')}" for k in ("noise_model", "sonar")
             if k not in varying] if results else []
    fig.suptitle(f"Table I over {n} missions ({n_ok} reached the target{', ' if fixed else ''}{', '.join(fixed)}):"
                 " boxes = this toolkit, stars = the paper's means", fontsize=10)
    return fig


def draw_pareto(points: Sequence[ParetoPoint], map_name: str, ax: Axes | None = None,
                highlight: str = "default") -> list[Any]:
    """Mean final error against median robot time on one map, one marker per setting and sonar model.

    Each sonar model's front (`ParetoPoint.on_front`) is joined by a line; settings that failed a
    trial or collided are drawn hollow; the `highlight` setting is labelled in bold.
    """
    ax = _ax(ax)
    out: list[Any] = []
    colours = {"ideal": "tab:blue", "nxt": "tab:orange"}
    mine = [p for p in points if p.map == map_name]
    for sonar in sorted({p.sonar for p in mine}):
        pts = sorted((p for p in mine if p.sonar == sonar), key=lambda p: p.robot_time_median_s)
        c = colours.get(sonar, "tab:gray")
        for p in pts:
            clean = p.success_rate == 1.0 and p.collisions == 0
            out.append(ax.scatter(p.robot_time_median_s, p.final_error_cm, s=40, marker="o",
                                  facecolors=c if clean else "none", edgecolors=c, zorder=4))
            out.append(ax.annotate(p.setting, (p.robot_time_median_s, p.final_error_cm), fontsize=7,
                                   xytext=(4, 3), textcoords="offset points",
                                   fontweight="bold" if p.setting == highlight else "normal"))
        front = [p for p in pts if p.on_front]
        if front:
            out.extend(ax.plot([p.robot_time_median_s for p in front], [p.final_error_cm for p in front], "-",
                               color=c, lw=1.2, label=f"{sonar} sonar: front", zorder=3))
    for values, axis, setter, spread in (([p.robot_time_median_s for p in mine], ax.xaxis, ax.set_xscale, 4.0),
                                         ([p.final_error_cm for p in mine], ax.yaxis, ax.set_yscale, 10.0)):
        v = [x for x in values if np.isfinite(x) and x > 0]
        if v and max(v) > spread * min(v):  # one far point would squash the others into a cluster
            setter("log")
            plain_log_axis(axis)
    ax.set_xlabel("median robot time (s)")
    ax.set_ylabel("mean true final error (cm)")
    ax.set_title(map_name, fontsize=9)
    ax.grid(alpha=0.3)
    if out:
        ax.legend(fontsize=7)
    return out


def animate_mission(report: MissionReport, m: Map, path: str | Path, radius: float | None = None,
                    fps: int = 8, max_frames: int = 120) -> Path:
    """Write the mission as an animated GIF (Pillow writer): the robot and its estimate step by step."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    r = RobotGeometry().radius_cm if radius is None else radius
    steps = report.trace
    idx = np.unique(np.linspace(0, max(len(steps) - 1, 0), min(len(steps), max_frames)).astype(int))
    fig: Figure
    fig, ax = plt.subplots(figsize=(6, 6))
    draw_map(m, ax, presets=False, title=False)
    draw_cspace(m, r, ax)
    ax.plot(*report.poses.target, marker="*", color="tab:red", ms=15, ls="", zorder=9)
    traj_line, = ax.plot([], [], "-", color="tab:blue", lw=1.5, zorder=6)
    est_dots = ax.scatter([], [], s=10, c="tab:purple", zorder=6)
    plan_line, = ax.plot([], [], "-o", color="tab:red", ms=3, lw=1.5, zorder=5)
    robot_circle = plt.Circle((np.nan, np.nan), r, fill=False, ec="tab:blue", lw=1.5, zorder=7)
    ax.add_patch(robot_circle)
    title = ax.set_title("", fontsize=9)
    plan_steps = [k for k, s in enumerate(steps) if s.action == Action.PLAN and not s.note.startswith("failed")]
    truth = [s.true_pose for s in steps]
    start = report.poses.start

    def frame(j: int) -> list[Any]:
        k = int(idx[j])
        pts = [p.xy for p in truth[: k + 1] if p is not None]
        if start is not None:
            pts.insert(0, start.xy)
        if pts:
            a = np.array(pts)
            traj_line.set_data(a[:, 0], a[:, 1])
            robot_circle.center = (a[-1, 0], a[-1, 1])
        ests = np.array([s.estimate.xy for s in steps[: k + 1] if s.estimate is not None
                         and (s.spread_cm is None or s.spread_cm <= 5.0)]).reshape(-1, 2)
        est_dots.set_offsets(ests)
        n_plans = sum(1 for p in plan_steps if p <= k)
        if n_plans and n_plans <= len(report.plans):
            p = report.plans[n_plans - 1]
            plan_line.set_data(p[:, 0], p[:, 1])
        s = steps[k] if steps else None
        title.set_text(f"{report.map}: step {k + 1}/{len(steps)} {s.action if s else ''}")
        return [traj_line, est_dots, plan_line, robot_circle, title]

    anim = FuncAnimation(fig, frame, frames=len(idx), blit=False)
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    anim.save(str(p), writer=PillowWriter(fps=fps))
    plt.close(fig)
    return p
