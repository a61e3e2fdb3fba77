"""Execution error: how far from the goal a robot ends when it drives a planned path open-loop.

The robot starts exactly at the path's first waypoint with a known heading (by default the heading
of the first segment) and, for each segment of the path, turns by the planned heading change and
moves the segment's length, never looking at its sensors. Motion noise (`MotionNoise`, the
paper's BotSim model by default) makes every repetition end somewhere else; the spread of the final
positions around the goal is the price of the path's turns and length. This measures the paper's
central claim that a path with fewer turns accumulates less error.

The repetitions are computed in numpy with exactly `SimRobot`'s noise semantics and draw order
(per repetition: turn noise, then the heading and distance noise of the move), so repetition ``i``
ends where a `SimRobot` seeded with the ``i``-th child of the same `SeedSequence` ends (see
`simulate_with_robot`, which drives the real simulator and is what the tests compare against).
Contacts with walls are found with the shared `CollisionChecker`: a motion that would touch
a wall stops at the contact, as in the simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..robots.sim import MotionNoise, SimRobot
from ..world import CollisionChecker, ConfigError, Map, PlanningError, Pose, RobotGeometry, wrap_angle
from ..world.arrays import FloatArray

__all__ = [
    "ExecutionError",
    "drive_commands",
    "execution_error",
    "repetition_seeds",
    "simulate_open_loop",
    "simulate_with_robot",
]


_SeedLike = int | np.random.SeedSequence | None


@dataclass(frozen=True, eq=False)
class ExecutionError:
    """The outcome of driving one path open-loop many times.

    Attributes
    ----------
    mean_cm, median_cm, std_cm, p90_cm : float
        Mean, median, standard deviation and 90th percentile of the final distance to the goal (cm).
    collision_fraction : float
        Fraction of repetitions in which the robot disc touched a wall (the motion stopped there).
    repeats : int
        Number of repetitions.
    turns : int
        Turn commands with a non-zero angle the robot executed per repetition.
    noise : MotionNoise
        The motion noise used.
    final_xy : (repeats, 2) ndarray
        Final positions (cm); not part of `to_dict`.
    """

    mean_cm: float
    median_cm: float
    std_cm: float
    p90_cm: float
    collision_fraction: float
    repeats: int
    turns: int
    noise: MotionNoise
    final_xy: FloatArray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "mean_cm": self.mean_cm,
            "median_cm": self.median_cm,
            "std_cm": self.std_cm,
            "p90_cm": self.p90_cm,
            "collision_fraction": self.collision_fraction,
            "repeats": self.repeats,
            "turns": self.turns,
            "noise": self.noise.to_dict(),
        }


def drive_commands(path: ArrayLike, start_heading: float | None = None) -> tuple[FloatArray, FloatArray, float]:
    """The open-loop commands for `path`: a turn then a move per segment.

    Consecutive collinear segments (same heading) are merged into one move and zero-length
    segments are dropped, as a robot would drive them.

    Parameters
    ----------
    path : (k, 2) array_like
        Waypoints (cm), k >= 2.
    start_heading : float or None
        Heading (rad) of the robot at the first waypoint; None faces the first segment.

    Returns
    -------
    turns : (s,) ndarray
        Turn before each move (rad, counter-clockwise positive, wrapped to [-pi, pi)).
    moves : (s,) ndarray
        Length of each move (cm).
    start_heading : float
        The heading used at the start (rad).
    """
    p = np.asarray(path, dtype=float).reshape(-1, 2)
    if len(p) < 2:
        raise PlanningError(f"a path to drive needs at least 2 waypoints, got {len(p)}")
    d = np.diff(p, axis=0)
    lengths = np.hypot(d[:, 0], d[:, 1])
    keep = lengths > 1e-9
    d, lengths = d[keep], lengths[keep]
    if len(lengths) == 0:
        h0 = 0.0 if start_heading is None else float(start_heading)
        return np.zeros(0), np.zeros(0), h0
    headings = np.arctan2(d[:, 1], d[:, 0])
    merged_h = [headings[0]]
    merged_l = [lengths[0]]
    for h, length in zip(headings[1:], lengths[1:], strict=True):
        if abs(wrap_angle(h - merged_h[-1])) < 1e-9:
            merged_l[-1] += length
        else:
            merged_h.append(h)
            merged_l.append(length)
    hs = np.asarray(merged_h)
    h0 = float(hs[0]) if start_heading is None else float(start_heading)
    turns = np.asarray(wrap_angle(np.diff(np.concatenate([[h0], hs]))), dtype=float).reshape(-1)
    return turns, np.asarray(merged_l), h0


def repetition_seeds(rng: _SeedLike, repeats: int) -> list[np.random.SeedSequence]:
    """One child `SeedSequence` per repetition, from an int seed or a `SeedSequence`."""
    ss = rng if isinstance(rng, np.random.SeedSequence) else np.random.SeedSequence(rng)
    return ss.spawn(repeats)


def _check_repeats(repeats: int) -> None:
    if repeats < 1:
        raise ConfigError(f"repeats must be >= 1, got {repeats}")


def simulate_open_loop(
    path: ArrayLike,
    checker: CollisionChecker,
    *,
    repeats: int = 100,
    noise: MotionNoise | None = None,
    rng: _SeedLike = None,
    start_heading: float | None = None,
) -> tuple[FloatArray, NDArray[np.bool_], int]:
    """Final positions of `repeats` open-loop drives of `path` (vectorised over repetitions).

    Parameters
    ----------
    path : (k, 2) array_like
        Waypoints (cm); the robot starts at ``path[0]``.
    checker : CollisionChecker
        The shared checker; its radius is the robot radius.
    repeats : int
        Number of repetitions.
    noise : MotionNoise or None
        Motion noise (default: the paper's BotSim values).
    rng : int, SeedSequence or None
        Seed; repetition ``i`` uses the ``i``-th child of ``SeedSequence(rng)``.
    start_heading : float or None
        Heading (rad) at the start; None faces the first segment.

    Returns
    -------
    final_xy : (repeats, 2) ndarray
        Final positions (cm).
    collided : (repeats,) bool ndarray
        Whether the robot touched a wall in that repetition.
    turns : int
        Non-zero turn commands per repetition.
    """
    _check_repeats(repeats)
    nz = noise or MotionNoise()
    turns, moves, h0 = drive_commands(path, start_heading)
    p0 = np.asarray(path, dtype=float).reshape(-1, 2)[0]
    s = len(moves)
    # SimRobot's draw order per repetition: turn noise, heading noise of the move, distance noise
    eps = np.empty((repeats, s, 3))
    for i, child in enumerate(repetition_seeds(rng, repeats)):
        eps[i] = np.random.default_rng(child).standard_normal((s, 3)) if s else np.zeros((0, 3))
    xy = np.tile(p0, (repeats, 1))
    theta = np.full(repeats, h0)
    collided = np.zeros(repeats, dtype=bool)
    for k in range(s):
        a, d = turns[k], moves[k]
        e_turn, e_head, e_move = eps[:, k, 0], eps[:, k, 1], eps[:, k, 2]
        if nz.model == "botsim":
            theta = wrap_angle(theta + a + a * e_turn * nz.turn)
            true_d = d + d * e_move * nz.motion
        else:
            theta = wrap_angle(theta + a + e_turn * nz.turn)
            true_d = d + e_move * nz.motion
        theta = wrap_angle(theta + e_head * nz.turn)
        end = xy + true_d[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
        free = checker.segments_free(xy, end)
        for j in np.flatnonzero(~free):
            frac = checker.first_contact(xy[j], end[j])
            end[j] = xy[j] + frac * (end[j] - xy[j])
            collided[j] = True
        xy = end
    return xy, collided, int(np.count_nonzero(np.abs(turns) > 1e-12))


def simulate_with_robot(
    path: ArrayLike,
    map: Map,
    *,
    repeats: int = 100,
    noise: MotionNoise | None = None,
    rng: _SeedLike = None,
    start_heading: float | None = None,
    robot_radius: float | None = None,
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The same drives as `simulate_open_loop`, with one `SimRobot` per repetition (slow, exact reference).

    The robot's collision watchdog is disabled and its sonar is noise-free, so the simulator draws
    random numbers for motion noise only, in the order `simulate_open_loop` reproduces.

    Returns
    -------
    final_xy : (repeats, 2) ndarray
        Final true positions (cm).
    collided : (repeats,) bool ndarray
        Whether the simulator counted a collision in that repetition.
    """
    _check_repeats(repeats)
    nz = noise or MotionNoise()
    turns, moves, h0 = drive_commands(path, start_heading)
    p0 = np.asarray(path, dtype=float).reshape(-1, 2)[0]
    geometry = RobotGeometry() if robot_radius is None else RobotGeometry(radius_cm=float(robot_radius))
    checker = CollisionChecker(map, geometry.radius_cm)
    final = np.empty((repeats, 2))
    collided = np.zeros(repeats, dtype=bool)
    for i, child in enumerate(repetition_seeds(rng, repeats)):
        robot = SimRobot(map, Pose(float(p0[0]), float(p0[1]), h0), geometry=geometry, noise=nz,
                         sonar="ideal", sensor_noise=0.0, watchdog_cm=-math.inf,
                         rng=np.random.default_rng(child), checker=checker)
        for a, d in zip(turns, moves, strict=True):
            robot.turn(float(a))
            robot.move(float(d))
        final[i] = robot.true_pose.xy
        collided[i] = robot.collisions > 0
    return final, collided


def execution_error(
    path: ArrayLike,
    checker: CollisionChecker,
    *,
    goal: ArrayLike | None = None,
    repeats: int = 100,
    noise: MotionNoise | None = None,
    rng: _SeedLike = None,
    start_heading: float | None = None,
) -> ExecutionError:
    """Drive `path` open-loop `repeats` times under `noise` and summarise the final distance to the goal.

    Parameters
    ----------
    path : (k, 2) array_like
        Waypoints (cm), k >= 2; the robot starts at the first.
    checker : CollisionChecker
        The shared checker (robot radius = its radius).
    goal : (2,) array_like or None
        Goal position (cm); default the last waypoint.
    repeats : int
        Number of seeded repetitions (default 100).
    noise : MotionNoise or None
        Motion noise; default ``MotionNoise("botsim", 0.1, 0.005)`` (the paper's).
    rng : int, SeedSequence or None
        Seed of the repetitions.
    start_heading : float or None
        Heading (rad) at the start, known exactly; None faces the first segment.

    Examples
    --------
    >>> from toolkit.world import load_map
    >>> m = load_map("map1")
    >>> err = execution_error([[20, 20], [20, 80], [80, 80]], CollisionChecker(m, 8.0), rng=0)
    >>> 0 < err.mean_cm < 20
    True
    """
    nz = noise or MotionNoise()
    final, collided, turns = simulate_open_loop(path, checker, repeats=repeats, noise=nz, rng=rng,
                                                start_heading=start_heading)
    g = np.asarray(path, dtype=float).reshape(-1, 2)[-1] if goal is None else np.asarray(goal, float).reshape(2)
    dist = np.hypot(final[:, 0] - g[0], final[:, 1] - g[1])
    return ExecutionError(
        mean_cm=float(dist.mean()),
        median_cm=float(np.median(dist)),
        std_cm=float(dist.std(ddof=1)) if repeats > 1 else 0.0,
        p90_cm=float(np.percentile(dist, 90)),
        collision_fraction=float(collided.mean()),
        repeats=repeats,
        turns=turns,
        noise=nz,
        final_xy=final,
    )
