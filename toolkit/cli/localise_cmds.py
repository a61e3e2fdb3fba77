"""`nxtnav localise` (one localisation in the simulator, drawn) and `nxtnav bench localisers`."""

from __future__ import annotations

import json
import math
import shlex
import time
from pathlib import Path
from typing import Any

import typer

from toolkit.world import SONAR_MODELS, NxtnavError, Pose, load_map

from .app import app, bench_app
from .choices import one_of
from .interrupts import Batch, run_batch
from .options import (
    ConfigFile,
    Dask,
    Force,
    JsonOut,
    Lobe,
    LocaliserName,
    MapList,
    MapName,
    NoiseModel,
    OutFolder,
    PluginSets,
    PngOut,
    PoseText,
    Radius,
    ScanProcessing,
    Seed,
    SensorNoise,
    Sonar,
    SonarProfile,
    TrackerPrior,
    Workers,
    check_out_folder,
    check_writable,
    count,
    parse_list,
    pose_on_map,
    sonar_profile,
)
from .run_config import configuration, given_sets, plugin_sets, robot_model, robot_sets
from .set_options import localiser_sets

__all__: list[str] = []


def _localiser_names() -> list[str]:
    """Registered localisers (importing the implementations registers them)."""
    for mod in ("localisation.particle_filter", "localisation.filterpy_variants"):
        try:
            __import__(mod)
        except ImportError:  # pragma: no cover - not every build ships every module
            pass
    from localisation.base import LOCALISERS

    return LOCALISERS.names()


def _check_sonar(sonar: str) -> str:
    if sonar not in SONAR_MODELS:
        raise NxtnavError(f"--sonar: unknown sonar model {sonar!r}; known: {', '.join(SONAR_MODELS.names())}")
    return sonar


def _check_construction(m: Any, options: dict[str, dict[str, Any]]) -> None:
    """Build each localiser that has --set options once, so that a value its constructor refuses is a
    one-line error now rather than a failure of every trial later."""
    from localisation import make_localiser

    for name, opts in options.items():
        try:
            make_localiser(name, m, rng=0, **opts)
        except (ValueError, TypeError) as exc:
            raise NxtnavError(f"--set: {name} refuses {', '.join(f'{k}={v!r}' for k, v in opts.items())}: "
                              f"{exc}") from None


@app.command("localise")
def localise_cmd(
    ctx: typer.Context,
    map_name: MapName = "map1",
    *,
    pose_text: PoseText,
    localiser: LocaliserName = "paper-pf",
    sonar: Sonar = "ideal",
    sensor_noise: SensorNoise = 1.0,
    sonar_profile_path: SonarProfile = None,
    noise_model: NoiseModel = "botsim",
    tracker_prior: TrackerPrior = "noisy-truth",
    scan_processing: ScanProcessing = "paper",
    lobe: Lobe = "auto",
    radius: Radius = None,
    seed: Seed = 0,
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
    output: PngOut = None,
    json_out: JsonOut = None,
) -> None:
    """Localise once in the simulator from a known true pose; print the result, draw it with -o."""
    from localisation import candidate_poses, describe_candidates

    from ..bench.localisers import BenchConfig, localise_once
    from ..bench.localisers.plots import draw_localisation
    from ..plotting import save_figure

    names = _localiser_names()
    if parse_list(localiser, "--localiser", names) != [localiser]:
        raise NxtnavError(f"--localiser: expected one localiser, got {localiser!r}")
    _check_sonar(sonar)
    profile = sonar_profile(sonar_profile_path, sonar)
    check_writable(output, "--output")
    check_writable(json_out, "--json")
    m = load_map(map_name)
    pose = pose_on_map(pose_text, "--pose", m)
    assert isinstance(pose, Pose)
    plugins = plugin_sets(ctx, sets, ("robot", "sonar"))
    cfg = _with_robot_sets(ctx, sets, BenchConfig(
        sonar=sonar, sensor_noise=sensor_noise, noise_model=noise_model, tracker_prior=tracker_prior,
        scan_processing=scan_processing, lobe=lobe, robot_radius_cm=radius,
        localiser_options=localiser_sets(plugins, [localiser]), sonar_model=profile))
    out, _, loc = localise_once(m, pose, localiser, config=cfg, rng=seed)
    candidates = candidate_poses(loc)
    if candidates:  # the mean of several modes means nothing: name the candidates instead
        t = out.truth  # where the robot truly is now (the procedure turns and drives)
        near = min(c.distance_to(t) for c in candidates)
        typer.echo(f"{localiser}: {describe_candidates(candidates)}; the hidden truth is ({t.x:.1f}, {t.y:.1f}, "
                   f"{t.heading_deg:.0f} deg), {near:.1f} cm from the nearest candidate")
    typer.echo(f"{localiser}: error {out.error_cm:.2f} cm, heading {out.heading_error_deg:+.2f}°, "
               f"{out.iterations} iterations, {out.scans} scans, {1e3 * out.time_s:.1f} ms "
               f"({'success' if out.success else 'failure'}{', converged' if out.converged else ', not converged'})")
    if json_out is not None:
        doc = {"map": m.name, "localiser": localiser, "sonar": sonar, "sonar_model": cfg.simulated_sonar.to_dict(),
               "seed": seed, **out.to_dict(),
               "ambiguous": bool(candidates), "candidates": [c.to_list_deg() for c in candidates],
               "configuration": configuration(ctx, sets, robot=cfg.robot.to_dict())}
        json_out.write_text(json.dumps(doc, indent=1))
        typer.echo(f"wrote {json_out}")
    if output is not None:
        fig = draw_localisation(m, out, title=f"{m.name}: {localiser}, sonar {sonar}, seed {seed}")
        save_figure(fig, output)
        typer.echo(f"wrote {output}")


def _scenarios(text: str) -> list[str]:
    from ..bench.localisers import SCENARIOS

    if text.strip() == "all":
        return list(SCENARIOS)
    return parse_list(text, "--scenario", list(SCENARIOS))


def _with_robot_sets(ctx: typer.Context, sets: list[str], cfg: Any) -> Any:
    """`cfg` (a `BenchConfig`) with the ``--set robot.`` and ``sonar.`` settings; a bad one, or one that a
    shorthand flag given with it also sets, is one line before any work."""
    from dataclasses import replace

    every = given_sets(ctx, sets)
    robot_model(cfg.robot, every, ctx, sets)
    return replace(cfg, robot_sets=tuple(robot_sets(every).items()))


def _check_bench_numbers(exploration: str, trials: int, workers: int, sensor_noise: float, out: Path,
                         force: bool) -> None:
    """The benchmark's exploration rule, counts, noise and output folder, checked before any work."""
    from localisation.global_localisation import EXPLORATIONS

    if exploration not in EXPLORATIONS:
        raise NxtnavError(f"--exploration: unknown rule {exploration!r}; known: {', '.join(EXPLORATIONS)}")
    if trials < 1:
        raise NxtnavError(f"--trials must be >= 1, got {trials}")
    if workers < 1:
        raise NxtnavError(f"--workers must be >= 1, got {workers}")
    check_out_folder(out, force)
    if not math.isfinite(sensor_noise) or sensor_noise < 0:
        raise NxtnavError(f"--sensor-noise must be a non-negative number, got {sensor_noise}")


def _bench_command(maps: list[str], locs: list[str], trials: int, sonar: str, sonar_profile_path: Path | None,
                   scenarios: list[str], seed: int, tracker_prior: str, scan_processing: str, exploration: str,
                   lobe: str, radius: float | None, out: Path, workers: int, dask: str | None,
                   sets: list[str]) -> str:
    """The command line that reproduces a localiser benchmark, for its summary."""
    return " ".join(shlex.quote(a) for a in [
        "nxtnav", "bench", "localisers", "--maps", ",".join(maps), "--localisers", ",".join(locs),
        "--trials", str(trials), "--sonar", sonar,
        *(["--sonar-profile", str(sonar_profile_path)] if sonar_profile_path is not None else []),
        "--scenario", ",".join(scenarios), "--seed", str(seed),
        "--tracker-prior", tracker_prior, "--scan-processing", scan_processing,
        *(["--exploration", exploration] if exploration != "modes" else []), "--lobe", lobe,
        *(["--radius", f"{radius:g}"] if radius is not None else []), "--out", str(out),
        "--workers", str(workers),
        *(["--dask", dask] if dask else []), *[a for s in sets for a in ("--set", s)]])


@bench_app.command("localisers")
def bench_localisers(
    ctx: typer.Context,
    out: OutFolder,
    maps_text: MapList = "map1,map2,map3",
    localisers_text: str = typer.Option("all", "--localisers",
                                        help="Comma-separated localisers " + one_of("localiser") + ", or all."),
    trials: int = typer.Option(20, help="Trials (random true poses) per map and localiser.", callback=count),
    sonar: Sonar = "ideal",
    sensor_noise: SensorNoise = 1.0,
    sonar_profile_path: SonarProfile = None,
    noise_model: NoiseModel = "botsim",
    scenario: str = typer.Option("global", help="Scenarios " + one_of("scenario") + ": one, a comma list, or all."),
    tracker_prior: TrackerPrior = "noisy-truth",
    tracking_steps: int = typer.Option(12, help="Actions of the tracking drive.", callback=count),
    recovery_rounds: int = typer.Option(3, help="Runs of the procedure (localiser not reset) allowed to recover "
                                                "from a kidnapping.", callback=count),
    scan_processing: ScanProcessing = "paper",
    exploration: str = typer.Option("modes", help="Exploration rule of the global strategy while the belief is "
                                                  "ambiguous " + one_of("exploration")
                                                  + ": modes (a mission's: safe from every candidate pose) "
                                                  "or scan (toward the longest free run of the last sweep)."),
    lobe: Lobe = "auto",
    radius: Radius = None,
    seed: Seed = 0,
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
    force: Force = False,
    workers: Workers = 1,
    dask: Dask = None,
) -> None:
    """Benchmark localisers on random true poses: runs.csv, summary.md and plots in --out."""

    from ..bench.localisers import FILES, BenchConfig, TrialResult, make_tasks, run_trial, write_csv, write_summary
    from ..bench.localisers.plots import write_plots

    names = _localiser_names()
    locs = names if localisers_text.strip() == "all" else parse_list(localisers_text, "--localisers", names)
    maps = parse_list(maps_text, "--maps")
    for m in maps:
        load_map(m)
    _check_sonar(sonar)
    profile = sonar_profile(sonar_profile_path, sonar)
    scenarios = _scenarios(scenario)
    _check_bench_numbers(exploration, trials, workers, sensor_noise, out, force)
    options = localiser_sets(plugin_sets(ctx, sets, ("robot", "sonar")), locs)
    cfg = _with_robot_sets(ctx, sets, BenchConfig(
        sonar=sonar, sensor_noise=sensor_noise, noise_model=noise_model, tracker_prior=tracker_prior,
        tracking_steps=tracking_steps, recovery_rounds=recovery_rounds, scan_processing=scan_processing,
        exploration=exploration, lobe=lobe, robot_radius_cm=radius, localiser_options=options, sonar_model=profile))
    _check_construction(load_map(maps[0]), options)
    tasks = [t for s in scenarios for t in make_tasks(s, maps, locs, trials, seed, cfg)]
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    batch: Batch[TrialResult] = run_batch(run_trial, tasks, "trials", label=f"{', '.join(scenarios)} on "
                                          f"{', '.join(maps)}", workers=workers, dask=dask)
    results, interrupted = batch.results, not batch.complete
    wall = time.perf_counter() - t0
    written = [write_csv(results, out / FILES[s], s) for s in scenarios]
    command = _bench_command(maps, locs, trials, sonar, sonar_profile_path, scenarios, seed, tracker_prior,
                             scan_processing, exploration, lobe, radius, out, workers, dask, sets)
    written.append(write_summary(results, out / "summary.md", config=cfg, maps=maps, localisers=locs,
                                 trials=trials, seed=seed, command=command, wall_time_s=wall))
    if not interrupted:  # the plots compare every localiser on every map: not for a partial run
        written.extend(write_plots(results, out, maps, locs))
    (out / "config.json").write_text(json.dumps({"maps": maps, "localisers": locs, "trials": trials, "seed": seed,
                                                 "scenarios": scenarios, "complete": not interrupted,
                                                 "trials_done": len(results), "trials_planned": len(tasks),
                                                 **cfg.to_dict(),
                                                 "configuration": configuration(ctx, sets, robot=cfg.robot.to_dict())},
                                                indent=1, default=str))
    summary = out / "summary.md"
    summary.write_text(batch.banner() + summary.read_text())
    typer.echo(summary.read_text())
    typer.echo(f"wrote {', '.join(str(p) for p in written)} ({len(results)} trials in {wall:.1f} s)")
    batch.finish(f"partial results (marked incomplete) in {out}")
