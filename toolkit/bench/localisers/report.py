"""The localiser benchmark's outputs: CSV files and the summary."""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import LOCALISERS

from ...number_format import cell, csv_cell, percent
from ..common import finite_median
from .records import COLUMNS, SUCCESS_CM, SUCCESS_DEG, BenchConfig, TrialResult


def write_csv(results: Iterable[TrialResult], path: str | Path, scenario: str = "global") -> Path:
    """Write results of one scenario, sorted by map, localiser and trial, with that scenario's columns."""
    cols = COLUMNS[scenario]
    rows = sorted((r for r in results if r.scenario == scenario), key=lambda r: (r.map, r.localiser, r.trial))
    p = Path(path)
    with p.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            d = r.to_dict()
            w.writerow([csv_cell(d[c], digits=6) for c in cols])
    return p


def read_csv(path: str | Path) -> list[dict[str, Any]]:
    """Rows of a benchmark CSV with numbers and booleans parsed (an empty cell is NaN)."""
    out: list[dict[str, Any]] = []
    with Path(path).open(newline="") as fh:
        for row in csv.DictReader(fh):
            parsed: dict[str, Any] = {}
            for k, v in row.items():
                if v in ("true", "false"):
                    parsed[k] = v == "true"
                elif k in ("map", "localiser"):
                    parsed[k] = v
                elif v == "":  # a value that does not exist (`csv_cell`)
                    parsed[k] = math.nan
                else:
                    try:
                        parsed[k] = int(v)
                    except ValueError:
                        try:
                            parsed[k] = float(v)
                        except ValueError:
                            parsed[k] = v
            out.append(parsed)
    return out


def _rms(values: Sequence[float]) -> float:
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    return float(np.sqrt(np.mean(a**2))) if a.size else math.nan


def summarise(results: Iterable[TrialResult]) -> dict[str, dict[tuple[str, str], dict[str, float]]]:
    """Per scenario, per (map, localiser): the numbers of the summary tables."""
    groups: dict[str, dict[tuple[str, str], list[Any]]] = {}
    for r in results:
        groups.setdefault(r.scenario, {}).setdefault((r.map, r.localiser), []).append(r)
    out: dict[str, dict[tuple[str, str], dict[str, float]]] = {}
    for scen, g in groups.items():
        table: dict[tuple[str, str], dict[str, float]] = {}
        for key, rs in sorted(g.items()):
            n = len(rs)
            if scen == "global":
                table[key] = {
                    "trials": n,
                    "success_rate": sum(r.success for r in rs) / n,
                    "converged_rate": sum(r.converged for r in rs) / n,
                    "ambiguous_rate": sum(r.candidates > 1 for r in rs) / n,
                    "median_error_cm": finite_median([r.error_cm for r in rs]),
                    "median_heading_error_deg": finite_median([abs(r.heading_error_deg) for r in rs]),
                    "median_time_s": finite_median([r.time_s for r in rs]),
                    "median_cpu_time_s": finite_median([r.cpu_time_s for r in rs]),
                    "median_scans": finite_median([r.scans for r in rs]),
                }
            elif scen == "tracking":
                table[key] = {
                    "trials": n,
                    "rmse_cm": _rms([r.rmse_cm for r in rs]),
                    "rmse_heading_deg": _rms([r.rmse_heading_deg for r in rs]),
                    "blind_fraction": sum(r.blind_steps for r in rs) / max(sum(r.steps for r in rs), 1),
                    "rmse_echo_cm": _pooled_rms([(r.rmse_echo_cm, r.steps - r.blind_steps) for r in rs]),
                    "rmse_blind_cm": _pooled_rms([(r.rmse_blind_cm, r.blind_steps) for r in rs]),
                    "dead_reckoning_rmse_cm": _rms([r.dead_reckoning_rmse_cm for r in rs]),
                    "median_final_error_cm": finite_median([r.final_error_cm for r in rs]),
                    "median_time_s": finite_median([r.time_s / max(r.steps, 1) for r in rs]),
                    "median_particles": finite_median([r.median_particles for r in rs]),
                    "max_particles": float(np.nanmax([r.max_particles for r in rs] + [math.nan]))
                    if any(math.isfinite(r.max_particles) for r in rs) else math.nan,
                    "median_update_ms": finite_median([r.update_ms for r in rs]),
                }
            else:
                loc = [r for r in rs if r.localised]
                rec = [r for r in loc if r.recovered]
                table[key] = {
                    "trials": n,
                    "localised": len(loc),
                    "recovery_rate": len(rec) / len(loc) if loc else math.nan,
                    "median_recovery_scans": finite_median([r.recovery_scans for r in rec]),
                }
            out[scen] = table
    return out


def _pooled_rms(parts: Sequence[tuple[float, int]]) -> float:
    """RMS over the steps of several trials from each trial's RMS and step count (NaN without steps)."""
    num = sum(v * v * k for v, k in parts if k > 0 and math.isfinite(v))
    den = sum(k for v, k in parts if k > 0 and math.isfinite(v))
    return math.sqrt(num / den) if den else math.nan


Row = dict[str, float]
Column = tuple[str, Callable[[Row], str]]
"""A column of a summary table: its header and how it shows a `summarise` row."""

_GLOBAL_COLUMNS: list[Column] = [
    ("trials", lambda r: f"{r['trials']:.0f}"),
    ("success", lambda r: percent(r["success_rate"], 1)),
    ("converged", lambda r: percent(r["converged_rate"], 1)),
    ("ambiguous", lambda r: percent(r["ambiguous_rate"], 1)),
    ("median error (cm)", lambda r: cell(r["median_error_cm"])),
    ("median heading error (deg)", lambda r: cell(r["median_heading_error_deg"])),
    ("median time (ms)", lambda r: cell(1e3 * r["median_time_s"], ".1f")),
    ("median CPU time (ms)", lambda r: cell(1e3 * r["median_cpu_time_s"], ".1f")),
    ("median scans", lambda r: cell(r["median_scans"], ".0f")),
]
_TRACKING_COLUMNS: list[Column] = [
    ("trials", lambda r: f"{r['trials']:.0f}"),
    ("RMSE (cm)", lambda r: cell(r["rmse_cm"])),
    ("heading RMSE (deg)", lambda r: cell(r["rmse_heading_deg"])),
    ("blind", lambda r: percent(r["blind_fraction"], 1)),
    ("RMSE with echo (cm)", lambda r: cell(r["rmse_echo_cm"])),
    ("RMSE blind (cm)", lambda r: cell(r["rmse_blind_cm"])),
    ("dead reckoning RMSE (cm)", lambda r: cell(r["dead_reckoning_rmse_cm"])),
    ("median final error (cm)", lambda r: cell(r["median_final_error_cm"])),
    ("median time per action (ms)", lambda r: cell(1e3 * r["median_time_s"], ".1f")),
    ("particles median / max", lambda r: f"{cell(r['median_particles'], '.0f')} / {cell(r['max_particles'], '.0f')}"),
    ("update (ms)", lambda r: cell(r["median_update_ms"], ".1f")),
]
_KIDNAPPED_COLUMNS: list[Column] = [
    ("trials", lambda r: f"{r['trials']:.0f}"),
    ("localised first", lambda r: f"{r['localised']:.0f}"),
    ("recovered", lambda r: percent(r["recovery_rate"], 1)),
    ("median scans to recover", lambda r: cell(r["median_recovery_scans"], ".0f")),
]


def _map_tables(summary: Mapping[tuple[str, str], Row], maps: Sequence[str], localisers: Sequence[str],
                columns: list[Column]) -> list[str]:
    """One Markdown table per map, a row per localiser that has results there."""
    lines: list[str] = []
    for m in maps:
        lines += [f"### {m}", "", "| localiser | " + " | ".join(h for h, _ in columns) + " |",
                  "|---|" + "---:|" * len(columns)]
        for n in localisers:
            row = summary.get((m, n))
            if row is not None:
                lines.append(f"| {n} | " + " | ".join(show(row) for _, show in columns) + " |")
        lines.append("")
    return lines


def _sonar_note(config: BenchConfig) -> str:
    """What the summary says of the simulated sonar's parameters."""
    if config.sonar == "ideal":
        return f"{config.sensor_noise:g} cm noise"
    model = config.simulated_sonar
    source = "a sonar profile" if config.sonar_model is not None else "the model's defaults"
    return (f"{source}: noise {getattr(model, 'noise_sd', math.nan):g} cm, lobe "
            f"{getattr(model, 'beam_width_deg', math.nan):g} degrees; every parameter in config.json")


def _strategy_note(config: BenchConfig) -> str:
    """The global strategy's settings in words."""
    g = config.strategy
    sweep = (f"sweep at {g.scan_step_deg:g}-degree steps" + (", turn toward the minimum reading, sweep again"
                                                              if g.align else ""))
    confirm = "each fix confirmed by a second look" if g.confirm else "fixes not confirmed"
    return (f"{sweep}; {confirm}; while ambiguous up to {g.max_explore_moves} exploration moves of at most "
            f"{g.explore_step_cm:g} cm (`{g.exploration}` rule) with a sweep after each; {g.attempts} attempts")


def _settings_lines(config: BenchConfig, maps: Sequence[str], localisers: Sequence[str], trials: int, seed: int,
                    command: str, wall_time_s: float | None) -> list[str]:
    """The summary's title and the settings of the run, as Markdown lines."""
    trackers = [n for n in localisers if getattr(LOCALISERS.get(n), "needs_prior", False)]
    lines = ["# Localiser benchmark", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    noise = config.noise
    lines += [
        f"- maps: {', '.join(maps)}; localisers: {', '.join(localisers)}; {trials} trials per map and "
        f"localiser; seed {seed}",
        f"- simulator: sonar `{config.sonar}` ({_sonar_note(config)}), motion noise "
        f"`{noise.model}` (motion {noise.motion:g}, turn {noise.turn:g})",
        f"- true poses: uniform over the free space at least {config.pose_clearance_cm:g} cm from the walls, "
        "heading uniform; the same poses for every localiser",
        f"- success: final estimate within {SUCCESS_CM:g} cm and {SUCCESS_DEG:g} degrees of the simulator's "
        "true pose at the end of the localisation; time = the localiser's computation time (its reset, predict "
        "and update calls) over the whole localisation, the simulator excluded (wall clock: it grows when other "
        "processes compete for the cores); CPU time = the worker's CPU time over the whole localisation, "
        "simulator included (not inflated by competing processes)",
        f"- global localisation: a mission's strategy ({_strategy_note(config)})",
        "- scans given to the localisers: "
        + ("the paper's windows (+-15 degrees around 0/90/180/270 from the minimum reading's direction)"
           if config.scan_processing == "paper" else "raw (every usable reading)"),
    ]
    lines.append(f"- robot model given to every localiser: {config.robot.describe()}"
                 + (" less the lobe and beam mixture (`--lobe off`: a thin ray)"
                    if config.lobe == "off" and config.sonar != "ideal" else ""))
    if trackers:
        if config.tracker_prior == "noisy-truth":
            how = (f"the true pose plus Gaussian noise ({config.prior_sd[0]:g} cm, {config.prior_sd[1]:g} "
                   "degrees): they track, they do not localise globally")
        else:
            how = "the first estimate of a `paper-pf` run on the same robot (its time not counted)"
        lines.append(f"- pose trackers ({', '.join(trackers)}) cannot localise globally; their prior is {how} "
                     f"(`--tracker-prior {config.tracker_prior}`)")
    if wall_time_s is not None:
        lines.append(f"- benchmark wall time: {wall_time_s:.1f} s")
    lines.append("")
    return lines


def _failure_lines(results: Sequence[TrialResult]) -> list[str]:
    """The trials that raised (the first 20), as Markdown lines; none when no trial raised."""
    lines: list[str] = []
    failed = [r for r in results if r.failure]
    if failed:
        lines += ["## Trials that raised", "",
                  f"{len(failed)} trial(s) raised an exception and count as failures (NaN errors in the CSV):", ""]
        for r in failed[:20]:
            lines.append(f"- {r.scenario} {r.map} {r.localiser} trial {r.trial} (seed {r.seed}): `{r.failure}`")
        if len(failed) > 20:
            lines.append(f"- ... and {len(failed) - 20} more")
        lines.append("")
    return lines


def write_summary(
    results: Sequence[TrialResult],
    path: str | Path,
    *,
    config: BenchConfig,
    maps: Sequence[str],
    localisers: Sequence[str],
    trials: int,
    seed: int,
    command: str = "",
    wall_time_s: float | None = None,
) -> Path:
    """Write ``summary.md``: settings, then per scenario and map one table row per localiser."""
    s = summarise(results)
    lines = _settings_lines(config, maps, localisers, trials, seed, command, wall_time_s)
    if "global" in s:
        lines += ["## Global localisation", ""]
        lines += _map_tables(s["global"], maps, localisers, _GLOBAL_COLUMNS)
    if "tracking" in s:
        lines += ["## Tracking", "",
                  f"A scripted drive of {config.tracking_steps} actions (turn, then a move of "
                  f"{config.tracking_step_cm[0]:g}-{config.tracking_step_cm[1]:g} cm); every localiser starts "
                  f"from the true pose plus noise ({config.prior_sd[0]:g} cm, {config.prior_sd[1]:g} degrees) "
                  "and predicts + updates with a full scan after every action. RMSE over all actions and trials "
                  "(blind = actions whose scan held no reading, no wall within the sonar's reach; RMSE with "
                  "echo / blind = over the other / those actions; dead reckoning = the prior's mean moved by the "
                  "executed actions without noise and never corrected, the best estimate without readings); "
                  "particles = the particles held after each update (median over the trials of each trial's "
                  "median, and the largest count seen); update = median time of one `update` call.", ""]
        lines += _map_tables(s["tracking"], maps, localisers, _TRACKING_COLUMNS)
    if "kidnapped" in s:
        lines += ["## Kidnapped robot", "",
                  f"After the global localisation the robot is teleported at least {config.kidnap_min_cm:g} cm "
                  f"away; the global strategy then runs again without resetting the localiser (one attempt, no "
                  f"confirmation: either would start afresh), at most {config.recovery_rounds} times. "
                  "Recovered = a run ends converged within the success tolerance. The rate counts the trials "
                  "whose first localisation succeeded; scans to recover count from the teleport.", ""]
        lines += _map_tables(s["kidnapped"], maps, localisers, _KIDNAPPED_COLUMNS)
    lines += _failure_lines(results)
    p = Path(path)
    p.write_text("\n".join(lines))
    return p
