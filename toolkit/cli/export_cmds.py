"""`nxtnav export`: a recording as a ROS 2 bag (rosbag2 folder, MCAP storage) for ROS tools."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import app
from .options import shipped, writable_folder

__all__: list[str] = []


@app.command("export")
def export_cmd(
    recording: Path = typer.Argument(..., metavar="REC.jsonl", callback=shipped,
                                     help="A recording (nxtnav run --record)."),
    mcap: Path = typer.Option(..., "--mcap", callback=writable_folder, metavar="DIR",
                              help="The rosbag2 folder to write (new or empty): MCAP storage, CDR messages."),
    grid_cm: float = typer.Option(1.0, "--grid-cm", min=0.1, metavar="CM", help="Cell size of the /map grid (cm)."),
    particles: int | None = typer.Option(None, "--particles", min=1, metavar="N",
                                         help="At most N particles per /particle_cloud (default: all recorded)."),
) -> None:
    """Write a recording as a ROS 2 bag with nav2's topics and REP-105 frames (docs/recording.md)."""
    from ..ros.export import export_mcap
    from .replay_cmds import warn_cut_short

    summary = export_mcap(recording, mcap, resolution_cm=grid_cm, particles=particles)
    warn_cut_short(summary.truncated)
    for topic, (kind, n) in summary.topics.items():
        typer.echo(f"{topic:16s} {kind:45s} {n:6d}")
    if summary.moved_scans:
        typer.echo(f"{summary.moved_scans} sweeps lie off a regular grid of angles (deskewed); /scan puts their "
                   f"readings in the nearest slot of a finer one, at most {summary.moved_rad:.1e} rad away")
    typer.echo(f"wrote {summary.path} ({summary.messages} messages)")


@app.command("view")
def view_cmd(
    source: Path = typer.Argument(..., metavar="REC.jsonl|DIR",
                                  help="A recording, or a bag written by nxtnav export --mcap."),
    save: Path | None = typer.Option(None, "--save", metavar="FILE.rrd",
                                     help="Write a Rerun recording instead of opening a viewer."),
) -> None:
    """Show a run in Rerun (extra 'viz'): map, c-space, truth, estimate and covariance, particles, sweeps, plan."""
    from ..view.viewer import check_view
    from .options import check_writable

    check_writable(save, "--save")
    check_view("view", "--save", spawn=save is None)  # before the recording's readers are imported
    from ..view.live import view_file

    n = view_file(source, save)
    typer.echo(f"{source}: {n} items drawn" + (f"; wrote {save}" if save is not None else ""))
