"""`run_mission`: the mission stack on any robot, from an unknown pose to a target."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from localisation.base import LOCALISERS, HeadingPrior, Localiser, make_localiser
from localisation.procedure import LocaliseProcedure, look
from planners.base import Planner, make_planner

from ..world import (
    ConfigError,
    Map,
    NxtnavError,
    Pose,
    RngLike,
    Robot,
    RobotCounters,
    TruthSource,
    as_rng,
    load_map,
)
from ..world.arrays import FloatArray
from .config import MissionConfig
from .machine import Mission
from .recovery import DEFAULT_RECONNECT_TIMEOUT_S, FaultLog, Recovery
from .report import _SPLIT_COUNTERS, MissionCounts, MissionPoses, MissionReport, MissionTimes, Outcome, _time_split

if TYPE_CHECKING:
    from ..recordings.recorder import Recorder

log = logging.getLogger(__name__)

_COUNTERS = ("watchdog_stops", "odometry_cm", *_SPLIT_COUNTERS)


def _counters(robot: Robot, truth: TruthSource | None) -> dict[str, float]:
    """The robot's own counters (`RobotCounters`, where it keeps them) and the truth's collisions."""
    out: dict[str, float] = {}
    if isinstance(robot, RobotCounters):
        own = robot.counters()
        out.update({k: float(own[k]) for k in _COUNTERS if k in own})
    if truth is not None:
        out["collisions"] = float(truth.collisions)
    return out


def run_mission(robot: Robot, map: Map | str, target: ArrayLike, *, planner: str | Planner = "min-turn",
                localiser: str | Localiser = "paper-pf", rng: RngLike = None, config: MissionConfig | None = None,
                recorder: Recorder | None = None, procedure: LocaliseProcedure = look,
                reconnect_timeout_s: float = DEFAULT_RECONNECT_TIMEOUT_S,
                truth: TruthSource | None = None, start_heading: HeadingPrior | None = None) -> MissionReport:
    """Run the stack on `robot` from its unknown pose to `target`.

    Parameters
    ----------
    robot : Robot
        A `SimRobot`, an NXT robot, or anything implementing the protocol; one that keeps counters
        (`toolkit.world.RobotCounters`) gets its odometry and robot-time split in the report.
    map, target : Map or str, (2,) array_like
        The map the robot is in (or its name) and the target position (cm).
    planner, localiser : str or plug-in
        Registry names (``min-turn``, ``ompl:BITstar``; ``paper-pf``) or a planner, a localiser built for `map`.
    rng, config : None, int or Generator; MissionConfig or None
        Seeds the planner's and the localiser's draws (the simulator has its own); how the mission runs.
    recorder : toolkit.recordings.recorder.Recorder, optional
        Records every command, scan and localiser call; the caller closes it.
    procedure : callable
        One look, ``procedure(robot, localiser, prior=..., rng=..., reset=..., **options)`` returning a
        `LocalisationResult` (`localisation.procedure.look`; tests pass stand-ins).
    reconnect_timeout_s : float
        After a lost link, how long (wall-clock s) to try to reach the robot again.
    truth, start_heading : TruthSource, HeadingPrior, optional
        What knows the true pose (the simulator, the virtual brick's world), for the report's true start,
        trajectory, final error and collisions; the start's heading, known roughly, for the first global fix.

    Returns
    -------
    MissionReport
        Never raises for an unreachable target, a target in a wall, a lost robot or a lost link that does
        not come back: ``status`` says what happened, ``success`` is False. Malformed arguments (an unknown
        planner name, a target that is not two finite numbers) raise `NxtnavError`/`ValueError`.
    """
    t0, cpu0 = time.perf_counter(), time.process_time()
    cfg = config or MissionConfig()
    m = map if isinstance(map, Map) else load_map(map)
    tgt = _target_xy(target)
    plan_rng, loc_rng = as_rng(rng).spawn(2)
    plan_obj = planner if isinstance(planner, Planner) else make_planner(planner, **cfg.planning.planner_kwargs())
    loc_name, build_localiser = _localiser_factory(localiser, m, cfg, loc_rng)
    if recorder is not None:
        robot, build_localiser = _recorded(recorder, robot, build_localiser, localiser, cfg, loc_rng)
    before = _Before(truth.true_pose if truth is not None else None, float(robot.robot_time_s), _counters(robot, truth))
    recovery = Recovery(reconnect_timeout_s, FaultLog(recorder))
    mission = Mission(robot, m, tgt, plan_obj, build_localiser, plan_rng, cfg, procedure=procedure, truth=truth,
                      recovery=recovery, on_plan=None if recorder is None else recorder.plan_event,
                      start_heading=start_heading)
    try:
        outcome, status = mission.run()
    except ConfigError:
        raise  # options that cannot work (a range model over its budget): bad input, not a mission result
    except NxtnavError as exc:
        outcome, status = Outcome.ABORTED, f"aborted: {exc}"
    log.info("mission on %s: %s", m.name, status)
    return _report(mission, robot, before, outcome, status, recovery, planner=plan_obj.name, localiser=loc_name,
                   seed=int(rng) if isinstance(rng, int | np.integer) else None,
                   clocks=(time.perf_counter() - t0, time.process_time() - cpu0))


def _target_xy(target: ArrayLike) -> FloatArray:
    tgt = np.asarray(target, dtype=float).ravel()
    if tgt.shape != (2,) or not np.all(np.isfinite(tgt)):
        raise NxtnavError(f"target must be two finite numbers (x, y) in cm, got {np.asarray(target).tolist()!r}")
    return tgt


class _Before(NamedTuple):
    """What the report measures from: the true start, the robot's clock and counters."""

    start: Pose | None
    robot_time_s: float
    counters: dict[str, float]


def _localiser_factory(localiser: str | Localiser, m: Map, cfg: MissionConfig,
                       loc_rng: np.random.Generator) -> tuple[str, Callable[[], Localiser]]:
    """The localiser's name and a factory (a name is built at first use; an unknown one fails here)."""
    if isinstance(localiser, Localiser):
        return localiser.name, lambda: localiser
    return LOCALISERS.get(localiser).name, partial(make_localiser, localiser, m, rng=loc_rng,
                                                   **dict(cfg.localiser_options))


def _report(mission: Mission, robot: Robot, before: _Before, outcome: Outcome, status: str,
            recovery: Recovery, clocks: tuple[float, float], **names: Any) -> MissionReport:
    """The report of `mission`; `clocks`: its wall-clock and CPU time (s); `names`: its planner, localiser and
    seed."""
    ctx = mission.context
    final = ctx.true_pose()
    est = ctx.estimate.pose if ctx.estimate is not None else None
    after = _counters(robot, ctx.truth)
    delta = {k: after[k] - before.counters[k] for k in before.counters if k in after}
    collisions = delta.get("collisions")
    robot_time = float(robot.robot_time_s) - before.robot_time_s
    return MissionReport(
        success=outcome is Outcome.REACHED, status=status,
        final_error_cm=None if final is None else final.distance_to(ctx.target),
        estimate_error_cm=None if est is None else est.distance_to(ctx.target),
        path_length_cm=float(delta.get("odometry_cm", ctx.counts.path_cm)),
        planned_length_cm=mission.planner.planned_length,
        collisions=None if collisions is None else int(collisions), map=ctx.map.name,
        times=MissionTimes(clocks[0], robot_time, clocks[1], _time_split(delta, robot_time)),
        counts=MissionCounts(ctx.counts.turns, int(delta.get("watchdog_stops", ctx.counts.watchdog_stops)),
                             ctx.counts.relocalisations, ctx.counts.replans),
        poses=MissionPoses(before.start, ctx.target, final, est, ctx.candidates),
        plans=ctx.plans, trace=ctx.trace, outcome=outcome, collision=ctx.cfg.collision,
        faults=list(recovery.log.notes), **names,
    )


def _recorded(recorder: Recorder, robot: Robot, build: Callable[[], Localiser], localiser: str | Localiser,
              cfg: MissionConfig, loc_rng: np.random.Generator) -> tuple[Any, Callable[[], Localiser]]:
    """The robot and the localiser factory with their calls written to `recorder`."""
    by_name = not isinstance(localiser, Localiser)
    options = dict(cfg.localiser_options) if by_name else {}
    return recorder.wrap_robot(robot), lambda: recorder.wrap_localiser(
        build(), options=options, rng=loc_rng if by_name else None)
