"""The localiser benchmark: global localisation, tracking and the kidnapped robot, in the simulator.

Three scenarios, each a list of independent trials that `toolkit.bench.executors.run_tasks` runs in
this process, over a process pool or on a Dask cluster:

``global``
    A `SimRobot` is put at a random free pose (seeded; at least `BenchConfig.pose_clearance_cm` from every
    wall, heading uniform) and localises by the global strategy a mission runs
    (`localisation.global_localisation.GlobalLocalisation`: sweep, decide, explore, sweep again;
    `BenchConfig.strategy`). The final estimate is compared with the simulator's true pose at the
    end of the localisation. Success = within `SUCCESS_CM` (2 cm) and
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
    the strategy runs again *without resetting the localiser* (``reset=False``; one attempt and no
    confirmation, which would start afresh), up to `BenchConfig.recovery_rounds` times. It has
    recovered when a run ends converged within the success tolerance of the truth; the iterations
    and scans it took are counted. One row of `KIDNAPPED_COLUMNS` per trial.

Pose trackers (`Localiser.needs_prior`, the EKF and UKF) cannot localise globally; in the global and
kidnapped scenarios they get a prior, either the true pose plus Gaussian noise (``noisy-truth``,
`BenchConfig.prior_sd`) or the first estimate of a ``paper-pf`` run on the same
robot (``pf``). The summary says which.

Randomness: trial ``t`` of map ``m`` uses the seed ``toolkit.seeds.derive_seed(seed, m, t)`` for the true pose, the
robot's noise and the localiser, whatever the localiser, so every localiser sees the same poses.
"""

from __future__ import annotations

from .records import (
    COLUMNS,
    FILES,
    KIDNAPPED_COLUMNS,
    RUNS_COLUMNS,
    SCENARIOS,
    SUCCESS_CM,
    SUCCESS_DEG,
    TRACKER_PRIORS,
    TRACKING_COLUMNS,
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
from .report import read_csv, summarise, write_csv, write_summary
from .runner import (
    call_localise,
    localise_once,
    localiser_options,
    make_tasks,
    particle_count,
    run_trial,
    scripted_drive,
)

__all__ = [
    "COLUMNS",
    "FILES",
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
    "TrialKey",
    "TrialResult",
    "TrialTask",
    "call_localise",
    "is_success",
    "localise_once",
    "localiser_options",
    "make_tasks",
    "particle_count",
    "pose_error",
    "read_csv",
    "run_trial",
    "scripted_drive",
    "summarise",
    "write_csv",
    "write_summary",
]
