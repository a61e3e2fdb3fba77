"""The paper's localisation procedure, driving any `toolkit.world.Robot`.

One iteration: Ultrascan; turn toward the minimum reading (the sonar then faces the nearest wall
nearly perpendicularly) and tell the localiser (``predict``); rescan; keep the readings within the
windows around 0/90/180/270 degrees (`localisation.scan`); ``update``. When the belief is not
converged (wide, or several plausible modes such as the identical rooms of map3) the robot turns
toward the direction where its disc can drive furthest according to the scan (`free_travel`),
drives part of the way, tells the localiser, and iterates.

Only the Robot protocol is used (`move`, `turn`, `ultrascan`, `turnback`), so the procedure runs
unchanged on the simulator and on a real NXT.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np

from toolkit.world import ConfigError, LocalisationError, RngLike, Robot, Scan, angle_diff, as_rng

from .base import Localiser, Motion, PoseEstimate, Prior, Snapshot
from .scan import ProcessedScan, ScanProcessing, min_reading, process_scan, sweep_fault

__all__ = ["LocalisationResult", "LocaliseProcedure", "TraceStep", "free_travel", "localise", "open_direction"]

log = logging.getLogger(__name__)

STUCK_SWEEPS = 3
"""Sweeps taken in a row before a stuck or garbage sonar (`localisation.scan.sweep_fault`) ends the
localisation."""


@dataclass(frozen=True, eq=False)
class TraceStep:
    """One iteration of the procedure, for plots and reports.

    Attributes
    ----------
    iteration : int
        1-based procedure iteration.
    scan : ProcessedScan
        The processed scan given to the localiser.
    aligned_turn_rad : float
        Turn toward the minimum reading before the rescan (0 when alignment is off).
    snapshots : tuple
        The localiser's per-filter-iteration snapshots during this update (particle filters; each has
        ``particles``, ``weights``, ``beta`` and ``estimate``), empty for Kalman filters.
    estimate : PoseEstimate
        The belief after the update.
    explore : Motion or None
        The exploration move made after this iteration (turn, distance driven), if any.
    """

    iteration: int
    scan: ProcessedScan
    aligned_turn_rad: float
    snapshots: tuple[Snapshot, ...]
    estimate: PoseEstimate
    explore: Motion | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "iteration": self.iteration,
            "scan": self.scan.to_dict(),
            "aligned_turn_deg": math.degrees(self.aligned_turn_rad),
            "snapshots": [s.to_dict() for s in self.snapshots],
            "estimate": self.estimate.to_dict(),
            "explore": None if self.explore is None else self.explore.to_dict(),
        }


@dataclass(frozen=True, eq=False)
class LocalisationResult:
    """Outcome of `localise`.

    Attributes
    ----------
    estimate : PoseEstimate
        The final belief (pose at the end of the procedure).
    scans : int
        Ultrascans taken (each iteration takes two when aligning).
    iterations : int
        Procedure iterations (updates of the localiser).
    converged : bool
        Whether the localiser reported convergence.
    trace : tuple of TraceStep
    moves : int
        Exploration moves made to break ambiguity.
    robot_time_s : float
        Robot time spent (the robot's own clock).
    compute_time_s : float
        Wall-clock time spent in the localiser's reset/predict/update calls.
    localiser : str
    """

    estimate: PoseEstimate
    scans: int
    iterations: int
    converged: bool
    trace: tuple[TraceStep, ...] = field(default=())
    moves: int = 0
    robot_time_s: float = 0.0
    compute_time_s: float = 0.0
    localiser: str = ""

    @property
    def pose(self) -> Any:
        return self.estimate.pose

    def to_dict(self, trace: bool = False) -> dict[str, Any]:
        d: dict[str, Any] = {
            "localiser": self.localiser,
            "estimate": self.estimate.to_dict(),
            "scans": self.scans,
            "iterations": self.iterations,
            "converged": self.converged,
            "moves": self.moves,
            "robot_time_s": self.robot_time_s,
            "compute_time_s": self.compute_time_s,
        }
        if trace:
            d["trace"] = [t.to_dict() for t in self.trace]
        return d



LocaliseProcedure: TypeAlias = Callable[..., LocalisationResult]
"""The seam the mission and the benchmarks call: ``procedure(robot, localiser, *, prior=..., rng=...,
**options) -> LocalisationResult``; `localise` is the one the toolkit ships, tests pass stand-ins."""

def free_travel(scan: Scan, radius_cm: float, directions: Any = None) -> tuple[Any, Any]:
    """How far a disc of `radius_cm` can drive along each direction before touching a scanned point.

    Every usable reading is a wall point in the robot frame; along direction ``phi`` the disc meets
    point ``p`` at ``t = p.u - sqrt(R^2 - (p x u)^2)`` when it passes within R of it. Directions
    default to the scan's own angles. Returns (directions, free distance in cm; ``inf`` when no
    reading limits it).
    """
    ok = scan.valid & np.isfinite(scan.ranges)
    phi = np.asarray(scan.angles if directions is None else directions, dtype=float)
    if not ok.any():
        return phi, np.full(phi.shape, np.inf)
    px = scan.ranges[ok] * np.cos(scan.angles[ok])
    py = scan.ranges[ok] * np.sin(scan.angles[ok])
    ux, uy = np.cos(phi)[:, None], np.sin(phi)[:, None]
    along = px[None, :] * ux + py[None, :] * uy
    across = np.abs(px[None, :] * uy - py[None, :] * ux)
    hit = (across < radius_cm) & (along > 0.0)
    t = along - np.sqrt(np.maximum(radius_cm**2 - across**2, 0.0))
    free = np.where(hit, np.maximum(t, 0.0), np.inf).min(axis=1)
    return phi, free


def open_direction(scan: Scan, clearance_cm: float, rng: RngLike = None, avoid_rad: float | None = None, *,
                   avoid_deg: float = 60.0, open_cm: float | None = None, clip_to_readings: bool = True,
                   need_open: bool = False) -> tuple[float, float]:
    """Where to drive to break an ambiguous belief, from one scan alone (no pose needed).

    For every usable reading direction, the free run of a disc of radius `clearance_cm` along it
    (`free_travel`; with `clip_to_readings`, never beyond the reading itself: a missing echo is as
    likely a wall seen at a glancing angle as open space). Among the directions within 2 cm of the
    longest run one is picked at random; directions within `avoid_deg` of `avoid_rad` (where the robot
    came from) only when no other one runs beyond `open_cm` (default `clearance_cm`).

    Returns
    -------
    (float, float)
        The direction (rad, relative to the heading) and its free run (cm); (0, 0) when no reading is
        usable, or, with `need_open`, when no run is longer than `open_cm` (then nothing is drawn).
    """
    ok = scan.valid & np.isfinite(scan.ranges)
    if not ok.any():
        return 0.0, 0.0
    enough = clearance_cm if open_cm is None else open_cm
    phi, free = free_travel(scan, clearance_cm, scan.angles[ok])
    if clip_to_readings:
        free = np.minimum(free, scan.ranges[ok])
    score = free.copy()
    if avoid_rad is not None:
        back = np.abs(angle_diff(phi, avoid_rad)) < math.radians(avoid_deg)
        if (score[~back] > enough).any():
            score = np.where(back, -np.inf, score)
    best = float(np.max(score))
    if need_open and best <= enough:
        return 0.0, 0.0
    cand = np.flatnonzero(score >= best - 2.0)
    k = int(as_rng(rng).choice(cand))
    return float(angle_diff(phi[k], 0.0)), float(free[k])


def localise(
    robot: Robot,
    localiser: Localiser,
    *,
    max_iterations: int = 6,
    rng: RngLike = None,
    prior: Prior | None = None,
    reset: bool = True,
    align: bool = True,
    processing: ScanProcessing | None = None,
    process: bool = True,
    scan_angles: Any = None,
    min_valid_readings: int = 8,
    max_move_cm: float = 40.0,
    move_fraction: float = 0.7,
    safety_cm: float | None = None,
    on_sweep_fault: Callable[[str], None] | None = None,
) -> LocalisationResult:
    """Localise `robot` with `localiser` the paper's way (see the module docstring).

    Parameters
    ----------
    robot : Robot
        Any implementation of the protocol (simulator, NXT).
    localiser : Localiser
        Built for the robot's map.
    max_iterations : int
        Scan-update iterations at most (exploration moves happen between them).
    rng : None, int or Generator
        Randomness of the procedure itself (choice among equally open directions).
    prior : Prior, optional
        Start belief (None: global localisation). Trackers (EKF, UKF) need one.
    reset : bool
        Reset the localiser with `prior` first (False continues from its current belief).
    align : bool
        Turn toward the minimum reading and rescan before processing (the paper's method).
    processing : ScanProcessing, optional
        The window selection (the paper's by default).
    process : bool
        False gives the localiser every usable reading of the scan (the raw baseline).
    scan_angles : array_like, optional
        Turret angles (rad, relative) for `Robot.ultrascan` (default: its 360 one-degree readings).
    min_valid_readings : int
        When the processed scan keeps fewer readings, all usable readings are used instead.
    max_move_cm, move_fraction : float
        An exploration move drives ``min(max_move_cm, move_fraction * (travel - (safety - radius)))``
        where ``travel`` is how far the robot's disc can go before touching a scanned point
        (`free_travel`).
    safety_cm : float, optional
        Distance kept from the wall ahead, centre to wall (default: the robot radius + 5 cm).
    on_sweep_fault : callable, optional
        Told (in words) of every sweep the procedure takes again because the sensor looked stuck or
        gave garbage (`localisation.scan.sweep_fault`); `STUCK_SWEEPS` such sweeps in a row raise
        `LocalisationError`.

    Returns
    -------
    LocalisationResult
    """
    gen = as_rng(rng)
    if max_iterations < 1:
        raise ConfigError(f"max_iterations must be >= 1, got {max_iterations}")
    settings = processing or ScanProcessing()
    radius = float(getattr(getattr(robot, "geometry", None), "radius_cm", 8.0))
    safety = radius + 5.0 if safety_cm is None else float(safety_cm)
    t_robot0 = float(robot.robot_time_s)
    compute = 0.0

    def timed(fn: Any, *args: Any) -> Any:
        nonlocal compute
        t0 = time.perf_counter()
        out = fn(*args)
        compute += time.perf_counter() - t0
        return out

    if reset:
        timed(localiser.reset, prior)
    trace: list[TraceStep] = []
    scans = 0
    moves = 0
    came_from: float | None = None
    est = localiser.estimate()
    def sweep() -> Scan:
        # a stuck or garbage sensor is swept again; one that stays so ends here
        nonlocal scans
        fault = ""
        for attempt in range(1, STUCK_SWEEPS + 1):
            scan = robot.ultrascan(scan_angles)
            scans += 1
            fault = sweep_fault(scan) or ""
            if not fault:
                return scan
            if on_sweep_fault is not None:
                on_sweep_fault(fault)  # the caller says it (once)
            else:
                log.warning("sweep %d: %s; sweeping again", attempt, fault)
        raise LocalisationError(f"the sonar stayed faulty for {STUCK_SWEEPS} sweeps in a row ({fault}); "
                                "check the sensor and its cable")

    for it in range(1, max_iterations + 1):
        scan = sweep()
        turn = 0.0
        if align:
            turn, _ = min_reading(scan, settings.min_range_cm)
            if abs(turn) > 1e-9:
                robot.turn(turn)
                timed(localiser.predict, Motion(turn_rad=turn))
                if came_from is not None:
                    came_from = float(angle_diff(came_from, turn))
            scan = sweep()
        processed = process_scan(scan, settings) if process else process_scan(
            scan, settings, centres_deg=(0.0,), window_deg=180.0)
        used = processed.scan
        if int(np.sum(used.valid)) < min_valid_readings:
            log.info("processed scan kept %d readings; using all usable readings", int(np.sum(used.valid)))
            used = process_scan(scan, settings, centres_deg=(0.0,), window_deg=180.0).scan
        n_snap = len(localiser.snapshots)
        timed(localiser.update, used)
        est = localiser.estimate()
        snaps = tuple(localiser.snapshots[n_snap:])
        step = TraceStep(it, processed, turn, snaps, est)
        if est.converged or it == max_iterations:
            trace.append(step)
            break
        # ambiguous or wide: drive toward free space and try again
        direction, travel = open_direction(scan, radius, gen, came_from)
        distance = max(0.0, min(max_move_cm, move_fraction * (travel - safety + radius)))
        robot.turn(direction)
        outcome = robot.move(distance) if distance > 0 else None
        driven = outcome.distance_cm if outcome is not None else 0.0
        motion = Motion(turn_rad=direction, distance_cm=driven)
        timed(localiser.predict, motion)
        if outcome is not None and outcome.watchdog:
            back = robot.turnback()
            timed(localiser.predict, Motion(distance_cm=back.distance_cm))
        came_from = math.pi  # behind the robot now
        moves += 1
        trace.append(TraceStep(it, processed, turn, snaps, est, motion))
    return LocalisationResult(
        estimate=est,
        scans=scans,
        iterations=len(trace),
        converged=bool(est.converged),
        trace=tuple(trace),
        moves=moves,
        robot_time_s=float(robot.robot_time_s) - t_robot0,
        compute_time_s=compute,
        localiser=getattr(localiser, "name", type(localiser).__name__),
    )
