"""The paper's look at the world, driving any `toolkit.world.Robot`.

`look`: Ultrascan; turn toward the minimum reading (the sonar then faces the nearest wall nearly
perpendicularly) and tell the localiser (``predict``); rescan; keep the readings within the windows
around 0/90/180/270 degrees (`localisation.scan`); ``update``. What to do when the belief is not
converged (wide, or several plausible modes such as the identical rooms of map3) is the global
strategy's decision (`localisation.global_localisation`, with the moves of
`localisation.exploration`).

Only the Robot protocol is used (`turn`, `ultrascan`), so a look runs unchanged on the simulator and
on a real NXT.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np

from toolkit.world import LocalisationError, RngLike, Robot, Scan

from .base import HeadingPrior, Localiser, Motion, PoseEstimate, Prior, Snapshot
from .scan import ProcessedScan, ScanProcessing, min_reading, process_scan, sweep_fault

__all__ = ["LocalisationResult", "LocaliseProcedure", "TraceStep", "look"]

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
"""The seam of one look, which the global strategy and the mission's tracking call:
``procedure(robot, localiser, *, prior=..., rng=..., reset=..., **options) -> LocalisationResult``;
`look` is the one the toolkit ships, tests pass stand-ins."""


def look(
    robot: Robot,
    localiser: Localiser,
    *,
    rng: RngLike = None,
    prior: Prior | HeadingPrior | None = None,
    reset: bool = True,
    align: bool = True,
    processing: ScanProcessing | None = None,
    process: bool = True,
    scan_angles: Any = None,
    min_valid_readings: int = 8,
    on_sweep_fault: Callable[[str], None] | None = None,
) -> LocalisationResult:
    """One look the paper's way: sweep, turn toward the minimum reading, sweep again, update.

    The robot does not drive: where to go when the belief stays ambiguous is the global strategy's
    decision (`localisation.global_localisation`).

    Parameters
    ----------
    robot : Robot
        Any implementation of the protocol (simulator, NXT).
    localiser : Localiser
        Built for the robot's map.
    rng : None, int or Generator
        Unused (a look draws nothing); accepted so that every look of the seam takes the same arguments.
    prior : Prior or HeadingPrior, optional
        Start belief when resetting (None: global; a `HeadingPrior`: global with the heading known
        roughly). Trackers (EKF, UKF) need a `Prior`.
    reset : bool
        Reset the localiser with `prior` first (False continues from its current belief).
    align : bool
        Turn toward the minimum reading and sweep again before processing (the paper's method).
    processing : ScanProcessing, optional
        The window selection (the paper's by default).
    process : bool
        False gives the localiser every usable reading of the scan (the raw baseline).
    scan_angles : array_like, optional
        Turret angles (rad, relative) for `Robot.ultrascan` (default: its 360 one-degree readings).
    min_valid_readings : int
        When the processed scan keeps fewer readings, all usable readings are used instead.
    on_sweep_fault : callable, optional
        Told (in words) of every sweep the look takes again because the sensor looked stuck or gave
        garbage (`localisation.scan.sweep_fault`); `STUCK_SWEEPS` such sweeps in a row raise
        `LocalisationError`.

    Returns
    -------
    LocalisationResult
        One iteration: its trace holds the one `TraceStep`.
    """
    settings = processing or ScanProcessing()
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
    scans = 0

    def sweep() -> Scan:
        # a stuck or garbage sensor is swept again; one that stays so ends here
        nonlocal scans
        fault = ""
        for attempt in range(1, STUCK_SWEEPS + 1):
            scan = robot.ultrascan(scan_angles)
            scans += 1
            fault = sweep_fault(scan, localiser.map) or ""
            if not fault:
                return scan
            if on_sweep_fault is not None:
                on_sweep_fault(fault)  # the caller says it (once)
            else:
                log.warning("sweep %d: %s; sweeping again", attempt, fault)
        raise LocalisationError(f"the sonar stayed faulty for {STUCK_SWEEPS} sweeps in a row ({fault}); "
                                "check the sensor and its cable")

    scan = sweep()
    turn = 0.0
    if align:
        turn, _ = min_reading(scan, settings.min_range_cm)
        if abs(turn) > 1e-9:
            robot.turn(turn)
            timed(localiser.predict, Motion(turn_rad=turn))
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
    step = TraceStep(1, processed, turn, tuple(localiser.snapshots[n_snap:]), est)
    return LocalisationResult(
        estimate=est,
        scans=scans,
        iterations=1,
        converged=bool(est.converged),
        trace=(step,),
        robot_time_s=float(robot.robot_time_s) - t_robot0,
        compute_time_s=compute,
        localiser=getattr(localiser, "name", type(localiser).__name__),
    )
