"""Drawing a replay (`toolkit.recordings.replay.ReplayReport`): estimates on the map, error or agreement per update."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MaxNLocator

from ..plotting import draw_map, new_axes

if TYPE_CHECKING:
    from .replay import ReplayReport

__all__ = ["draw_replay"]


def draw_replay(report: ReplayReport) -> Figure:
    """Left: the map, the true path (when recorded) and each localiser's estimates after its updates.
    Right: each localiser's error against the truth (or distance to the first localiser) per update.
    Returns the figure (never shown)."""
    fig, (ax_map, ax_err) = new_axes(ncols=2, size=5.5)
    draw_map(report.recording.map, ax_map)
    ups = [s for s in report.steps if s.call == "update"]
    truth = np.array([s.truth.as_array()[:2] for s in ups if s.truth is not None]).reshape(-1, 2)
    if truth.size:
        # a robot that never moved while recorded (an imported sweep set): separate places, not a path
        moved = any(e["type"] in ("turn", "move", "turnback", "predict") for _, e in report.recording.events)
        ax_map.plot(truth[:, 0], truth[:, 1], "k-" if moved else "k+", lw=1.5, ms=10, mew=2,
                    label="truth" if moved else "true positions")
    ref = report.localisers[0]
    top = 0.0
    for name in report.localisers:
        ests = [s.estimates.get(name) for s in ups]
        est = np.array([e.pose.as_array()[:2] for e in ests if e is not None]).reshape(-1, 2)
        if est.size:
            ax_map.plot(est[:, 0], est[:, 1], ".", ms=5, label=name)
        y = [s.error_cm(name) if report.has_truth else s.agreement_cm(name, ref) for s in ups]
        ax_err.plot(range(1, len(ups) + 1), y, ".-", label=name)
        top = max([top, *(v for v in y if v is not None and np.isfinite(v))])
    ax_map.legend(loc="best", fontsize=8)
    ax_err.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax_err.set_xlabel("update" if report.truth_heading else "update (position error only: no true heading)")
    ax_err.set_ylabel("error (cm)" if report.has_truth else f"distance to {ref} (cm)")
    if top > 1.0:  # a lost localiser (tens of cm) beside sub-centimetre ones: linear below 1 cm, log above
        ax_err.set_yscale("symlog", linthresh=1.0)
        ax_err.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    else:  # all within 1 cm: symlog would stay linear but label the limits in powers of ten
        ax_err.set_ylim(bottom=0.0)
    ax_err.grid(True, alpha=0.3)
    ax_err.legend(loc="best", fontsize=8)
    ax_err.set_title(f"{report.recording.path.name}: {'error' if report.has_truth else 'agreement'} per update")
    return fig
