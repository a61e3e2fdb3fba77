"""``nxtnav bench challenge``: the course's challenge (`toolkit.mission.challenge`) on real sweeps.

For every source of a sweep set with sweeps at two or more waypoints, every start waypoint, every
seed and every localiser, one mission on the simulator whose sweeps are that source's real ones
(`toolkit.real_sonar.sweep_sonar`): start at the waypoint at a seeded random heading, visit the others in the
course's order. A mission *reached* when the robot truly ended within 10 cm of every waypoint.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import make_localiser
from localisation.robot_options import localiser_options
from planners.base import make_planner
from toolkit.bench.common import write_rows_csv
from toolkit.mission.challenge import ChallengeConfig, ChallengeReport, run_challenge
from toolkit.number_format import cell, json_safe
from toolkit.real_sonar.sweep_sonar import SweepSetRobot, SweepSetSonar, course_waypoints, load_challenge_set
from toolkit.real_sonar.sweeps import SweepSet
from toolkit.robots.sim import SimRobot
from toolkit.seeds import derive_seeds
from toolkit.world import MotionNoise, NxtSonar, Pose, RobotModel, load_map
from toolkit.world.arrays import finite_median

__all__ = ["COLUMNS", "ChallengeRun", "ChallengeTask", "challenge_mission", "challenge_tasks", "crashed_mission",
           "run_challenge_task",
           "summarise", "summary_markdown", "write_challenge_csv"]


@dataclass(frozen=True)
class ChallengeTask:
    """One challenge mission (picklable: models travel as their parameters)."""

    folder: str
    map: str
    repo: str
    start: int
    seed: int
    localiser: str
    planner: str
    sonar: dict[str, Any]
    noise: dict[str, Any]
    config: ChallengeConfig = field(default_factory=ChallengeConfig)
    headings: tuple[tuple[str, float], ...] | None = None
    """The sweeps' headings (degrees, by sweep label) in place of ``heading_deg`` (``--headings aligned|model``)."""


@dataclass(frozen=True)
class ChallengeRun:
    """The outcome of one `ChallengeTask` (the CSV's columns, in order)."""

    repo: str
    start_x_cm: float
    start_y_cm: float
    seed: int
    localiser: str
    reached: bool
    worst_error_cm: float
    collisions: int
    robot_time_s: float
    leg_heading_error_deg: float
    waypoints: int
    status: str

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


COLUMNS = tuple(f.name for f in fields(ChallengeRun))


@lru_cache(maxsize=4)
def _sweep_set(folder: str, map: str, headings: tuple[tuple[str, float], ...] | None = None) -> SweepSet:
    return load_challenge_set(Path(folder), load_map(map), None if headings is None else dict(headings))


def challenge_tasks(sweeps: SweepSet, map: str, localisers: Sequence[str], seeds: Sequence[int], *,
                    planner: str = "min-turn", sonar: NxtSonar | None = None,
                    noise: MotionNoise | None = None, config: ChallengeConfig | None = None,
                    headings: Mapping[str, float] | None = None) -> list[ChallengeTask]:
    """Every source (with two or more waypoints) x start waypoint x seed x localiser (`config`: the missions'
    settings, default `ChallengeConfig()`; `headings`: the sweeps' headings in place of ``heading_deg``)."""
    folder = str(Path(sweeps.folder).absolute())
    params = asdict(sonar or NxtSonar())
    motion = (noise or MotionNoise()).to_dict()
    settings = config or ChallengeConfig()
    given = None if headings is None else tuple(sorted(headings.items()))
    return [ChallengeTask(folder, map, repo, i, int(s), name, planner, params, motion, settings, given)
            for name in localisers for s in seeds for repo in sweeps.repos
            for i in range(len(course_waypoints(sweeps, repo))) if len(course_waypoints(sweeps, repo)) >= 2]


def challenge_mission(sweeps: SweepSet, repo: str, start: int, seed: int, localiser: str, planner: str = "min-turn",
                      sonar: NxtSonar | None = None, noise: MotionNoise | None = None,
                      config: ChallengeConfig | None = None) -> ChallengeReport:
    """One challenge mission of `repo`'s sweeps from its waypoint `start` (seeded: the start heading, the
    simulator, the sweep drawn at each waypoint, the localiser and the planner). With
    ``challenge.sonar.readings=simulated`` the robot's sweeps are the `sonar` model's at its true pose
    instead: the same mission, route and seeds on simulated readings."""
    m = sweeps.map
    course = course_waypoints(sweeps, repo)
    heading_seed, sim_seed, loc_seed, plan_seed = derive_seeds(seed, "challenge", repo, start, n=4)
    heading = float(np.random.default_rng(heading_seed).uniform(-math.pi, math.pi))
    motion = noise or MotionNoise()
    settings = config or ChallengeConfig()
    start_pose = Pose(course[start][0], course[start][1], heading)
    robot: SimRobot
    if settings.sonar.readings == "simulated":  # the sonar model's sweeps at the true pose, for comparison
        robot = SimRobot(m, start_pose, sonar=sonar or NxtSonar(), noise=motion, rng=sim_seed)
    else:
        sonar_of_sweeps = SweepSetSonar(sweeps, repo, radius_cm=settings.sonar.radius_cm,
                                        offset_correction=settings.sonar.offset_correction)
        robot = SweepSetRobot(m, start_pose, sonar_of_sweeps, noise=motion, rng=sim_seed)
    model = RobotModel(sonar or NxtSonar(), motion=motion, readings="real")
    loc = make_localiser(localiser, m, rng=loc_seed, **localiser_options(localiser, model))
    return run_challenge(robot, m, course, start, loc, make_planner(planner), np.random.default_rng(plan_seed),
                         config, motion)


def run_challenge_task(task: ChallengeTask) -> ChallengeRun:
    """Run one `ChallengeTask` and score it."""
    sweeps = _sweep_set(task.folder, task.map, task.headings)
    noise = MotionNoise(**task.noise)
    report = challenge_mission(sweeps, task.repo, task.start, task.seed, task.localiser, task.planner,
                               NxtSonar(**task.sonar), noise, task.config)
    x, y = report.start
    return ChallengeRun(task.repo, x, y, task.seed, task.localiser, report.reached, round(report.worst_error_cm, 3),
                        report.collisions, round(report.robot_time_s, 2), round(report.leg_heading_error_deg, 2),
                        len(report.route), report.status)


def crashed_mission(task: ChallengeTask, reason: str) -> ChallengeRun:
    """The row of a mission whose worker process died (`toolkit.bench.executors.run_tasks`'s ``crashed``):
    not reached, its status the `reason`."""
    sweeps = _sweep_set(task.folder, task.map, task.headings)
    x, y = course_waypoints(sweeps, task.repo)[task.start]
    return ChallengeRun(task.repo, x, y, task.seed, task.localiser, False, math.nan, 0, math.nan, math.nan,
                        len(course_waypoints(sweeps, task.repo)), f"crashed: {reason}")


def write_challenge_csv(runs: Sequence[ChallengeRun], path: Path) -> Path:
    """`runs` as CSV with `COLUMNS` (written to a temporary file, then moved into place)."""
    return write_rows_csv((r.to_dict() for r in runs), COLUMNS, path)


def summarise(runs: Sequence[ChallengeRun]) -> dict[str, dict[str, Any]]:
    """Per localiser, then per source of each: missions, share reached, median and worst of the worst
    errors (cm), missions with a collision, collisions, median robot time (s), median of the missions' median
    heading errors at a leg's start (deg)."""
    out: dict[str, dict[str, Any]] = {}
    for name in dict.fromkeys(r.localiser for r in runs):
        mine = [r for r in runs if r.localiser == name]
        repos = dict.fromkeys(r.repo for r in mine)
        rows = {"all": mine, **{repo: [r for r in mine if r.repo == repo] for repo in repos}}
        out[name] = {key: _figures(group) for key, group in rows.items()}
    return out


def _figures(runs: Sequence[ChallengeRun]) -> dict[str, Any]:
    worst = [r.worst_error_cm for r in runs if math.isfinite(r.worst_error_cm)]  # a crashed mission has none
    return {"missions": len(runs), "reached": float(np.mean([r.reached for r in runs])),
            "median_worst_error_cm": finite_median(worst), "max_worst_error_cm": max(worst, default=math.nan),
            "missions_with_collision": int(sum(r.collisions > 0 for r in runs)),
            "collisions": int(sum(r.collisions for r in runs)),
            "median_robot_time_s": finite_median(r.robot_time_s for r in runs),
            "median_leg_heading_error_deg": finite_median(r.leg_heading_error_deg for r in runs)}


def summary_markdown(runs: Sequence[ChallengeRun], *, sweeps: SweepSet, seeds: Sequence[int], command: str,
                     complete: bool = True, readings: str = "real") -> str:
    """The summary as Markdown: one table, a row per localiser and source (and all sources); `readings`:
    whose sweeps the robot read (``challenge.sonar.readings``)."""
    lines = [] if complete else [f"**INCOMPLETE**: {len(runs)} missions finished; the table covers only them.\n"]
    lines += [f"# The challenge on {readings} sweeps: `{sweeps.folder}`, map `{sweeps.map.name}`, seeds "
              f"{', '.join(map(str, seeds))}", "",
              "| localiser | source | missions | reached every waypoint (10 cm) | median worst error (cm) "
              "| max worst error (cm) | missions with a collision | collisions | median robot time (s) "
              "| median heading error at a leg's start (deg) |",
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, groups in summarise(runs).items():
        for key, s in groups.items():
            lines.append(f"| {name} | {key} | {s['missions']} | {s['reached']:.0%} | "
                         f"{cell(s['median_worst_error_cm'], '.1f')} | {cell(s['max_worst_error_cm'], '.1f')} | "
                         f"{s['missions_with_collision']} | {s['collisions']} | "
                         f"{cell(s['median_robot_time_s'], '.0f')} | "
                         f"{cell(s['median_leg_heading_error_deg'], '.1f')} |")
    left = [f"Left out (a challenge needs sweeps at two or more waypoints): {r}, sweeps at one waypoint  "
            for r in sweeps.repos if len(course_waypoints(sweeps, r)) < 2]
    left += [f"Left out (its readings cannot be used): {why}  " for why in sweeps.left_out]
    lines += ["", *left] if left else []
    lines += ["", "Each mission starts at one waypoint of a source (a seeded random heading, the waypoint unknown to "
              "the robot) and visits the others in the course's order, sweeping only at waypoints with that "
              "source's real sweeps. *Worst error*: the largest true distance from a waypoint where a visit ended. "
              "*Heading error*: how far the belief's heading was from the truth's as each leg started, the median "
              "over the missions of each mission's median.",
              "", f"Command: `{command}`", ""]
    return "\n".join(lines)


def summary_json(runs: Sequence[ChallengeRun], **extra: Any) -> str:
    """The summary (`summarise`) and `extra` as JSON text."""
    return json.dumps(json_safe({**extra, "summary": summarise(runs)}), indent=1, allow_nan=False)
