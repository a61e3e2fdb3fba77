"""The robot's cost of a path: its robot time, its predicted open-loop error, and the planners' objectives.

A path is a (k, 2) polyline (cm) the robot drives as the mission does: at each waypoint it stops,
turns in place to the next segment's heading, and drives the segment straight. The start heading
and the goal heading are free (the first segment starts facing its heading; no turn at the goal).

Robot time (`robot_time_s`) is `RobotTiming`'s own account of those commands, the one the simulator
charges (`toolkit.robots.sim.SimRobot`) and the model clock checks on the brick: each drive at
``drive_speed_cm_s``, each turn at ``turn_rate_deg_s`` plus the fixed ``stop_turn_s`` of a
stop-and-turn command.

Predicted open-loop error (`predicted_error_cm`) is the root-mean-square distance between where the
robot ends and the goal when it drives the path blind under its `MotionNoise`, in closed form to
first order in the noise (exact for the drive noise, linearised in the heading noise):

    E|e|^2 = sum_i var(delta d_i) + sum_j var(eta_j) * |g - p_(j-1)|^2

where segment ``i`` of length ``d_i`` has distance noise ``delta d_i`` (``botsim``: ``d_i * motion``;
``absolute``: ``motion`` cm), and the heading noise ``eta_j`` drawn before segment ``j`` (its turn's,
``botsim``: ``|a_j| * turn``, ``absolute``: ``turn`` rad per turn; plus ``turn`` rad per move) swings the
rest of the path, ``g - p_(j-1)``, about the segment's start. `monte_carlo_error_cm` draws the same
commands through the simulator's noise equations (seeded) to check the closed form.

Objectives (`OBJECTIVES`): ``length`` (cm), ``turns`` (interior waypoints turning by more than
`TURN_THRESHOLD_RAD`) and ``robot-time`` (s). `objective_cost` gives a path's cost under one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .arrays import FloatArray
from .errors import ConfigError
from .geometry import wrap_angle
from .robot_model import MotionNoise
from .robot_timing import RobotTiming

__all__ = ["OBJECTIVES", "OBJECTIVE_UNITS", "TURN_THRESHOLD_RAD", "PathCost", "check_objective",
           "monte_carlo_error_cm", "objective_cost", "path_cost", "predicted_error_cm", "robot_time_s", "robot_times_s",
           "segment_turns"]

OBJECTIVES = ("length", "turns", "robot-time")
"""What a planner can be asked to minimise."""
OBJECTIVE_UNITS = {"length": "cm", "turns": "turns", "robot-time": "s"}
TURN_THRESHOLD_RAD = math.radians(1.0)
"""A waypoint is a *turn* when the heading changes there by more than this (rad)."""
_EPS_CM = 1e-9
_EPS_RAD = 1e-9


def check_objective(objective: str, supported: tuple[str, ...] = OBJECTIVES, who: str = "") -> str:
    """`objective` when it is one of `supported`, else a `ConfigError` that names the choices."""
    if objective not in OBJECTIVES:
        raise ConfigError(f"unknown objective {objective!r}; choose one of {', '.join(OBJECTIVES)}")
    if objective not in supported:
        raise ConfigError(f"{who or 'this planner'} cannot optimise objective {objective!r}; "
                          f"it optimises {', '.join(supported)}")
    return objective


def _segments(path: ArrayLike) -> FloatArray:
    """Non-degenerate segment vectors of the path, shape (m, 2) (repeated waypoints dropped)."""
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        return np.empty((0, 2))
    d = np.diff(p, axis=0)
    return d[np.hypot(d[:, 0], d[:, 1]) > _EPS_CM]


def segment_turns(path: ArrayLike) -> FloatArray:
    """Signed heading change (rad, in [-pi, pi)) at each interior waypoint, zero-length segments skipped."""
    d = _segments(path)
    if len(d) < 2:
        return np.empty(0)
    return np.asarray(wrap_angle(np.diff(np.arctan2(d[:, 1], d[:, 0]))))


def robot_time_s(path: ArrayLike, timing: RobotTiming | None = None) -> float:
    """Robot time (s) to drive `path`: every segment by `RobotTiming.move`, every turn by `RobotTiming.turn`.

    >>> robot_time_s([[0, 0], [30, 0], [30, 15]])  # 45 cm at 15 cm/s, 90 degrees at 90 deg/s
    4.0
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) >= 2:
        step = np.hypot(*np.diff(p, axis=0).T)
        p = np.vstack([p[:1], p[1:][step > _EPS_CM]])
    return float(robot_times_s(p[None], timing)[0])


def robot_times_s(paths: ArrayLike, timing: RobotTiming | None = None) -> FloatArray:
    """Robot times (s) of many polylines at once, shape (m, k, 2) -> (m,): `robot_time_s` of each (their
    segments must have a length: a repeated waypoint would count as a turn to heading 0)."""
    t = timing or RobotTiming()
    p = np.asarray(paths, dtype=float)
    if p.shape[1] < 2:
        return np.zeros(p.shape[0])
    d = np.diff(p, axis=1)
    drive = np.hypot(d[..., 0], d[..., 1]).sum(axis=1) / t.drive_speed_cm_s
    heading = np.arctan2(d[..., 1], d[..., 0])
    turn = np.abs(np.asarray(wrap_angle(np.diff(heading, axis=1))))
    spin = np.degrees(turn) / t.turn_rate_deg_s + np.where(turn > _EPS_RAD, t.stop_turn_s, 0.0)
    return np.asarray(drive + np.where(turn > _EPS_RAD, spin, 0.0).sum(axis=1), dtype=float)


def _heading_variances(turns: FloatArray, n_moves: int, noise: MotionNoise) -> FloatArray:
    """Variance (rad^2) of the heading noise drawn before each segment's drive: its turn's and its move's."""
    var = np.full(n_moves, noise.turn**2)
    if n_moves > 1:
        turned = np.abs(turns) > _EPS_RAD
        var[1:] += np.where(turned, (turns * noise.turn) ** 2 if noise.model == "botsim" else noise.turn**2, 0.0)
    return var


def predicted_error_cm(path: ArrayLike, noise: MotionNoise | None = None) -> float:
    """Root-mean-square final position error (cm) of driving `path` open loop, in closed form (module notes).

    >>> round(predicted_error_cm([[0, 0], [100, 0]], MotionNoise("botsim", 0.1, 0.0)), 6)  # 10 % of 100 cm
    10.0
    """
    n = noise or MotionNoise()
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) >= 2:
        step = np.hypot(*np.diff(p, axis=0).T)
        p = np.vstack([p[:1], p[1:][step > _EPS_CM]])
    if len(p) < 2:
        return 0.0
    lengths = np.hypot(*np.diff(p, axis=0).T)
    drive_var = (lengths * n.motion) ** 2 if n.model == "botsim" else np.full(len(lengths), n.motion**2)
    lever = np.sum((p[-1] - p[:-1]) ** 2, axis=1)
    heading_var = _heading_variances(segment_turns(p), len(lengths), n)
    return float(math.sqrt(float(drive_var.sum() + (heading_var * lever).sum())))


def monte_carlo_error_cm(path: ArrayLike, noise: MotionNoise | None = None, runs: int = 2000,
                         seed: int = 0) -> float:
    """Root-mean-square final position error (cm) over `runs` seeded open-loop drives of `path`, each
    command drawn by the simulator's noise equations (`toolkit.robots.sim`); no walls."""
    n = noise or MotionNoise()
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    d = _segments(p)
    if len(d) == 0:
        return 0.0
    rng = np.random.default_rng(seed)
    lengths = np.hypot(d[:, 0], d[:, 1])
    turns = np.concatenate([[0.0], segment_turns(p)])
    heading = np.full(runs, math.atan2(d[0, 1], d[0, 0]))
    xy = np.tile(p[0], (runs, 1))
    for length, turn in zip(lengths, turns, strict=True):
        if abs(turn) > _EPS_RAD:
            eps = rng.standard_normal(runs) * n.turn
            heading = heading + turn + (turn * eps if n.model == "botsim" else eps)
        heading = heading + rng.standard_normal(runs) * n.turn
        eps = rng.standard_normal(runs) * n.motion
        driven = length + (length * eps if n.model == "botsim" else eps)
        xy = xy + driven[:, None] * np.column_stack([np.cos(heading), np.sin(heading)])
    return float(math.sqrt(float(np.mean(np.sum((xy - p[-1]) ** 2, axis=1)))))


def objective_cost(objective: str, path: ArrayLike, timing: RobotTiming | None = None) -> float:
    """Cost of `path` under `objective`: length (cm), turns (count) or robot time (s)."""
    check_objective(objective)
    if objective == "length":
        p = np.asarray(path, dtype=float).reshape(-1, 2)
        return float(np.sum(np.hypot(*np.diff(p, axis=0).T))) if len(p) >= 2 else 0.0
    if objective == "turns":
        return float(np.count_nonzero(np.abs(segment_turns(path)) > TURN_THRESHOLD_RAD))
    return robot_time_s(path, timing)


@dataclass(frozen=True)
class PathCost:
    """A path's cost to the robot: robot time (s) and predicted open-loop error (cm, closed form)."""

    robot_time_s: float
    predicted_error_cm: float

    def to_dict(self) -> dict[str, float]:
        return {"robot_time_s": self.robot_time_s, "predicted_error_cm": self.predicted_error_cm}


def path_cost(path: ArrayLike, timing: RobotTiming | None = None, noise: MotionNoise | None = None) -> PathCost:
    """`PathCost` of `path` for a robot with `timing` and motion `noise` (defaults: the simulator's)."""
    return PathCost(robot_time_s(path, timing), predicted_error_cm(path, noise))
