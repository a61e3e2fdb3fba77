"""`nxtnav bench sweeps`: localisers on real sweeps at known waypoints (global, one sweep, no motion)."""

from __future__ import annotations

import json
import shlex
import time
from pathlib import Path

import typer

from toolkit.world import NxtnavError

from .app import bench_app
from .interrupts import run_batch
from .options import (
    ConfigFile,
    Dask,
    Force,
    GlobalLocalisers,
    OutFolder,
    Seeds,
    SourceProfiles,
    SweepSetFolder,
    SweepsMap,
    Workers,
    check_out_folder,
    parse_heading_prior,
    parse_list,
)
from .options import sonar_profile as load_profile
from .run_config import configuration, given_sets, section_settings


def _seeds(text: str) -> list[int]:
    out = []
    for part in parse_list(text, "--seeds"):
        try:
            v = int(part)
        except ValueError:
            raise NxtnavError(f"--seeds: not a whole number: {part!r}") from None
        if v < 0:
            raise NxtnavError(f"--seeds: seeds are >= 0, got {v}")
        out.append(v)
    return out


@bench_app.command("sweeps")
def bench_sweeps(
    ctx: typer.Context,
    folder: SweepSetFolder,
    map_file: SweepsMap = None,
    localisers_text: GlobalLocalisers = "paper-pf,amcl",
    seeds_text: Seeds = "0,1,2",
    sonar_profile: SourceProfiles = None,
    heading_prior_text: str | None = typer.Option(
        None, "--heading-prior", metavar="H:SD",
        help="The robot believes its heading is H degrees, give or take SD (the position stays unknown); "
             "default: global localisation, no heading known."),
    out: OutFolder = Path("out/sweeps"),
    force: Force = False,
    workers: Workers = 1,
    dask: Dask = None,
    sets: list[str] = typer.Option([], "--set", metavar="sonar.FIELD=VALUE",
                                   help="A field of the nxt sonar model the localisers are told (repeatable; "
                                        "every source's profile), e.g. sonar.noise_sd=4."),
    config_file: ConfigFile = None,
) -> None:
    """Global localisation from each real sweep alone: sweeps.csv and summary.md in --out."""
    from localisation.base import LOCALISERS
    from toolkit.bench.sweeps import make_sweep_tasks, run_sweep, write_sweeps_csv, write_sweeps_summary
    from toolkit.real_sonar.fit import profiles_by_source
    from toolkit.real_sonar.sweeps import load_sweep_set
    from toolkit.world import NxtSonar
    from toolkit.world.bundled import data_path

    names = LOCALISERS.names()
    locs = parse_list(localisers_text, "--localisers", list(names))
    trackers = [n for n in locs if LOCALISERS.get(n).needs_prior]
    if trackers:
        raise NxtnavError(f"--localisers: {', '.join(trackers)} track a known pose and cannot localise from one "
                          "sweep alone; use particle filters (paper-pf, amcl, pf-*)")
    seeds = _seeds(seeds_text)
    heading_prior = parse_heading_prior(heading_prior_text, "--heading-prior")
    sweeps = load_sweep_set(folder, map_file)
    sonar: NxtSonar | dict[str, NxtSonar] = NxtSonar()
    if sonar_profile is not None and data_path(sonar_profile).is_dir():
        sonar = profiles_by_source(data_path(sonar_profile), sweeps.repos)
    elif sonar_profile is not None:
        sonar = load_profile(sonar_profile, "nxt") or sonar
    sonar_sets = given_sets(ctx, sets)
    if sonar_sets:
        sonar = ({repo: section_settings(m, sonar_sets, "sonar", "bench sweeps") for repo, m in sonar.items()}
                 if isinstance(sonar, dict) else section_settings(sonar, sonar_sets, "sonar", "bench sweeps"))
    check_out_folder(out, force)
    tasks = make_sweep_tasks(sweeps, map_file, locs, seeds, sonar, heading_prior=heading_prior)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    batch = run_batch(run_sweep, tasks, "runs", label=f"{len(sweeps)} sweeps x {len(locs)} localisers x "
                      f"{len(seeds)} seeds", workers=workers, dask=dask)
    runs, complete = batch.results, batch.complete
    wall = time.perf_counter() - t0
    order = {(t.localiser, t.seed, t.index): i for i, t in enumerate(tasks)}
    label = {(s.repo, s.file): i for i, s in enumerate(sweeps)}
    runs = sorted(runs, key=lambda r: order[(r.localiser, r.seed, label[(r.repo, r.file)])])
    command = " ".join(shlex.quote(a) for a in [
        "nxtnav", "bench", "sweeps", str(folder), *(["--map", map_file] if map_file else []),
        "--localisers", ",".join(locs), "--seeds", ",".join(map(str, seeds)),
        *(["--sonar-profile", str(sonar_profile)] if sonar_profile else []),
        *(["--heading-prior", heading_prior_text] if heading_prior_text else []), "--out", str(out),
        "--workers", str(workers), *(["--dask", dask] if dask else [])])
    csv_path = write_sweeps_csv(runs, out / "sweeps.csv")
    md = write_sweeps_summary(runs, out / "summary.md", localisers=locs, sweeps=sweeps, seeds=seeds, sonar=sonar,
                              command=command, wall_time_s=wall, complete=complete, heading_prior=heading_prior)
    (out / "config.json").write_text(json.dumps({"folder": str(folder), "map": map_file, "localisers": locs,
                                                 "seeds": seeds,
                                                 "sonar": sonar.to_dict() if isinstance(sonar, NxtSonar) else
                                                 {repo: m.to_dict() for repo, m in sonar.items()},
                                                 "heading_prior": heading_prior and heading_prior.to_dict(),
                                                 "complete": complete,
                                                 "runs_done": len(runs), "runs_planned": len(tasks),
                                                 "wall_time_s": wall, "configuration": configuration(ctx, sets)},
                                                indent=1))
    typer.echo(md.read_text())
    typer.echo(f"wrote {csv_path}, {md} ({len(runs)} runs in {wall:.1f} s)")
    batch.finish(f"partial results (marked incomplete) in {out}")
