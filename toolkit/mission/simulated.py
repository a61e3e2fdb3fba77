"""One seeded mission on the simulator: seeds, random starts and `run_sim_mission`."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from localisation.base import HeadingPrior, Localiser
from localisation.robot_options import localiser_options
from planners.base import Planner

from ..seeds import derive_seeds
from ..world import (
    Map,
    NxtnavError,
    NxtSonar,
    Pose,
    RobotModel,
    load_map,
    make_checker,
)
from .config import MissionConfig
from .report import MissionReport
from .runner import run_mission

if TYPE_CHECKING:
    from ..recordings.recorder import Recorder


def run_sim_mission(map: Map | str, *, seed: int = 0, start: Pose | ArrayLike | None = None,
                    random_start_pose: bool = False, target: ArrayLike | None = None,
                    planner: str | Planner = "min-turn", localiser: str | Localiser = "paper-pf",
                    noise_model: str = "botsim", sensor_noise: float = 1.0, motion_noise: float = 0.1,
                    turn_noise: float = 0.005, sonar: str = "ideal", sonar_model: NxtSonar | None = None,
                    config: MissionConfig | None = None, recorder: Recorder | None = None,
                    robot_radius_cm: float | None = None, start_heading: HeadingPrior | None = None,
                    robot: RobotModel | None = None) -> MissionReport:
    """One seeded mission on the simulator, as `nxtnav run` and `nxtnav paper` run it.

    Parameters
    ----------
    map : Map or str
    seed : int
        Expands (`toolkit.seeds.derive_seeds(seed, n=3)`) into the start heading (or random start),
        the simulator's noise and the stack's draws: the same seed gives the same mission.
    start : Pose, (x, y) or None
        True start pose; (x, y), or None (the map's preset start), gets a seeded random heading.
    random_start_pose : bool
        Ignore `start` and draw a free pose at least 10 cm from every wall.
    target : (2,) array_like or None
        Target (cm); None is the map's preset.
    planner, localiser : str or plug-in
    noise_model, sensor_noise, motion_noise, turn_noise : {"botsim", "absolute"}, float
        The noise model, the ``ideal`` sonar's noise (cm), motion noise (fraction or cm) and turn noise
        (fraction or rad); the paper's by default. The ``nxt`` sonar's noise is part of its model.
    sonar, sonar_model : {"ideal", "nxt"}, NxtSonar or None
        The sonar, and the ``nxt`` one's model (a fitted profile's): the simulator reads with it and the
        localiser is told it (`localisation.robot_options`). None: the model's defaults.
    config : MissionConfig, optional (default: `MissionConfig.for_sonar(sonar)`)
    recorder : toolkit.recordings.recorder.Recorder, optional
    robot_radius_cm : float, optional
        The robot disc's radius (cm; default 8): a random start keeps it plus 2 cm from the walls, and
        localisers that take ``clearance_cm`` get it.
    start_heading : HeadingPrior, optional
        What the mission is told of the start's heading (`run_mission`).
    robot : RobotModel, optional
        The whole robot (``--set robot.*``): given, it replaces the noise, sonar and radius arguments.
    """
    from ..robots.sim import SimRobot

    robot_model = robot or _robot_of(sonar, sonar_model, dict(sensor_noise=sensor_noise, noise_model=noise_model,
                                                              motion_noise=motion_noise, turn_noise=turn_noise,
                                                              radius_cm=robot_radius_cm))
    radius = robot_model.geometry.radius_cm
    m = map if isinstance(map, Map) else load_map(map)
    s_start, s_sim, s_stack = derive_seeds(seed, n=3)
    pose = _start_pose(m, start, random_start_pose, np.random.default_rng(s_start),
                       10.0 if robot_radius_cm is None else radius + 2.0)
    target = _target(m, target)
    cfg = config or MissionConfig.for_sonar(sonar)
    if isinstance(localiser, str):
        cfg = cfg.with_localiser_defaults(localiser_options(localiser, robot_model))
    simulator = SimRobot(m, pose, geometry=robot_model.geometry, noise=robot_model.motion, sonar=robot_model.sonar,
                         timing=robot_model.timing, rng=s_sim,
                         checker=make_checker(m, radius, cfg.collision))  # the simulator's contacts: one backend
    report = run_mission(simulator, m, target, planner=planner, localiser=localiser,
                         rng=s_stack, config=cfg, recorder=recorder, truth=simulator, start_heading=start_heading)
    return replace(report, seed=int(seed))


def _robot_of(sonar: str, sonar_model: NxtSonar | None, noise: dict[str, Any]) -> RobotModel:
    """The robot model of `sonar` (or of the ``nxt`` sonar's `sonar_model`, a fitted profile's) with
    `noise` (`RobotModel.build`'s keyword arguments)."""
    if sonar_model is not None and sonar != "nxt":
        raise NxtnavError(f"a sonar model (profile) is for the nxt sonar, not {sonar!r}")
    return RobotModel.build(sonar if sonar_model is None else sonar_model, **noise)


def _target(m: Map, target: ArrayLike | None) -> ArrayLike:
    """The mission's target: the one given, else the map's preset (a map without one needs it given)."""
    chosen = m.target if target is None else target
    if chosen is None:
        raise NxtnavError(f"map {m.name} has no preset target: give one")
    return chosen


def _start_pose(m: Map, start: Pose | ArrayLike | None, random_start: bool, rng: np.random.Generator,
                clearance_cm: float) -> Pose:
    """The true start: drawn (`random_start`, `clearance_cm` from the walls), given, or the map's preset
    position, with a drawn heading where none is given."""
    if random_start:
        return m.random_pose(rng, clearance_cm)
    if isinstance(start, Pose):
        return start
    xy = m.start if start is None else np.asarray(start, dtype=float).ravel()
    if xy is None:
        raise NxtnavError(f"map {m.name} has no preset start: give one")
    if xy.shape != (2,) or not np.all(np.isfinite(xy)):
        raise NxtnavError(f"start must be (x, y) or a Pose, got {np.asarray(start).tolist()!r}")
    return Pose(float(xy[0]), float(xy[1]), float(rng.uniform(-math.pi, math.pi)))
