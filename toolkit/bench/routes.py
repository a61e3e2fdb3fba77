"""``nxtnav bench routes``: localisers on real sweeps along routes through a source's waypoints.

One real sweep alone often cannot tell a waypoint from a twin place; a robot sweeps, moves and sweeps
again. For every source (``repo``) of a sweep set with sweeps at two or more waypoints, a *route*
visits all its waypoints once:

* ``course-K``: the course's order (the order of the waypoints in ``sweeps.csv``, or ``--order``)
  starting from its K-th waypoint (0-based) and wrapping round;
* ``random-J``: the J-th seeded random order (the same orders on every run and for every seed).

The truth at a sweep is its waypoint with the sweep's aligned heading (``heading_deg``; with
``--headings model``, the heading at which the sonar model finds the sweep most likely). Between two
sweeps the robot turns to face the next waypoint, drives there and turns to the next sweep's heading;
the localiser is told those two motions as the robot's odometry would report them: the truth's
relative motion with the robot model's motion noise (`odometry`). Where a source has several sweeps at
a waypoint, each visit draws one. Every draw is seeded by (seed, source, route), so every localiser
faces the same sweeps and odometry. The first sweep is global localisation (no prior); every later one
a predict and an update. Each step is scored:

* ``error_cm``, ``heading_error_deg``: the estimate against the truth;
* ``converged``, ``ambiguous`` (two or more candidate poses), ``candidates``, ``truth_in_candidates``
  (a candidate within 20 cm of the waypoint);
* **confidently wrong**: converged, not ambiguous, more than 20 cm off;
* **honest**: within 10 cm, or ambiguous with the truth among the candidates.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from localisation.ambiguity import candidate_poses, confidently_wrong, truth_among
from localisation.base import Motion, make_localiser
from localisation.robot_options import localiser_options
from toolkit.bench.common import write_rows_csv
from toolkit.real_sonar.sweeps import Sweep, SweepSet, SweepSetError, aligned_heading_deg, load_sweep_set, warn_once
from toolkit.seeds import derive_seed
from toolkit.world import MotionNoise, NxtSonar, Pose, RobotModel, angle_diff, wrap_angle

__all__ = [
    "COLUMNS",
    "WITHIN_CM",
    "Route",
    "RouteStep",
    "RouteTask",
    "aligned_headings",
    "course_order",
    "make_route_tasks",
    "model_headings",
    "odometry",
    "plan_routes",
    "run_route",
    "summarise_steps",
    "truth_headings",
    "warn_twin_headings",
    "write_routes_csv",
]

COLUMNS = ("repo", "route", "step", "waypoint_x_cm", "waypoint_y_cm", "file", "localiser", "seed", "error_cm",
           "heading_error_deg", "converged", "ambiguous", "candidates", "truth_in_candidates", "time_s")
"""The columns of ``routes.csv``, in order."""
WITHIN_CM = 10.0
"""An estimate this close (cm) to the waypoint is right."""

Waypoint = tuple[float, float]


@dataclass(frozen=True)
class Route:
    """One order of visiting a source's waypoints (cm), first to last."""

    repo: str
    name: str
    waypoints: tuple[Waypoint, ...]


def course_order(sweeps: SweepSet, repo: str, order: Sequence[Waypoint] | None = None) -> list[Waypoint]:
    """The waypoints of `repo` in the course's order: as listed in `order` (every waypoint of the source
    must be in it), or without one in the set's order. Raises `SweepSetError` naming a missing waypoint."""
    listed = sweeps.waypoints(repo)
    if order is None:
        return listed
    missing = [w for w in listed if w not in order]
    if missing:
        raise SweepSetError(f"--order: waypoint ({missing[0][0]:g}, {missing[0][1]:g}) of {repo} is not in the "
                            f"order ({', '.join(f'{x:g}:{y:g}' for x, y in order)})")
    return [w for w in order if w in listed]


def plan_routes(sweeps: SweepSet, orders: int = 0, order: Sequence[Waypoint] | None = None, *,
                need_headings: bool = True) -> list[Route]:
    """Every route of the module docstring for every source with sweeps at two or more waypoints.

    Raises `SweepSetError` when no source has two waypoints, or (with `need_headings`) a sweep of a route
    has no heading."""
    routes: list[Route] = []
    left_out: list[str] = []
    for repo in sweeps.repos:
        course = course_order(sweeps, repo, order)
        if len(course) < 2:
            left_out.append(f"source {repo} has sweeps at one waypoint only ({course[0][0]:g}, {course[0][1]:g}); "
                            "a route needs two: it is left out")
            continue
        for w in course if need_headings else []:
            for sw in sweeps.at(*w, repo=repo):
                if math.isnan(sw.heading_deg):
                    raise SweepSetError(f"{sweeps.folder / 'sweeps.csv'}: sweep {sw.label} has no heading_deg; "
                                        "a route's truth is the waypoint at the sweep's aligned heading "
                                        "(or give --headings aligned or model)")
        routes += [Route(repo, f"course-{k}", tuple(course[k:] + course[:k])) for k in range(len(course))]
        for j in range(orders):
            perm = np.random.default_rng(derive_seed(0, "routes-order", repo, j)).permutation(len(course))
            routes.append(Route(repo, f"random-{j}", tuple(course[int(i)] for i in perm)))
    if not routes:
        counts = ", ".join(f"{r} {len(sweeps.waypoints(r))}" for r in sweeps.repos)
        raise SweepSetError(f"{sweeps.folder}: no source has sweeps at two or more waypoints (waypoints per "
                            f"source: {counts}); a route needs two")
    for why in left_out:
        warn_once(f"{sweeps.folder}: {why}")
    return routes


def odometry(start: Pose, end: Pose, noise: MotionNoise, rng: np.random.Generator) -> list[Motion]:
    """The motions from `start` to `end` as the robot issues them (turn to face `end`, drive there, turn to
    `end`'s heading), as its odometry reports them: the true motion with `noise` (the simulator's
    semantics: proportional for ``botsim``, absolute for ``absolute``; a drive also turns the heading)."""
    dx, dy = end.x - start.x, end.y - start.y
    bearing = math.atan2(dy, dx)
    face, drive, last = wrap_angle(bearing - start.theta), math.hypot(dx, dy), wrap_angle(end.theta - bearing)

    def noisy(value: float, sd: float) -> float:
        eps = float(rng.standard_normal()) * sd
        return value + (value * eps if noise.model == "botsim" else eps)

    face = noisy(face, noise.turn) + float(rng.standard_normal()) * noise.turn  # the drive's heading noise
    return [Motion(turn_rad=face, distance_cm=noisy(drive, noise.motion)), Motion(turn_rad=noisy(last, noise.turn))]


@dataclass(frozen=True)
class RouteTask:
    """One localiser along one route with one seed (picklable: models travel as their parameters)."""

    folder: str
    map: str | None
    route: Route
    localiser: str
    seed: int
    sonar: dict[str, Any]
    noise: dict[str, Any]
    options: dict[str, Any] = field(default_factory=dict)
    keep_belief: bool = False
    headings: dict[str, float] | None = None
    """The truth's heading (degrees) by sweep label, in place of each sweep's ``heading_deg``."""


@dataclass(frozen=True)
class RouteStep:
    """The outcome of one sweep of a route (`COLUMNS`), and for a figure the belief after it."""

    repo: str
    route: str
    step: int
    waypoint_x_cm: float
    waypoint_y_cm: float
    file: str
    localiser: str
    seed: int
    error_cm: float
    heading_error_deg: float
    converged: bool
    ambiguous: bool
    candidates: int
    truth_in_candidates: bool
    time_s: float
    truth: Pose | None = None
    estimate: Pose | None = None
    candidate_poses: tuple[Pose, ...] = ()
    cloud: np.ndarray | None = None

    @property
    def within(self) -> bool:
        return self.error_cm <= WITHIN_CM

    @property
    def confidently_wrong(self) -> bool:
        return confidently_wrong(self.converged, self.ambiguous, self.error_cm)

    @property
    def honest(self) -> bool:
        return self.within or (self.ambiguous and self.truth_in_candidates)

    def row(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in COLUMNS}


@lru_cache(maxsize=8)
def _sweep_set(folder: str, map: str | None) -> SweepSet:
    return load_sweep_set(folder, map)


def make_route_tasks(sweeps: SweepSet, map: str | None, routes: Sequence[Route], localisers: Sequence[str],
                     seeds: Sequence[int], sonars: Mapping[str, NxtSonar], noise: MotionNoise,
                     options: Mapping[str, dict[str, Any]] | None = None,
                     headings: Mapping[str, float] | None = None) -> list[RouteTask]:
    """Every localiser x seed x route; `sonars` holds each source's model, `headings` (optional) the
    truth's heading (degrees) by sweep label. The first task keeps its beliefs for the figure. The folder
    is named by its absolute path (a worker may run elsewhere)."""
    folder = str(Path(sweeps.folder).absolute())
    opts = options or {}

    def mine(r: Route) -> dict[str, float] | None:
        return None if headings is None else {k: v for k, v in headings.items() if k.startswith(r.repo + "/")}

    tasks = [RouteTask(folder, map, r, name, int(s), asdict(sonars[r.repo]), noise.to_dict(),
                       dict(opts.get(name, {})), headings=mine(r))
             for name in localisers for s in seeds for r in routes]
    if tasks:
        tasks[0] = RouteTask(**{**tasks[0].__dict__, "keep_belief": True})
    return tasks


def model_headings(sweeps: SweepSet, sonars: Mapping[str, NxtSonar], repos: Sequence[str]) -> dict[str, float]:
    """The heading (degrees) at which each source's model finds each of its sweeps most likely
    (`toolkit.real_sonar.fit.align_sweeps`, position within 3 cm of the waypoint), by sweep label: the
    robot's heading, the turret's (the model's ``turret_offset_deg``) taken off."""
    from toolkit.real_sonar.fit import align_sweeps

    out: dict[str, float] = {}
    for repo in repos:
        mine = SweepSet(sweeps.folder, sweeps.map, tuple(sw for sw in sweeps if sw.repo == repo))
        turret = sonars[repo].turret_offset_deg
        out.update({a.sweep.label: round(math.degrees(float(wrap_angle(a.heading_rad - math.radians(turret)))), 2)
                    for a in align_sweeps(sonars[repo], mine)})
    return out


def warn_twin_headings(sweeps: SweepSet, sonars: Mapping[str, NxtSonar]) -> None:
    """Warn (once a process) about every sweep of the sources of `sonars` whose ``heading_deg`` lies more than
    45 degrees from the heading its source's model finds it most likely at (`model_headings`): a truth
    heading that is the arena's twin (`toolkit.real_sonar.fit.heading_disagreements`)."""
    from toolkit.real_sonar.fit import heading_disagreements

    found = model_headings(sweeps, sonars, list(sonars))
    for line in heading_disagreements(((sw.label, sw.heading_deg, found[sw.label]) for sw in sweeps
                                       if sw.label in found), "sonar"):
        warn_once(line)


def aligned_headings(sweeps: SweepSet) -> dict[str, float]:
    """The heading (degrees) that aligns each sweep with the map at its waypoint, by sweep label: found as a
    sweep set's ``heading_deg`` is (`toolkit.real_sonar.sweeps.aligned_heading_deg`)."""
    return {sw.label: aligned_heading_deg(sw, sweeps.map) for sw in sweeps}


def truth_headings(kind: str, sweeps: SweepSet, sonars: Mapping[str, NxtSonar]) -> dict[str, float] | None:
    """The truth's heading (degrees, by sweep label) of ``--headings KIND``: ``model`` (`model_headings`, the
    sources of `sonars` with their models), ``aligned`` (`aligned_headings`), or None for ``column`` (the
    set's own ``heading_deg``)."""
    if kind == "model":
        return model_headings(sweeps, sonars, list(sonars))
    return aligned_headings(sweeps) if kind == "aligned" else None


def _draws(sweeps: SweepSet, task: RouteTask) -> tuple[list[Sweep], list[list[Motion]]]:
    """The sweep drawn at each waypoint of the route and the odometry between them (seeded by the task's
    seed, source and route: the same for every localiser)."""
    rng = np.random.default_rng(derive_seed(task.seed, "routes", task.route.repo, task.route.name))
    noise = MotionNoise(**task.noise)
    drawn = []
    for w in task.route.waypoints:
        here = sweeps.at(*w, repo=task.route.repo)
        drawn.append(here[int(rng.integers(len(here)))])
    truths = [_truth(sw, task.headings) for sw in drawn]
    moves = [odometry(a, b, noise, rng) for a, b in itertools.pairwise(truths)]
    return drawn, moves


def _truth(sw: Sweep, headings: Mapping[str, float] | None = None) -> Pose:
    """The waypoint at the sweep's heading (from `headings` by label when given, else ``heading_deg``)."""
    heading = sw.heading_deg if headings is None else headings[sw.label]
    return Pose(sw.x_cm, sw.y_cm, math.radians(heading))


def run_route(task: RouteTask) -> list[RouteStep]:
    """Localise along one route (`RouteTask`): a global fix from the first sweep, then a predict and an
    update per waypoint; every step scored against the truth."""
    sweeps = _sweep_set(task.folder, task.map)
    drawn, moves = _draws(sweeps, task)
    noise = MotionNoise(**task.noise)
    sonar = NxtSonar(**task.sonar)
    robot = RobotModel(sonar, motion=noise, readings="real")
    opts = {**localiser_options(task.localiser, robot), **task.options}
    loc = make_localiser(task.localiser, sweeps.map,
                         rng=derive_seed(task.seed, "routes-localiser", task.route.repo, task.route.name), **opts)
    steps: list[RouteStep] = []
    for k, sw in enumerate(drawn):
        t0 = time.perf_counter()
        if k == 0:
            loc.reset(None)
        else:
            for m in moves[k - 1]:
                loc.predict(m)
        loc.update(sw.scan(sonar.turret_offset_deg))
        est = loc.estimate()
        cands = candidate_poses(loc)
        elapsed = time.perf_counter() - t0
        truth = _truth(sw, task.headings)
        cloud = loc.cloud() if task.keep_belief else None
        steps.append(RouteStep(
            task.route.repo, task.route.name, k + 1, sw.x_cm, sw.y_cm, sw.file, task.localiser, task.seed,
            round(math.hypot(est.pose.x - truth.x, est.pose.y - truth.y), 3),
            round(abs(math.degrees(float(angle_diff(est.pose.theta, truth.theta)))), 3), bool(est.converged),
            len(cands) > 1, len(cands), truth_among(cands, truth.x, truth.y), round(elapsed, 4),
            truth=truth if task.keep_belief else None, estimate=est.pose if task.keep_belief else None,
            candidate_poses=tuple(cands) if task.keep_belief else (),
            cloud=None if cloud is None else np.asarray(cloud[0])[:400].copy()))
    return steps


def write_routes_csv(steps: Sequence[RouteStep], path: Path) -> Path:
    """`steps` as CSV with `COLUMNS` (written to a temporary file, then moved into place)."""
    return write_rows_csv((s.row() for s in steps), COLUMNS, path)


def _mean(flags: Sequence[bool]) -> float:
    """The share of true `flags`; nan for none."""
    return float(np.mean(flags)) if flags else math.nan


def _shares(mine: Sequence[RouteStep]) -> dict[str, float]:
    err = np.array([s.error_cm for s in mine])
    return {"runs": len(mine), "within_10cm": float(np.mean(err <= WITHIN_CM)),
            "within_20cm": float(np.mean(err <= 20.0)), "median_error_cm": float(np.median(err)),
            "median_heading_error_deg": float(np.median([s.heading_error_deg for s in mine])),
            "converged": float(np.mean([s.converged for s in mine])),
            "ambiguous": float(np.mean([s.ambiguous for s in mine])),
            "truth_in_candidates": _mean([s.truth_in_candidates for s in mine if s.ambiguous]),
            "confidently_wrong": float(np.mean([s.confidently_wrong for s in mine])),
            "honest": float(np.mean([s.honest for s in mine])),
            "median_time_s": float(np.median([s.time_s for s in mine]))}


def summarise_steps(steps: Sequence[RouteStep], localisers: Sequence[str]) -> dict[str, Any]:
    """Per localiser: the shares of `_shares` at each step (over the routes that have it), and per route
    whether any step was confidently wrong; the three figures the issue sets targets for, the first of them
    also per source (which robot's sweeps hold the share down)."""
    out: dict[str, Any] = {}
    for name in localisers:
        mine = [s for s in steps if s.localiser == name]
        if not mine:
            continue
        by_step = {k: _shares([s for s in mine if s.step == k]) for k in sorted({s.step for s in mine})}
        runs: dict[tuple[str, str, int], list[RouteStep]] = {}
        for s in mine:
            runs.setdefault((s.repo, s.route, s.seed), []).append(s)
        wrong_routes = float(np.mean([any(s.confidently_wrong for s in r) for r in runs.values()]))
        second = by_step.get(2, {})
        at_second = [s for s in mine if s.step == 2]
        out[name] = {"routes": len(runs), "steps": by_step,
                     "within_10cm_after_second": second.get("within_10cm", math.nan),
                     "within_10cm_after_second_by_source": {
                         repo: _mean([s.within for s in at_second if s.repo == repo])
                         for repo in sorted({s.repo for s in at_second})},
                     "within_10cm_from_second_on": float(np.mean([s.within for s in mine if s.step >= 2])),
                     "confidently_wrong_routes": wrong_routes,
                     "first_honest": by_step[1]["honest"]}
    return out
