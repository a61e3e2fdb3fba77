"""The figure of ``nxtnav bench routes``: one route, step by step (the sweep's rays, the belief, the truth)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib.pyplot as plt

from toolkit.plotting import draw_map, draw_pose, draw_scan_rays, save_figure
from toolkit.real_sonar.sweeps import Sweep

from .routes import RouteStep, RouteTask, _sweep_set

__all__ = ["route_figure"]


def _sweep(steps: RouteStep, sweeps: Sequence[Sweep]) -> Sweep:
    return next(sw for sw in sweeps if sw.repo == steps.repo and sw.file == steps.file
                and (sw.x_cm, sw.y_cm) == (steps.waypoint_x_cm, steps.waypoint_y_cm))


def route_figure(steps: Sequence[RouteStep], task: RouteTask, path: Path) -> Path:
    """One panel per step of a route whose task kept its beliefs (`RouteTask.keep_belief`): the map, the
    real sweep's valid readings as rays from the true pose (orange), the particle cloud (grey), the
    candidate poses (purple), the estimate (blue) and the truth (green); the path so far (dashed).

    Returns the PNG written to `path`.
    """
    sweeps = _sweep_set(task.folder, task.map)
    turret = task.sonar["turret_offset_deg"]  # the rays in the robot's frame, as the filter read them
    n = len(steps)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.4 * rows), squeeze=False)
    for ax in axes.ravel()[n:]:
        ax.set_axis_off()
    for k, (st, ax) in enumerate(zip(steps, axes.ravel(), strict=False)):
        assert st.truth is not None and st.estimate is not None
        draw_map(sweeps.map, ax, presets=False, title=False)
        if st.cloud is not None and len(st.cloud):
            ax.scatter(st.cloud[:, 0], st.cloud[:, 1], s=2, c="0.45", alpha=0.5, zorder=3, label="particles")
        draw_scan_rays(st.truth, _sweep(st, sweeps.sweeps).scan(turret), ax, color="tab:orange", every=3)
        path_so_far = [(s.waypoint_x_cm, s.waypoint_y_cm) for s in steps[:k + 1]]
        ax.plot(*zip(*path_so_far, strict=True), "--", color="tab:green", lw=1, zorder=5)
        for c in st.candidate_poses:
            ax.plot(c.x, c.y, "x", color="tab:purple", ms=8, mew=2, zorder=9)
        draw_pose(st.truth, ax, color="tab:green", label="truth", length=14)
        draw_pose(st.estimate, ax, color="tab:blue", label="estimate", length=14)
        verdict = (f"ambiguous, {st.candidates} candidates; truth among them: "
                   f"{'yes' if st.truth_in_candidates else 'no'}" if st.ambiguous else
                   "converged" if st.converged else "not converged")
        ax.set_title(f"step {st.step} at ({st.waypoint_x_cm:g}, {st.waypoint_y_cm:g}): {st.error_cm:.1f} cm off\n"
                     f"{verdict}", fontsize=9)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
    axes.ravel()[0].legend(loc="upper right", fontsize=7)
    fig.suptitle(f"{steps[0].repo}, route {steps[0].route}, {steps[0].localiser}, seed {steps[0].seed}: "
                 "real sweep rays from the truth (orange), candidates (purple x)", fontsize=10)
    fig.tight_layout()
    return save_figure(fig, path)
