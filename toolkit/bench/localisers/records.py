"""What the localiser benchmark runs and records: its configuration, trial tasks and trial results."""

from __future__ import annotations

import math
import typing
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from pydantic import Field, InstanceOf, ValidationInfo, field_validator, model_validator

from localisation.base import PoseEstimate
from localisation.global_localisation import EXPLORATIONS, GlobalLocalisation
from localisation.robot_options import THIN_RAY, localiser_options
from toolkit.world import (
    MotionNoise,
    NxtSonar,
    Pose,
    RobotGeometry,
    RobotModel,
    SonarModel,
    angle_diff,
)
from toolkit.world.robot_model import NoiseModelName, with_robot_sets
from toolkit.world.typed import NonNegative, typed_dataclass, worded

SUCCESS_CM = 2.0
"""Position tolerance of a successful localisation (cm)."""


SUCCESS_DEG = 3.0
"""Heading tolerance of a successful localisation (degrees)."""


SCENARIOS = ("global", "tracking", "kidnapped")


TRACKER_PRIORS = ("noisy-truth", "pf")


_CHOICES: dict[str, tuple[str, ...]] = {
    "noise_model": typing.get_args(NoiseModelName), "tracker_prior": TRACKER_PRIORS,
    "scan_processing": ("paper", "raw"), "exploration": EXPLORATIONS, "lobe": ("auto", "off")}
"""The values each text setting of `BenchConfig` takes."""


RUNS_COLUMNS = (
    "map", "localiser", "trial", "seed", "success", "error_cm", "heading_error_deg", "time_s",
    "iterations", "scans", "converged", "candidates",
)


TRACKING_COLUMNS = (
    "map", "localiser", "trial", "seed", "steps", "rmse_cm", "rmse_heading_deg", "final_error_cm",
    "max_error_cm", "time_s", "collisions", "median_particles", "max_particles", "update_ms", "blind_steps",
    "rmse_echo_cm", "rmse_blind_cm", "dead_reckoning_rmse_cm",
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


@typed_dataclass()
class BenchConfig:
    """Settings shared by every trial of a benchmark run.

    Parameters
    ----------
    sonar : str
        Simulated sonar model (``ideal`` or ``nxt``).
    sensor_noise : float
        Noise (cm) of the ``ideal`` sonar; the paper's 1 cm. The ``nxt`` sonar's comes from its model.
    noise_model, motion_noise, turn_noise
        The robot's `MotionNoise` (the paper's BotSim values by default).
    tracker_prior : {"noisy-truth", "pf"}
        Prior of the pose trackers in the global and kidnapped scenarios.
    prior_sd : (float, float)
        Standard deviations of the noisy-truth prior (cm, degrees); also the prior of every localiser
        in the tracking scenario.
    clearance_cm : float
        Least distance from true poses to the walls (cm); with `robot_radius_cm`, that radius + 2 cm.
    robot_radius_cm : float or None
        The simulated robot's radius (cm): a robot scaled to the map, as ``nxtnav run --radius``
        (localisers that take ``clearance_cm`` get it, the scripted drive keeps it plus 3 cm from
        the walls). None: `RobotGeometry`'s 8 cm and `clearance_cm` as given.
    tracking_steps : int
        Actions (turn + move) of the scripted drive.
    tracking_step_cm : tuple of float
        Range of the drive's move lengths (cm).
    kidnap_min_cm : float
        Least distance of the teleport (cm).
    recovery_rounds : int
        Runs of the global strategy allowed to recover from a kidnapping, without resetting the
        localiser (one attempt, no confirmation: either would start afresh).
    scan_processing : {"paper", "raw"}
        Scans given to the localiser, in the global strategy's looks and in the tracking loop: the
        paper's processing (windows around 0/90/180/270 degrees from the minimum reading) or every
        usable reading.
    exploration : {"modes", "scan"}
        The global strategy's exploration rule (`localisation.global_localisation.EXPLORATIONS`;
        a mission's is ``modes``).
    lobe : {"auto", "off"}
        ``auto`` tells every localiser the whole robot model (`robot`); ``off`` leaves out the sonar's
        lobe and beam mixture (the localisers model a thin ray).
    localiser_options : mapping
        Per localiser name, keyword arguments for `make_localiser` (they override the robot model's).
    localise_options : mapping
        Extra keyword arguments of every look (`localisation.procedure.look`).
    sonar_model : NxtSonar, optional
        The ``nxt`` sonar's model (a fitted profile's, `toolkit.real_sonar.fit.load_sonar_profile`): the
        simulator reads with it and the localisers get its lobe. None: `NxtSonar`'s defaults.
    robot_sets : tuple of (key, text)
        ``--set robot.GROUP.FIELD`` and ``sonar.FIELD`` settings applied to the robot model
        (`toolkit.world.robot_model.with_robot_sets`).
    """

    sonar: str = "ideal"
    sensor_noise: float = Field(default=1.0, ge=0, allow_inf_nan=False)
    noise_model: str = "botsim"
    motion_noise: float = Field(default=0.1, ge=0, allow_inf_nan=False)
    turn_noise: float = Field(default=0.005, ge=0, allow_inf_nan=False)
    tracker_prior: str = "noisy-truth"
    prior_sd: tuple[NonNegative, NonNegative] = (3.0, 5.0)
    clearance_cm: float = Field(default=10.0, ge=0, allow_inf_nan=False)
    robot_radius_cm: float | None = Field(default=None, gt=0, allow_inf_nan=False)
    tracking_steps: int = Field(default=12, ge=1)
    tracking_step_cm: tuple[float, float] = (6.0, 15.0)
    kidnap_min_cm: float = Field(default=30.0, ge=0, allow_inf_nan=False)
    recovery_rounds: int = Field(default=3, ge=1)
    scan_processing: str = "paper"
    exploration: str = "modes"
    lobe: str = "auto"
    localiser_options: Mapping[str, Mapping[str, Any]] = Field(default_factory=dict)
    localise_options: Mapping[str, Any] = Field(default_factory=dict)
    sonar_model: InstanceOf[NxtSonar] | None = None
    robot_sets: tuple[tuple[str, str], ...] = ()

    @field_validator(*_CHOICES)
    @classmethod
    def _one_of(cls, value: str, info: ValidationInfo) -> str:
        name = str(info.field_name)
        if value not in _CHOICES[name]:
            raise worded(f"{name.replace('_', ' ')} must be one of {', '.join(_CHOICES[name])}, got {value!r}")
        return value

    @model_validator(mode="after")
    def _fits(self) -> BenchConfig:
        lo, hi = self.tracking_step_cm
        if not 0 < lo <= hi:
            raise ValueError(f"tracking_step_cm must be 0 < low <= high, got {self.tracking_step_cm}")
        if self.sonar_model is not None and self.sonar != "nxt":
            raise ValueError(f"a sonar model (profile) is for the nxt sonar, not {self.sonar!r}")
        return self

    @property
    def strategy(self) -> GlobalLocalisation:
        """The global-localisation strategy of the global and kidnapped scenarios: a mission's
        (`GlobalLocalisation`'s defaults), with this run's scan processing and exploration rule."""
        return GlobalLocalisation(process=self.scan_processing == "paper", exploration=self.exploration)

    @property
    def geometry(self) -> RobotGeometry:
        """The simulated robot's constants (`robot_radius_cm`, or the default 8 cm robot)."""
        return self.robot.geometry

    @property
    def pose_clearance_cm(self) -> float:
        """Least distance of true poses from the walls: `clearance_cm`, or the given radius + 2 cm."""
        return self.clearance_cm if self.robot_radius_cm is None else self.robot_radius_cm + 2.0

    @property
    def robot(self) -> RobotModel:
        """The one robot model of the run: the simulator reads and moves with it, every localiser is told it."""
        base = RobotModel.build(self.sonar if self.sonar_model is None else self.sonar_model,
                                sensor_noise=self.sensor_noise, noise_model=self.noise_model,
                                motion_noise=self.motion_noise, turn_noise=self.turn_noise,
                                radius_cm=self.robot_radius_cm)
        return with_robot_sets(base, dict(self.robot_sets)) if self.robot_sets else base

    @property
    def noise(self) -> MotionNoise:
        return self.robot.motion

    @property
    def simulated_sonar(self) -> SonarModel:
        """The model the simulated robot reads with."""
        return self.robot.sonar

    def robot_options(self, localiser: str) -> dict[str, Any]:
        """The robot model as options of `localiser` (`localisation.robot_options.localiser_options`);
        with ``lobe="off"`` without the lobe and the NXT's beam mixture (a thin ray)."""
        return localiser_options(localiser, self.robot, leave_out=THIN_RAY if self.lobe == "off" else ())

    def to_dict(self) -> dict[str, Any]:
        return {
            "sonar": self.sonar, "sensor_noise": self.sensor_noise, "sonar_model": self.simulated_sonar.to_dict(),
            "noise": self.noise.to_dict(),
            "tracker_prior": self.tracker_prior, "prior_sd_cm": self.prior_sd[0],
            "prior_sd_deg": self.prior_sd[1], "clearance_cm": self.pose_clearance_cm,
            "robot_radius_cm": self.geometry.radius_cm,
            "tracking_steps": self.tracking_steps, "tracking_step_cm": list(self.tracking_step_cm),
            "kidnap_min_cm": self.kidnap_min_cm, "recovery_rounds": self.recovery_rounds,
            "scan_processing": self.scan_processing, "lobe": self.lobe,
            "global_localisation": asdict(self.strategy),
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
        What the global strategy (`localisation.global_localisation`) returned (its per-look trace for plots).
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


# -- trial results ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrialKey:
    """Which trial a result is: map, localiser, trial number and seed (the first columns of every CSV)."""

    map: str
    localiser: str
    trial: int
    seed: int


_KEY_FIELDS = frozenset(TrialKey.__dataclass_fields__)


class _KeyedTrial:
    """A trial result whose `key`'s fields read as its own (``run.map``, ``run.seed``): the CSV's column names."""

    key: TrialKey

    def __getattr__(self, name: str) -> Any:
        if name in _KEY_FIELDS and "key" in self.__dict__:
            return getattr(self.key, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def _row(self, columns: tuple[str, ...]) -> dict[str, Any]:
        return {k: getattr(self, k) for k in columns}


@dataclass(frozen=True)
class GlobalRun(_KeyedTrial):
    """One global-localisation trial (a row of ``runs.csv``)."""

    key: TrialKey
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
        return self._row(RUNS_COLUMNS)


@dataclass(frozen=True)
class TrackingRun(_KeyedTrial):
    """One tracking trial (a row of ``tracking.csv``); errors are against the true pose after every action."""

    key: TrialKey
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
    blind_steps: int = 0
    """Actions after which the localiser's scan held no reading (no wall within the sonar's reach)."""
    rmse_echo_cm: float = math.nan
    """RMSE over the other actions (NaN when every scan was blind)."""
    rmse_blind_cm: float = math.nan
    """RMSE over the blind actions (NaN when none was)."""
    dead_reckoning_rmse_cm: float = math.nan
    """RMSE of dead reckoning: the prior's mean moved by each action as executed, without noise, never
    corrected by a reading. With no reading that is the best estimate there is (no filter beats it on
    average on blind actions); elsewhere it shows what the readings are worth."""
    failure: str = field(default="", repr=False)
    scenario: str = field(default="tracking", repr=False)

    def to_dict(self) -> dict[str, Any]:
        return self._row(TRACKING_COLUMNS)


@dataclass(frozen=True)
class KidnappedRun(_KeyedTrial):
    """One kidnapped-robot trial (a row of ``kidnapped.csv``).

    `recovery_iterations` and `recovery_scans` count the procedure's iterations and scans after the
    teleport until it ended converged within the success tolerance (-1 when it never recovered);
    `error_cm` and `heading_error_deg` are those of the last estimate; `time_s` is the wall-clock time
    of the whole trial.
    """

    key: TrialKey
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
        return self._row(KIDNAPPED_COLUMNS)


TrialResult = GlobalRun | TrackingRun | KidnappedRun


# -- writers ----------------------------------------------------------------------------------------

COLUMNS = {"global": RUNS_COLUMNS, "tracking": TRACKING_COLUMNS, "kidnapped": KIDNAPPED_COLUMNS}


FILES = {"global": "runs.csv", "tracking": "tracking.csv", "kidnapped": "kidnapped.csv"}
