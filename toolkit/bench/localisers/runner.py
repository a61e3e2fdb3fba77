"""Running the localiser benchmark: trial seeds, one localisation, the three scenarios."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from localisation.ambiguity import candidate_poses
from localisation.base import LOCALISERS, Localiser, Motion, PoseEstimate, Prior, make_localiser
from localisation.global_localisation import GlobalLocalisation
from localisation.models import MotionModel
from localisation.procedure import LocalisationResult, LocaliseProcedure, look
from toolkit.robots.sim import SimRobot
from toolkit.seeds import derive_seed
from toolkit.world import (
    Map,
    NxtnavError,
    Pose,
    RobotGeometry,
    Scan,
    wrap_angle,
)

from ..common import cached_map
from .records import (
    SCENARIOS,
    BenchConfig,
    GlobalRun,
    KidnappedRun,
    LocalisationOutcome,
    TrackingRun,
    TrialKey,
    TrialResult,
    TrialTask,
    is_success,
    pose_error,
)

log = logging.getLogger(__name__)


def call_localise(robot: SimRobot, localiser: Localiser, prior: Prior | None, rng: Any,
                  options: Mapping[str, Any] | None = None, *, strategy: GlobalLocalisation | None = None,
                  reset: bool = True, procedure: LocaliseProcedure = look) -> LocalisationResult:
    """Localise by the global strategy missions run (`strategy`, default `GlobalLocalisation()`), each
    look ``procedure(robot, localiser, prior=..., rng=..., reset=..., **options)``."""
    return (strategy or GlobalLocalisation()).run(robot, localiser, prior=prior, rng=rng, reset=reset,
                                                  procedure=procedure, look_options=options)


def _noisy_truth(truth: Pose, cfg: BenchConfig, rng: np.random.Generator) -> Prior:
    sd_cm, sd_deg = cfg.prior_sd
    sd = np.array([sd_cm, sd_cm, math.radians(sd_deg)])
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
        robot = SimRobot(m, truth, geometry=cfg.geometry, noise=cfg.noise, sonar=cfg.simulated_sonar,
                         rng=np.random.default_rng(robot_ss))
    if localiser is None:
        localiser = make_localiser(localiser_name, m, rng=np.random.default_rng(loc_ss),
                                   **localiser_options(cfg, localiser_name))
    prior: Prior | None = None
    prior_kind = "global"
    if localiser.needs_prior:
        prior_kind = cfg.tracker_prior
        if cfg.tracker_prior == "noisy-truth":
            prior = _noisy_truth(robot.true_pose, cfg, np.random.default_rng(prior_ss))
        else:
            pf = make_localiser("paper-pf", m, rng=np.random.default_rng(prior_ss),
                                **localiser_options(cfg, "paper-pf"))
            first = call_localise(robot, pf, None, np.random.default_rng(prior_ss.spawn(1)[0]),
                                  cfg.localise_options, strategy=cfg.strategy)
            prior = _prior_from_estimate(first.estimate, cfg)
    t0, c0 = time.perf_counter(), time.thread_time()
    result = call_localise(robot, localiser, prior, np.random.default_rng(proc_ss), cfg.localise_options,
                           strategy=cfg.strategy)
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    est = result.estimate
    final_truth = robot.true_pose
    err, herr = pose_error(est.pose, final_truth)
    outcome = LocalisationOutcome(
        estimate=est.pose,
        truth=final_truth,
        error_cm=err,
        heading_error_deg=herr,
        iterations=result.iterations,
        scans=result.scans,
        converged=result.converged,
        time_s=result.compute_time_s,
        wall_time_s=wall,
        cpu_time_s=cpu,
        robot_time_s=float(robot.robot_time_s),
        prior=prior_kind,
        pose_estimate=est,
        result=result,
    )
    return outcome, robot, localiser


def localiser_options(cfg: BenchConfig, name: str) -> dict[str, Any]:
    """Constructor options of localiser `name`: the run's robot model (`BenchConfig.robot_options`), then
    `--set` options."""
    return {**cfg.robot_options(name), **dict(cfg.localiser_options.get(name, {}))}


def _entropy(rng: Any) -> Any:
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(0, 2**63 - 1))
    return rng


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
        TrialTask(scenario, m, name, t, derive_seed(seed, m, t), config)
        for t in range(trials)
        for m in maps
        for name in localisers
    ]


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
    head = _key(task)
    if task.scenario == "global":
        return GlobalRun(head, False, nan, nan, nan, 0, 0, False, nan, failure=msg)
    if task.scenario == "tracking":
        return TrackingRun(head, 0, nan, nan, nan, nan, nan, 0, failure=msg)
    return KidnappedRun(head, False, nan, False, -1, -1, nan, nan, nan, failure=msg)


def _key(task: TrialTask) -> TrialKey:
    return TrialKey(task.map, task.localiser, task.trial, task.seed)


def _trial_streams(task: TrialTask) -> tuple[np.random.Generator, np.random.Generator]:
    pose_ss, run_ss = np.random.SeedSequence(task.seed).spawn(2)
    return np.random.default_rng(pose_ss), np.random.default_rng(run_ss)


def _run_global(task: TrialTask) -> GlobalRun:
    m = cached_map(task.map)
    pose_rng, run_rng = _trial_streams(task)
    truth = m.random_pose(pose_rng, task.config.pose_clearance_cm)
    out, _, loc = localise_once(m, truth, task.localiser, config=task.config, rng=run_rng)
    return GlobalRun(_key(task), out.success, out.error_cm,
                     out.heading_error_deg, out.time_s, out.iterations, out.scans, out.converged, out.cpu_time_s,
                     candidates=len(candidate_poses(loc)))


def scripted_drive(m: Map, start: Pose, steps: int, step_cm: tuple[float, float], rng: np.random.Generator,
                   margin_cm: float = 3.0, radius_cm: float | None = None) -> list[Motion]:
    """A drive of `steps` (turn, move) actions from `start`, collision-free for the noise-free robot.

    Each action turns by a random angle (preferring headings with room ahead) and moves a random
    length in `step_cm`; the path keeps `margin_cm` beyond the robot radius (`radius_cm`, default
    `RobotGeometry`'s) from every wall. When no heading has room, the action is a turn in place.
    """
    from toolkit.world import CollisionChecker

    checker = CollisionChecker(m, (RobotGeometry().radius_cm if radius_cm is None else radius_cm) + margin_cm)
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
    m = cached_map(task.map)
    pose_rng, run_rng = _trial_streams(task)
    truth = m.random_pose(pose_rng, cfg.pose_clearance_cm)
    drive = scripted_drive(m, truth, cfg.tracking_steps, cfg.tracking_step_cm, pose_rng,
                           radius_cm=cfg.geometry.radius_cm)
    robot_ss, loc_ss, prior_ss = np.random.SeedSequence(_entropy(run_rng)).spawn(3)
    robot = SimRobot(m, truth, geometry=cfg.geometry, noise=cfg.noise, sonar=cfg.simulated_sonar,
                     rng=np.random.default_rng(robot_ss))
    loc = make_localiser(task.localiser, m, rng=np.random.default_rng(loc_ss),
                         **localiser_options(cfg, task.localiser))
    prep = _scan_preparer(loc, cfg.scan_processing)
    errs: list[float] = []
    herrs: list[float] = []
    counts: list[int] = []
    update_s: list[float] = []
    blind: list[bool] = []
    t0 = time.perf_counter()
    prior = _noisy_truth(truth, cfg, np.random.default_rng(prior_ss))
    loc.reset(prior)
    reckoned = prior.mean
    dr_errs: list[float] = []
    for motion in drive:
        if motion.turn_rad:
            robot.turn(motion.turn_rad)
        dist = robot.move(motion.distance_cm).distance_cm if motion.distance_cm else 0.0
        loc.predict(Motion(motion.turn_rad, dist))
        reckoned = Pose.from_array(MotionModel().mean(reckoned.as_array(), Motion(motion.turn_rad, dist)))
        dr_errs.append(reckoned.distance_to(robot.true_pose))
        scan = prep(robot.ultrascan())
        blind.append(not bool(np.any(scan.valid)))
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
    echo = ~np.asarray(blind)
    return TrackingRun(_key(task), len(drive),
                       float(np.sqrt(np.mean(ea**2))), float(np.sqrt(np.mean(ha**2))), float(ea[-1]),
                       float(ea.max()), elapsed, int(robot.collisions), float(np.median(ca)), float(ca.max()),
                       1e3 * float(np.median(update_s)), tuple(float(e) for e in ea), int((~echo).sum()),
                       float(np.sqrt(np.mean(ea[echo] ** 2))) if echo.any() else math.nan,
                       float(np.sqrt(np.mean(ea[~echo] ** 2))) if (~echo).any() else math.nan,
                       float(np.sqrt(np.mean(np.asarray(dr_errs) ** 2))))


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
    m = cached_map(task.map)
    pose_rng, run_rng = _trial_streams(task)
    truth = m.random_pose(pose_rng, cfg.pose_clearance_cm)
    t0 = time.perf_counter()
    out, robot, loc = localise_once(m, truth, task.localiser, config=cfg, rng=run_rng)
    localised = out.converged and out.success
    # teleport: a random free pose at least kidnap_min_cm away (the closest of 50 draws if none is)
    here = robot.true_pose
    cands = m.sample_free(50, clearance=cfg.pose_clearance_cm, rng=pose_rng)
    dist = np.hypot(*(cands - here.xy).T)
    far = np.flatnonzero(dist >= cfg.kidnap_min_cm)
    i = int(far[0]) if far.size else int(np.argmax(dist))
    target = Pose(float(cands[i, 0]), float(cands[i, 1]), float(pose_rng.uniform(-math.pi, math.pi)))
    robot.teleport(target)
    recovered = False
    iterations = scans = 0
    err, herr = pose_error(loc.estimate().pose, robot.true_pose)
    # the localiser's own recovery: no reset, neither a confirmation nor a new attempt (each starts afresh)
    recover = replace(cfg.strategy, attempts=1, confirm=False)
    for _ in range(cfg.recovery_rounds):
        res = call_localise(robot, loc, None, run_rng, cfg.localise_options, strategy=recover, reset=False)
        est = res.estimate
        iterations += res.iterations
        scans += res.scans
        err, herr = pose_error(est.pose, robot.true_pose)
        if est.converged and is_success(err, herr):
            recovered = True
            break
    elapsed = time.perf_counter() - t0
    return KidnappedRun(_key(task), localised, float(dist[i]), recovered,
                        iterations if recovered else -1, scans if recovered else -1, err, herr, elapsed)
