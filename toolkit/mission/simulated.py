"""One seeded mission on the simulator: seeds, random starts and `run_sim_mission`."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from localisation.base import Localiser
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
    from ..recording import Recorder


def run_sim_mission(
    map: Map | str,
    *,
    seed: int = 0,
    start: Pose | ArrayLike | None = None,
    random_start_pose: bool = False,
    target: ArrayLike | None = None,
    planner: str | Planner = "min-turn",
    localiser: str | Localiser = "paper-pf",
    noise_model: str = "botsim",
    sensor_noise: float = 1.0,
    motion_noise: float = 0.1,
    turn_noise: float = 0.005,
    sonar: str = "ideal",
    sonar_model: NxtSonar | None = None,
    config: MissionConfig | None = None,
    recorder: Recorder | None = None,
    robot_radius_cm: float | None = None,
) -> MissionReport:
    """One seeded mission on the simulator, as `nxtnav run` and `nxtnav paper` run it.

    Parameters
    ----------
    map : Map or str
    seed : int
        Expands (`toolkit.seeds.derive_seeds(seed, n=3)`) into the start heading (or random start),
        the simulator's noise and the stack's draws: the same seed gives the same mission.
    start : Pose, (x, y) or None
        True start pose; (x, y) gets a seeded random heading; None is the map's preset start with a
        seeded random heading.
    random_start_pose : bool
        Ignore `start` and draw a free pose at least 10 cm from every wall.
    target : (2,) array_like or None
        Target (cm); None is the map's preset.
    planner, localiser : str or plug-in
    noise_model : {"botsim", "absolute"}
    sensor_noise, motion_noise, turn_noise : float
        Noise of the ``ideal`` sonar (cm), motion noise (fraction or cm) and turn noise (fraction or rad);
        the paper's by default. The ``nxt`` sonar's noise is part of its model.
    sonar : {"ideal", "nxt"}
    sonar_model : NxtSonar, optional
        The ``nxt`` sonar's model (a fitted profile's, `toolkit.sonar_fit.load_sonar_profile`): the
        simulator reads with it and the localiser is told it (`localisation.robot_options`). None: the
        model's defaults. Only with ``sonar="nxt"``.
    config : MissionConfig or None
        None: `MissionConfig.for_sonar(sonar)`.
    recorder : toolkit.recording.Recorder, optional
        Passed to `run_mission`.
    robot_radius_cm : float, optional
        Radius of the robot disc (cm; default `RobotGeometry`'s 8 cm): a robot scaled to the map. The
        random start keeps it plus 2 cm from the walls, and localisers that take ``clearance_cm``
        get it.
    """
    from ..robots.sim import SimRobot

    if sonar_model is not None and sonar != "nxt":
        raise NxtnavError(f"a sonar model (profile) is for the nxt sonar, not {sonar!r}")
    robot_model = RobotModel.build(sonar if sonar_model is None else sonar_model, sensor_noise=sensor_noise,
                                   noise_model=noise_model, motion_noise=motion_noise, turn_noise=turn_noise,
                                   radius_cm=robot_radius_cm)
    geometry = robot_model.geometry

    m = map if isinstance(map, Map) else load_map(map)
    s_start, s_sim, s_stack = derive_seeds(seed, n=3)
    start_rng = np.random.default_rng(s_start)
    if random_start_pose:
        pose = m.random_pose(start_rng, 10.0 if robot_radius_cm is None else geometry.radius_cm + 2.0)
    elif isinstance(start, Pose):
        pose = start
    else:
        xy = m.start if start is None else np.asarray(start, dtype=float).ravel()
        if xy is None:
            raise NxtnavError(f"map {m.name} has no preset start: give one")
        if xy.shape != (2,) or not np.all(np.isfinite(xy)):
            raise NxtnavError(f"start must be (x, y) or a Pose, got {np.asarray(start).tolist()!r}")
        pose = Pose(float(xy[0]), float(xy[1]), float(start_rng.uniform(-math.pi, math.pi)))
    if target is None:
        if m.target is None:
            raise NxtnavError(f"map {m.name} has no preset target: give one")
        target = m.target
    cfg = config or MissionConfig.for_sonar(sonar)
    if isinstance(localiser, str):
        opts = localiser_options(localiser, robot_model)
        cfg = replace(cfg, localiser_options={**opts, **dict(cfg.localiser_options)})
    checker = make_checker(m, geometry.radius_cm, cfg.collision)  # the simulator's contacts too: one backend
    robot = SimRobot(m, pose, geometry=geometry, noise=robot_model.motion, sonar=robot_model.sonar, rng=s_sim,
                     checker=checker)
    report = run_mission(robot, m, target, planner=planner, localiser=localiser, rng=s_stack, config=cfg,
                         recorder=recorder)
    return replace(report, seed=int(seed))
