"""The paper's Table I regenerated: whole missions on the three BotSim maps over seeded trials.

For each noise model (``botsim`` proportional and ``absolute``, the two readings of the paper's
"motion error 0.1 cm"), each stack (planner/localiser pair) and each map, `run_paper` runs `trials`
missions from the map's preset start with a seeded random heading to the preset target and reports
the mean completion time (wall-clock), mean true final error, mean driven path length, the total of
true collisions, the success rate and the mean robot time, beside the paper's numbers. A trial
succeeds when the mission reports success and the robot is truly within the mission's success radius
(3 cm by default) of the target.

With ``random_start`` each trial starts instead from a seeded random free pose at least 10 cm from
every wall (``nxtnav paper --random-start``); those tables say so (``starts``: ``random``).

Trial ``i`` of map ``k`` has the mission seed ``toolkit.seeds.derive_seed(seed, k, i)``: the same on every
noise model and stack (common random numbers), and `nxtnav run --map MAP --seed SEED` replays one
trial exactly.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from toolkit.world import ConfigError, NxtSonar, RobotModel
from toolkit.world.robot_model import with_robot_sets

from ..mission import MissionConfig, RobotTimeSplit, run_sim_mission
from ..robots.sim import simulated_sonar
from ..seeds import derive_seed
from .common import isolate_planners
from .executors import collect_tasks

__all__ = [
    "PAPER_MAPS",
    "PAPER_TABLE",
    "PaperResult",
    "PaperRow",
    "PaperTable",
    "PaperTrial",
    "in_task_order",
    "paper_tasks",
    "run_paper",
    "run_trial",
    "summarise",
    "tables_to_markdown",
]

PAPER_MAPS = ("map1", "map2", "map3")

PAPER_TABLE: dict[str, dict[str, float]] = {
    "map1": {"completion_s": 15.22, "final_error_cm": 1.79, "path_length_cm": 116.9, "collisions": 0},
    "map2": {"completion_s": 16.69, "final_error_cm": 1.83, "path_length_cm": 120.1, "collisions": 0},
    "map3": {"completion_s": 23.48, "final_error_cm": 2.11, "path_length_cm": 276.2, "collisions": 0},
}
"""Table I of Liu et al. (completion time on a Core i7 in MATLAB, distance from target, path length,
detected collisions)."""




@dataclass(frozen=True)
class PaperTrial:
    """One mission of the table (a picklable task)."""

    map: str
    trial: int
    seed: int
    noise_model: str
    planner: str = "min-turn"
    localiser: str = "paper-pf"
    sonar: str = "ideal"
    sensor_noise: float = 1.0
    motion_noise: float = 0.1
    turn_noise: float = 0.005
    random_start: bool = False
    options: tuple[tuple[str, Any], ...] = ()
    sonar_params: tuple[tuple[str, Any], ...] = ()
    """The ``nxt`` sonar's parameters (a fitted profile's; empty: the model's defaults)."""
    collision: str = "index"
    """Backend of the mission's and the simulator's collision checks (`MissionConfig.collision`)."""
    robot_sets: tuple[tuple[str, str], ...] = ()
    """``--set robot.GROUP.FIELD`` and ``sonar.FIELD`` settings (`toolkit.world.with_robot_sets`)."""

    @property
    def stack(self) -> str:
        return f"{self.planner}/{self.localiser}"

    @property
    def sonar_model(self) -> NxtSonar | None:
        """The ``nxt`` sonar's model given by `sonar_params` (None: the model's defaults)."""
        return NxtSonar(**dict(self.sonar_params)) if self.sonar_params else None

    def sonar_dict(self) -> dict[str, Any]:
        """The simulated sonar's name and parameters (``to_dict`` of the model the simulator reads with)."""
        robot = self.robot()
        if robot is not None:
            return robot.sonar.to_dict()
        return simulated_sonar(self.sonar if self.sonar_model is None else self.sonar_model,
                               self.sensor_noise).to_dict()

    def robot(self) -> RobotModel | None:
        """The robot simulated when `robot_sets` change it (None: the one the noise fields describe)."""
        if not self.robot_sets:
            return None
        sonar = simulated_sonar(self.sonar if self.sonar_model is None else self.sonar_model, self.sensor_noise)
        base = RobotModel.build(sonar, noise_model=self.noise_model, motion_noise=self.motion_noise,
                                turn_noise=self.turn_noise)
        return with_robot_sets(base, dict(self.robot_sets))

    def config(self) -> MissionConfig:
        """The mission configuration: the sonar's defaults with this trial's `options` and backend applied."""
        return MissionConfig.for_sonar(self.sonar, **{**dict(self.options), "collision": self.collision})


@dataclass(frozen=True)
class PaperResult:
    """What one trial gave (the mission report's numbers, with its task)."""

    task: PaperTrial
    success: bool
    status: str
    completion_s: float
    final_error_cm: float
    path_length_cm: float
    collisions: int
    robot_time_s: float
    watchdog_stops: int
    relocalisations: int
    replans: int
    time_split: RobotTimeSplit | None = None
    cpu_s: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in self.__dict__.items() if k not in ("task", "time_split")}
        d["robot_time_split"] = None if self.time_split is None else self.time_split.to_dict()
        d.update({k: v for k, v in self.task.__dict__.items() if k not in ("options", "sonar_params", "robot_sets")})
        if self.task.robot_sets:
            d["robot_sets"] = dict(self.task.robot_sets)
        d["options"] = dict(self.task.options)
        d["sonar_model"] = self.task.sonar_dict()
        return d


def crashed_trial(task: PaperTrial, reason: str) -> PaperResult:
    """The result of a trial that crashed (`reason`: the exception, or how its worker process died, as
    ``killed by signal 11 (SIGSEGV)``): a failed trial, its measures unknown."""
    return PaperResult(task, False, f"crashed: {reason}", math.nan, math.nan, math.nan, 0, math.nan, 0, 0, 0)


def run_trial(task: PaperTrial, config: MissionConfig | None = None) -> PaperResult:
    """Run one trial's mission on the simulator (top-level, so it pickles for process pools);
    `config` None is the task's own (`PaperTrial.config`)."""
    config = config or task.config()
    try:
        r = run_sim_mission(
            task.map, seed=task.seed, planner=task.planner, localiser=task.localiser,
            noise_model=task.noise_model, sensor_noise=task.sensor_noise, motion_noise=task.motion_noise,
            turn_noise=task.turn_noise, sonar=task.sonar, sonar_model=task.sonar_model, config=config,
            random_start_pose=task.random_start, robot=task.robot(),
        )
    except Exception as exc:  # a crash in one trial is a failed trial, not a lost table
        return crashed_trial(task, f"{type(exc).__name__}: {exc}")
    # success in the table is judged by the truth: the mission says it arrived AND the robot is truly
    # within the mission's success radius of the target
    cfg = config
    truly = r.success and r.final_error_cm is not None and r.final_error_cm <= cfg.final.success_radius_cm
    status = r.status if truly or not r.success else f"{r.status}, but truly {r.final_error_cm:.1f} cm away"
    return PaperResult(
        task, truly, status, r.times.completion_s,
        math.nan if r.final_error_cm is None else r.final_error_cm,
        r.path_length_cm, int(r.collisions or 0), r.times.robot_time_s, r.counts.watchdog_stops,
        r.counts.relocalisations, r.counts.replans, r.times.split, r.times.cpu_s,
    )


def paper_tasks(
    trials: int,
    seed: int = 0,
    *,
    maps: Sequence[str] = PAPER_MAPS,
    noise_models: Sequence[str] = ("botsim", "absolute"),
    stacks: Sequence[tuple[str, str]] = (("min-turn", "paper-pf"),),
    sonar: str = "ideal",
    sensor_noise: float = 1.0,
    motion_noise: float = 0.1,
    turn_noise: float = 0.005,
    random_start: bool = False,
    options: Mapping[str, Any] | None = None,
    sonar_model: NxtSonar | None = None,
    collision: str = "index",
    robot_sets: Mapping[str, str] | None = None,
) -> list[PaperTrial]:
    """Every trial of the table, in a fixed order (`random_start`: a seeded random free start pose
    at least 10 cm from the walls instead of the preset start; `options`: `MissionConfig` fields
    replacing the sonar's defaults; `sonar_model`: the ``nxt`` sonar's model, a fitted profile's;
    `collision`: the collision backend; `robot_sets`: ``robot.`` and ``sonar.`` settings of every trial)."""
    if trials < 1:
        raise ConfigError(f"trials must be >= 1, got {trials}")
    if sonar_model is not None and sonar != "nxt":
        raise ConfigError(f"a sonar model (profile) is for the nxt sonar, not {sonar!r}")
    opts = tuple(sorted((options or {}).items()))
    if "collision" in dict(opts):
        raise ConfigError("the collision backend is set for the trials (--collision), not as a mission option")
    MissionConfig.for_sonar(sonar, **dict(opts), collision=collision)  # a bad option fails here, not in every trial
    params = () if sonar_model is None else tuple(asdict(sonar_model).items())
    robot = tuple((robot_sets or {}).items())
    return [
        PaperTrial(m, i, derive_seed(seed, k, i), nm, p, lo, sonar, sensor_noise, motion_noise, turn_noise,
                   random_start, opts, params, collision, robot)
        for nm in noise_models
        for p, lo in stacks
        for k, m in enumerate(maps)
        for i in range(trials)
    ]


@dataclass(frozen=True)
class PaperRow:
    """One map's line of the table (means over the trials; collisions summed)."""

    map: str
    trials: int
    success_rate: float
    completion_s: float
    final_error_cm: float
    path_length_cm: float
    collisions: int
    robot_time_s: float
    final_error_max_cm: float
    completion_max_s: float
    completion_median_s: float = math.nan
    failures: list[str] = field(default_factory=list)
    robot_time_median_s: float = math.nan
    time_split: RobotTimeSplit | None = None
    cpu_median_s: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        return {
            "map": self.map,
            "trials": self.trials,
            "success_rate": self.success_rate,
            "completion_s": self.completion_s,
            "final_error_cm": self.final_error_cm,
            "path_length_cm": self.path_length_cm,
            "collisions": self.collisions,
            "robot_time_s": self.robot_time_s,
            "robot_time_median_s": self.robot_time_median_s,
            "robot_time_split": None if self.time_split is None else self.time_split.to_dict(),
            "final_error_max_cm": self.final_error_max_cm,
            "completion_max_s": self.completion_max_s,
            "completion_median_s": self.completion_median_s,
            "cpu_median_s": self.cpu_median_s,
            "failures": list(self.failures),
            "paper": dict(PAPER_TABLE.get(self.map, {})),
        }


@dataclass(frozen=True)
class PaperTable:
    """The table for one noise model and one stack."""

    noise_model: str
    planner: str
    localiser: str
    sonar: str
    rows: list[PaperRow]
    starts: str = "preset"
    options: tuple[tuple[str, Any], ...] = ()
    sonar_model: dict[str, Any] = field(default_factory=dict)
    """The simulated sonar's name and parameters (`PaperTrial.sonar_dict`)."""
    collision: str = "index"

    def to_dict(self) -> dict[str, Any]:
        return {
            "noise_model": self.noise_model,
            "collision": self.collision,
            "planner": self.planner,
            "localiser": self.localiser,
            "sonar": self.sonar,
            "sonar_model": dict(self.sonar_model),
            "starts": self.starts,
            "options": dict(self.options),
            "rows": [r.to_dict() for r in self.rows],
        }


def _stat(func: Callable[[NDArray[np.float64]], Any], values: Iterable[float]) -> float:
    """`func` (np.mean, np.median, np.max) of the values that are not NaN; NaN when none is."""
    v = np.array([x for x in values if not math.isnan(x)], dtype=float)
    return float(func(v)) if v.size else math.nan


def _mean_split(results: Sequence[PaperResult]) -> RobotTimeSplit | None:
    """The mean time split over the trials that have one (None when none has)."""
    splits = [r.time_split for r in results if r.time_split is not None]
    if not splits:
        return None
    def mean(k: str) -> float:
        return float(np.mean([getattr(s, k) for s in splits]))

    return RobotTimeSplit(mean("sweep_s"), mean("turret_return_s"), mean("drive_s"), mean("turn_s"),
                          round(mean("readings")), mean("other_s"))


def summarise(results: Iterable[PaperResult]) -> list[PaperTable]:
    """Group trial results into tables (noise model x stack x options), one row per map in the paper's order."""
    Key = tuple[str, str, str, str, bool, tuple[tuple[str, Any], ...], tuple[tuple[str, Any], ...], float, str]
    groups: dict[Key, dict[str, list[PaperResult]]] = {}
    for r in results:
        t = r.task
        key = (t.noise_model, t.planner, t.localiser, t.sonar, t.random_start, t.options, t.sonar_params,
               t.sensor_noise, t.collision)
        groups.setdefault(key, {}).setdefault(t.map, []).append(r)
    tables = []
    for (nm, p, lo, so, rs_, opts, _, _, coll), by_map in groups.items():
        order = sorted(by_map, key=lambda m: (PAPER_MAPS.index(m) if m in PAPER_MAPS else len(PAPER_MAPS), m))
        rows = []
        for m in order:
            rs = sorted(by_map[m], key=lambda r: r.task.trial)
            rows.append(PaperRow(
                map=m,
                trials=len(rs),
                success_rate=sum(r.success for r in rs) / len(rs),
                completion_s=_stat(np.mean, [r.completion_s for r in rs]),
                final_error_cm=_stat(np.mean, [r.final_error_cm for r in rs]),
                path_length_cm=_stat(np.mean, [r.path_length_cm for r in rs]),
                collisions=int(sum(r.collisions for r in rs)),
                robot_time_s=_stat(np.mean, [r.robot_time_s for r in rs]),
                final_error_max_cm=_stat(np.max, [r.final_error_cm for r in rs]),
                completion_max_s=_stat(np.max, [r.completion_s for r in rs]),
                completion_median_s=_stat(np.median, [r.completion_s for r in rs]),
                failures=[f"trial {r.task.trial} (seed {r.task.seed}): {r.status}" for r in rs if not r.success],
                robot_time_median_s=_stat(np.median, [r.robot_time_s for r in rs]),
                time_split=_mean_split(rs),
                cpu_median_s=_stat(np.median, [r.cpu_s for r in rs]),
            ))
        first = next(iter(by_map.values()))[0].task
        tables.append(PaperTable(nm, p, lo, so, rows, "random" if rs_ else "preset", opts, first.sonar_dict(), coll))
    model_order = {"botsim": 0, "absolute": 1}
    tables.sort(key=lambda t: (model_order.get(t.noise_model, 2), t.noise_model))
    return tables


def in_task_order(results: Iterable[PaperResult], tasks: Sequence[PaperTrial]) -> list[PaperResult]:
    """`results` (as they finished, on any backend) in the order of their `tasks`, so that the tables,
    their order and the plots depend on the seed alone."""
    index = {repr(t): i for i, t in enumerate(tasks)}
    return sorted(results, key=lambda r: index[repr(r.task)])


def run_paper(
    tasks: Sequence[PaperTrial],
    *,
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[PaperResult], None] | None = None,
) -> tuple[list[PaperTable], list[PaperResult]]:
    """Run the trials (over a process pool when `workers` > 1, or on the Dask cluster at
    `dask_address`: see `toolkit.bench.executors.run_tasks`) and summarise them; the results come
    back in the order of `tasks`.

    Ctrl-C raises `toolkit.bench.executors.TasksInterrupted` carrying the finished trials
    (order them with `in_task_order` and summarise them with `summarise`)."""
    results = collect_tasks(run_trial, list(tasks), workers=workers, dask_address=dask_address, on_done=on_done,
                            crashed=crashed_trial, isolate=isolate_planners(t.planner for t in tasks))
    results = in_task_order(results, tasks)
    return summarise(results), results


def _num(v: float, digits: int = 2) -> str:
    return "-" if math.isnan(v) else f"{v:.{digits}f}"


def _split_cells(split: RobotTimeSplit | None) -> str:
    if split is None:
        return "- | -"
    return (f"{split.sweep_s:.1f} / {split.turret_return_s:.1f} / {split.drive_s:.1f} / {split.turn_s:.1f} "
            f"| {split.readings}")


def tables_to_markdown(tables: Sequence[PaperTable]) -> str:
    """The tables as Markdown, ours beside the paper's (paper values in parentheses)."""
    out: list[str] = []
    for t in tables:
        starts = ", random starts" if t.starts == "random" else ""
        opts = "".join(f", `{k}={v}`" for k, v in t.options)
        out.append(f"### Noise model `{t.noise_model}`, stack `{t.planner}/{t.localiser}`, sonar `{t.sonar}`"
                   f"{starts}{opts}, collision checks `{t.collision}`\n")
        out.append("| Map | Trials | Success | Completion (s) | Median completion (s) | Median CPU (s) "
                   "| Distance from target (cm) | Path length (cm) | Collisions | Robot time (s) "
                   "| Median robot time (s) | Sweeping / turret back / driving / turning (s) | Readings |")
        out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in t.rows:
            p = PAPER_TABLE.get(r.map, {})

            def paper(key: str, digits: int = 2, p: dict[str, float] = p) -> str:
                return f" ({p[key]:.{digits}f})" if key in p else ""

            out.append(
                f"| {r.map} | {r.trials} | {100 * r.success_rate:.0f} % "
                f"| {_num(r.completion_s, 3)}{paper('completion_s')} | {_num(r.completion_median_s, 3)} "
                f"| {_num(r.cpu_median_s, 3)} "
                f"| {_num(r.final_error_cm)}{paper('final_error_cm')} "
                f"| {_num(r.path_length_cm, 1)}{paper('path_length_cm', 1)} "
                f"| {r.collisions}{paper('collisions', 0)} | {_num(r.robot_time_s, 1)} "
                f"| {_num(r.robot_time_median_s, 1)} | {_split_cells(r.time_split)} |"
            )
        out.append("")
    out.append("Means over the trials (collisions: total); the paper's Table I in parentheses (completion time "
               "on a Core i7 in MATLAB; ours is the wall-clock time of the whole mission in Python, robot time "
               "is the modelled time a real NXT would take, split into its mean parts, with the mean number "
               "of sonar readings). The mean completion includes each worker process's one-off "
               "precomputation of the map's range table (0.5 s on map1 to 3 s on map3, in that map's first "
               "trial); the median shows a mission without it. CPU is the process time of one mission "
               "(every thread), the cost of the computation on a machine shared with other work.")
    return "\n".join(out) + "\n"
