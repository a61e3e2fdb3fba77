"""`nxtnav sonar fit|score|loo`: the `nxt` sonar model against real sweeps taken at known waypoints.

``fit`` writes a sonar profile (`toolkit.real_sonar.fit.save_sonar_profile`) that ``--sonar-profile`` of
``scan``, ``localise``, ``run``, ``paper``, ``bench localisers`` and ``brick serve`` reads; ``score`` says
how well a model explains sweeps; ``loo`` fits without each source of sweeps in turn and scores the
held-out source, the honest test of a fitted model.
"""

from __future__ import annotations

import json
import logging
import math
import statistics
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, replace
from functools import partial
from pathlib import Path
from typing import Any

import typer
from rich import box
from rich.console import Console
from rich.table import Table

from ..bench.executors import quiet_logger
from ..number_format import cell, json_safe, percent
from ..world import NxtnavError, NxtSonar
from .app import sonar_app
from .choices import one_of
from .interrupts import run_batch
from .options import (
    JsonOut,
    OutFolder,
    Seed,
    Workers,
    check_writable,
    output_problem,
    parse_heading_prior,
    parse_list,
    shipped,
    writable_folder,
)
from .options import sonar_profile as load_profile
from .progress import progress

log = logging.getLogger(__name__)

__all__: list[str] = []

_DIRS = typer.Argument(..., metavar="DIR...", callback=shipped,
                       help="Sweep sets: folders with a sweeps.csv (maps/real-nxt is one; format: "
                            "toolkit/real_sonar/sweeps.py).")
_MAP = typer.Option(None, "--map", metavar="FILE", help="The map of every sweep set (default: each folder's "
                                                        "arena.yaml).")
_WIDTHS = typer.Option("10,20,30,40,60", "--widths", metavar="DEG[,DEG]",
                       help="Lobe widths tried (degrees, > 0 and <= 120).")
_CRITICALS = typer.Option("20,30,40,50,60", "--criticals", metavar="DEG[,DEG]",
                          help="Specular incidence limits tried (degrees, > 0 and <= 90).")
_MODEL = typer.Option(None, "--sonar-profile", metavar="FILE",
                      help="The model (default: the toolkit's nxt model, fitted to real sweeps).")

_UNITS = {"noise_sd": "cm", "noise_per_m": "cm/m", "bias_cm": "cm", "beam_width_deg": "deg", "beam_rays": "",
          "critical_incidence_deg": "deg", "min_range_cm": "cm", "max_range_cm": "cm", "reach_cm": "cm",
          "reach_width_cm": "cm", "correlation_deg": "deg"}


def _grid(text: str, option: str, hi: float) -> list[float]:
    """Comma-separated angles (degrees) in (0, hi], each once, in the order given."""
    out: list[float] = []
    for part in parse_list(text, option):
        try:
            v = float(part)
        except ValueError:
            raise NxtnavError(f"{option}: expected comma-separated degrees, got {part!r}") from None
        if not 0.0 < v <= hi:
            raise NxtnavError(f"{option}: each value must be > 0 and <= {hi:g} degrees, got {part!r}")
        if v not in out:
            out.append(v)
    return out


def _load_sets(dirs: Sequence[Path], map_file: Path | None) -> list[Any]:
    from ..real_sonar.sweeps import load_sweep_set

    return [load_sweep_set(d, map=map_file) for d in dirs]


@contextmanager
def _stuck_noted(sets: Sequence[Any]) -> Iterator[None]:
    """Say once which sweeps have stuck readings (the fit and the scores leave them out), and keep the
    scan module's per-call warning about them quiet meanwhile (a fit prepares the sweeps many times)."""
    from localisation.scan import stuck_mask

    for s in sets:
        for sw in s:
            scan = sw.scan()
            k = int(stuck_mask(scan, s.map, position=(sw.x_cm, sw.y_cm)).sum())
            if k:
                typer.echo(f"{sw.label}: {k} of {len(scan)} readings are a stuck sonar (one value repeated over "
                           "a long arc the walls do not explain at its waypoint); left out", err=True)
    with quiet_logger("localisation.scan"):
        yield


def _write_json(path: Path, doc: Any) -> None:
    """`doc` as strict JSON (NaN and infinities as null), written whole or not at all."""
    tmp = path.with_name(path.name + ".part")
    try:
        tmp.write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False), encoding="utf-8")
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
    typer.echo(f"wrote {path}")


def _rounded(value: Any) -> Any:
    """Floats to 6 significant decimals for a profile's provenance (dicts and lists inside too)."""
    if isinstance(value, float):
        return round(value, 6)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_rounded(v) for v in value]
    return value


def _params_table(model: NxtSonar, title: str) -> Table:
    """The fitted parameters beside the hardware facts."""
    from ..real_sonar.fit import FIT_PARAMETERS

    hw = NxtSonar.hardware_facts()
    table = Table("parameter", "fitted", "hardware facts", "unit", title=title)
    shown = ("beam_width_deg", "beam_rays", "critical_incidence_deg", *FIT_PARAMETERS, "correlation_deg")
    for k in shown:
        a, b = getattr(model, k), getattr(hw, k)
        fmt = (lambda v: f"{v:d}") if k == "beam_rays" else (lambda v: f"{v:.4g}")
        table.add_row(k, fmt(a), fmt(b), _UNITS.get(k, ""))
    return table


@sonar_app.command("fit")
def sonar_fit(
    dirs: list[Path] = _DIRS,
    map_file: Path | None = _MAP,
    output: Path = typer.Option(..., "-o", "--output", metavar="PROFILE.yaml|DIR",
                                help="The sonar profile to write (with --per-source: the folder of profiles)."),
    widths_text: str = _WIDTHS,
    criticals_text: str = _CRITICALS,
    per_source: bool = typer.Option(False, "--per-source",
                                    help="Fit each source (the repo column) on its own sweeps; write one profile "
                                         "per source into the folder -o, named OWNER+NAME.yaml (what "
                                         "--sonar-profile DIR of bench routes and bench sweeps reads)."),
    json_out: JsonOut = None,
) -> None:
    """Fit the nxt sonar model by maximum likelihood to real sweeps; write it as a sonar profile.

    Every lobe of the grid (--widths x --criticals) gets its mixture fitted (noise, bias, losses, wrong
    readings) and each sweep its heading; the most likely lobe wins. The profile records where it came
    from (folders, sweeps, readings, likelihood, headings) and nothing else, so a rerun writes the same
    bytes. With --per-source, one such fit per source, each on that source's sweeps alone.
    """
    from ..real_sonar.fit import fit_sonar, save_sonar_profile

    widths = _grid(widths_text, "--widths", 120.0)
    criticals = _grid(criticals_text, "--criticals", 90.0)
    problem = output_problem(output, folder=per_source)
    if problem:
        raise NxtnavError(f"--output: {problem}")
    if per_source:
        check_writable(json_out, "--json")
        _fit_per_source(_load_sets(dirs, map_file), dirs, output, widths, criticals, json_out)
        return
    check_writable(output, "--output")
    check_writable(json_out, "--json")
    sets = _load_sets(dirs, map_file)
    lobes = len(widths) * len(criticals)
    with _stuck_noted(sets), progress("lobes", lobes) as advance:
        fit = fit_sonar(sets, widths=widths, criticals=criticals, progress=lambda done, total: advance())
    provenance = _rounded({
        "folders": [str(d) for d in dirs], "maps": [s.map.name for s in sets], "sweeps": fit.sweeps,
        "readings": fit.readings, "mean_log_likelihood": fit.mean_log_likelihood,
        "widths_deg": widths, "criticals_deg": criticals, "headings_deg": fit.headings_deg})
    save_sonar_profile(fit.model, output, fit=provenance)
    Console().print(_params_table(fit.model, f"{fit.sweeps} sweeps, {fit.readings} readings: "
                                             f"{fit.mean_log_likelihood:.3f} nats per reading"))
    typer.echo(f"wrote {output}")
    if json_out is not None:
        _write_json(json_out, {"profile": str(output), "fit": provenance, **fit.to_dict()})


def _fit_per_source(sets: Sequence[Any], dirs: Sequence[Path], folder: Path, widths: list[float],
                    criticals: list[float], json_out: Path | None) -> None:
    """`sonar fit --per-source`: one fit per source on its own sweeps, each written to `folder` as
    `toolkit.real_sonar.fit.source_profile_name`; nothing is written until every fit is done."""
    from ..real_sonar.fit import fit_sonar, save_sonar_profile, source_profile_name
    from ..real_sonar.sweeps import SweepSet

    if folder.exists() and not folder.is_dir():
        raise NxtnavError(f"--output: {folder} exists and is not a folder (--per-source writes a folder of profiles)")
    repos = list(dict.fromkeys(sw.repo for s in sets for sw in s))
    fits = {}
    with _stuck_noted(sets), progress("lobes", len(repos) * len(widths) * len(criticals)) as advance:
        for repo in repos:
            mine = [SweepSet(s.folder, s.map, tuple(sw for sw in s if sw.repo == repo)) for s in sets]
            fits[repo] = fit_sonar([s for s in mine if len(s)], widths=widths, criticals=criticals,
                                   progress=lambda done, total: advance())
    folder.mkdir(parents=True, exist_ok=True)
    doc = []
    for repo, fit in fits.items():
        provenance = _rounded({
            "folders": [str(d) for d in dirs], "source": repo, "sweeps": fit.sweeps, "readings": fit.readings,
            "mean_log_likelihood": fit.mean_log_likelihood, "widths_deg": widths, "criticals_deg": criticals,
            "headings_deg": fit.headings_deg})
        path = folder / source_profile_name(repo)
        save_sonar_profile(fit.model, path, fit=provenance)
        Console().print(_params_table(fit.model, f"{repo}: {fit.sweeps} sweeps, {fit.readings} readings: "
                                                 f"{fit.mean_log_likelihood:.3f} nats per reading"))
        typer.echo(f"wrote {path}")
        doc.append({"source": repo, "profile": str(path), "fit": provenance, **fit.to_dict()})
    if json_out is not None:
        _write_json(json_out, {"profiles": doc})


@sonar_app.command("turret")
def sonar_turret(
    dirs: list[Path] = _DIRS,
    map_file: Path | None = _MAP,
    output: Path = typer.Option(..., "-o", "--output", metavar="DIR", callback=writable_folder,
                                help="The folder of per-source profiles to write (OWNER+NAME.yaml)."),
    sonar_profile: Path | None = _MODEL,
    headings: str = typer.Option("column", "--headings", metavar="column|aligned",
                                 help="The headings to measure against: column (sweeps.csv's heading_deg) or "
                                      "aligned (the heading that aligns each sweep with the map at its waypoint, "
                                      "as heading_deg is made: for a set without the column)."),
    json_out: JsonOut = None,
) -> None:
    """Find each source's heading offset under one sonar model; write the model with it, one profile per source.

    Each sweep with a heading_deg is aligned with the model at its waypoint (the heading, and a position
    within 3 cm, where the model finds it most likely). A source's turret_offset_deg is the circular mean
    of the aligned headings less heading_deg, twins (more than 45 degrees apart) left out: a turret set off
    the robot's axis, or the model seeing the sweeps differently from heading_deg. A source with no
    heading_deg keeps 0 (with --headings aligned every sweep has one). bench routes and bench sweeps take
    the folder as --sonar-profile and turn each source's readings into its robot's frame. Unlike sonar fit
    --per-source, nothing else of the model is refitted on a source's few sweeps.
    """
    import math

    from ..real_sonar.fit import align_sweeps, save_sonar_profile, source_profile_name, turret_offset_deg
    from ..real_sonar.sweeps import SweepSet, aligned_heading_deg

    if headings not in ("column", "aligned"):
        raise NxtnavError(f"--headings: must be column or aligned, got {headings!r}")
    check_writable(json_out, "--json")
    model = load_profile(sonar_profile, "nxt") or NxtSonar()
    sets = _load_sets(dirs, map_file)
    table = Table("source", "sweeps", "with heading_deg", "turret_offset_deg", title="heading offset per source")
    rows = []
    with _stuck_noted(sets):
        for repo in dict.fromkeys(sw.repo for s in sets for sw in s):
            mine = [SweepSet(s.folder, s.map, tuple(sw for sw in s if sw.repo == repo)) for s in sets]
            aligned = {a.sweep.label: math.degrees(a.heading_rad)
                       for s in mine if len(s) for a in align_sweeps(model, s)}
            sweeps = [sw if headings == "column" else replace(sw, heading_deg=aligned_heading_deg(sw, s.map))
                      for s in mine for sw in s]
            offset = turret_offset_deg(sweeps, aligned)
            rows.append((repo, sweeps, aligned, offset))
            table.add_row(repo, str(len(sweeps)), str(sum(not math.isnan(sw.heading_deg) for sw in sweeps)),
                          f"{offset:.2f}")
    output.mkdir(parents=True, exist_ok=True)
    doc = []
    for repo, sweeps, aligned, offset in rows:
        provenance = _rounded({"folders": [str(d) for d in dirs], "source": repo, "sweeps": len(sweeps),
                               "model": str(sonar_profile) if sonar_profile else "default", "against": headings,
                               "headings_deg": aligned})
        path = output / source_profile_name(repo)
        save_sonar_profile(replace(model, turret_offset_deg=offset), path, fit=provenance)
        doc.append({"source": repo, "profile": str(path), "turret_offset_deg": offset, "fit": provenance})
    Console().print(table)
    typer.echo(f"wrote {len(rows)} profiles into {output}")
    if json_out is not None:
        _write_json(json_out, {"profiles": doc})


def _score_models(profile: Path | None, baselines: list[str]) -> dict[str, tuple[NxtSonar, str]]:
    """The models to score by label, with where each comes from: the profile (or the default), then the
    baselines."""
    from ..real_sonar.fit import BASELINES

    models: dict[str, tuple[NxtSonar, str]] = {}
    fitted = load_profile(profile, "nxt")
    if fitted is not None:
        models["profile"] = (fitted, str(profile))
    else:
        models["default"] = (NxtSonar(), "NxtSonar()")
    for name in baselines:
        if name not in models:
            models[name] = (BASELINES[name](), "NxtSonar()" if name == "default" else "NxtSonar.hardware_facts()")
    return models


@sonar_app.command("score")
def sonar_score(
    dirs: list[Path] = _DIRS,
    map_file: Path | None = _MAP,
    sonar_profile: Path | None = _MODEL,
    baseline_text: str | None = typer.Option(None, "--baseline", metavar="NAME[,NAME]",
                                             help="Also score these beside it " + one_of("sonar baseline")
                                                  + ": hardware (the model from the "
                                                  "published hardware facts), default (the toolkit's nxt model)."),
    heading_prior_text: str | None = typer.Option(
        None, "--heading-prior", metavar="H:SD",
        help="Weigh the places by a heading prior (degrees; the position stays unknown): the bound for a "
             "localiser that knows the heading roughly."),
    json_out: JsonOut = None,
) -> None:
    """How well a sonar model explains real sweeps at their waypoints.

    Per model: the mean log-likelihood per reading (higher is better), the no-echo share of the real
    readings and the one the model expects, and the median |real - model| of the readings where both
    answer; the share of sweeps the model explains best at their waypoint (no pose further than 20 cm
    explains them better: an upper bound on what any localiser using the model gets right from one sweep);
    then the same per sweep, with that margin in nats. Each sweep is taken at the heading the model finds
    most likely, shown beside the set's own heading_deg; a warning names each sweep whose two headings
    differ by more than 45 degrees (a twin taken as the truth).
    """
    from ..real_sonar.fit import BASELINES, heading_disagreements, score_sonar

    heading = parse_heading_prior(heading_prior_text, "--heading-prior")
    baselines = [] if baseline_text is None else parse_list(baseline_text, "--baseline", list(BASELINES))
    check_writable(json_out, "--json")
    models = _score_models(sonar_profile, baselines)
    sets = _load_sets(dirs, map_file)
    sweeps = len(models) * sum(len(s) for s in sets)
    with _stuck_noted(sets), progress("sweeps scored", sweeps,
                                      transient=True, announce=True) as advance:
        scores = {label: score_sonar(model, sets, heading_prior=heading, on_sweep=advance)
                  for label, (model, _) in models.items()}
    console = Console()
    table = Table("model", "readings", "log-lik", "no echo real", "no echo model", "median |Δ|", "waypoint best",
                  title="sonar models against real sweeps (log-lik: nats per reading, higher is better; |Δ|: "
                        "|real - model| where both answer; waypoint best: sweeps the model explains best at "
                        "their waypoint, an upper bound for one-sweep localisation)")
    for label, sc in scores.items():
        table.add_row(label, str(sc.readings), cell(sc.mean_log_likelihood, ".3f"), percent(sc.no_echo_real, 1),
                      percent(sc.no_echo_model, 1), cell(sc.median_abs_diff_cm, ".1f", " cm"),
                      percent(sc.waypoint_most_likely, 0))
    console.print(table)
    # borderless and terse; in a narrow terminal the sweep's name folds, never a number
    per = Table(title="per sweep (at the heading each model finds most likely)", box=box.SIMPLE_HEAD,
                pad_edge=False, collapse_padding=True)
    per.add_column("sweep", overflow="fold", ratio=1)
    per.add_column("model", no_wrap=True)
    for name in ("heading", "set's\nheading", "log-lik", "no echo %\nreal / model", "|Δ|\ncm", "margin\nnats"):
        per.add_column(name, justify="right", no_wrap=True)
    for i, row in enumerate(next(iter(scores.values())).per_sweep):
        for k, (label, sc) in enumerate(scores.items()):
            r = sc.per_sweep[i]
            per.add_row(row["sweep"] if k == 0 else "", label, cell(r["heading_deg"], ".1f", "°"),
                        cell(r["set_heading_deg"], ".1f", "°"),
                        cell(r["mean_log_likelihood"], ".3f"),
                        f"{_pct(r['no_echo_real'])} / {_pct(r['no_echo_model'])}",
                        cell(r["median_abs_diff_cm"], ".1f"), cell(r["margin_nats"], "+.1f"))
    console.print(per)
    for label, sc in scores.items():
        for line in heading_disagreements(((r["sweep"], r["set_heading_deg"], r["heading_deg"])
                                           for r in sc.per_sweep), label):
            log.warning("%s", line)
    if json_out is not None:
        _write_json(json_out, {"folders": [str(d) for d in dirs],
                               "heading_prior": heading and heading.to_dict(), "models": [
            {"label": label, "source": models[label][1], "params": models[label][0].to_dict(), **sc.to_dict()}
            for label, sc in scores.items()]})


def _pct(fraction: float | None) -> str:
    """A fraction in whole percent, without the sign (the table's header has it)."""
    return cell(None if fraction is None else 100.0 * fraction, ".0f")


@sonar_app.command("loo")
def sonar_loo(
    dirs: list[Path] = _DIRS,
    map_file: Path | None = _MAP,
    widths_text: str = _WIDTHS,
    criticals_text: str = _CRITICALS,
    workers: Workers = 1,
    json_out: JsonOut = None,
    per_source: bool = typer.Option(
        False, "--per-source", help="Leave one sweep out of its source instead: fit on the source's other sweeps, "
                                    "score the sweep (the test of `sonar fit --per-source`)."),
) -> None:
    """Leave one repository out: fit without each source of sweeps, score its sweeps.

    For each source (the `repo` column) the model is fitted on the other sources' sweeps; the held-out
    sweeps are scored with that fit and with the hardware-facts model. Reports each held-out source and
    the means weighted by their readings, whether the fitted models explain held-out readings better than
    the hardware facts, and whether they expect a no-echo share within 0.05 of the real one. With
    --per-source, one fold per sweep of every source with two or more: a robot's own model, fitted on
    its other sweeps.
    """
    from ..real_sonar.fit import LeaveOneOut, repo_folds, score_fold, sweep_folds

    widths = _grid(widths_text, "--widths", 120.0)
    criticals = _grid(criticals_text, "--criticals", 90.0)
    check_writable(json_out, "--json")
    sets = _load_sets(dirs, map_file)
    folds = sweep_folds(sets) if per_source else repo_folds(sets)
    lobes = len(widths) * len(criticals)
    with _stuck_noted(sets):
        if workers == 1:
            with progress(f"lobes ({len(folds)} folds)", len(folds) * lobes) as advance:
                held = [score_fold(f, widths=widths, criticals=criticals, progress=lambda d, t: advance())
                        for f in folds]
        else:
            done = run_batch(partial(score_fold, widths=widths, criticals=criticals), folds, "folds",
                             workers=workers, keep_partial=False).results
            order = {f.repo: i for i, f in enumerate(folds)}
            held = sorted(done, key=lambda h: order[h.repo])
    loo = LeaveOneOut.of(held)
    what = "leave one sweep out of its source" if per_source else "leave one repository out"
    table = Table(title=f"{what} (log-lik: nats per reading, higher is better; |Δ|: |real - model| where both "
                        "answer)")
    table.add_column("held out", overflow="fold")
    for name in ("sweeps", "readings", "log-lik fitted / hardware", "no echo real / fitted / hardware",
                 "median |Δ| fitted / hardware"):
        table.add_column(name)

    def row(label: str, sweeps: int, readings: int, fit: dict[str, float], base: dict[str, float]) -> None:
        table.add_row(label, str(sweeps), str(readings),
                      f"{cell(fit['mean_log_likelihood'], '.3f')} / {cell(base['mean_log_likelihood'], '.3f')}",
                      f"{percent(fit['no_echo_real'], 1)} / {percent(fit['no_echo_model'], 1)} / "
                      f"{percent(base['no_echo_model'], 1)}",
                      f"{cell(fit['median_abs_diff_cm'], '.1f')} / {cell(base['median_abs_diff_cm'], '.1f', ' cm')}")

    for h in held:
        row(h.repo, h.fitted.sweeps, h.readings, asdict(h.fitted), asdict(h.baseline))
    f, b = loo.fitted, loo.baseline
    row("weighted mean", sum(h.fitted.sweeps for h in held), loo.readings, f, b)
    Console().print(table)
    typer.echo(f"fitted beats the hardware facts on held-out readings: {'yes' if loo.beats_baseline else 'no'} "
               f"({f['mean_log_likelihood']:.3f} against {b['mean_log_likelihood']:.3f} nats per reading)")
    close = loo.no_echo_gap <= 0.05
    typer.echo(f"fitted no-echo share within 0.05 of the real one: {'yes' if close else 'no'} "
               f"({f['no_echo_model']:.3f} against {f['no_echo_real']:.3f}, gap {loo.no_echo_gap:.3f})")
    gaps = [g for g in loo.fold_no_echo_gaps if not math.isnan(g)]  # nan: a fold without a valid reading
    if gaps:
        typer.echo(f"no-echo gap per held-out {'sweep' if per_source else 'source'}: median "
                   f"{statistics.median(gaps):.3f}, largest {max(gaps):.3f}")
    if json_out is not None:
        _write_json(json_out, {"folders": [str(d) for d in dirs], "widths_deg": widths, "criticals_deg": criticals,
                               "per_source": per_source, "baseline": NxtSonar.hardware_facts().to_dict(),
                               **loo.to_dict()})


@sonar_app.command("plot")
def sonar_plot(
    dirs: list[Path] = _DIRS,
    map_file: Path | None = _MAP,
    sonar_profile: Path | None = _MODEL,
    out: OutFolder = Path("out"),
    seed: Seed = 0,
    heading_prior_text: str | None = typer.Option(
        None, "--heading-prior", metavar="H:SD",
        help="Also draw where the first sweep puts the robot with the heading known (degrees)."),
) -> None:
    """Real sweeps against the model: real_sonar_radar.png (three waypoints, real and model on one radar
    chart each), real_sonar_no_echo.png (no-echo share against incidence and range, real and model) and
    real_sonar_places.png (where the first sweep puts the robot in the map)."""
    from ..real_sonar.plots import real_sonar_figures

    heading = parse_heading_prior(heading_prior_text, "--heading-prior")
    model = load_profile(sonar_profile, "nxt") or NxtSonar()
    if out.exists() and not out.is_dir():
        raise NxtnavError(f"--out: {out} exists and is not a folder")
    sets = _load_sets(dirs, map_file)
    with _stuck_noted(sets), progress("figures", 3, transient=True, announce=True) as advance:
        written = real_sonar_figures(sets, model, out, rng=seed, heading_prior=heading, on_figure=advance)
    typer.echo(f"wrote {', '.join(str(p) for p in written)}")
