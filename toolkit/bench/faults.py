"""A fault campaign: missions through virtual bricks that fail them on purpose (`nxtnav bench faults`).

Each mission runs twice on its own in-process virtual brick (`toolkit.robots.virtual_brick`), over
nxt-python's socket link, with the `NxtRobot` and the mission a user runs on a real NXT:

1. without faults (the baseline): its robot time says when the mission is under way;
2. with one or two faults drawn from the mission's seed (`draw_faults`), each scheduled at a brick
   time inside the baseline's run, so that it meets the mission.

The brick imitates a real NXT that keeps its motors running after a lost link (tacho limits stop
them), and its clock advances a fixed 0.01 s per exchange (``--time-factor 1000 --max-step 0.01``),
so the same seed gives the same mission up to the first fault, whatever the machine's load.

What each mission reports (`FaultMission`): whether it reached the target (the brick's true pose within
`SUCCESS_CM` of it, no collision: the brick's truth, not the estimate), the faults scheduled, fired
and acting (the brick's count: readings spoiled, motions slipped, connections cut, replies held), the
faults the mission noticed and recovered from (its report), the extra robot time against the
baseline, motors left running (powered without a tacho limit when a connection ended, or still
powered ten brick seconds after the mission's end, in either run), and whether both runs' recordings
read back and replay bit for bit (`toolkit.recordings.replay`).
"""

from __future__ import annotations

import contextlib
import io
import math
import statistics
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..robots.brick_faults import FAULT_KINDS, Fault, fault_class, known_fault_kinds
from ..seeds import derive_seeds
from ..world import ConfigError, Pose, load_map
from .executors import quiet_logger

if TYPE_CHECKING:
    from ..mission import MissionReport

__all__ = ["CAMPAIGN_MAPS", "FAULT_KINDS", "SUCCESS_CM", "FaultMission", "FaultTask", "draw_faults", "fault_tasks",
           "run_fault_task", "summarise"]

SUCCESS_CM = 3.0
"""A mission reaches the target when the brick's true pose ends within this distance of it (cm)."""
CAMPAIGN_MAPS = ("map1", "map2", "map3")
_SETTLE_S = 10.0  # brick seconds run after a mission to see whether a motor keeps going
_TIME_FACTOR, _MAX_STEP_S = 1000.0, 0.01


@dataclass(frozen=True)
class FaultTask:
    """One mission of the campaign: its number, map, seed, start pose, fault kinds and timeouts."""

    index: int
    map: str
    seed: int
    start: tuple[float, float, float]
    kinds: tuple[str, ...]
    reconnect_timeout_s: float = 30.0
    reply_timeout_s: float = 3.0
    recordings: str | None = None


def fault_tasks(missions: int, seed: int, kinds: Sequence[str] = FAULT_KINDS, maps: Sequence[str] = CAMPAIGN_MAPS,
                reconnect_timeout_s: float = 30.0, reply_timeout_s: float = 3.0,
                recordings: str | Path | None = None) -> list[FaultTask]:
    """`missions` tasks, cycling through `maps`, each from the map's start with a seeded heading."""
    drawable = [k for k in known_fault_kinds() if fault_class(k).draw_range is not None]
    unknown = [k for k in kinds if k not in drawable]
    if unknown or not kinds:
        raise ConfigError(f"fault kinds must be some of {', '.join(drawable)}, got {', '.join(kinds) or 'none'}")
    out = []
    for i in range(missions):
        name = maps[i % len(maps)]
        m = load_map(name)
        if m.start is None or m.target is None:
            raise ConfigError(f"map {name} needs a start and a target preset")
        s_mission, s_heading = derive_seeds(seed, "faults", i, n=2)
        heading = float(np.random.default_rng(s_heading).uniform(-math.pi, math.pi))
        out.append(FaultTask(i, name, int(s_mission % (2**31)), (float(m.start[0]), float(m.start[1]), heading),
                             tuple(kinds), reconnect_timeout_s, reply_timeout_s,
                             None if recordings is None else str(recordings)))
    return out


def draw_faults(rng: np.random.Generator, kinds: Sequence[str], duration_s: float) -> list[Fault]:
    """One or two faults of `kinds`, each at a brick time inside a run of `duration_s` (s).

    Each kind draws its ARG uniformly from its own `FaultKind.draw_range` (and a kind
    `FaultKind.drawn_from_start` is scheduled at 0 instead): a link down for 0.5-10 s (Bluetooth coming
    back, a cable plugged in again); a stall of 0.5-6 s (shorter or longer than the robot's 3 s reply
    timeout); a sensor stuck for 1-7 brick s (the stuck arcs of real sweeps span 50 to 250 degrees: 1.4
    to 6.9 s at the robot-time model's 27 ms a degree); garbage with probability 0.02-0.3 from the
    start; a motion slipping to 50-90 % of its tacho travel. A kind without a draw range is an error.
    """
    n = 1 + int(rng.random() < 0.3)
    out = []
    for _ in range(n):
        kind = str(rng.choice(list(kinds)))
        cls = fault_class(kind)
        if cls.draw_range is None:
            raise ConfigError(f"fault kind {kind!r} has no draw range for bench faults (FaultKind.draw_range)")
        at = float(np.round(rng.uniform(0.1, 0.85) * duration_s, 2))
        if cls.drawn_from_start:
            at = 0.0
        arg = rng.uniform(*cls.draw_range)
        out.append(Fault(kind, at, float(np.round(arg, 2))))
    return out


@dataclass(frozen=True)
class _Run:
    """What one run on a virtual brick gave."""

    report: MissionReport
    true_error_cm: float
    collisions: int
    faults: list[dict[str, Any]]
    left_running: int
    departures: int
    readable: bool = True
    reproduced: bool | None = None
    truncated: bool = False
    problem: str = ""


@dataclass(frozen=True)
class FaultMission:
    """One mission of the campaign (see the module docstring); `to_dict` is its JSON row."""

    index: int
    map: str
    seed: int
    faults: list[dict[str, Any]]
    success: bool
    outcome: str
    status: str
    true_error_cm: float
    collisions: int
    robot_time_s: float
    baseline_robot_time_s: float
    baseline_success: bool
    noticed: list[dict[str, Any]]
    left_running: int
    readable: bool
    reproduced: bool | None
    truncated: bool
    wall_s: float
    problems: list[str] = field(default_factory=list)

    @property
    def extra_robot_s(self) -> float:
        return self.robot_time_s - self.baseline_robot_time_s

    def to_dict(self) -> dict[str, Any]:
        return {**self.__dict__, "extra_robot_s": self.extra_robot_s}


def _world(task: FaultTask, faults: list[Fault], log: io.StringIO) -> Any:
    from ..robots.brick_faults import FaultSchedule
    from ..robots.virtual_brick_world import BrickConfig, BrickWorld

    s_world, s_faults = derive_seeds(task.seed, "brick", n=2)
    config = BrickConfig(time_factor=_TIME_FACTOR, max_step_s=_MAX_STEP_S, brake_on_disconnect=False)
    return BrickWorld(load_map(task.map), Pose(*task.start), config, sonar="nxt", rng=s_world, log=log,
                      faults=FaultSchedule(faults, rng=s_faults))


def _mission(task: FaultTask, faults: list[Fault], record: Path | None) -> _Run:
    """One run on its own virtual brick; with `record`, its recording is written there and checked."""
    from localisation.robot_options import localiser_options

    from ..mission import MissionConfig, run_mission
    from ..recordings.recorder import Recorder
    from ..robots.nxt import connect_robot
    from ..robots.virtual_brick import BrickServer
    from ..world import NxtSonar, RobotModel

    m = load_map(task.map)
    assert m.target is not None
    world = _world(task, faults, io.StringIO())
    report = None
    recorder = None
    with BrickServer(world, port=0) as server:
        robot = connect_robot("socket", host=server.host, port=server.port, reply_timeout_s=task.reply_timeout_s)
        # as nxtnav run --robot nxt tells the localiser of the virtual brick's sensor
        model = RobotModel(NxtSonar(), geometry=robot.geometry, readings="simulated")
        config = MissionConfig.for_sonar("nxt", localiser_options=localiser_options("paper-pf", model))
        try:
            if record is not None:
                recorder = Recorder(record, map=m, robot={"kind": "nxt", "link": robot.link, "virtual": True,
                                                          "profile": robot.profile.to_dict()},
                                    sonar={"model": "nxt", "params": NxtSonar().to_dict()}, seed=task.seed,
                                    truth=lambda: world.pose, extra={"faults": [f.to_dict() for f in faults]})
            with quiet_logger("toolkit.mission.recovery"):
                report = run_mission(robot, m, m.target, planner="min-turn", localiser="paper-pf", rng=task.seed,
                                     config=config, recorder=recorder, reconnect_timeout_s=task.reconnect_timeout_s,
                                     truth=world)
        finally:
            robot.close()
            if recorder is not None:
                recorder.close(None if report is None else report.status,
                               None if report is None else report.success, end=report is not None)
        server.wait_departures(server.clients, timeout=10.0)
        unbounded = sum(len(d.unbounded) for d in server.departures)
        world.run_for(_SETTLE_S)
        left = unbounded + len(world.driven_ports())
        true_error = float(world.pose.distance_to(m.target))
        run = _Run(report, true_error, int(world.collisions), world.faults.to_dict(), left, len(server.departures))
    if record is not None:
        run = _checked(run, record)
    return run


def _checked(run: _Run, path: Path) -> _Run:
    """`run` with its recording read back and replayed (the live localiser, bit for bit)."""
    from ..recordings.replay import read_recording, replay
    from ..world import NxtnavError

    try:
        rec = read_recording(path)
    except NxtnavError as exc:
        return _replace(run, readable=False, problem=f"recording unreadable: {exc}")
    out = replay(rec, [rec.localiser.name]) if rec.localiser is not None else None
    reproduced = None if out is None else next(iter(out.reproduced.values()), None)
    return _replace(run, reproduced=reproduced, truncated=rec.truncated is not None)


def _replace(run: _Run, **changes: Any) -> _Run:
    return _Run(**{**run.__dict__, **changes})


def run_fault_task(task: FaultTask) -> FaultMission:
    """The baseline, then the mission with its faults (a picklable top-level function for the executors)."""
    import time

    t0 = time.perf_counter()
    keep = Path(task.recordings) if task.recordings is not None else None
    with contextlib.ExitStack() as stack:
        folder = keep if keep is not None else Path(stack.enter_context(tempfile.TemporaryDirectory()))
        folder.mkdir(parents=True, exist_ok=True)
        # the baseline is recorded too: the recorder's tacho reads cost brick time, the same in both runs
        base = _mission(task, [], folder / f"mission-{task.index:04d}-baseline.jsonl")
        rng = np.random.default_rng(derive_seeds(task.seed, "draw")[0])
        faults = draw_faults(rng, task.kinds, float(base.report.times.robot_time_s))
        run = _mission(task, faults, folder / f"mission-{task.index:04d}.jsonl")
    report = run.report
    success = bool(report.success) and run.true_error_cm <= SUCCESS_CM and run.collisions == 0
    problems = [p for p in (base.problem, run.problem) if p]
    return FaultMission(
        index=task.index, map=task.map, seed=task.seed, faults=run.faults, success=success,
        outcome=report.outcome.value, status=report.status, true_error_cm=run.true_error_cm,
        collisions=run.collisions, robot_time_s=float(report.times.robot_time_s),
        baseline_robot_time_s=float(base.report.times.robot_time_s),
        baseline_success=bool(base.report.success) and base.true_error_cm <= SUCCESS_CM and base.collisions == 0,
        noticed=[n.to_dict() for n in report.faults], left_running=run.left_running + base.left_running,
        readable=run.readable and base.readable,
        reproduced=None if run.reproduced is None or base.reproduced is None else run.reproduced and base.reproduced,
        truncated=run.truncated or base.truncated,
        wall_s=time.perf_counter() - t0, problems=problems)


def _kind_rows(results: Sequence[FaultMission]) -> dict[str, dict[str, Any]]:
    rows: dict[str, dict[str, Any]] = {}
    for r in results:
        single = len(r.faults) == 1
        for f in r.faults:
            row = rows.setdefault(f["kind"], {"scheduled": 0, "fired": 0, "acting": 0, "recovered": 0,
                                              "missions_with_collisions": 0, "extra_robot_s": []})
            row["scheduled"] += 1
            row["fired"] += f["fired_at_s"] is not None
            acting = f["acted"] > 0
            row["acting"] += acting
            row["recovered"] += acting and r.success
            row["missions_with_collisions"] += acting and r.collisions > 0
            if single and acting:
                row["extra_robot_s"].append(r.extra_robot_s)
    for row in rows.values():
        extra = row.pop("extra_robot_s")
        row["missions_with_it_alone"] = len(extra)
        row["median_extra_robot_s"] = statistics.median(extra) if extra else None
    return rows


def summarise(results: Sequence[FaultMission]) -> dict[str, Any]:
    """The campaign's numbers: success, collisions, faults by kind, extra robot time, motors, recordings."""
    n = len(results)
    acting = [f for r in results for f in r.faults if f["acted"] > 0]
    lost = [x for r in results for x in r.noticed if x["kind"] == "link-lost"]
    back = [x for x in lost if x["recovered"]]
    per_fault = [r.extra_robot_s / len(r.faults) for r in results if r.faults]
    return {
        "missions": n,
        "success": sum(r.success for r in results),
        "success_rate": sum(r.success for r in results) / n if n else math.nan,
        "baseline_success": sum(r.baseline_success for r in results),
        "collisions": sum(r.collisions for r in results),
        "motors_left_running": sum(r.left_running for r in results),
        "faults_scheduled": sum(len(r.faults) for r in results),
        "faults_acting": len(acting),
        "faults_acting_recovered": sum(f["acted"] > 0 and r.success for r in results for f in r.faults),
        "links_lost": len(lost),
        "links_back": sum(bool(x["recovered"]) for x in lost),
        "median_outage_s": statistics.median(x["outage_s"] for x in lost) if lost else None,
        "median_recovery_robot_s": statistics.median(x["recovery_robot_s"] for x in back) if back else None,
        "sonar_sweeps_repeated": sum(x["kind"] == "sonar" for r in results for x in r.noticed),
        "fixes_off_course": sum(x["kind"] == "motion" for r in results for x in r.noticed),
        "median_extra_robot_s_per_fault": statistics.median(per_fault) if per_fault else None,
        "recordings_readable": sum(r.readable for r in results),
        "recordings_reproduced": sum(r.reproduced is True for r in results),
        "recordings_truncated": sum(r.truncated for r in results),
        "by_kind": _kind_rows(results),
        "failures": [f"mission {r.index} ({r.map}): {r.status}; true error {r.true_error_cm:.1f} cm, "
                     f"{r.collisions} collision(s); faults "
                     + ", ".join(f"{f['kind']}:{f['at_s']:g}:{f['arg']:g}" for f in r.faults)
                     for r in results if not r.success],
    }
