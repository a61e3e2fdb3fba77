"""`run_mission`: the mission stack on any robot, from an unknown pose to a target."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from localisation.base import LOCALISERS, Localiser, make_localiser
from localisation.procedure import LocaliseProcedure, look
from planners.base import Planner, make_planner

from ..world import (
    ConfigError,
    Map,
    NxtnavError,
    Pose,
    RngLike,
    Robot,
    as_rng,
    load_map,
)
from .config import MissionConfig
from .recovery import DEFAULT_RECONNECT_TIMEOUT_S, FaultLog, Recovery, StopCheck
from .report import _SPLIT_COUNTERS, MissionReport, Outcome, _time_split
from .stack import _Mission, _MissionEnded

if TYPE_CHECKING:
    from ..recording import Recorder

log = logging.getLogger(__name__)


def _robot_counters(robot: Robot) -> dict[str, float]:
    """The robot's own counters (simulator: collisions, watchdog stops, odometry), where it has them."""
    out: dict[str, float] = {}
    for name in ("collisions", "watchdog_stops", "odometry_cm", *_SPLIT_COUNTERS):
        v = getattr(robot, name, None)
        if isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool):
            out[name] = float(v)
    return out


def run_mission(
    robot: Robot,
    map: Map | str,
    target: ArrayLike,
    *,
    planner: str | Planner = "min-turn",
    localiser: str | Localiser = "paper-pf",
    rng: RngLike = None,
    config: MissionConfig | None = None,
    recorder: Recorder | None = None,
    procedure: LocaliseProcedure = look,
    reconnect_timeout_s: float = DEFAULT_RECONNECT_TIMEOUT_S,
) -> MissionReport:
    """Run the stack on `robot` from its unknown pose to `target`.

    Parameters
    ----------
    robot : Robot
        A `SimRobot`, an NXT robot, or anything implementing the protocol. A robot with a
        ``true_pose`` (the simulator) gets the true final error and true trajectory in the report;
        one with a ``collisions`` counter gets the true collision count.
    map : Map or str
        The map the robot is in (or its name/path).
    target : (2,) array_like
        Target position (cm).
    planner : str or Planner
        Registry name (``min-turn``, ``rrtstar``, ``ompl:BITstar``, ...) or a configured planner.
    localiser : str or Localiser
        Registry name (``paper-pf``, ...) or a localiser built for `map`.
    rng : None, int or Generator
        Seeds the planner's and the localiser's draws (the simulator has its own `rng`).
    config : MissionConfig or None
        Tolerances and limits; the defaults are tuned for the paper's setting.
    recorder : toolkit.recording.Recorder, optional
        Records every robot command, scan and localiser call (`toolkit.recording`); the caller closes it.
    procedure : callable
        One look (`localisation.procedure.look`, the paper's; tests pass stand-ins), for the global
        strategy and the re-localisations: called as ``procedure(robot, localiser, prior=..., rng=...,
        reset=..., **options)``, it returns a `LocalisationResult`.
    reconnect_timeout_s : float
        After a lost link (`toolkit.world.LinkLostError`), how long (wall-clock s) to try to reach the
        robot again before the mission ends (`toolkit.mission.recovery`).

    Returns
    -------
    MissionReport
        Never raises for an unreachable target, a target in a wall or a lost robot: ``status`` says
        what happened and ``success`` is False; nor for a lost link that does not come back
        (``Outcome.LINK_LOST``). Malformed arguments (unknown planner name, a target
        that is not two finite numbers) raise `NxtnavError`/`ValueError`.
    """
    t0, cpu0 = time.perf_counter(), time.process_time()
    cfg = config or MissionConfig()
    m = map if isinstance(map, Map) else load_map(map)
    tgt = np.asarray(target, dtype=float).ravel()
    if tgt.shape != (2,) or not np.all(np.isfinite(tgt)):
        raise NxtnavError(f"target must be two finite numbers (x, y) in cm, got {np.asarray(target).tolist()!r}")
    seed = int(rng) if isinstance(rng, int | np.integer) else None
    gen = as_rng(rng)
    plan_rng, loc_rng = gen.spawn(2)
    plan_obj = planner if isinstance(planner, Planner) else make_planner(planner, **dict(cfg.planner_options))
    if isinstance(localiser, Localiser):
        loc_name, build_localiser = localiser.name, lambda: localiser
    else:  # built at first use; an unknown name fails here, before anything runs
        loc_name = LOCALISERS.get(localiser).name
        build_localiser = partial(make_localiser, localiser, m, rng=loc_rng, **dict(cfg.localiser_options))
    if recorder is not None:
        robot, build_localiser = _recorded(recorder, robot, build_localiser, localiser, cfg, loc_rng)
    start_pose = getattr(robot, "true_pose", None)
    start = start_pose if isinstance(start_pose, Pose) else None
    time0 = float(robot.robot_time_s)
    counters0 = _robot_counters(robot)
    mission = _Mission(robot, m, tgt, plan_obj, build_localiser, plan_rng, cfg, procedure,
                       on_plan=None if recorder is None else recorder.plan_event)
    recovery = Recovery(reconnect_timeout_s, FaultLog(recorder))
    mission.on_sweep_fault = partial(recovery.sonar_fault, mission)
    mission.on_motion_fault = partial(recovery.motion_fault, mission)
    mission.on_watchdog_stop = StopCheck()
    try:
        outcome, status = recovery.run(mission)
    except _MissionEnded as end:
        outcome, status = end.outcome, end.status
    except ConfigError:
        raise  # options that cannot work (a range model over its budget): bad input, not a mission result
    except NxtnavError as exc:
        outcome, status = Outcome.ABORTED, f"aborted: {exc}"
    success = outcome is Outcome.REACHED
    log.info("mission on %s: %s", m.name, status)
    final = mission.true_pose()
    est = mission.estimate.pose if mission.estimate is not None else None
    counters1 = _robot_counters(robot)
    delta = {k: counters1[k] - counters0[k] for k in counters0 if k in counters1}
    collisions = delta.get("collisions")
    path_length = float(delta.get("odometry_cm", mission.path_length))
    robot_time = float(robot.robot_time_s) - time0
    return MissionReport(
        success=success,
        status=status,
        final_error_cm=None if final is None else final.distance_to(tgt),
        estimate_error_cm=None if est is None else est.distance_to(tgt),
        completion_s=time.perf_counter() - t0,
        cpu_s=time.process_time() - cpu0,
        robot_time_s=robot_time,
        path_length_cm=path_length,
        planned_length_cm=mission.planned_length,
        turns=mission.turns,
        collisions=None if collisions is None else int(collisions),
        watchdog_stops=int(delta.get("watchdog_stops", mission.watchdog_stops)),
        relocalisations=mission.relocalisations,
        replans=mission.replans,
        map=m.name,
        planner=plan_obj.name,
        localiser=loc_name,
        seed=seed,
        start=start,
        target=tgt,
        final_pose=final,
        final_estimate=est,
        plans=mission.plans,
        trace=mission.trace,
        candidates=mission.candidates,
        time_split=_time_split(delta, robot_time),
        outcome=outcome,
        collision=cfg.collision,
        faults=list(recovery.log.notes),
    )


def _recorded(recorder: Recorder, robot: Robot, build: Callable[[], Localiser], localiser: str | Localiser,
              cfg: MissionConfig, loc_rng: np.random.Generator) -> tuple[Any, Callable[[], Localiser]]:
    """The robot and the localiser factory with their calls written to `recorder`."""
    by_name = not isinstance(localiser, Localiser)
    options = dict(cfg.localiser_options) if by_name else {}
    return recorder.wrap_robot(robot), lambda: recorder.wrap_localiser(
        build(), options=options, rng=loc_rng if by_name else None)
