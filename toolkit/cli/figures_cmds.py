"""`nxtnav figures`: every figure the README and docs show, regenerated from seeded nxtnav commands.

Each `FigureJob` is one ordinary `nxtnav` command (the one a reader can run to get the same figure)
and the PNGs it writes; `nxtnav figures --out docs/img` runs them in this process, copies the
figures under their documentation names, shrinks them to a 256-colour palette (a fraction of the
size, the same look) and writes ``README.md`` into the folder: each figure with its command.
``--quick`` runs every command on a reduced setting (fewer runs and trials, shorter budgets): the
same files, for the tests. Run it from the repository root (as ``make figures`` does): the replay
job reads a recording shipped in ``tests/data``.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import typer

from ..world import NxtnavError
from .app import app, main
from .choices import one_of
from .figure_jobs import FIGURE_JOBS, SCREENSHOTS, FigureJob, figure_names
from .options import OutFolder, parse_list

__all__ = ["FIGURE_JOBS", "SCREENSHOTS", "FigureJob", "figure_names", "run_job", "shrink_png"]

def shrink_png(src: Path, dst: Path, colours: int = 256) -> Path:
    """Copy PNG `src` to `dst` as a palette image of at most `colours` colours (no dithering)."""
    from PIL import Image

    with Image.open(src) as im:
        pal = im.convert("RGB").quantize(colors=colours, method=Image.Quantize.MEDIANCUT,
                                         dither=Image.Dither.NONE)
    dst.parent.mkdir(parents=True, exist_ok=True)
    pal.save(dst, optimize=True)
    return dst


def run_job(job: FigureJob, work: Path, out: Path, quick: bool = False) -> list[Path]:
    """Run `job`'s command with outputs in `work`; copy its figures, shrunk, into `out`."""
    work.mkdir(parents=True, exist_ok=True)
    try:
        main(job.args(str(work), quick))
    except SystemExit as exc:
        raise NxtnavError(f"figure job {job.name!r} failed (exit {exc.code}): {job.command()}") from None
    written = []
    for name, produced in job.figures.items():
        src = work / produced
        if not src.is_file():
            raise NxtnavError(f"figure job {job.name!r} wrote no {produced}")
        written.append(shrink_png(src, out / name))
    return written


def _index(jobs: Sequence[FigureJob], quick: bool) -> str:
    lines = ["# Figures", "",
             "Written by `make figures` (`nxtnav figures --out docs/img`); do not edit. Each figure comes from",
             "the seeded command below it (outputs of benchmarks in `out/`), shrunk to a 256-colour palette.", ""]
    if quick:
        lines += ["**Reduced setting (`--quick`): not the figures of the documentation.**", ""]
    for job in jobs:
        lines += [f"- {', '.join(f'`{f}`' for f in job.figures)}: {job.caption}.", f"  `{job.command()}`"]
    lines += ["", "Not made by `make figures`:", ""]
    lines += [f"- `{name}`: {how}." for name, how in SCREENSHOTS.items()]
    return "\n".join(lines) + "\n"


@app.command("figures")
def figures(
    out: OutFolder = Path("docs/img"),
    quick: bool = typer.Option(False, "--quick", help="Reduced setting (fewer runs and trials): for tests."),
    only: str | None = typer.Option(None, "--only", metavar="NAMES",
                                    help="Comma-separated jobs " + one_of("figure job") + "."),
) -> None:
    """Regenerate the figures of the README and docs from seeded commands."""
    names = [j.name for j in FIGURE_JOBS]
    chosen = parse_list(only, "--only", names) if only else names
    jobs = [j for j in FIGURE_JOBS if j.name in chosen]
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="nxtnav-figures-") as tmp:
        for job in jobs:
            t0 = time.perf_counter()
            typer.echo(f"{job.name}: {job.command()}", err=True)
            files = run_job(job, Path(tmp) / job.name, out, quick)
            sizes = ", ".join(f"{p.name} {p.stat().st_size / 1e3:.0f} kB" for p in files)
            typer.echo(f"{job.name}: {sizes} ({time.perf_counter() - t0:.1f} s)")
    (out / "README.md").write_text(_index(FIGURE_JOBS, quick), encoding="utf-8")
