"""`nxtnav plan` (one query, drawn with its metrics) and `nxtnav bench planners` (the planner benchmark)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import typer

from ..number_format import json_safe
from ..world import (
    ConfigError,
    NxtnavError,
    PlanningError,
    RobotGeometry,
    RobotModel,
    RobotTiming,
    check_objective,
    load_map,
    make_checker,
    objective_cost,
    path_cost,
)
from .app import Interrupted, app, bench_app, fail
from .choices import one_of
from .compiling import compile_note, warm_up_planner
from .options import (
    TIMING,
    Collision,
    ConfigFile,
    Dask,
    DriveSpeed,
    ExecRepeats,
    FigureOut,
    Force,
    JsonOut,
    MapList,
    MapName,
    MotionNoiseLevel,
    NoiseModel,
    Objective,
    OutFolder,
    PlannerList,
    PlannerName,
    PlanRadius,
    PluginSets,
    Queries,
    Seed,
    StopTurn,
    TimeLimit,
    TurnNoiseLevel,
    TurnRate,
    Workers,
    check_writable,
    count,
    parse_list,
    parse_xy,
    positive,
)
from .options import time_limit as time_limit_ok
from .progress import progress
from .run_config import add_configuration, configuration, dumps, given_sets, plugin_sets, robot_model
from .set_options import checked_sets, parse_sets

__all__: list[str] = []

_KERNELS = "the collision checks and planners"
"""What `compile_note` says compiles on the first run."""
ROBOT_RADIUS_CM = RobotGeometry().radius_cm
"""The default robot's radius (cm), the default of --radius."""
DEFAULT_PLANNERS = ("min-turn", "astar", "rrtstar", "prm", "ompl:RRTConnect", "ompl:InformedRRTstar", "ompl:BITstar")
"""`bench planners`' default set: the paper's planner, grid A*, and OMPL's optimising planners (RRT*, PRM,
Informed RRT*, BIT*) with RRTConnect as the fast feasible one (OMPL 2.0.1's Python wheel has no AIT*,
ABIT* or LazyPRM*, and its AORRTC crashes the process now and then)."""


REFERENCE_OF = {"length": "shortest", "turns": "min-link", "robot-time": "fastest"}
"""The reference planner whose path is the optimum of a query under each objective."""


def robot_timing(drive_speed: float, turn_rate: float, stop_turn: float) -> RobotTiming:
    """The robot's timing from ``--drive-speed``, ``--turn-rate`` and ``--stop-turn`` (one-line errors)."""
    try:
        return RobotTiming(drive_speed_cm_s=drive_speed, turn_rate_deg_s=turn_rate, stop_turn_s=stop_turn)
    except ConfigError as exc:
        names = {"drive_speed_cm_s": "--drive-speed", "turn_rate_deg_s": "--turn-rate", "stop_turn_s": "--stop-turn"}
        option = next((o for k, o in names.items() if k in str(exc)), "--drive-speed/--turn-rate/--stop-turn")
        raise NxtnavError(f"{option}: {exc}") from None


def planner_objectives(objective: str | None, planners: list[str],
                       options: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """`options` per planner with `objective` added (a planner's own ``--set NAME.objective`` wins); an
    unknown objective, or one a planner cannot minimise, is a one-line error before any planning."""
    from planners import PLANNERS

    out = {name: dict(options.get(name, {})) for name in planners}
    for name in planners:
        chosen = out[name].get("objective", objective)
        if chosen is None:
            continue
        check_objective(chosen, PLANNERS.class_of(name).objectives_for(name), f"planner {name!r}")
        out[name]["objective"] = chosen
    return out


def able_planners(names: list[str], objective: str | None) -> list[str]:
    """The planners of a default list that can minimise `objective`; those left out are named on stderr
    (a list the user gave is checked whole by `planner_objectives`: one it cannot minimise is an error)."""
    from planners import can_minimise

    if objective is None:
        return names
    able = [n for n in names if can_minimise(n, objective)]
    left = [n for n in names if n not in able]
    if left:
        typer.echo(f"--objective {objective}: left out of the default planners (they cannot minimise it): "
                   f"{', '.join(left)}", err=True)
    return able


def _noise(model: str, motion: float, turn: float) -> Any:
    from ..robots.sim import MotionNoise

    try:
        return MotionNoise(model, motion, turn)  # type: ignore[arg-type]
    except ValueError as exc:
        raise NxtnavError(f"--noise-model/--motion-noise/--turn-noise: {exc}") from None


def _plan_robot(ctx: typer.Context, sets: list[str], noise: Any, timing: RobotTiming) -> RobotModel:
    """The robot of `nxtnav plan`: its motion noise and timing flags, then ``--set robot.`` settings (a flag
    and a ``--set`` of the same field on the command line are an error)."""
    return robot_model(RobotModel(motion=noise, timing=timing), given_sets(ctx, sets), ctx, sets)


def _to_builtin(obj: Any) -> Any:
    """numpy scalars and arrays (planner `info` extras) as JSON values."""
    if isinstance(obj, np.ndarray | np.generic):
        return json_safe(obj.tolist())
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


@app.command("plan")
def plan(
    ctx: typer.Context,
    map_name: MapName = "map1",
    planner: PlannerName = "min-turn",
    start_text: str | None = typer.Option(None, "--start", metavar="X,Y", help="Start in cm (default: preset)."),
    goal_text: str | None = typer.Option(None, "--goal", metavar="X,Y", help="Goal in cm (default: preset)."),
    seed: Seed = 0,
    time_limit: TimeLimit = 1.0,
    radius: PlanRadius = ROBOT_RADIUS_CM,
    collision: Collision = "index",
    exec_repeats: ExecRepeats = 100,
    noise_model: NoiseModel = "botsim",
    motion_noise: MotionNoiseLevel = 0.1,
    turn_noise: TurnNoiseLevel = 0.005,
    *,
    output: FigureOut,
    json_out: JsonOut = None,
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
    objective: Objective = None,
    drive_speed: DriveSpeed = TIMING.drive_speed_cm_s,
    turn_rate: TurnRate = TIMING.turn_rate_deg_s,
    stop_turn: StopTurn = TIMING.stop_turn_s,
) -> None:
    """Plan one query and draw the path on the map (with the shortest path, dashed) and its metrics."""
    from planners import PlanningProblem, make_planner
    from planners.declarations import planner_kwargs, planner_options

    from ..bench.planners import check_planner_names, planner_for
    from ..plotting import draw_cspace, draw_map, new_axes, save_figure

    if not (math.isfinite(time_limit) and time_limit > 0):
        raise NxtnavError(f"--time-limit must be a positive number of seconds, got {time_limit:g}")
    robot = _plan_robot(ctx, sets, _noise(noise_model, motion_noise, turn_noise),
                        robot_timing(drive_speed, turn_rate, stop_turn))
    nz, timing = robot.motion, robot.timing
    check_planner_names([planner])
    plugins = parse_sets(plugin_sets(ctx, sets, ("robot", "sonar")))
    options = planner_objectives(objective, [planner], checked_sets(plugins, [planner], planner_options,
                                                                    "planner"))[planner]
    check_writable(output, "--output")
    check_writable(json_out, "--json")
    m = load_map(map_name)
    with compile_note(_KERNELS):
        checker = make_checker(m, radius, collision)

    start = _query_point(start_text, "--start", m.start, m, checker, radius)
    goal = _query_point(goal_text, "--goal", m.target, m, checker, radius)
    problem = PlanningProblem(m, checker, start, goal, time_limit, np.random.default_rng(seed), timing)
    built = planner_for(planner, m, options) or make_planner(planner, **planner_kwargs(planner, options))
    with compile_note(_KERNELS):  # before the timer: planning time never holds compilation
        warm_up_s = warm_up_planner(planner, options, checker, radius, collision, start, goal)
    result = built.plan(problem)
    refs = _reference_paths(m, checker, start, goal, timing)
    doc: dict[str, Any] = {"map": m.name, "planner": planner, "seed": seed, "time_limit_s": time_limit,
                           "robot_radius_cm": radius, "collision": checker.backend, "start": start.tolist(),
                           "goal": goal.tolist(), "warm_up_s": warm_up_s,
                           "configuration": configuration(ctx, sets, robot=robot.to_dict()),
                           **{k: v for k, v in result.to_dict().items() if k != "planner"}}
    fig, ax = new_axes(size=6.0)
    draw_map(m, ax, presets=False, title=False)
    draw_cspace(m, radius, ax)
    ax.plot(*start, "o", color="tab:green", ms=9, label="start", zorder=6)
    ax.plot(*goal, "*", color="tab:red", ms=14, label="goal", zorder=6)
    lines = [f"{planner} on {m.name}: {result.message} in {1e3 * result.time_s:.2f} ms"]
    reference = refs.get(REFERENCE_OF[result.objective])
    doc["reference_cost"] = objective_cost(result.objective, reference, timing) if reference is not None else None
    if result.success:
        cost = path_cost(result.path, timing, nz)
        doc.update(robot_time_s=cost.robot_time_s, predicted_error_cm=cost.predicted_error_cm)
        lines += _found_path(result, planner, refs, checker, goal, (exec_repeats, nz, seed), ax, doc)
        lines.insert(2, _cost_line(result, cost, doc["reference_cost"]))
    doc["references"] = {k: {"path": v.tolist(), "length_cm": float(np.sum(np.hypot(*np.diff(v, axis=0).T)))}
                         for k, v in refs.items()}
    ax.set_title("\n".join(lines), fontsize=9)
    ax.legend(loc="upper left", fontsize=8, bbox_to_anchor=(1.01, 1.0))
    save_figure(fig, output)
    typer.echo(f"wrote {output}")
    if json_out is not None:
        json_out.write_text(json.dumps(json_safe(doc), indent=1, default=_to_builtin), encoding="utf-8")
        typer.echo(f"wrote {json_out}")
    for line in lines:
        typer.echo(line)
    if not result.success:
        raise fail(f"{planner} found no path on {m.name}: {result.message}", code=1)



def _cost_line(result: Any, cost: Any, reference: float | None) -> str:
    """The path's cost to the robot and under its planner's objective, against the reference optimum."""
    from ..world import OBJECTIVE_UNITS

    unit = OBJECTIVE_UNITS[result.objective]
    ratio = f", x{result.objective_cost / reference:.3f} the optimum" if reference else ""
    return (f"objective {result.objective}: {result.objective_cost:.3g} {unit}{ratio}; robot time "
            f"{cost.robot_time_s:.2f} s, predicted open-loop error {cost.predicted_error_cm:.2f} cm")


def _query_point(text: str | None, option: str, preset: Any, m: Any, checker: Any, radius: float) -> np.ndarray:
    """The start or goal typed as `text` (None: the map's `preset`): a point where the robot fits, else a
    `PlanningError` (bad input, not a failed plan)."""
    if text is None:
        if preset is None:
            raise NxtnavError(f"{option}: map {m.name!r} has no preset; give {option} X,Y")
        p = np.asarray(preset, dtype=float)
        where = f"{option} (the map's preset)"
    else:
        p = np.array(parse_xy(text, option))
        where = option
    if not checker.point_free(p):
        raise PlanningError(f"{where} ({p[0]:g}, {p[1]:g}) puts the robot (radius {radius:g} cm) in a wall "
                            f"or outside map {m.name!r}")
    return p


def _found_path(result: Any, planner: str, refs: dict[str, np.ndarray], checker: Any, goal: np.ndarray,
                execution: tuple[int, Any, int], ax: Any, doc: dict[str, Any]) -> list[str]:
    """A found path's metrics against the references and its open-loop execution error (`execution`:
    drives, noise, seed): drawn on `ax` with the shortest path, added to `doc`, and the lines saying so."""
    from planners.metrics import count_turns, path_length, path_metrics

    from ..bench.execution import execution_error
    from ..plotting import draw_path

    sp, ml = refs.get("shortest"), refs.get("min-link")
    met = path_metrics(result.path, checker, reference_length=path_length(sp) if sp is not None else None,
                       reference_turns=count_turns(ml) if ml is not None else None)
    doc["metrics"] = met.to_dict()
    draw_path(result.path, ax, label=planner)
    if sp is not None and planner != "shortest":
        ax.plot(sp[:, 0], sp[:, 1], "--", color="0.25", lw=1.2, label="shortest", zorder=5)
    ratio = f" (x{met.length_ratio:.3f} shortest)" if math.isfinite(met.length_ratio) else ""
    lines = [f"length {met.length_cm:.1f} cm{ratio}, {met.turns} turns "
             f"({math.degrees(met.turn_angle_rad):.0f} deg), min clearance {met.min_clearance_cm:.1f} cm"]
    repeats, nz, seed = execution
    if repeats > 0 and len(result.path) >= 2:
        ex = execution_error(result.path, checker, goal=goal, repeats=repeats, noise=nz, rng=seed)
        doc["execution"] = ex.to_dict()
        lines.append(f"execution error {ex.mean_cm:.2f} cm mean, {ex.median_cm:.2f} cm median "
                     f"({ex.repeats} drives, {nz.model} noise), touched a wall in "
                     f"{100 * ex.collision_fraction:.0f}%")
    lines.append(f"{result.collision_checks} collision checks ({checker.backend})")
    return lines


def _reference_paths(m: Any, checker: Any, start: np.ndarray, goal: np.ndarray,
                     timing: RobotTiming | None = None) -> dict[str, np.ndarray]:
    """The paths of the reference planners that solve the query (shortest, min-link, fastest), by name."""
    from planners import PlanningProblem

    from ..bench.planners import REFERENCE_PLANNERS, REFERENCE_TIME_LIMIT_S, planner_for

    refs: dict[str, np.ndarray] = {}
    for name in REFERENCE_PLANNERS:
        ref_planner = planner_for(name, m)
        if ref_planner is None:
            continue
        try:
            ref = ref_planner.plan(PlanningProblem(m, checker, start, goal, REFERENCE_TIME_LIMIT_S,
                                                   np.random.default_rng(0), timing or RobotTiming()))
        except NxtnavError:
            continue
        if ref.success:
            refs[name] = ref.path
    return refs


def _parse_budgets(text: str) -> tuple[float, ...]:
    """``--budgets``: comma-separated positive numbers of seconds, none repeated."""
    from ..bench.planners import check_budgets

    values = []
    for part in parse_list(text, "--budgets"):
        try:
            values.append(float(part))
        except ValueError:
            raise NxtnavError(f"--budgets: {part!r} is not a number of seconds") from None
    try:
        return check_budgets(values)
    except PlanningError as exc:
        raise NxtnavError(f"--budgets: {exc}") from None


@bench_app.command("planners")
def bench_planners(
    ctx: typer.Context,
    out: OutFolder,
    maps: MapList = "map1,map2,map3",
    planners: PlannerList = ",".join(DEFAULT_PLANNERS),  # noqa: B008 - a constant text
    runs: int = typer.Option(50, "--runs", help="Runs per planner and map.", callback=count),
    time_limit: float | None = typer.Option(None, "--time-limit", metavar="SECONDS",
                                            help="Planning budget per run (s; default 1).", callback=time_limit_ok),
    budgets: str | None = typer.Option(None, "--budgets", metavar="S1,S2,...",
                                       help="Budget sweep: run the benchmark at each budget (s) instead of "
                                            "--time-limit; budgets.md, budgets.csv, budget_sweep.png."),
    simplify: str = typer.Option("ompl", "--simplify", help="Simplify each path before measuring it again "
                                 + one_of("simplify") + ": none, shortcut (greedy waypoint shortcuts) or ompl "
                                 "(OMPL's PathSimplifier)."),
    progress_interval: float = typer.Option(0.01, "--progress-interval", metavar="SECONDS", callback=positive,
                                            help="Budget (s) between two best-cost samples of the anytime "
                                                 "planners (also sampled at every improvement)."),
    seed: Seed = 0,
    force: Force = False,
    workers: Workers = 1,
    dask: Dask = None,
    queries: Queries = "presets",
    exec_repeats: ExecRepeats = 100,
    radius: PlanRadius = ROBOT_RADIUS_CM,
    collision: Collision = "index",
    noise_model: NoiseModel = "botsim",
    motion_noise: MotionNoiseLevel = 0.1,
    turn_noise: TurnNoiseLevel = 0.005,
    plots: bool = typer.Option(True, "--plots/--no-plots", help="Write the box plots."),
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
    objective: Objective = None,
    drive_speed: DriveSpeed = TIMING.drive_speed_cm_s,
    turn_rate: TurnRate = TIMING.turn_rate_deg_s,
    stop_turn: StopTurn = TIMING.stop_turn_s,
) -> None:
    """Benchmark planners on maps: runs.csv, progress.csv, paths.jsonl, summary.md, plots and an OMPL benchmark.log."""
    from ..bench.planners import (
        SIMPLIFY_METHODS,
        BenchmarkConfig,
        check_out_dir,
        check_planner_names,
        run_benchmark,
        write_results,
    )

    if simplify not in SIMPLIFY_METHODS:
        raise NxtnavError(f"--simplify must be one of {', '.join(SIMPLIFY_METHODS)}, got {simplify!r}")
    if budgets is not None and time_limit is not None:
        raise NxtnavError("--budgets replaces --time-limit: give one of them")
    budget_list = _parse_budgets(budgets) if budgets is not None else None
    map_list = parse_list(maps, "--maps")
    planner_list = parse_list(planners, "--planners")
    check_planner_names(planner_list)
    if getattr(ctx.get_parameter_source("planners"), "name", "") == "DEFAULT":  # typer's own click: by name
        planner_list = able_planners(planner_list, objective)
    from planners.declarations import planner_options

    timing = robot_timing(drive_speed, turn_rate, stop_turn)
    checked = checked_sets(parse_sets(given_sets(ctx, sets)), planner_list, planner_options, "planner")
    options = planner_objectives(objective, planner_list, checked)
    for name in map_list:
        load_map(name)  # a bad map name fails before any work
    config = BenchmarkConfig(maps=tuple(map_list), planners=tuple(planner_list), runs=runs,
                             time_limit=1.0 if time_limit is None else time_limit,
                             seed=seed, queries=queries,  # type: ignore[arg-type]
                             exec_repeats=exec_repeats, robot_radius=radius, collision=collision,
                             noise=_noise(noise_model, motion_noise, turn_noise),
                             simplify=simplify, progress_interval=progress_interval, planner_options=options,
                             objective=objective, timing=timing)
    out_dir = check_out_dir(out, force)
    if budget_list is not None:
        _sweep_budgets(config, budget_list, out_dir, workers, dask, plots)
        return
    with progress("references and runs", config.n_tasks()) as advance:
        result = run_benchmark(config, workers=workers, dask_address=dask, on_done=advance)
    if not result.records:
        raise Interrupted("no planner run had finished; nothing written")
    files = write_results(result, out_dir, plots=plots)
    add_configuration(out_dir / "config.json", configuration(ctx, sets))
    typer.echo((out_dir / "summary.md").read_text(encoding="utf-8"))
    typer.echo(f"wrote {len(files)} files to {out_dir} in {result.total_time_s:.1f} s")
    if not result.complete:
        raise Interrupted(f"{len(result.records)} planner runs done; partial results (marked incomplete) in {out_dir}")


def _sweep_budgets(config: Any, budgets: tuple[float, ...], out_dir: Path, workers: int, dask: str | None,
                   plots: bool) -> None:
    """``bench planners --budgets``: the benchmark at every budget, then the sweep's files."""
    from ..bench.planners import run_budget_sweep, write_budget_sweep

    with progress("budgets: references and runs", config.n_tasks() * len(budgets)) as advance:
        try:
            sweep = run_budget_sweep(config, budgets, workers=workers, dask_address=dask, on_done=advance)
        except KeyboardInterrupt:
            raise Interrupted("no budget had finished; nothing written") from None
    files = write_budget_sweep(sweep, out_dir, plots=plots)
    typer.echo(files["summary"].read_text(encoding="utf-8"))
    typer.echo(f"wrote {len(files)} files to {out_dir}")
    if not sweep.complete:
        raise Interrupted(f"{len(sweep.results)} of {len(budgets)} budgets done; partial results in {out_dir}")


OBJECTIVE_PLANNERS = ("rrtstar", "ompl:InformedRRTstar", "ompl:BITstar", "astar", "min-turn")
"""`bench objectives`' default set: OMPL's optimising planners, grid A* and the paper's planner."""


@bench_app.command("objectives")
def bench_objectives(
    ctx: typer.Context,
    out: OutFolder,
    maps: MapList = "map1,map2,map3",
    planners: PlannerList = ",".join(OBJECTIVE_PLANNERS),  # noqa: B008 - a constant text
    runs: int = typer.Option(20, "--runs", help="Runs per planner, objective and map.", callback=count),
    time_limit: TimeLimit = 1.0,
    seed: Seed = 0,
    force: Force = False,
    workers: Workers = 1,
    queries: Queries = "presets",
    exec_repeats: ExecRepeats = 100,
    radius: PlanRadius = ROBOT_RADIUS_CM,
    noise_model: NoiseModel = "botsim",
    motion_noise: MotionNoiseLevel = 0.1,
    turn_noise: TurnNoiseLevel = 0.005,
    drive_speed: DriveSpeed = TIMING.drive_speed_cm_s,
    turn_rate: TurnRate = TIMING.turn_rate_deg_s,
    stop_turn: StopTurn = TIMING.stop_turn_s,
    plots: bool = typer.Option(True, "--plots/--no-plots",
                               help="Write the Pareto figure of each map and the cost over time under robot-time."),
    sets: PluginSets = [],  # noqa: B006 - typer reads the default, never mutates it
    config_file: ConfigFile = None,
) -> None:
    """Every planner under every objective it can minimise: robot time, open-loop error, the targets checked."""
    from ..bench.planners import BenchmarkConfig, check_out_dir, check_planner_names
    from ..bench.planners.objectives import run_objectives, write_objectives

    timing = robot_timing(drive_speed, turn_rate, stop_turn)
    map_list = parse_list(maps, "--maps")
    planner_list = parse_list(planners, "--planners")
    check_planner_names(planner_list)
    from planners.declarations import planner_options

    options = checked_sets(parse_sets(given_sets(ctx, sets)), planner_list, planner_options, "planner")
    for name in map_list:
        load_map(name)
    config = BenchmarkConfig(maps=tuple(map_list), planners=tuple(planner_list), runs=runs, time_limit=time_limit,
                             seed=seed, queries=queries,  # type: ignore[arg-type]
                             exec_repeats=exec_repeats, robot_radius=radius, planner_options=options,
                             noise=_noise(noise_model, motion_noise, turn_noise), simplify="none", timing=timing)
    out_dir = check_out_dir(out, force)
    with progress("objectives: references and runs", 3 * config.n_tasks()) as advance:
        sweep = run_objectives(config, workers=workers, on_done=advance)
    files = write_objectives(sweep, out_dir, plots=plots)
    files["config"] = out_dir / "config.json"
    files["config"].write_text(dumps({"configuration": configuration(ctx, sets)}), encoding="utf-8")
    typer.echo(files["summary"].read_text(encoding="utf-8"))
    typer.echo(f"wrote {len(files)} files to {out_dir}")
