"""`nxtnav import sweeps`: a sweep set (real sweeps at known waypoints) as a recording for `nxtnav replay`."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import import_app
from .options import check_writable, shipped

__all__: list[str] = []


@import_app.command("sweeps")
def import_sweeps(
    folder: Path = typer.Argument(..., metavar="DIR", callback=shipped,
                                  help="A sweep set: a folder with sweeps.csv and the sweep files."),
    map_file: str | None = typer.Option(None, "--map", metavar="FILE",
                                        help="The map the sweeps were taken in (default: DIR/arena.yaml)."),
    output: Path = typer.Option(..., "-o", "--output", metavar="REC.jsonl", help="The recording to write."),
) -> None:
    """A sweep set as one recording, each sweep a global-localisation episode; score it with nxtnav replay.

    Each sweep becomes a global reset of the localiser and an update with the sweep, its waypoint the
    true position (without a heading: a real sweep's heading is not known). Then
    `nxtnav replay REC.jsonl --localisers A,B` scores the localisers' position after each sweep.
    """
    from ..imports import import_sweep_set
    from ..sweeps import load_sweep_set

    check_writable(output, "--output")
    sweeps = load_sweep_set(folder, map=map_file)
    result = import_sweep_set(sweeps, output)
    share = result.no_echo / result.readings if result.readings else 0.0
    typer.echo(f"{folder}: {result.episodes} sweeps on map {result.map}, {result.readings} readings "
               f"({result.no_echo} no-echo, {share:.0%}); sources: {', '.join(sweeps.repos)}")
    typer.echo(f"wrote {output} ({result.lines} lines); score it with: nxtnav replay {output} --localisers A,B")
