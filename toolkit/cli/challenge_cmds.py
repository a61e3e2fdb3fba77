"""`nxtnav bench challenge` and `nxtnav run --sonar sweeps:DIR`: the course's challenge on real sweeps."""

from __future__ import annotations

import json
import shlex
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from toolkit.world import MotionNoise, NxtnavError, NxtSonar, load_map

from .app import EXIT_FAILED, bench_app, fail
from .interrupts import run_batch
from .options import (
    ConfigFile,
    Force,
    GlobalLocalisers,
    NoiseModel,
    OutFolder,
    PlannerName,
    Seeds,
    SweepSetFolder,
    SweepsMap,
    SweepsNoise,
    TruthHeadings,
    Workers,
    check_out_folder,
    check_writable,
    checked_headings,
    parse_floats,
    parse_list,
    shipped,
)
from .options import sonar_profile as load_profile
from .run_config import configuration, given_sets, section_settings
from .sweeps_cmds import _seeds

if TYPE_CHECKING:
    from collections.abc import Callable

    from toolkit.mission.challenge import ChallengeConfig
    from toolkit.real_sonar.sweeps import SweepSet

__all__ = ["run_sweeps_mission"]


def _noise(noise_model: str, text: str) -> MotionNoise:
    """The motion noise of ``--noise SENSOR,MOTION,TURN`` (the sensor's is the real sweeps': unused)."""
    _, motion, turn = parse_floats(text, "--noise", (3,))
    if min(motion, turn) < 0:
        raise NxtnavError(f"--noise: values must be >= 0, got {text!r}")
    return MotionNoise(noise_model, motion, turn)  # type: ignore[arg-type]


ChallengeSets = Annotated[list[str], typer.Option(
    "--set", metavar="challenge.KEY=VALUE",
    help="A setting of the challenge mission (repeatable), e.g. challenge.move_step_cm=15 (docs/real-sonar.md).")]


def challenge_config(sets: list[str], command: str) -> ChallengeConfig:
    """The challenge mission's settings: the defaults with the ``challenge.KEY=VALUE`` values of `sets`."""
    from toolkit.mission.challenge import ChallengeConfig

    return section_settings(ChallengeConfig(), sets, "challenge", command)


def _map_of(folder: Path, map_name: str | None) -> str:
    if map_name is not None:
        return map_name
    if (folder / "arena.yaml").is_file():
        return str(folder / "arena.yaml")
    raise NxtnavError(f"{folder}: no arena.yaml; name the map with --map")


def run_sweeps_mission(sonar: str, map_name: str, planner: str, localiser: str, seed: int, noise_model: str,
                       noise_text: str, profile: Path | None, json_out: Path | None,
                       not_here: dict[str, Any] | None = None, ctx: typer.Context | None = None,
                       sets: list[str] | None = None, headings: str = "column") -> None:
    """`nxtnav run --sonar sweeps:DIR`: one challenge mission (`toolkit.mission.challenge`) on a seeded
    source of the set, from a seeded waypoint; exit 1 when a waypoint was not reached within 10 cm.
    `not_here`: options of `run` a challenge does not take, with their values (any set one is an error);
    `ctx` and `sets`: the command and its ``--set`` values (``challenge.KEY=VALUE`` only), for the settings
    and the configuration the report carries; `headings`: ``--headings`` (as `bench challenge` takes it)."""
    import numpy as np

    from toolkit.bench.challenge import challenge_mission
    from toolkit.bench.routes import warn_twin_headings
    from toolkit.number_format import json_safe
    from toolkit.real_sonar.sweep_sonar import course_waypoints, load_challenge_set, sweeps_folder
    from toolkit.seeds import derive_seed

    given = [option for option, value in (not_here or {}).items() if value not in (None, False)]
    if given:
        raise NxtnavError(f"{', '.join(given)}: not with --sonar {sonar} (the challenge starts at a seeded waypoint "
                          "of the sweep set, in the simulator, and writes --json only)")
    all_sets = [] if ctx is None else given_sets(ctx, sets or [])
    settings = challenge_config(all_sets, f"run --sonar {sonar}")
    folder = sweeps_folder(sonar)
    assert folder is not None
    folder = shipped(folder)
    noise = _noise(noise_model, noise_text)
    model = load_profile(profile, "nxt")
    check_writable(json_out, "--json")
    sweeps = load_challenge_set(folder, load_map(map_name), _truth_headings(headings, model or NxtSonar()))
    repos = [r for r in sweeps.repos if len(course_waypoints(sweeps, r)) >= 2]
    pick = np.random.default_rng(derive_seed(seed, "run challenge"))
    repo = repos[int(pick.integers(len(repos)))]
    start = int(pick.integers(len(course_waypoints(sweeps, repo))))
    if headings == "column":
        warn_twin_headings(sweeps, {repo: model or NxtSonar()})
    report = challenge_mission(sweeps, repo, start, seed, localiser, planner, model, noise, settings)
    typer.echo(f"sweeps of {repo} ({folder})")
    typer.echo(report.summary())
    if json_out is not None:
        doc = {**report.to_dict(), "repo": repo, "sweeps": str(folder), "seed": seed, "noise": noise.to_dict(),
               "headings": headings}
        if ctx is not None:
            doc["configuration"] = configuration(ctx, sets or [], challenge=settings.model_dump())
        json_out.write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False))
        typer.echo(f"wrote {json_out}")
    if not report.reached:
        raise fail(f"mission failed: {report.status}", code=EXIT_FAILED)


def _truth_headings(headings: str, model: NxtSonar) -> Callable[[SweepSet], dict[str, float] | None]:
    """What finds the sweeps' headings (degrees, by label) of ``--headings aligned|model`` from the set once it
    is read (`load_challenge_set`); None from it for ``column``."""
    from toolkit.bench.routes import truth_headings

    checked_headings(headings)
    return lambda sweeps: truth_headings(headings, sweeps, dict.fromkeys(sweeps.repos, model))


@bench_app.command("challenge")
def bench_challenge(
    ctx: typer.Context,
    folder: SweepSetFolder,
    map_name: SweepsMap = None,
    localisers_text: GlobalLocalisers = "paper-pf,amcl",
    seeds_text: Seeds = "0,1,2",
    planner: PlannerName = "min-turn",
    noise_model: NoiseModel = "botsim",
    noise_text: SweepsNoise = "1,0.1,0.005",
    sonar_profile: Path | None = typer.Option(None, "--sonar-profile",
                                              help="nxt sonar model for the localisers (YAML; default: fitted)."),
    headings: TruthHeadings = "column",
    out: OutFolder = Path("out/challenge"),
    force: Force = False,
    workers: Workers = 1,
    sets: ChallengeSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
) -> None:
    """The course's challenge on real sweeps: every source x start waypoint x seed x localiser; challenge.csv,
    summary.md and summary.json in --out."""
    from localisation.base import LOCALISERS
    from planners import PLANNERS
    from toolkit.bench.challenge import (
        challenge_tasks,
        crashed_mission,
        run_challenge_task,
        summary_json,
        summary_markdown,
        write_challenge_csv,
    )
    from toolkit.bench.common import isolate_planners
    from toolkit.bench.routes import warn_twin_headings
    from toolkit.real_sonar.sweep_sonar import load_challenge_set

    locs = parse_list(localisers_text, "--localisers", list(LOCALISERS.names()))
    PLANNERS.check(planner)
    seeds = _seeds(seeds_text)
    noise = _noise(noise_model, noise_text)
    settings = challenge_config(given_sets(ctx, sets), "bench challenge")
    model = load_profile(sonar_profile, "nxt")
    map_ref = _map_of(folder, map_name)
    sweeps = load_challenge_set(folder, load_map(map_ref), _truth_headings(headings, model or NxtSonar()))
    truth = None if headings == "column" else {s.label: s.heading_deg for s in sweeps}
    check_out_folder(out, force)
    if truth is None:
        warn_twin_headings(sweeps, dict.fromkeys(sweeps.repos, model or NxtSonar()))
    tasks = challenge_tasks(sweeps, map_ref, locs, seeds, planner=planner, sonar=model, noise=noise, config=settings,
                            headings=truth)
    batch = run_batch(run_challenge_task, tasks, "missions", label=f"{len(tasks)} challenge missions",
                      workers=workers, crashed=crashed_mission, isolate=isolate_planners([planner]))
    runs, complete = batch.results, batch.complete
    command = " ".join(shlex.quote(a) for a in [
        "nxtnav", "bench", "challenge", str(folder), *(["--map", map_name] if map_name else []),
        "--localisers", ",".join(locs), "--seeds", ",".join(map(str, seeds)), "--planner", planner,
        "--noise-model", noise_model, "--noise", noise_text,
        *(["--headings", headings] if headings != "column" else []),
        *(["--sonar-profile", str(sonar_profile)] if sonar_profile else []),
        *[a for s in given_sets(ctx, sets) for a in ("--set", s)], "--out", str(out)])
    out.mkdir(parents=True, exist_ok=True)
    csv_path = write_challenge_csv(runs, out / "challenge.csv")
    text = summary_markdown(runs, sweeps=sweeps, seeds=seeds, command=command, complete=complete,
                            readings=settings.sonar.readings)
    (out / "summary.md").write_text(text)
    extra: dict[str, Any] = {"folder": str(folder), "map": sweeps.map.name, "localisers": locs, "seeds": seeds,
                             "planner": planner, "noise": noise.to_dict(), "complete": complete,
                             "headings": headings, "truth_headings_deg": truth,
                             "missions_done": len(runs), "missions_planned": len(tasks), "command": command,
                             "configuration": configuration(ctx, sets, challenge=settings.model_dump())}
    (out / "summary.json").write_text(summary_json(runs, **extra))
    typer.echo(text)
    typer.echo(f"wrote {csv_path}, {out / 'summary.md'}, {out / 'summary.json'}")
    batch.finish(f"partial results (marked incomplete) in {out}")
