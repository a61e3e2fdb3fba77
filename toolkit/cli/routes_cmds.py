"""`nxtnav bench routes`: localisers on real sweeps along routes through each source's waypoints."""

from __future__ import annotations

import json
import math
import shlex
import time
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.table import Table

from toolkit.number_format import cell, json_safe, percent
from toolkit.world import NxtnavError

from .app import bench_app
from .interrupts import run_batch
from .options import (
    ConfigFile,
    Force,
    GlobalLocalisers,
    NoiseModel,
    OutFolder,
    PluginSets,
    Seeds,
    SourceProfiles,
    SweepSetFolder,
    SweepsMap,
    SweepsNoise,
    TruthHeadings,
    Workers,
    check_out_folder,
    checked_headings,
    parse_floats,
    parse_list,
)
from .run_config import configuration, given_sets
from .set_options import localiser_sets
from .sweeps_cmds import _seeds

__all__: list[str] = []

ORDER_HELP = ("The course's order: 'listed' (the order of the waypoints in sweeps.csv) or the waypoints "
              "as X:Y,X:Y,... (cm; every waypoint of a routed source must be among them).")


def _order(text: str) -> list[tuple[float, float]] | None:
    """``listed`` (None) or the waypoints of ``X:Y,X:Y,...`` (cm)."""
    if text.strip() == "listed":
        return None
    out: list[tuple[float, float]] = []
    for part in parse_list(text, "--order"):
        x, sep, y = part.partition(":")
        try:
            xy = (float(x), float(y)) if sep else None
        except ValueError:
            xy = None
        if xy is None or not all(math.isfinite(v) for v in xy):
            raise NxtnavError(f"--order: unknown order {text!r}; give 'listed' or waypoints X:Y,X:Y,... (cm)")
        out.append(xy)
    return out


def _noise(model: str, text: str) -> Any:
    from toolkit.world import MotionNoise

    _, motion, turn = parse_floats(text, "--noise", (3,))
    if min(motion, turn) < 0:
        raise NxtnavError(f"--noise: noise values must be >= 0, got {text!r}")
    if model not in ("botsim", "absolute"):
        raise NxtnavError(f"--noise-model: unknown noise model {model!r}; known: botsim, absolute")
    return MotionNoise(model, motion, turn)  # type: ignore[arg-type]


def _summary_table(summary: dict[str, Any]) -> Table:
    table = Table("localiser", "step", "runs", "within 10 cm", "median error", "median heading error",
                  "converged", "ambiguous", "confidently wrong", "honest",
                  title="localisation along routes of real sweeps, by step (honest: within 10 cm, or ambiguous "
                        "with the truth among the candidates)")
    for name, s in summary.items():
        for k, st in s["steps"].items():
            table.add_row(name if k == 1 else "", str(k), str(st["runs"]), percent(st["within_10cm"], 0),
                          cell(st["median_error_cm"], ".1f", " cm"), cell(st["median_heading_error_deg"], ".1f", "°"),
                          percent(st["converged"], 0), percent(st["ambiguous"], 0),
                          percent(st["confidently_wrong"], 0), percent(st["honest"], 0))
    return table


def _targets(summary: dict[str, Any]) -> list[str]:
    lines = []
    for name, s in summary.items():
        lines.append(f"{name}: within 10 cm after the second sweep {s['within_10cm_after_second']:.0%} "
                     f"(target >= 95 %), routes confidently wrong at any step {s['confidently_wrong_routes']:.0%} "
                     f"(target 0 %), first sweep honest {s['first_honest']:.0%} (target >= 95 %)")
        by_source = s["within_10cm_after_second_by_source"]
        if len(by_source) > 1:
            lines.append("  after the second sweep, by source: "
                         + ", ".join(f"{repo} {share:.0%}" for repo, share in by_source.items()))
    return lines


@bench_app.command("routes")
def bench_routes(
    ctx: typer.Context,
    folder: SweepSetFolder,
    map_file: SweepsMap = None,
    localisers_text: GlobalLocalisers = "paper-pf,amcl",
    seeds_text: Seeds = "0,1,2",
    orders: int = typer.Option(0, "--orders", help="Seeded random orders per source, besides the course's order "
                                                  "from each waypoint."),
    order_text: str = typer.Option("listed", "--order", metavar="listed|X:Y,...", help=ORDER_HELP),
    noise_model: NoiseModel = "botsim",
    noise_text: SweepsNoise = "1,0.1,0.005",
    headings: TruthHeadings = "column",
    sonar_profile: SourceProfiles = None,
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    out: OutFolder = Path("out/routes"),
    force: Force = False,
    workers: Workers = 1,
    config_file: ConfigFile = None,
) -> None:
    """Localise along routes of real sweeps: routes.csv, summary.json and route.png in --out.

    For every source with sweeps at two or more waypoints: the course's order from each waypoint and
    --orders random orders; the first sweep is global localisation, every later one follows the robot's
    odometry (the true motion with motion noise). Per step: error, heading error, converged, ambiguous,
    candidates, truth among the candidates.
    """
    from localisation.base import LOCALISERS
    from toolkit.bench.routes import make_route_tasks, plan_routes, truth_headings, warn_twin_headings
    from toolkit.real_sonar.fit import profiles_by_source
    from toolkit.real_sonar.sweeps import load_sweep_set
    from toolkit.world import NxtSonar
    from toolkit.world.bundled import data_path

    locs = parse_list(localisers_text, "--localisers", list(LOCALISERS.names()))
    trackers = [n for n in locs if LOCALISERS.get(n).needs_prior]
    if trackers:
        raise NxtnavError(f"--localisers: {', '.join(trackers)} track a known pose and cannot localise globally "
                          "from the first sweep; use particle filters (paper-pf, amcl, pf-*)")
    seeds = _seeds(seeds_text)
    if orders < 0:
        raise NxtnavError(f"--orders: must be 0 or more, got {orders}")
    order = _order(order_text)
    noise = _noise(noise_model, noise_text)
    options = localiser_sets(given_sets(ctx, sets), locs)
    sweeps = load_sweep_set(folder, map_file)
    checked_headings(headings)
    routes = plan_routes(sweeps, orders, order, need_headings=headings == "column")
    repos = list(dict.fromkeys(r.repo for r in routes))
    sonars = (profiles_by_source(data_path(sonar_profile), repos) if sonar_profile is not None
              else dict.fromkeys(repos, NxtSonar()))
    check_out_folder(out, force)
    truth = truth_headings(headings, sweeps, sonars)
    if truth is None:
        warn_twin_headings(sweeps, sonars)
    tasks = make_route_tasks(sweeps, map_file, routes, locs, seeds, sonars, noise, options, truth)
    command = " ".join(shlex.quote(a) for a in [
        "nxtnav", "bench", "routes", str(folder), *(["--map", map_file] if map_file else []),
        "--localisers", ",".join(locs), "--seeds", ",".join(map(str, seeds)), "--orders", str(orders),
        *(["--order", order_text] if order is not None else []), "--noise-model", noise_model, "--noise", noise_text,
        *(["--headings", headings] if headings != "column" else []),
        *(["--sonar-profile", str(sonar_profile)] if sonar_profile else []),
        *[a for s in given_sets(ctx, sets) for a in ("--set", s)], "--out", str(out), "--workers", str(workers)])
    _run_and_write(tasks, out, locs, command=command, config={
        "folder": str(folder), "map": map_file, "localisers": locs, "seeds": seeds, "orders": orders,
        "order": order, "noise": noise.to_dict(), "options": options, "headings": headings,
        "truth_headings_deg": truth,
        "routes": [{"repo": r.repo, "route": r.name, "waypoints": r.waypoints} for r in routes],
        "sonar": {repo: m.to_dict() for repo, m in sonars.items()}}, workers=workers,
        configured=configuration(ctx, sets))


def _run_and_write(tasks: list[Any], out: Path, locs: list[str], *, command: str, config: dict[str, Any],
                   workers: int, configured: dict[str, Any]) -> None:
    """Run the route tasks, then write routes.csv, summary.json (with `configured`: the command's effective
    configuration, `toolkit.cli.run_config`) and route.png and print the summary."""
    from toolkit.bench.routes import run_route, summarise_steps, write_routes_csv
    from toolkit.bench.routes_plots import route_figure

    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    batch = run_batch(run_route, tasks, "routes", label=f"{len(tasks)} routes", workers=workers)
    done, complete = batch.results, batch.complete
    wall = time.perf_counter() - t0
    order = {(t.localiser, t.seed, t.route.repo, t.route.name): i for i, t in enumerate(tasks)}
    done.sort(key=lambda steps: order[(steps[0].localiser, steps[0].seed, steps[0].repo, steps[0].route)])
    steps = [s for route in done for s in route]
    csv_path = write_routes_csv(steps, out / "routes.csv")
    summary = summarise_steps(steps, locs)
    doc = {"command": command, "complete": complete, "routes_done": len(done), "routes_planned": len(tasks),
           "wall_time_s": wall, "config": config, "localisers": summary, "configuration": configured}
    (out / "summary.json").write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False))
    figure = [route_figure(done[0], tasks[0], out / "route.png")] if done and done[0][0].truth is not None else []
    Console().print(_summary_table(summary))
    for line in _targets(summary):
        typer.echo(line)
    typer.echo(f"wrote {csv_path}, {out / 'summary.json'}{''.join(f', {p}' for p in figure)} "
               f"({len(steps)} steps of {len(done)} routes in {wall:.1f} s)")
    batch.finish(f"partial results (marked incomplete) in {out}")
