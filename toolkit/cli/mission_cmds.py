"""`nxtnav run` (one mission, simulated or on a real NXT) and `nxtnav paper` (the paper's Table I)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import typer

from ..formats import json_safe
from ..world import SONAR_MODELS, NxtnavError, NxtSonar, Pose, RobotGeometry, load_map, make_checker
from .app import EXIT_BAD_INPUT, EXIT_FAILED, Interrupted, app, fail
from .choices import one_of
from .options import (
    COLLISION_HELP,
    NOISE_MODEL_HELP,
    SONAR_PROFILE_HELP,
    check_writable,
    count,
    non_negative,
    parse_floats,
    parse_heading_prior,
    parse_list,
    parse_pose,
    parse_xy,
    port,
    positive,
    sonar_profile,
    writable_file,
)
from .options import collision as collision_ok
from .options import seed as seed_ok
from .options import workers as workers_ok
from .progress import progress
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
    map_name: str = typer.Option("map1", "--map", metavar="NAME|PATH", help="Map name (map1) or YAML file."),
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
    planner: str = typer.Option("min-turn", help="Planner " + one_of("planner") + "."),
    localiser: str = typer.Option("paper-pf", help="Localiser " + one_of("localiser") + "."),
    robot_kind: str = typer.Option("sim", "--robot", help="sim or nxt."),
    sonar: str = typer.Option("ideal", help="Sonar model of the simulator " + one_of("sonar") + "."),
    sonar_profile_path: Path | None = typer.Option(
        None, "--sonar-profile", metavar="FILE",
        help=SONAR_PROFILE_HELP + " With --robot nxt: the real sensor's model, for the localiser."),
    noise_model: str = typer.Option("botsim", "--noise-model", help=NOISE_MODEL_HELP),
    noise_text: str = typer.Option("1,0.1,0.005", "--noise", metavar="SENSOR,MOTION,TURN",
                                   help="Noise of the ideal sonar (cm; the nxt sonar's comes from its model), "
                                        "motion noise, turn noise (the paper's by default)."),
    seed: int = typer.Option(0, help="Random seed (start heading, simulator noise, stack).", callback=seed_ok),
    radius: float | None = typer.Option(None, "--radius", min=0.1,
                                        help="Simulated robot's radius (cm; default 8): a robot scaled to the map."),
    collision: str = typer.Option("index", "--collision", metavar="index|fcl", help=COLLISION_HELP,
                                  callback=collision_ok),
    json_out: Path | None = typer.Option(None, "--json", callback=writable_file,
                                         metavar="FILE", help="Write the report as JSON."),
    plot: Path | None = typer.Option(None, "--plot", callback=writable_file,
                                     metavar="FILE.png", help="Draw the mission."),
    animate: Path | None = typer.Option(None, "--animate", callback=writable_file,
                                        metavar="FILE.gif", help="Animate the mission (GIF)."),
    nxt_backend: str = typer.Option("usb", "--nxt-backend", help="NXT link " + one_of("nxt backend") + "."),
    server_host: str = typer.Option("localhost", "--server-host", help="nxt-server / virtual brick host (socket)."),
    server_port: int = typer.Option(2727, "--server-port", help="nxt-server / virtual brick port (socket).",
                                     callback=port),
    profile: Path | None = typer.Option(None, "--profile", metavar="FILE", help="NXT calibration profile."),
    reconnect_timeout: float = typer.Option(
        30.0, "--reconnect-timeout", metavar="S", callback=non_negative,
        help="NXT: after a lost link, try this many seconds to reach the brick again before the mission ends."),
    reply_timeout: float = typer.Option(
        3.0, "--reply-timeout", metavar="S", callback=positive,
        help="NXT (socket, Bluetooth): a reply that takes longer than this counts as a lost link."),
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
    objective: str | None = typer.Option(None, "--objective", metavar="length|turns|robot-time",
                                         help="What the planner minimises (default: its own)."),
) -> None:
    """Run one mission: localise, plan, drive with the watchdog, re-localise, correct at the target."""
    from ..robots.sim import simulated_sonar

    m = load_map(map_name)
    planner = _check_name(planner, "--planner", _planner_names(), allow_ompl=True)
    localiser = _check_name(localiser, "--localiser", _localiser_names())
    _check_kinds(robot_kind, sonar, noise_model, nxt_backend)
    sensor_noise, motion_noise, turn_noise = _noise(noise_text)
    start_heading = parse_heading_prior(start_heading_text, "--start-heading")
    fitted_sonar = sonar_profile(sonar_profile_path, "nxt" if robot_kind == "nxt" else sonar)
    outputs = RunOutputs(record, record_particles, view, view_save, json_out, plot, animate)
    outputs.check()
    if start_text is not None and random_start:
        raise typer.BadParameter("give either --start or --random-start", param_hint="--start")
    target = np.array(parse_xy(target_text, "--target")) if target_text is not None else m.target
    if target is None:
        raise typer.BadParameter(f"map {m.name} has no preset target; give --target X,Y", param_hint="--target")
    # the sonar model: the simulator's readings come from it; a real NXT's localiser is told it
    named = "nxt" if robot_kind == "nxt" else sonar
    sonar_model = simulated_sonar(named if fitted_sonar is None else fitted_sonar, sensor_noise)
    _check_objective(objective, [planner])
    stack = Stack(planner, localiser, seed, collision, start_heading, objective)
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
        robot_radius = radius if radius is not None else RobotGeometry().radius_cm  # the simulator's robot
        simulator = {"sonar": sonar, "noise_model": noise_model, "sensor_noise": sensor_noise,
                     "motion_noise": motion_noise, "turn_noise": turn_noise}
        report = mission_on_sim(m, target, _sim_start(start_text, m), random_start, stack, simulator,
                                fitted_sonar, sonar_model, radius, robot_radius, outputs)
        doc["simulator"] = simulator
    typer.echo(report.summary())
    note = None if robot_kind != "nxt" else \
        f"robot time by the simulator's time model for the same commands: {doc['model_robot_time_s']:.1f} s"
    outputs.write(report, m, doc, note)
    if not report.success:  # a target no robot disc fits on is bad input (2); any other failure is 1
        reachable = bool(m.contains(target)) and bool(make_checker(m, robot_radius, collision).point_free(target))
        raise fail(f"mission failed: {report.status}", code=EXIT_FAILED if reachable else EXIT_BAD_INPUT)


def _sim_start(text: str | None, m: Any) -> Any:
    """The simulator's start from ``--start`` (a pose, or a position with a seeded heading), or None."""
    if text is None:
        return None
    start = parse_pose(text, "--start", heading_required=False)
    xy = start.xy if isinstance(start, Pose) else np.array(start)
    if not m.contains(xy):
        raise typer.BadParameter(f"start ({xy[0]:g}, {xy[1]:g}) is outside the free area of {m.name}",
                                 param_hint="--start")
    return start


def _names(text: str, option: str, known: list[str]) -> list[str]:
    out = [s.strip() for s in text.split(",") if s.strip()]
    for name in out:
        if name not in known:
            raise typer.BadParameter(f"unknown value {name!r}; known: {', '.join(known)}", param_hint=option)
    if not out:
        raise typer.BadParameter("give at least one name", param_hint=option)
    return out


def _parse_options(items: list[str] | None) -> dict[str, Any]:
    """``KEY=VALUE`` pairs as mission options (`MissionConfig.with_options`: KEY is ``group.field`` or a
    field name only one group has; values as YAML scalars: 2, 2.5, true, null, spread)."""
    from ..mission import MissionConfig
    from ..world.yaml_text import YAMLError, load_yaml

    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise typer.BadParameter(f"expected KEY=VALUE with a mission option as KEY, got {item!r}",
                                     param_hint="--option")
        try:
            out[key] = load_yaml(value)
        except YAMLError:
            raise typer.BadParameter(f"cannot read the value of {item!r}", param_hint="--option") from None
    try:
        MissionConfig().with_options(**out)
    except (TypeError, ValueError) as exc:
        raise typer.BadParameter(str(exc), param_hint="--option") from None
    return out


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
    trials: int = typer.Option(20, "--trials", help="Missions per map and noise model.", callback=count),
    seed: int = typer.Option(0, help="Seed of the table (each trial's seed derives from it).", callback=seed_ok),
    json_out: Path | None = typer.Option(None, "--json", callback=writable_file,
                                         metavar="FILE", help="Write the tables as JSON."),
    markdown: Path | None = typer.Option(None, "--markdown", callback=writable_file,
                                         metavar="FILE", help="Write the tables as Markdown."),
    plot: Path | None = typer.Option(None, "--plot", callback=writable_file, metavar="FILE.png",
                                     help="Draw final errors and path lengths beside the paper's means."),
    stack: list[str] | None = typer.Option(None, "--stack", metavar="PLANNER/LOCALISER",
                                           help="Stack(s) to run (repeatable; default min-turn/paper-pf)."),
    sonar: str | None = typer.Option(
        None, metavar="NAME[,NAME]",
        help="Sonar model(s) " + one_of("sonar") + " (default ideal; with --pareto ideal and nxt)."),
    sonar_profile_path: Path | None = typer.Option(None, "--sonar-profile", metavar="FILE",
                                                   help=SONAR_PROFILE_HELP + " For the nxt tables."),
    noise_model: list[str] | None = typer.Option(
        None, "--noise-model", help=_PAPER_NOISE_HELP),
    maps: str = typer.Option("map1,map2,map3", "--maps", help="Comma-separated maps (default the paper's three)."),
    workers: int = typer.Option(1, "--workers", help="Worker processes.", callback=workers_ok),
    dask: str | None = typer.Option(None, "--dask", metavar="ADDRESS",
                                    help="Dask scheduler address (tcp://host:8786), or local: run the missions "
                                         "there (docs/cluster.md)."),
    random_start: bool = typer.Option(False, "--random-start",
                                      help="Start each trial from a seeded random free pose (>= 10 cm from walls)."),
    option: list[str] | None = typer.Option(None, "--option", metavar="KEY=VALUE",
                                            help="A MissionConfig option for every mission (repeatable), "
                                                 "group.field or a field name, e.g. sweeps.track_scan_step_deg=2."),
    pareto: Path | None = typer.Option(None, "--pareto", callback=writable_file, metavar="FILE.png",
                                       help="Run every mission setting instead and draw mean final error "
                                            "against median robot time (the Pareto front)."),
    settings: str | None = typer.Option(None, "--settings", metavar="NAME[,NAME]",
                                        help=_SETTINGS_HELP),
    collision: str = typer.Option("index", "--collision", metavar="index|fcl", help=COLLISION_HELP,
                                  callback=collision_ok),
    objective: str | None = typer.Option(None, "--objective", metavar="length|turns|robot-time",
                                         help="What every stack's planner minimises (default: its own); the "
                                              "table's robot time is then each planner's under it."),
) -> None:
    """The paper's Table I regenerated: completion time, final error, path length, collisions, robot time."""
    from ..bench.executors import TasksInterrupted
    from ..bench.paper import in_task_order, paper_tasks, run_paper, summarise

    sonars = _names(sonar or ("ideal,nxt" if pareto is not None else "ideal"), "--sonar", SONAR_MODELS.names())
    profile = sonar_profile(sonar_profile_path, sonars)
    models = _noise_models(noise_model, pareto is not None)
    map_names = parse_list(maps, "--maps")
    for name in map_names:
        load_map(name)
    check_writable(json_out, "--json")
    check_writable(markdown, "--markdown")
    stacks = _parse_stacks(stack)
    options = _parse_options(option)
    _check_objective(objective, [p for p, _ in stacks])
    if objective is not None:
        options["planning.objective"] = objective
    if pareto is not None:
        _run_pareto(pareto, trials, seed, sonars, map_names, models, settings, workers, random_start, json_out,
                    profile, collision, dask)
        return
    tasks = [t for so in sonars
             for t in paper_tasks(trials, seed, maps=map_names, noise_models=models, stacks=stacks, sonar=so,
                                  random_start=random_start, options=options,
                                  sonar_model=profile if so == "nxt" else None, collision=collision)]
    with progress("missions", len(tasks), transient=True) as advance:
        done = len(tasks)
        try:
            tables, results = run_paper(tasks, workers=workers, dask_address=dask, on_done=advance)
        except TasksInterrupted as exc:  # keep the finished missions; every output says it is incomplete
            results = in_task_order(exc.results, tasks)
            done, tables = len(results), summarise(results)
    complete = done == len(tasks)
    if not complete and not tables:
        raise Interrupted(f"no mission had finished (of {len(tasks)}); nothing written")
    _write_paper(tables, results, done, len(tasks), json_out, markdown, plot)


def _write_paper(tables: list[Any], results: list[Any], done: int, planned: int, json_out: Path | None,
                 markdown: Path | None, plot: Path | None) -> None:
    """Print Table I (marked incomplete when only `done` of the `planned` missions finished) and the first
    failures, write it as JSON, Markdown and a plot where asked; after an interrupt, say where it is."""
    from ..bench.paper import tables_to_markdown

    complete = done == planned
    text = tables_to_markdown(tables)
    if not complete:
        text = (f"**INCOMPLETE**: interrupted after {done} of {planned} missions; the rows below cover only "
                f"the finished missions.\n\n{text}")
    typer.echo(text)
    for t in tables:
        for r in t.rows:
            for f in r.failures[:5]:
                typer.echo(f"{t.noise_model} {r.map}: {f}", err=True)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        doc = json_safe([{**t.to_dict(), "complete": complete, "missions_done": done,
                        "missions_planned": planned} for t in tables])
        json_out.write_text(json.dumps(doc, indent=1, allow_nan=False))
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
    if not complete:
        saved = [str(p) for p in (json_out, markdown) if p is not None]
        where = f"partial results (marked incomplete) in {' and '.join(saved)}" if saved else \
            "the partial table is printed above (give --json/--markdown to keep it in a file)"
        raise Interrupted(f"{done} of {planned} missions done; {where}")
