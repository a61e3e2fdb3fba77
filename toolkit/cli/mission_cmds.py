"""`nxtnav run` (one mission, simulated or on a real NXT) and `nxtnav paper` (the paper's Table I)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from ..number_format import json_safe
from ..world import SONAR_MODELS, NxtnavError, NxtSonar, RobotGeometry, RobotModel, load_map, make_checker
from .app import EXIT_BAD_INPUT, EXIT_FAILED, app, fail
from .choices import one_of
from .interrupts import Batch, run_batch
from .options import (
    Collision,
    ConfigFile,
    Dask,
    JsonOut,
    LocaliserName,
    MapList,
    MapName,
    NoiseModel,
    NxtBackend,
    Objective,
    OptionGone,
    PlannerName,
    ProfileFile,
    Radius,
    ReconnectTimeout,
    ReplyTimeout,
    RunSets,
    Seed,
    ServerHost,
    ServerPort,
    SonarProfile,
    TruthHeadings,
    Workers,
    check_writable,
    count,
    parse_floats,
    parse_heading_prior,
    parse_list,
    parse_xy,
    pose_on_map,
    sonar_profile,
    writable_file,
)
from .progress import progress
from .run_config import configuration, dumps, given_sets, mission_config, robot_sets
from .run_parts import RunOutputs, Stack, mission_on_nxt, mission_on_sim

__all__: list[str] = []

_PAPER_NOISE_HELP = "Noise model(s) " + one_of("noise model") + " (default all; with --pareto botsim)."
_SETTINGS_HELP = "Mission settings for --pareto " + one_of("mission setting") + " (default all)."


def _planner_names() -> list[str]:
    from planners import PLANNERS

    return PLANNERS.names()


def _localiser_names() -> list[str]:
    from localisation import LOCALISERS

    return LOCALISERS.names()


def _check_name(value: str, option: str, known: list[str], allow_ompl: bool = False) -> str:
    if value in known:
        return value
    if allow_ompl:  # the planner registry knows its ompl:NAME family
        from planners import PLANNERS

        PLANNERS.check(value)
        return value
    raise typer.BadParameter(f"unknown {option.lstrip('-')} {value!r}; known: {', '.join(known) or 'none'}",
                             param_hint=option)


def _noise(text: str) -> tuple[float, float, float]:
    sensor, motion, turn = parse_floats(text, "--noise", (3,))
    if min(sensor, motion, turn) < 0:
        raise typer.BadParameter(f"noise values must be >= 0, got {text!r}", param_hint="--noise")
    return sensor, motion, turn


def _connect_nxt(backend: str, host: str, port: int, profile: Path | None, reply_timeout_s: float) -> Any:
    try:
        from ..robots.nxt import connect_robot
    except ImportError as exc:
        raise NxtnavError(f"the NXT backend is not available ({exc}); install the 'nxt' extra") from None
    return connect_robot(backend, host=host, port=port, profile=profile, reply_timeout_s=reply_timeout_s)


def _noise_models(chosen: list[str] | None, pareto: bool) -> list[str]:
    """The motion noise models of `paper` (default all, botsim alone for the Pareto front), each checked."""
    from localisation.models import NOISE_MODELS

    models = chosen or (["botsim"] if pareto else list(NOISE_MODELS))
    for nm in models:
        if nm not in NOISE_MODELS:
            raise typer.BadParameter(f"unknown noise model {nm!r}; known: {', '.join(NOISE_MODELS)}",
                                     param_hint="--noise-model")
    return models


def _check_kinds(robot_kind: str, sonar: str, noise_model: str, nxt_backend: str) -> None:
    """A usage error naming the option whose value is none of the names its registry knows."""
    from localisation.models import NOISE_MODELS

    from ..robots.nxt import BACKENDS

    checks = (("--robot", robot_kind, ("sim", "nxt")), ("--sonar", sonar, SONAR_MODELS.names()),
              ("--noise-model", noise_model, NOISE_MODELS), ("--nxt-backend", nxt_backend, BACKENDS))
    for option, value, known in checks:
        if value not in known:
            what = option.lstrip("-").replace("-", " ")
            raise typer.BadParameter(f"unknown {what} {value!r}; known: {', '.join(known)}", param_hint=option)


@app.command("run")
def run(
    ctx: typer.Context,
    map_name: MapName = "map1",
    start_text: str | None = typer.Option(
        None, "--start", metavar="X,Y[,HEADING_DEG]",
        help="True start (simulator): default the map's preset with a seeded random heading."),
    random_start: bool = typer.Option(False, "--random-start",
                                      help="Start from a random free pose at least 10 cm from every wall."),
    target_text: str | None = typer.Option(None, "--target", metavar="X,Y", help="Target (default: the preset)."),
    start_heading_text: str | None = typer.Option(
        None, "--start-heading", metavar="H:SD",
        help="The robot's heading at the start is H degrees, give or take SD (its position unknown): the first "
             "global localisation knows it. Default: nothing known."),
    planner: PlannerName = "min-turn",
    localiser: LocaliserName = "paper-pf",
    robot_kind: str = typer.Option("sim", "--robot", help="sim or nxt."),
    sonar: Annotated[str, typer.Option(help="Sonar model of the simulator " + one_of("sonar") + ", or "
                                       "sweeps:DIR: real sweeps at a sweep set's waypoints (the course's "
                                       "challenge).")] = "ideal",
    sonar_profile_path: SonarProfile = None,
    headings: TruthHeadings = "column",
    noise_model: NoiseModel = "botsim",
    noise_text: str = typer.Option("1,0.1,0.005", "--noise", metavar="SENSOR,MOTION,TURN",
                                   help="Noise of the ideal sonar (cm; the nxt sonar's comes from its model), "
                                        "motion noise, turn noise (the paper's by default)."),
    seed: Seed = 0,
    radius: Radius = None,
    collision: Collision = "index",
    sets: RunSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
    option: OptionGone = None,
    json_out: JsonOut = None,
    plot: Path | None = typer.Option(None, "--plot", callback=writable_file,
                                     metavar="FILE.png", help="Draw the mission."),
    animate: Path | None = typer.Option(None, "--animate", callback=writable_file,
                                        metavar="FILE.gif", help="Animate the mission (GIF)."),
    nxt_backend: NxtBackend = "usb",
    server_host: ServerHost = "localhost",
    server_port: ServerPort = 2727,
    profile: ProfileFile = None,
    reconnect_timeout: ReconnectTimeout = 30.0,
    reply_timeout: ReplyTimeout = 3.0,
    record: Path | None = typer.Option(None, "--record", callback=writable_file, metavar="FILE.jsonl",
                                       help="Record every command, scan and localiser call (docs/recording.md)."),
    record_particles: int = typer.Option(
        100, "--record-particles", min=0, metavar="N",
        help="With --record or a view: keep at most N particles of the cloud with each estimate (0: none)."),
    view: bool = typer.Option(
        False, "--view", help="Watch the mission live in a Rerun viewer (extra 'viz'; needs a display, "
                              "else use --view-save)."),
    view_save: Path | None = typer.Option(None, "--view-save", callback=writable_file, metavar="FILE.rrd",
                                          help="Stream the live view into a Rerun file instead of a viewer."),
    objective: Objective = None,
) -> None:
    """Run one mission: localise, plan, drive with the watchdog, re-localise, correct at the target."""

    if sonar.startswith("sweeps:"):  # real sweeps at waypoints: the course's challenge (docs/real-sonar.md)
        from .challenge_cmds import run_sweeps_mission

        return run_sweeps_mission(sonar, map_name, planner, localiser, seed, noise_model, noise_text,
                                  sonar_profile_path, json_out, {
                                      "--robot": robot_kind != "sim", "--start": start_text, "--random-start":
                                      random_start, "--target": target_text, "--start-heading": start_heading_text,
                                      "--radius": radius, "--plot": plot, "--animate": animate, "--record": record,
                                      "--view": view, "--view-save": view_save}, ctx, sets, headings)
    if headings != "column":
        raise NxtnavError(f"--headings {headings}: only with --sonar sweeps:DIR (a real sweep's heading)")
    m = load_map(map_name)
    planner = _check_name(planner, "--planner", _planner_names(), allow_ompl=True)
    localiser = _check_name(localiser, "--localiser", _localiser_names())
    _check_kinds(robot_kind, sonar, noise_model, nxt_backend)
    sensor_noise = _noise(noise_text)[0]
    start_heading = parse_heading_prior(start_heading_text, "--start-heading")
    named = "nxt" if robot_kind == "nxt" else sonar
    fitted_sonar = sonar_profile(sonar_profile_path, named)
    mission = _run_mission_config(named, planner, localiser, collision, given_sets(ctx, sets))
    robot_model = _run_robot_model(ctx, sets, named, fitted_sonar, noise_model, noise_text, radius)
    configured = configuration(ctx, sets, mission=mission.to_dict(), robot=robot_model.to_dict())
    outputs = RunOutputs(record, record_particles, view, view_save, json_out, plot, animate, configured)
    outputs.check()
    if start_text is not None and random_start:
        raise typer.BadParameter("give either --start or --random-start", param_hint="--start")
    target = np.array(parse_xy(target_text, "--target")) if target_text is not None else m.target
    if target is None:
        raise typer.BadParameter(f"map {m.name} has no preset target; give --target X,Y", param_hint="--target")
    # the sonar model: the simulator's readings come from it; a real NXT's localiser is told it
    sonar_model = robot_model.sonar
    _check_objective(objective, [planner])
    stack = Stack(planner, localiser, seed, collision, start_heading, mission, objective)
    doc: dict[str, Any] = {"robot": robot_kind, "sonar_model": sonar_model.to_dict(), "objective": objective}
    if robot_kind == "nxt":
        if start_text is not None or random_start:
            raise typer.BadParameter("the start of a real robot is unknown; --start/--random-start are for the "
                                     "simulator", param_hint="--start")
        robot = _connect_nxt(nxt_backend, server_host, server_port, profile, reply_timeout)
        report, robot_radius, model_time = mission_on_nxt(robot, m, target, stack, sonar_model, outputs,
                                                          reconnect_timeout)
        doc["model_robot_time_s"] = model_time
    else:
        robot_radius = robot_model.geometry.radius_cm  # the simulator's robot
        if robot_model.geometry != RobotGeometry():
            radius = robot_radius
        motion = robot_model.motion
        simulator = {"sonar": sonar, "noise_model": motion.model,
                     "sensor_noise": float(getattr(sonar_model, "noise_sd", sensor_noise)),
                     "motion_noise": motion.motion, "turn_noise": motion.turn}
        report = mission_on_sim(m, target, _sim_start(start_text, m), random_start, stack, simulator,
                                robot_model, radius, outputs)
        doc["simulator"] = simulator
    typer.echo(report.summary())
    note = None if robot_kind != "nxt" else \
        f"robot time by the simulator's time model for the same commands: {doc['model_robot_time_s']:.1f} s"
    outputs.write(report, m, doc, note)
    if not report.success:  # a target no robot disc fits on is bad input (2); any other failure is 1
        reachable = bool(m.contains(target)) and bool(make_checker(m, robot_radius, collision).point_free(target))
        raise fail(f"mission failed: {report.status}", code=EXIT_FAILED if reachable else EXIT_BAD_INPUT)


def _run_robot_model(ctx: typer.Context, sets: list[str], sonar: str, fitted: NxtSonar | None, noise_model: str,
                     noise_text: str, radius: float | None) -> RobotModel:
    """The robot of `nxtnav run`: its flags (``--sonar``, ``--sonar-profile``, ``--noise``, ``--noise-model``,
    ``--radius``), then the ``robot.`` and ``sonar.`` settings of ``--set`` (a flag and a ``--set`` of the
    same field on the command line are an error). A real NXT's build comes from its profile: only its
    sonar may be set."""
    from ..robots.sim import simulated_sonar
    from .run_config import robot_model, split_sets

    sensor_noise, motion_noise, turn_noise = _noise(noise_text)
    every = given_sets(ctx, sets)
    if ctx.params.get("robot_kind") == "nxt" and split_sets(every)[0].get("robot"):
        raise NxtnavError("--set robot.*: a real NXT's build comes from its --profile; --set sonar.* sets its "
                          "sonar model")
    base = RobotModel.build(simulated_sonar(sonar if fitted is None else fitted, sensor_noise),
                            noise_model=noise_model, motion_noise=motion_noise, turn_noise=turn_noise,
                            radius_cm=radius)
    return robot_model(base, every, ctx, sets)


def _run_mission_config(sonar: str, planner: str, localiser: str, collision: str, sets: list[str]) -> Any:
    """The mission settings of `nxtnav run`: the sonar's tuning, then ``--set`` (``mission.`` settings, and
    the planner's and localiser's options, checked against their declarations)."""
    from localisation import LOCALISERS
    from planners.declarations import planner_kwargs, planner_options

    from .run_config import mission_config, split_sets
    from .set_options import checked_sets, parse_sets

    plugins = split_sets(sets)[1]
    declared = {planner: lambda: planner_options(planner), localiser: lambda: LOCALISERS.get(localiser).options_model}
    options = checked_sets(parse_sets(plugins), [planner, localiser], lambda n: declared[n](), "plug-in")
    planning = {"planner_options": planner_kwargs(planner, options.get(planner, {}))}
    base = mission_config(sonar, sets, collision)
    return base.model_copy(update={"planning": base.planning.model_copy(update=planning),
                                   "localiser_options": {**base.localiser_options, **options.get(localiser, {})}})


def _sim_start(text: str | None, m: Any) -> Any:
    """The simulator's start from ``--start`` (a pose, or a position with a seeded heading), or None."""
    if text is None:
        return None
    return pose_on_map(text, "--start", m, heading_required=False)


def _names(text: str, option: str, known: list[str]) -> list[str]:
    out = [s.strip() for s in text.split(",") if s.strip()]
    for name in out:
        if name not in known:
            raise typer.BadParameter(f"unknown value {name!r}; known: {', '.join(known)}", param_hint=option)
    if not out:
        raise typer.BadParameter("give at least one name", param_hint=option)
    return out


def _paper_options(sets: list[str], sonars: list[str]) -> dict[str, Any]:
    """The ``--set mission.GROUP.FIELD=VALUE`` settings of every paper mission (values read as YAML), checked
    against the mission settings of each sonar; a key outside the ``mission`` section is an error."""
    from ..world.typed import parse_value
    from .run_config import mission_config, split_sets

    sections, plugins = split_sets(sets)
    if plugins:
        raise NxtnavError(f"--set: nxtnav paper takes mission settings (mission.GROUP.FIELD=VALUE), got {plugins[0]!r}")
    for sonar in sonars:
        mission_config(sonar, sets)
    return {key: parse_value(text) for key, text in sections.get("mission", {}).items()}


def _paper_robots(ctx: typer.Context, sets: list[str], sonars: list[str], models: list[str],
                  profile: NxtSonar | None) -> dict[str, Any]:
    """The robot of each sonar and noise model (``ideal/botsim``), ``--set robot.`` and ``sonar.`` settings
    applied; a bad setting is one line naming it."""
    from ..robots.sim import simulated_sonar
    from .run_config import robot_model

    every = given_sets(ctx, sets)
    robots = {}
    for so in sonars:
        sonar = simulated_sonar(profile if so == "nxt" and profile is not None else so, 1.0)
        for nm in models:
            robots[f"{so}/{nm}"] = robot_model(RobotModel.build(sonar, noise_model=nm), every, ctx, sets).to_dict()
    return robots


def _run_pareto(png: Path, trials: int, seed: int, sonars: list[str], maps: list[str], models: list[str],
                settings: str | None, workers: int, random_start: bool, json_out: Path | None,
                profile: NxtSonar | None = None, collision: str = "index", dask: str | None = None) -> None:
    """`nxtnav paper --pareto`: every mission setting, both sonar models; a figure and a table."""
    from ..bench.paper import run_paper
    from ..bench.paper_pareto import MISSION_SETTINGS, pareto_points, pareto_tasks
    from ..bench.paper_plots import draw_pareto
    from ..plotting import save_figure

    names = _names(settings or ",".join(MISSION_SETTINGS), "--settings", list(MISSION_SETTINGS))
    tasks = pareto_tasks(trials, seed, settings=names, sonars=sonars, maps=maps, noise_models=models,
                         random_start=random_start, sonar_model=profile, collision=collision)
    with progress("missions", len(tasks), transient=True) as advance:
        _, results = run_paper(tasks, workers=workers, dask_address=dask, on_done=advance)
    points = pareto_points(results)
    typer.echo(f"Collision checks: {collision}.\n")
    typer.echo("| Setting | Sonar | Map | Trials | Success | Collisions | Mean final error (cm) "
               "| Median robot time (s) | Median completion (s) | On the front |")
    typer.echo("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
    for p in sorted(points, key=lambda p: (p.sonar, p.map, p.robot_time_median_s)):
        typer.echo(f"| {p.setting} | {p.sonar} | {p.map} | {p.trials} | {100 * p.success_rate:.0f} % "
                   f"| {p.collisions} | {p.final_error_cm:.2f} | {p.robot_time_median_s:.1f} "
                   f"| {p.completion_median_s:.2f} | {'yes' if p.on_front else ''} |")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(maps), figsize=(4.5 * len(maps), 4.0), squeeze=False)
    for ax, m in zip(axes[0], maps, strict=True):
        draw_pareto(points, m, ax)
    save_figure(fig, png)
    typer.echo(f"wrote {png}")
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        models_used = {t.sonar: t.sonar_dict() for t in tasks}
        doc = {"settings": {k: MISSION_SETTINGS[k] for k in names}, "sonar_models": models_used,
               "collision": collision, "points": [p.to_dict() for p in points]}
        json_out.write_text(json.dumps(json_safe(doc), indent=1, allow_nan=False))
        typer.echo(f"wrote {json_out}")


def _check_objective(objective: str | None, planners: list[str]) -> None:
    """A one-line error, before any mission, for an objective unknown or one of `planners` cannot minimise."""
    from .plan_cmds import planner_objectives

    planner_objectives(objective, planners, {})


def _parse_stacks(stacks: list[str] | None) -> list[tuple[str, str]]:
    if not stacks:
        return [("min-turn", "paper-pf")]
    out = []
    planners, localisers = _planner_names(), _localiser_names()
    for s in stacks:
        for item in s.split(","):
            parts = item.strip().split("/")
            if len(parts) != 2 or not all(parts):
                raise typer.BadParameter(f"expected PLANNER/LOCALISER, got {item!r}", param_hint="--stack")
            out.append((_check_name(parts[0], "--planner", planners, allow_ompl=True),
                        _check_name(parts[1], "--localiser", localisers)))
    return out


@app.command("paper")
def paper(
    ctx: typer.Context,
    trials: int = typer.Option(20, "--trials", help="Missions per map and noise model.", callback=count),
    seed: Seed = 0,
    json_out: JsonOut = None,
    markdown: Path | None = typer.Option(None, "--markdown", callback=writable_file,
                                         metavar="FILE", help="Write the tables as Markdown."),
    plot: Path | None = typer.Option(None, "--plot", callback=writable_file, metavar="FILE.png",
                                     help="Draw final errors and path lengths beside the paper's means."),
    stack: list[str] | None = typer.Option(None, "--stack", metavar="PLANNER/LOCALISER",
                                           help="Stack(s) to run (repeatable; default min-turn/paper-pf)."),
    sonar: str | None = typer.Option(
        None, metavar="NAME[,NAME]",
        help="Sonar model(s) " + one_of("sonar") + " (default ideal; with --pareto ideal and nxt)."),
    sonar_profile_path: SonarProfile = None,
    noise_model: list[str] | None = typer.Option(
        None, "--noise-model", help=_PAPER_NOISE_HELP),
    maps: MapList = "map1,map2,map3",
    workers: Workers = 1,
    dask: Dask = None,
    random_start: bool = typer.Option(False, "--random-start",
                                      help="Start each trial from a seeded random free pose (>= 10 cm from walls)."),
    sets: RunSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
    option: OptionGone = None,
    pareto: Path | None = typer.Option(None, "--pareto", callback=writable_file, metavar="FILE.png",
                                       help="Run every mission setting instead and draw mean final error "
                                            "against median robot time (the Pareto front)."),
    settings: str | None = typer.Option(None, "--settings", metavar="NAME[,NAME]",
                                        help=_SETTINGS_HELP),
    collision: Collision = "index",
    objective: Objective = None,
) -> None:
    """The paper's Table I regenerated: completion time, final error, path length, collisions, robot time."""
    from ..bench.common import isolate_planners
    from ..bench.paper import crashed_trial, in_task_order, paper_tasks, run_trial, summarise

    sonars = _names(sonar or ("ideal,nxt" if pareto is not None else "ideal"), "--sonar", SONAR_MODELS.names())
    profile = sonar_profile(sonar_profile_path, sonars)
    models = _noise_models(noise_model, pareto is not None)
    map_names = parse_list(maps, "--maps")
    for name in map_names:
        load_map(name)
    check_writable(json_out, "--json")
    check_writable(markdown, "--markdown")
    stacks = _parse_stacks(stack)
    options = _paper_options(given_sets(ctx, sets), sonars)
    robots = _paper_robots(ctx, sets, sonars, models, profile)
    configured = configuration(ctx, sets, mission={so: mission_config(so, given_sets(ctx, sets), collision).to_dict()
                                                   for so in sonars}, robot=robots)
    _check_objective(objective, [p for p, _ in stacks])
    if objective is not None:
        options["planning.objective"] = objective
    if pareto is not None:
        if robot_sets(given_sets(ctx, sets)):
            raise NxtnavError("--pareto compares mission settings on the paper's robot; --set robot.* and sonar.* "
                              "are for the tables")
        _run_pareto(pareto, trials, seed, sonars, map_names, models, settings, workers, random_start, json_out,
                    profile, collision, dask)
        return
    tasks = [t for so in sonars
             for t in paper_tasks(trials, seed, maps=map_names, noise_models=models, stacks=stacks, sonar=so,
                                  random_start=random_start, options=options,
                                  robot_sets=robot_sets(given_sets(ctx, sets)),
                                  sonar_model=profile if so == "nxt" else None, collision=collision)]
    batch = run_batch(run_trial, tasks, "missions", workers=workers, dask=dask, transient=True,
                      crashed=crashed_trial, isolate=isolate_planners(t.planner for t in tasks))
    results = in_task_order(batch.results, tasks)  # as `run_paper` orders and summarises them
    _write_paper(summarise(results), results, batch, configured, json_out, markdown, plot)


def _write_paper(tables: list[Any], results: list[Any], batch: Batch[Any], configured: dict[str, Any],
                 json_out: Path | None, markdown: Path | None, plot: Path | None) -> None:
    """Print Table I (marked incomplete when only part of the `batch` finished) and the first failures,
    write it as JSON (each table with the run's configuration), Markdown and a plot where asked; after an
    interrupt, say where it is."""
    from ..bench.paper import tables_to_markdown

    text = batch.banner() + tables_to_markdown(tables)
    typer.echo(text)
    for t in tables:
        for r in t.rows:
            for f in r.failures[:5]:
                typer.echo(f"{t.noise_model} {r.map}: {f}", err=True)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(dumps([{**t.to_dict(), "complete": batch.complete, "missions_done": batch.done,
                                    "missions_planned": batch.planned, "configuration": configured}
                                   for t in tables]))
        typer.echo(f"wrote {json_out}")
    if markdown is not None:
        markdown.parent.mkdir(parents=True, exist_ok=True)
        markdown.write_text(text)
        typer.echo(f"wrote {markdown}")
    if plot is not None:
        from ..bench.paper_plots import draw_paper_table
        from ..plotting import save_figure

        save_figure(draw_paper_table(results), plot)
        typer.echo(f"wrote {plot}")
    saved = [str(p) for p in (json_out, markdown) if p is not None]
    batch.finish(f"partial results (marked incomplete) in {' and '.join(saved)}" if saved else
                 "the partial table is printed above (give --json/--markdown to keep it in a file)")
