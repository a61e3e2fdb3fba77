"""`nxtnav replay`: run localisers offline over a recording (`nxtnav run --record`, `nxtnav import`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from ..number_format import cell
from .app import app
from .options import (
    ConfigFile,
    JsonOut,
    PluginSets,
    PngOut,
    Seed,
    parse_floats,
    parse_heading_prior,
    parse_list,
    shipped,
)
from .progress import progress_after
from .run_config import configuration, given_sets
from .set_options import localiser_sets

if TYPE_CHECKING:
    from localisation.base import Prior

    from ..recordings.replay import ReplayReport

__all__ = ["warn_cut_short"]


def warn_cut_short(truncated: str | None) -> None:
    """The one warning of every command that reads a recording cut short (`Recording.truncated`: where it
    breaks): the command goes on with what was read up to there."""
    if truncated:
        typer.echo(f"nxtnav: warning: {truncated}; only what comes before is used", err=True)


def _localiser_names() -> list[str]:
    from localisation import LOCALISERS

    return LOCALISERS.names()


@app.command("replay")
def replay_cmd(
    ctx: typer.Context,
    recording: Path = typer.Argument(..., metavar="FILE.jsonl", callback=shipped,
                                     help="A recording (nxtnav run --record, nxtnav import)."),
    localisers_text: str = typer.Option("", "--localisers", metavar="A,B,...",
                                        help="Localisers to compare (default: the one used live)."),
    seed: Seed = 0,
    json_out: JsonOut = None,
    output: PngOut = None,
    initial_pose: str | None = typer.Option(
        None, "--initial-pose", metavar="X,Y,H[,SD_CM,SD_DEG]",
        help="Start every localiser here (cm, cm, degrees; spread default 10 cm, 5 degrees) instead of the "
             "recording's first reset."),
    initial_heading: str | None = typer.Option(
        None, "--initial-heading", metavar="H:SD",
        help="Every global reset of the recording (each sweep of a sweep set) knows the heading (degrees, "
             "give or take SD) but not the position (global localisers only)."),
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
) -> None:
    """Replay the recorded motions and scans through localisers: estimate, spread and error per step.

    With true poses, the summary also gives evo's absolute pose error after the best rigid alignment
    (ape_rmse_cm, ape_heading_rmse_deg) and relative pose error per metre driven (rpe_per_m_cm), and
    every localiser's CPU time (cpu_s).
    """
    from ..recordings.replay import read_recording, replay

    prior = _initial_prior(initial_pose) if initial_pose is not None else None
    heading = parse_heading_prior(initial_heading, "--initial-heading")
    rec = read_recording(recording)
    warn_cut_short(rec.truncated)
    names = parse_list(localisers_text, "--localisers", _localiser_names()) if localisers_text.strip() else []
    if not names:
        if rec.localiser is None:
            raise typer.BadParameter(f"{recording} names no localiser; give --localisers", param_hint="--localisers")
        names = [rec.localiser.name]
    options = localiser_sets(given_sets(ctx, sets), names)
    with progress_after("replay", rec.calls) as advance:
        report = replay(rec, names, seed=seed, initial=prior, heading=heading, options=options, on_step=advance)
    live = rec.localiser.name if rec.localiser else "none"
    typer.echo(f"{recording}: map {rec.map.name}, robot {rec.header['robot'].get('kind')}, sonar "
               f"{rec.header['sonar'].get('model')}, live localiser {live}, {rec.calls} localiser calls, "
               f"{'with' if report.has_truth else 'without'} true poses")
    _print_scores(report, names)
    for n, ok in report.reproduced.items():
        if ok is None and n in options:
            typer.echo(f"{n}: given --set options, a new run; not compared with the live estimates")
        elif ok is None:
            why = "holds no live estimate" if not report.compared else "lacks the localiser's random stream"
            typer.echo(f"{n}: the recording {why}; not compared with the live estimates")
        elif ok:
            typer.echo(f"{n}: replayed estimates equal the {report.compared} live ones bit for bit")
        else:
            typer.echo(f"{n}: replay differs from the live estimates from line {report.diverged.get(n)}")
    for n, msg in report.failures.items():
        typer.echo(f"{n}: failed at {msg}", err=True)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        doc = {**report.to_dict(), "configuration": configuration(ctx, sets)}
        json_out.write_text(json.dumps(doc, indent=1, allow_nan=False))
        typer.echo(f"wrote {json_out}")
    if output is not None:
        from ..plotting import save_figure
        from ..recordings.replay_plots import draw_replay

        save_figure(draw_replay(report), output)
        typer.echo(f"wrote {output}")


def _print_scores(report: ReplayReport, names: list[str]) -> None:
    """The table of scores (against the truth, or agreement without one); with a truth, the reason for each
    large error and the verdicts per localiser (`ReplayReport.explanations`)."""
    summary = report.summary()
    if report.has_truth and not report.truth_heading:
        typer.echo("the true poses have no heading (real sweeps at known waypoints): errors are of position only")
    if report.has_truth:
        typer.echo("| localiser | updates | RMSE (cm) | median error (cm) | final error (cm) | final heading error "
                   "(deg) | median spread (cm) | APE aligned (cm) | APE heading (deg) | RPE (cm/m) | CPU (s) |")
        typer.echo("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for n, r in summary.items():
            typer.echo(f"| {n} | {r['updates']:.0f} | {cell(r['rmse_cm'])} | {cell(r['median_error_cm'])} | "
                       f"{cell(r['final_error_cm'])} | {cell(r['final_heading_error_deg'])} | "
                       f"{cell(r['median_spread_cm'])} | {cell(r['ape_rmse_cm'])} | "
                       f"{cell(r['ape_heading_rmse_deg'])} | {cell(r['rpe_per_m_cm'])} | {cell(r['cpu_s'])} |")
        if report.truth_heading:  # else the line above says why the scores are missing
            _explain_missing_scores(report)
        for line in report.explanations():
            typer.echo(line)
    else:
        typer.echo(f"| localiser | updates | median distance to {names[0]} (cm) | largest (cm) | median spread (cm) "
                   "| CPU (s) |")
        typer.echo("|---|---:|---:|---:|---:|---:|")
        for n, r in summary.items():
            typer.echo(f"| {n} | {r['updates']:.0f} | {cell(r['median_agreement_cm'])} | "
                       f"{cell(r['max_agreement_cm'])} | {cell(r['median_spread_cm'])} | {cell(r['cpu_s'])} |")


def _explain_missing_scores(report: ReplayReport) -> None:
    """One line per reason a score of the table is "–"; the reasons are the truth's, so usually the same
    for every localiser: said once, naming the localisers."""
    reasons: dict[tuple[str, str], list[str]] = {}
    for name in report.localisers:
        notes = report.score_notes(name)
        ape, rpe = notes.get("ape_note"), notes.get("rpe_note")
        if ape and ape == rpe:
            reasons.setdefault(("APE and RPE", ape), []).append(name)
            continue
        for column, note in (("APE", ape), ("RPE", rpe)):
            if note:
                reasons.setdefault((column, note), []).append(name)
    for (column, note), names in reasons.items():
        who = "every localiser" if len(names) == len(report.localisers) > 1 else ", ".join(names)
        typer.echo(f"{column} – for {who}: {note}")


def _initial_prior(text: str) -> Prior:
    """``X,Y,H[,SD_CM,SD_DEG]`` (cm, cm, degrees) as a Gaussian prior; the spread defaults to 10 cm, 5 degrees."""
    import math

    import numpy as np

    from localisation.base import Prior

    from ..world import NxtnavError, Pose

    values = parse_floats(text, "--initial-pose", (3, 5))
    sd_cm, sd_deg = (values[3], values[4]) if len(values) == 5 else (10.0, 5.0)
    if not (sd_cm > 0 and sd_deg > 0):
        raise NxtnavError(f"--initial-pose: the spreads SD_CM and SD_DEG must be > 0, got {text!r}")
    return Prior(Pose.from_deg(*values[:3]), np.diag([sd_cm**2, sd_cm**2, math.radians(sd_deg) ** 2]))
