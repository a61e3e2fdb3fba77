"""The localiser benchmark: global localisation, tracking and the kidnapped robot, in the simulator.

Three scenarios, each a list of independent trials that `toolkit.bench.executors.run_tasks` runs in
this process, over a process pool or on a Dask cluster:

``global``
    A `SimRobot` is put at a random free pose (seeded; at least `BenchConfig.clearance_cm` from every
    wall, heading uniform) and `localisation.procedure.localise` runs the paper's procedure (scan,
    turn toward the minimum reading, rescan, iterate). The final estimate is compared with the
    simulator's true pose at the end of the procedure. Success = within `SUCCESS_CM` (2 cm) and
    `SUCCESS_DEG` (3 degrees). One row of `RUNS_COLUMNS` per trial.
``tracking``
    The localiser starts from a prior at the true pose (see `BenchConfig.tracker_prior`), then the
    robot follows a scripted drive (turn, move, chosen from the seed to stay collision-free); after
    every action the localiser predicts with the commanded turn and the odometry distance and
    updates with a full scan. Position and heading RMSE over the drive. One row of
    `TRACKING_COLUMNS` per trial.
``kidnapped``
    A global localisation as above; once it has converged the robot is teleported
    (`SimRobot.teleport`) to another random free pose at least `BenchConfig.kidnap_min_cm` away and
    the procedure runs again *without resetting the localiser* (``reset=False``), up to
    `BenchConfig.recovery_rounds` times. It has recovered when a run ends converged within the
    success tolerance of the truth; the iterations and scans it took are counted. One row of
    `KIDNAPPED_COLUMNS` per trial.

Pose trackers (`Localiser.needs_prior`, the EKF and UKF) cannot localise globally; in the global and
kidnapped scenarios they get a prior, either the true pose plus Gaussian noise (``noisy-truth``,
`BenchConfig.prior_sd_cm` / `prior_sd_deg`) or the first estimate of a ``paper-pf`` run on the same
robot (``pf``). The summary says which.

Randomness: trial ``t`` of map ``m`` uses the seed ``trial_seed(seed, m, t)`` for the true pose, the
robot's noise and the localiser, whatever the localiser, so every localiser sees the same poses.
"""

from __future__ import annotations

import csv
import inspect
import logging
import math
import time
import zlib
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from localisation.ambiguity import candidate_poses
from localisation.base import LOCALISERS, Localiser, Motion, PoseEstimate, Prior, make_localiser
from toolkit.mission import lobe_options as mission_lobe_options
from toolkit.robots.sim import MotionNoise, SimRobot
from toolkit.world import (
    LocalisationError,
    Map,
    NxtnavError,
    Pose,
    RobotGeometry,
    Scan,
    angle_diff,
    load_map,
    wrap_angle,
)

__all__ = [
    "KIDNAPPED_COLUMNS",
    "RUNS_COLUMNS",
    "SCENARIOS",
    "SUCCESS_CM",
    "SUCCESS_DEG",
    "TRACKER_PRIORS",
    "TRACKING_COLUMNS",
    "BenchConfig",
    "GlobalRun",
    "KidnappedRun",
    "LocalisationOutcome",
    "TrackingRun",
    "TrialTask",
    "call_localise",
    "is_success",
    "lobe_options",
    "localise_once",
    "localiser_options",
    "make_tasks",
    "particle_count",
    "random_pose",
    "read_csv",
    "run_trial",
    "summarise",
    "trial_seed",
    "write_csv",
    "write_summary",
]

log = logging.getLogger(__name__)

SUCCESS_CM = 2.0
"""Position tolerance of a successful localisation (cm)."""
SUCCESS_DEG = 3.0
"""Heading tolerance of a successful localisation (degrees)."""

SCENARIOS = ("global", "tracking", "kidnapped")
TRACKER_PRIORS = ("noisy-truth", "pf")

RUNS_COLUMNS = (
    "map", "localiser", "trial", "seed", "success", "error_cm", "heading_error_deg", "time_s",
    "iterations", "scans", "converged", "candidates",
)
TRACKING_COLUMNS = (
    "map", "localiser", "trial", "seed", "steps", "rmse_cm", "rmse_heading_deg", "final_error_cm",
    "max_error_cm", "time_s", "collisions", "median_particles", "max_particles", "update_ms",
)
KIDNAPPED_COLUMNS = (
    "map", "localiser", "trial", "seed", "localised", "kidnap_cm", "recovered", "recovery_iterations",
    "recovery_scans", "error_cm", "heading_error_deg", "time_s",
)


def is_success(error_cm: float, heading_error_deg: float) -> bool:
    """Whether an estimate error counts as a successful localisation (2 cm and 3 degrees, inclusive)."""
    return bool(error_cm <= SUCCESS_CM and abs(heading_error_deg) <= SUCCESS_DEG)


def pose_error(estimate: Pose, truth: Pose) -> tuple[float, float]:
    """Position error (cm) and signed heading error (degrees, estimate - truth, wrapped)."""
    return estimate.distance_to(truth), math.degrees(angle_diff(estimate.theta, truth.theta))


def trial_seed(seed: int, map_name: str, trial: int) -> int:
    """The seed of trial `trial` on map `map_name`: independent of the localiser and of the map order."""
    ss = np.random.SeedSequence([int(seed) & 0xFFFFFFFF, zlib.crc32(map_name.encode()), int(trial)])
    return int(ss.generate_state(1)[0])


def random_pose(m: Map, rng: np.random.Generator, clearance_cm: float) -> Pose:
    """A pose uniform over the free space at least `clearance_cm` from every wall, heading uniform."""
    xy = m.sample_free(1, clearance=clearance_cm, rng=rng)[0]
    return Pose(float(xy[0]), float(xy[1]), float(rng.uniform(-math.pi, math.pi)))


@dataclass(frozen=True)
class BenchConfig:
    """Settings shared by every trial of a benchmark run.

    Parameters
    ----------
    sonar : str
        Simulated sonar model (``ideal`` or ``nxt``).
    sensor_noise : float
        Sonar noise (cm); the paper's 1 cm.
    noise_model, motion_noise, turn_noise
        The robot's `MotionNoise` (the paper's BotSim values by default).
    tracker_prior : {"noisy-truth", "pf"}
        Prior of the pose trackers in the global and kidnapped scenarios.
    prior_sd_cm, prior_sd_deg : float
        Standard deviations of the noisy-truth prior (cm, degrees); also the prior of every localiser
        in the tracking scenario.
    clearance_cm : float
        Least distance from true poses to the walls (cm).
    tracking_steps : int
        Actions (turn + move) of the scripted drive.
    tracking_step_cm : tuple of float
        Range of the drive's move lengths (cm).
    kidnap_min_cm : float
        Least distance of the teleport (cm).
    recovery_rounds : int
        Runs of the localisation procedure, without resetting the localiser, allowed to recover
        from a kidnapping.
    scan_processing : {"paper", "raw"}
        Scans given to the localiser in the tracking and kidnapped loops: the paper's processing
        (windows around 0/90/180/270 degrees from the minimum reading) or every usable reading.
    lobe : {"auto", "off"}
        ``auto`` tells localisers that can model it the simulated sonar's lobe (see `lobe_options`);
        ``off`` leaves them with their defaults (a thin ray).
    localiser_options : mapping
        Per localiser name, keyword arguments for `make_localiser` (they override the lobe options).
    localise_options : mapping
        Extra keyword arguments for `localisation.procedure.localise` (those it does not accept are dropped).
    """

    sonar: str = "ideal"
    sensor_noise: float = 1.0
    noise_model: str = "botsim"
    motion_noise: float = 0.1
    turn_noise: float = 0.005
    tracker_prior: str = "noisy-truth"
    prior_sd_cm: float = 3.0
    prior_sd_deg: float = 5.0
    clearance_cm: float = 10.0
    tracking_steps: int = 12
    tracking_step_cm: tuple[float, float] = (6.0, 15.0)
    kidnap_min_cm: float = 30.0
    recovery_rounds: int = 3
    scan_processing: str = "paper"
    lobe: str = "auto"
    localiser_options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    localise_options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.tracker_prior not in TRACKER_PRIORS:
            raise NxtnavError(f"tracker prior must be one of {', '.join(TRACKER_PRIORS)}, got {self.tracker_prior!r}")
        for k in ("sensor_noise", "prior_sd_cm", "prior_sd_deg", "clearance_cm", "kidnap_min_cm"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v >= 0):
                raise NxtnavError(f"{k} must be a non-negative number, got {v!r}")
        if self.lobe not in ("auto", "off"):
            raise NxtnavError(f"lobe must be 'auto' or 'off', got {self.lobe!r}")
        if self.scan_processing not in ("paper", "raw"):
            raise NxtnavError(f"scan processing must be 'paper' or 'raw', got {self.scan_processing!r}")
        if self.tracking_steps < 1 or self.recovery_rounds < 1:
            raise NxtnavError("tracking_steps and recovery_rounds must be >= 1")
        lo, hi = self.tracking_step_cm
        if not 0 < lo <= hi:
            raise NxtnavError(f"tracking_step_cm must be 0 < low <= high, got {self.tracking_step_cm}")
        MotionNoise(self.noise_model, self.motion_noise, self.turn_noise)  # type: ignore[arg-type]

    @property
    def noise(self) -> MotionNoise:
        return MotionNoise(self.noise_model, self.motion_noise, self.turn_noise)  # type: ignore[arg-type]

    def to_dict(self) -> dict[str, Any]:
        return {
            "sonar": self.sonar, "sensor_noise": self.sensor_noise, "noise": self.noise.to_dict(),
            "tracker_prior": self.tracker_prior, "prior_sd_cm": self.prior_sd_cm,
            "prior_sd_deg": self.prior_sd_deg, "clearance_cm": self.clearance_cm,
            "tracking_steps": self.tracking_steps, "tracking_step_cm": list(self.tracking_step_cm),
            "kidnap_min_cm": self.kidnap_min_cm, "recovery_rounds": self.recovery_rounds,
            "scan_processing": self.scan_processing, "lobe": self.lobe,
            "localiser_options": {k: dict(v) for k, v in self.localiser_options.items()},
            "localise_options": dict(self.localise_options),
        }


@dataclass(frozen=True)
class TrialTask:
    """One trial: a scenario, a map, a localiser, a trial index and its seed."""

    scenario: str
    map: str
    localiser: str
    trial: int
    seed: int
    config: BenchConfig


# -- the localisation procedure ---------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class LocalisationOutcome:
    """One localisation in the simulator, measured against the truth.

    Attributes
    ----------
    estimate, truth : Pose
        The localiser's final mean pose and the simulator's true pose at that moment.
    error_cm, heading_error_deg : float
        Position error (cm) and signed heading error (degrees).
    iterations, scans : int
        Filter iterations and 360-degree scans the procedure used.
    converged : bool
        The localiser's own verdict.
    time_s : float
        Computation time of the localiser (s): its reset, predict and update calls as the procedure
        measures them (`LocalisationResult.compute_time_s`); the simulator's own time is excluded, and
        so is the tracker prior's PF run.
    wall_time_s : float
        Wall-clock time of the whole procedure (s), simulated scans and motions included.
    cpu_time_s : float
        CPU time of this thread over the whole procedure (s), simulator included: unlike the
        wall-clock times it does not grow when other processes compete for the cores.
    robot_time_s : float
        Modelled time a real NXT would have spent (s).
    prior : str
        How the localiser was initialised (``global``, ``noisy-truth`` or ``pf``).
    result : object
        What `localisation.procedure.localise` returned (its per-iteration trace for plots).
    """

    estimate: Pose
    truth: Pose
    error_cm: float
    heading_error_deg: float
    iterations: int
    scans: int
    converged: bool
    time_s: float
    wall_time_s: float
    cpu_time_s: float
    robot_time_s: float
    prior: str
    pose_estimate: PoseEstimate
    result: Any = None

    @property
    def success(self) -> bool:
        return is_success(self.error_cm, self.heading_error_deg)

    def to_dict(self) -> dict[str, Any]:
        return {
            "estimate": self.estimate.to_list_deg(),
            "truth": self.truth.to_list_deg(),
            "error_cm": self.error_cm,
            "heading_error_deg": self.heading_error_deg,
            "success": self.success,
            "iterations": self.iterations,
            "scans": self.scans,
            "converged": self.converged,
            "time_s": self.time_s,
            "wall_time_s": self.wall_time_s,
            "cpu_time_s": self.cpu_time_s,
            "robot_time_s": self.robot_time_s,
            "prior": self.prior,
            "cov": np.asarray(self.pose_estimate.cov).tolist(),
        }


def _procedure() -> Callable[..., Any]:
    try:
        from localisation.procedure import localise
    except ImportError as exc:  # pragma: no cover - the procedure ships with the package
        raise LocalisationError(f"the localisation procedure is not available: {exc}") from exc
    return localise


def call_localise(robot: SimRobot, localiser: Localiser, prior: Prior | None, rng: Any,
                  options: Mapping[str, Any] | None = None) -> Any:
    """`localisation.procedure.localise(robot, localiser, prior=..., rng=..., **options)`.

    Options the procedure does not accept are dropped (logged at debug level), so one benchmark
    configuration works with every version of the procedure.
    """
    localise = _procedure()
    kwargs: dict[str, Any] = {"prior": prior, "rng": rng, **dict(options or {})}
    params = inspect.signature(localise).parameters
    if not any(p.kind is p.VAR_KEYWORD for p in params.values()):
        dropped = [k for k in kwargs if k not in params]
        if dropped:
            log.debug("localise() does not take %s; dropped", ", ".join(dropped))
        kwargs = {k: v for k, v in kwargs.items() if k in params}
    return localise(robot, localiser, **kwargs)


def _count(value: Any, default: int) -> int:
    if value is None:
        return default
    if isinstance(value, int | np.integer):
        return int(value)
    try:
        return len(value)
    except TypeError:
        return default


def _noisy_truth(truth: Pose, cfg: BenchConfig, rng: np.random.Generator) -> Prior:
    sd = np.array([cfg.prior_sd_cm, cfg.prior_sd_cm, math.radians(cfg.prior_sd_deg)])
    mean = truth.as_array() + rng.standard_normal(3) * sd
    cov = np.diag(np.maximum(sd, 1e-3) ** 2)
    return Prior(Pose(mean[0], mean[1], wrap_angle(mean[2])), cov)


def _prior_from_estimate(est: PoseEstimate, cfg: BenchConfig) -> Prior:
    floor = np.diag([1.0, 1.0, math.radians(2.0) ** 2])
    cov = np.asarray(est.cov, dtype=float)
    cov = 0.5 * (cov + cov.T) if cov.shape == (3, 3) and np.all(np.isfinite(cov)) else np.zeros((3, 3))
    return Prior(est.pose, cov + floor)


def localise_once(
    m: Map,
    truth: Pose,
    localiser_name: str,
    *,
    config: BenchConfig | None = None,
    rng: Any = None,
    robot: SimRobot | None = None,
    localiser: Localiser | None = None,
) -> tuple[LocalisationOutcome, SimRobot, Localiser]:
    """Run the localisation procedure once in the simulator, from the true pose `truth`.

    Parameters
    ----------
    m : Map
        The map.
    truth : Pose
        The robot's true start pose (must be collision-free).
    localiser_name : str
        Registered localiser.
    config : BenchConfig
        Sonar, noise and tracker-prior settings.
    rng : None, int or Generator
        Seeds the robot, the localiser and the prior noise (independent child streams).
    robot, localiser : optional
        Reuse an existing robot / localiser (the kidnapped scenario); otherwise built here.

    Returns
    -------
    outcome, robot, localiser
    """
    cfg = config or BenchConfig()
    ss = np.random.SeedSequence(_entropy(rng))
    robot_ss, loc_ss, prior_ss, proc_ss = ss.spawn(4)
    if robot is None:
        robot = SimRobot(m, truth, noise=cfg.noise, sonar=cfg.sonar, sensor_noise=cfg.sensor_noise,
                         rng=np.random.default_rng(robot_ss))
    if localiser is None:
        localiser = make_localiser(localiser_name, m, rng=np.random.default_rng(loc_ss),
                                   **localiser_options(cfg, localiser_name))
    prior: Prior | None = None
    prior_kind = "global"
    if getattr(localiser, "needs_prior", False):
        prior_kind = cfg.tracker_prior
        if cfg.tracker_prior == "noisy-truth":
            prior = _noisy_truth(robot.true_pose, cfg, np.random.default_rng(prior_ss))
        else:
            pf = make_localiser("paper-pf", m, rng=np.random.default_rng(prior_ss),
                                **localiser_options(cfg, "paper-pf"))
            first = call_localise(robot, pf, None, np.random.default_rng(prior_ss.spawn(1)[0]),
                                  _procedure_options(cfg))
            prior = _prior_from_estimate(_estimate_of(first, pf), cfg)
    t0, c0 = time.perf_counter(), time.thread_time()
    result = call_localise(robot, localiser, prior, np.random.default_rng(proc_ss), _procedure_options(cfg))
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    compute = getattr(result, "compute_time_s", None)
    est = _estimate_of(result, localiser)
    final_truth = robot.true_pose
    err, herr = pose_error(est.pose, final_truth)
    outcome = LocalisationOutcome(
        estimate=est.pose,
        truth=final_truth,
        error_cm=err,
        heading_error_deg=herr,
        iterations=_count(getattr(result, "iterations", None), est.iterations),
        scans=_count(getattr(result, "scans", None), 0),
        converged=bool(getattr(result, "converged", est.converged)),
        time_s=float(compute) if isinstance(compute, int | float) else wall,
        wall_time_s=wall,
        cpu_time_s=cpu,
        robot_time_s=float(robot.robot_time_s),
        prior=prior_kind,
        pose_estimate=est,
        result=result,
    )
    return outcome, robot, localiser


def lobe_options(cfg: BenchConfig, name: str) -> dict[str, Any]:
    """The sonar's lobe as localiser options, for localisers that take them (``lobe="auto"``).

    A localiser whose constructor accepts ``beam_width_deg`` / ``critical_incidence_deg`` (the
    particle filters' range tables) gets the simulated sonar's values (for ``nxt``: its 20-degree
    lobe and 40-degree critical incidence; a thin ray for ``ideal``). Nothing for ``lobe="off"``.
    """
    if cfg.lobe == "off":
        return {}
    return mission_lobe_options(name, cfg.sonar, cfg.sensor_noise)


def localiser_options(cfg: BenchConfig, name: str) -> dict[str, Any]:
    """Constructor options of localiser `name`: the sonar's lobe (see `lobe_options`), then `--set` options."""
    return {**lobe_options(cfg, name), **dict(cfg.localiser_options.get(name, {}))}


def _procedure_options(cfg: BenchConfig) -> dict[str, Any]:
    return {"process": cfg.scan_processing == "paper", **dict(cfg.localise_options)}


def _entropy(rng: Any) -> Any:
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, 2**63 - 1))
    return rng


def _estimate_of(result: Any, localiser: Localiser) -> PoseEstimate:
    est = getattr(result, "estimate", None)
    return est if isinstance(est, PoseEstimate) else localiser.estimate()


# -- trial results ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class GlobalRun:
    """One global-localisation trial (a row of ``runs.csv``)."""

    map: str
    localiser: str
    trial: int
    seed: int
    success: bool
    error_cm: float
    heading_error_deg: float
    time_s: float
    iterations: int
    scans: int
    converged: bool
    cpu_time_s: float = field(default=math.nan, repr=False)
    failure: str = field(default="", repr=False)
    scenario: str = field(default="global", repr=False)
    candidates: int = 0
    """Candidate poses of an ambiguous final belief (0: not ambiguous)."""

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in RUNS_COLUMNS}


@dataclass(frozen=True)
class TrackingRun:
    """One tracking trial (a row of ``tracking.csv``); errors are against the true pose after every action."""

    map: str
    localiser: str
    trial: int
    seed: int
    steps: int
    rmse_cm: float
    rmse_heading_deg: float
    final_error_cm: float
    max_error_cm: float
    time_s: float
    collisions: int
    median_particles: float = math.nan
    max_particles: float = math.nan
    update_ms: float = math.nan
    errors_cm: tuple[float, ...] = field(default=(), repr=False)
    failure: str = field(default="", repr=False)
    scenario: str = field(default="tracking", repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in TRACKING_COLUMNS}


@dataclass(frozen=True)
class KidnappedRun:
    """One kidnapped-robot trial (a row of ``kidnapped.csv``).

    `recovery_iterations` and `recovery_scans` count the procedure's iterations and scans after the
    teleport until it ended converged within the success tolerance (-1 when it never recovered);
    `error_cm` and `heading_error_deg` are those of the last estimate; `time_s` is the wall-clock time
    of the whole trial.
    """

    map: str
    localiser: str
    trial: int
    seed: int
    localised: bool
    kidnap_cm: float
    recovered: bool
    recovery_iterations: int
    recovery_scans: int
    error_cm: float
    heading_error_deg: float
    time_s: float
    failure: str = field(default="", repr=False)
    scenario: str = field(default="kidnapped", repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in KIDNAPPED_COLUMNS}


TrialResult = GlobalRun | TrackingRun | KidnappedRun


# -- the scenarios ----------------------------------------------------------------------------------


def make_tasks(
    scenario: str,
    maps: Sequence[str],
    localisers: Sequence[str],
    trials: int,
    seed: int,
    config: BenchConfig,
) -> list[TrialTask]:
    """Every (map, trial, localiser) of a scenario, trial-major so that early results cover every localiser."""
    if scenario not in SCENARIOS:
        raise NxtnavError(f"unknown scenario {scenario!r}; known: {', '.join(SCENARIOS)}")
    if trials < 1:
        raise NxtnavError(f"trials must be >= 1, got {trials}")
    for name in localisers:
        LOCALISERS.get(name)
    return [
        TrialTask(scenario, m, name, t, trial_seed(seed, m, t), config)
        for t in range(trials)
        for m in maps
        for name in localisers
    ]


_MAPS: dict[str, Map] = {}


def _map(name: str) -> Map:
    if name not in _MAPS:
        _MAPS[name] = load_map(name)
    return _MAPS[name]


def run_trial(task: TrialTask) -> TrialResult:
    """Run one trial (a top-level function, so it pickles for process pools and Dask).

    A localiser that raises (a numerical failure, say) does not end the benchmark: the trial counts
    as a failure, with NaN errors and the exception in its `failure` field (the summary lists them).
    """
    runners: dict[str, Callable[[TrialTask], TrialResult]] = {
        "global": _run_global, "tracking": _run_tracking, "kidnapped": _run_kidnapped}
    if task.scenario not in runners:
        raise NxtnavError(f"unknown scenario {task.scenario!r}; known: {', '.join(SCENARIOS)}")
    try:
        return runners[task.scenario](task)
    except (KeyboardInterrupt, MemoryError):
        raise
    except Exception as exc:
        msg = f"{type(exc).__name__}: {' '.join(str(exc).split())}"[:300]
        log.warning("trial %s/%s/%s/%d raised %s", task.scenario, task.map, task.localiser, task.trial, msg)
        return _failed(task, msg)


def _failed(task: TrialTask, msg: str) -> TrialResult:
    nan = math.nan
    head = (task.map, task.localiser, task.trial, task.seed)
    if task.scenario == "global":
        return GlobalRun(*head, False, nan, nan, nan, 0, 0, False, nan, failure=msg)
    if task.scenario == "tracking":
        return TrackingRun(*head, 0, nan, nan, nan, nan, nan, 0, failure=msg)
    return KidnappedRun(*head, False, nan, False, -1, -1, nan, nan, nan, failure=msg)


def _trial_streams(task: TrialTask) -> tuple[np.random.Generator, np.random.Generator]:
    pose_ss, run_ss = np.random.SeedSequence(task.seed).spawn(2)
    return np.random.default_rng(pose_ss), np.random.default_rng(run_ss)


def _run_global(task: TrialTask) -> GlobalRun:
    m = _map(task.map)
    pose_rng, run_rng = _trial_streams(task)
    truth = random_pose(m, pose_rng, task.config.clearance_cm)
    out, _, loc = localise_once(m, truth, task.localiser, config=task.config, rng=run_rng)
    return GlobalRun(task.map, task.localiser, task.trial, task.seed, out.success, out.error_cm,
                     out.heading_error_deg, out.time_s, out.iterations, out.scans, out.converged, out.cpu_time_s,
                     candidates=len(candidate_poses(loc)))


def scripted_drive(m: Map, start: Pose, steps: int, step_cm: tuple[float, float], rng: np.random.Generator,
                   margin_cm: float = 3.0) -> list[Motion]:
    """A drive of `steps` (turn, move) actions from `start`, collision-free for the noise-free robot.

    Each action turns by a random angle (preferring headings with room ahead) and moves a random
    length in `step_cm`; the path keeps `margin_cm` beyond the robot radius from every wall. When no
    heading has room, the action is a turn in place.
    """
    from toolkit.world import CollisionChecker

    checker = CollisionChecker(m, RobotGeometry().radius_cm + margin_cm)
    x, y, th = start.x, start.y, start.theta
    out: list[Motion] = []
    for _ in range(steps):
        d = float(rng.uniform(*step_cm))
        chosen: Motion | None = None
        for turn in rng.uniform(-math.pi / 2, math.pi / 2, 12):
            h = th + turn
            end = (x + d * math.cos(h), y + d * math.sin(h))
            if checker.segment_free((x, y), end):
                chosen = Motion(float(turn), d)
                x, y, th = end[0], end[1], wrap_angle(h)
                break
        if chosen is None:
            chosen = Motion(float(rng.choice([-1.0, 1.0]) * rng.uniform(math.pi / 2, math.pi)), 0.0)
            th = wrap_angle(th + chosen.turn_rad)
        out.append(chosen)
    return out


def _run_tracking(task: TrialTask) -> TrackingRun:
    cfg = task.config
    m = _map(task.map)
    pose_rng, run_rng = _trial_streams(task)
    truth = random_pose(m, pose_rng, cfg.clearance_cm)
    drive = scripted_drive(m, truth, cfg.tracking_steps, cfg.tracking_step_cm, pose_rng)
    robot_ss, loc_ss, prior_ss = np.random.SeedSequence(_entropy(run_rng)).spawn(3)
    robot = SimRobot(m, truth, noise=cfg.noise, sonar=cfg.sonar, sensor_noise=cfg.sensor_noise,
                     rng=np.random.default_rng(robot_ss))
    loc = make_localiser(task.localiser, m, rng=np.random.default_rng(loc_ss),
                         **localiser_options(cfg, task.localiser))
    prep = _scan_preparer(loc, cfg.scan_processing)
    errs: list[float] = []
    herrs: list[float] = []
    counts: list[int] = []
    update_s: list[float] = []
    t0 = time.perf_counter()
    loc.reset(_noisy_truth(truth, cfg, np.random.default_rng(prior_ss)))
    for motion in drive:
        if motion.turn_rad:
            robot.turn(motion.turn_rad)
        dist = robot.move(motion.distance_cm).distance_cm if motion.distance_cm else 0.0
        loc.predict(Motion(motion.turn_rad, dist))
        scan = prep(robot.ultrascan())
        tu = time.perf_counter()
        loc.update(scan)
        update_s.append(time.perf_counter() - tu)
        counts.append(particle_count(loc))
        e, h = pose_error(loc.estimate().pose, robot.true_pose)
        errs.append(e)
        herrs.append(h)
    elapsed = time.perf_counter() - t0
    ea, ha = np.asarray(errs), np.asarray(herrs)
    ca = np.asarray(counts, dtype=float)
    return TrackingRun(task.map, task.localiser, task.trial, task.seed, len(drive),
                       float(np.sqrt(np.mean(ea**2))), float(np.sqrt(np.mean(ha**2))), float(ea[-1]),
                       float(ea.max()), elapsed, int(robot.collisions), float(np.median(ca)), float(ca.max()),
                       1e3 * float(np.median(update_s)), tuple(float(e) for e in ea))


def particle_count(loc: Localiser) -> int:
    """Particles a localiser holds after an update (its `particles` array; 1 for a Kalman filter's one
    Gaussian)."""
    p = getattr(loc, "particles", None)
    return int(np.asarray(p).shape[0]) if p is not None else 1


def _scan_preparer(loc: Localiser, processing: str) -> Callable[[Scan], Scan]:
    """The scans a localiser gets in the loops outside the procedure (tracking, kidnapped).

    ``paper``: the paper's windows around 0/90/180/270 degrees, aligned virtually on the scan's minimum
    reading (the scripted robot does not turn toward it); ``raw``: every usable reading.
    """
    from localisation.scan import process_scan, raw_scan

    if processing == "raw":
        return raw_scan
    return lambda s: process_scan(s, reference="min").scan


def _run_kidnapped(task: TrialTask) -> KidnappedRun:
    cfg = task.config
    m = _map(task.map)
    pose_rng, run_rng = _trial_streams(task)
    truth = random_pose(m, pose_rng, cfg.clearance_cm)
    t0 = time.perf_counter()
    out, robot, loc = localise_once(m, truth, task.localiser, config=cfg, rng=run_rng)
    localised = out.converged and out.success
    # teleport: a random free pose at least kidnap_min_cm away (the closest of 50 draws if none is)
    here = robot.true_pose
    cands = m.sample_free(50, clearance=cfg.clearance_cm, rng=pose_rng)
    dist = np.hypot(*(cands - here.xy).T)
    far = np.flatnonzero(dist >= cfg.kidnap_min_cm)
    i = int(far[0]) if far.size else int(np.argmax(dist))
    target = Pose(float(cands[i, 0]), float(cands[i, 1]), float(pose_rng.uniform(-math.pi, math.pi)))
    robot.teleport(target)
    recovered = False
    iterations = scans = 0
    err, herr = pose_error(loc.estimate().pose, robot.true_pose)
    opts = {**_procedure_options(cfg), "reset": False}
    for _ in range(cfg.recovery_rounds):
        res = call_localise(robot, loc, None, run_rng, opts)
        est = _estimate_of(res, loc)
        iterations += _count(getattr(res, "iterations", None), 1)
        scans += _count(getattr(res, "scans", None), 1)
        err, herr = pose_error(est.pose, robot.true_pose)
        if est.converged and is_success(err, herr):
            recovered = True
            break
    elapsed = time.perf_counter() - t0
    return KidnappedRun(task.map, task.localiser, task.trial, task.seed, localised, float(dist[i]), recovered,
                        iterations if recovered else -1, scans if recovered else -1, err, herr, elapsed)


# -- writers ----------------------------------------------------------------------------------------

COLUMNS = {"global": RUNS_COLUMNS, "tracking": TRACKING_COLUMNS, "kidnapped": KIDNAPPED_COLUMNS}
FILES = {"global": "runs.csv", "tracking": "tracking.csv", "kidnapped": "kidnapped.csv"}


def _fmt(v: Any) -> Any:
    if isinstance(v, bool | np.bool_):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    return v


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
            w.writerow([_fmt(d[c]) for c in cols])
    return p


def read_csv(path: str | Path) -> list[dict[str, Any]]:
    """Rows of a benchmark CSV with numbers and booleans parsed."""
    out: list[dict[str, Any]] = []
    with Path(path).open(newline="") as fh:
        for row in csv.DictReader(fh):
            parsed: dict[str, Any] = {}
            for k, v in row.items():
                if v in ("true", "false"):
                    parsed[k] = v == "true"
                elif k in ("map", "localiser"):
                    parsed[k] = v
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


def _median(values: Sequence[float]) -> float:
    """Median of the finite values (NaN marks a trial that raised); NaN when there are none."""
    a = np.asarray(values, dtype=float)
    a = a[np.isfinite(a)]
    return float(np.median(a)) if a.size else math.nan


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
                    "median_error_cm": _median([r.error_cm for r in rs]),
                    "median_heading_error_deg": _median([abs(r.heading_error_deg) for r in rs]),
                    "median_time_s": _median([r.time_s for r in rs]),
                    "median_cpu_time_s": _median([r.cpu_time_s for r in rs]),
                    "median_scans": _median([r.scans for r in rs]),
                }
            elif scen == "tracking":
                table[key] = {
                    "trials": n,
                    "rmse_cm": _rms([r.rmse_cm for r in rs]),
                    "rmse_heading_deg": _rms([r.rmse_heading_deg for r in rs]),
                    "median_final_error_cm": _median([r.final_error_cm for r in rs]),
                    "median_time_s": _median([r.time_s / max(r.steps, 1) for r in rs]),
                    "median_particles": _median([r.median_particles for r in rs]),
                    "max_particles": float(np.nanmax([r.max_particles for r in rs] + [math.nan]))
                    if any(math.isfinite(r.max_particles) for r in rs) else math.nan,
                    "median_update_ms": _median([r.update_ms for r in rs]),
                }
            else:
                loc = [r for r in rs if r.localised]
                rec = [r for r in loc if r.recovered]
                table[key] = {
                    "trials": n,
                    "localised": len(loc),
                    "recovery_rate": len(rec) / len(loc) if loc else math.nan,
                    "median_recovery_scans": _median([r.recovery_scans for r in rec]),
                }
            out[scen] = table
    return out


def _pct(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{100 * x:.1f} %"


def _num(x: float, unit: str = "", digits: int = 2) -> str:
    return "-" if not math.isfinite(x) else f"{x:.{digits}f}{unit}"


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
    trackers = [n for n in localisers if getattr(LOCALISERS.get(n), "needs_prior", False)]
    lines = ["# Localiser benchmark", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    noise = config.noise
    lines += [
        f"- maps: {', '.join(maps)}; localisers: {', '.join(localisers)}; {trials} trials per map and "
        f"localiser; seed {seed}",
        f"- simulator: sonar `{config.sonar}` ({config.sensor_noise:g} cm noise), motion noise "
        f"`{noise.model}` (motion {noise.motion:g}, turn {noise.turn:g})",
        f"- true poses: uniform over the free space at least {config.clearance_cm:g} cm from the walls, "
        "heading uniform; the same poses for every localiser",
        f"- success: final estimate within {SUCCESS_CM:g} cm and {SUCCESS_DEG:g} degrees of the simulator's "
        "true pose at the end of the procedure; time = the localiser's computation time (its reset, predict "
        "and update calls) over the whole procedure, the simulator excluded (wall clock: it grows when other "
        "processes compete for the cores); CPU time = the worker's CPU time over the whole procedure, "
        "simulator included (not inflated by competing processes)",
        "- scans given to the localisers: "
        + ("the paper's processing (align to the minimum reading, rescan, keep +-15 degrees around "
           "0/90/180/270)" if config.scan_processing == "paper" else "raw (every usable reading)"),
    ]
    lobed = [n for n in localisers if lobe_options(config, n)]
    if lobed:
        ex = lobe_options(config, lobed[0])
        lines.append(f"- sonar lobe given to the localisers that model it ({', '.join(lobed)}): "
                     + ", ".join(f"`{k}={v:g}`" for k, v in ex.items()) + " (`--lobe auto`); the others use a thin ray")
    elif config.lobe == "off" and config.sonar != "ideal":
        lines.append("- localisers keep their default thin-ray range model (`--lobe off`)")
    if trackers:
        if config.tracker_prior == "noisy-truth":
            how = (f"the true pose plus Gaussian noise ({config.prior_sd_cm:g} cm, {config.prior_sd_deg:g} "
                   "degrees): they track, they do not localise globally")
        else:
            how = "the first estimate of a `paper-pf` run on the same robot (its time not counted)"
        lines.append(f"- pose trackers ({', '.join(trackers)}) cannot localise globally; their prior is {how} "
                     f"(`--tracker-prior {config.tracker_prior}`)")
    if wall_time_s is not None:
        lines.append(f"- benchmark wall time: {wall_time_s:.1f} s")
    lines.append("")
    if "global" in s:
        lines += ["## Global localisation", ""]
        for m in maps:
            lines += [f"### {m}", "", "| localiser | trials | success | converged | ambiguous | median error (cm) | "
                      "median heading error (deg) | median time (ms) | median CPU time (ms) | median scans |",
                      "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
            for n in localisers:
                row = s["global"].get((m, n))
                if row is None:
                    continue
                lines.append(f"| {n} | {row['trials']:.0f} | {_pct(row['success_rate'])} | "
                             f"{_pct(row['converged_rate'])} | {_pct(row['ambiguous_rate'])} | "
                             f"{_num(row['median_error_cm'])} | "
                             f"{_num(row['median_heading_error_deg'])} | {_num(1e3 * row['median_time_s'], '', 1)} | "
                             f"{_num(1e3 * row['median_cpu_time_s'], '', 1)} | {_num(row['median_scans'], '', 0)} |")
            lines.append("")
    if "tracking" in s:
        lines += ["## Tracking", "",
                  f"A scripted drive of {config.tracking_steps} actions (turn, then a move of "
                  f"{config.tracking_step_cm[0]:g}-{config.tracking_step_cm[1]:g} cm); every localiser starts "
                  f"from the true pose plus noise ({config.prior_sd_cm:g} cm, {config.prior_sd_deg:g} degrees) "
                  "and predicts + updates with a full scan after every action. RMSE over all actions and trials; "
                  "particles = the particles held after each update (median over the trials of each trial's "
                  "median, and the largest count seen); update = median time of one `update` call.", ""]
        for m in maps:
            lines += [f"### {m}", "", "| localiser | trials | RMSE (cm) | heading RMSE (deg) | "
                      "median final error (cm) | median time per action (ms) | particles median / max | "
                      "update (ms) |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
            for n in localisers:
                row = s["tracking"].get((m, n))
                if row is None:
                    continue
                lines.append(f"| {n} | {row['trials']:.0f} | {_num(row['rmse_cm'])} | "
                             f"{_num(row['rmse_heading_deg'])} | {_num(row['median_final_error_cm'])} | "
                             f"{_num(1e3 * row['median_time_s'], '', 1)} | "
                             f"{_num(row['median_particles'], '', 0)} / {_num(row['max_particles'], '', 0)} | "
                             f"{_num(row['median_update_ms'], '', 1)} |")
            lines.append("")
    if "kidnapped" in s:
        lines += ["## Kidnapped robot", "",
                  f"After the global localisation the robot is teleported at least {config.kidnap_min_cm:g} cm "
                  f"away; the localisation procedure then runs again without resetting the localiser, at most "
                  f"{config.recovery_rounds} times. Recovered = a run ends converged within the success "
                  "tolerance. The rate counts the trials whose first localisation succeeded; scans to "
                  "recover count from the teleport.", ""]
        for m in maps:
            lines += [f"### {m}", "", "| localiser | trials | localised first | recovered | "
                      "median scans to recover |", "|---|---:|---:|---:|---:|"]
            for n in localisers:
                row = s["kidnapped"].get((m, n))
                if row is None:
                    continue
                lines.append(f"| {n} | {row['trials']:.0f} | {row['localised']:.0f} | "
                             f"{_pct(row['recovery_rate'])} | {_num(row['median_recovery_scans'], '', 0)} |")
            lines.append("")
    failed = [r for r in results if r.failure]
    if failed:
        lines += ["## Trials that raised", "",
                  f"{len(failed)} trial(s) raised an exception and count as failures (NaN errors in the CSV):", ""]
        for r in failed[:20]:
            lines.append(f"- {r.scenario} {r.map} {r.localiser} trial {r.trial} (seed {r.seed}): `{r.failure}`")
        if len(failed) > 20:
            lines.append(f"- ... and {len(failed) - 20} more")
        lines.append("")
    p = Path(path)
    p.write_text("\n".join(lines))
    return p
