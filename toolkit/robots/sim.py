"""The simulated robot: BotSim's semantics with an exact collision model and a robot-time model.

Noise models (``MotionNoise.model``):

``botsim`` (BotSim's own, proportional)
    turn(a): heading += a + a * N(0,1) * turn; move(d): heading += N(0,1) * turn, then the robot
    drives d + d * N(0,1) * motion.
``absolute``
    turn(a): heading += a + N(0,1) * turn (rad per turn); move(d): heading += N(0,1) * turn, then
    the robot drives d + N(0,1) * motion (cm per move).

A forward move is carried out in steps of ``watchdog_step_cm`` commanded centimetres; after each step
the forward sonar is read and the move stops when it reads closer than ``watchdog_cm`` twice in a row
(the paper's collision watchdog; the second reading, at the same place, rejects the real sensor's
occasional short reading). Independently, the robot disc can never pass through a wall: a motion that would
touch one ends at the contact and counts as a true collision.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ..world import (
    CollisionChecker,
    ConfigError,
    Map,
    MotionNoise,
    MoveOutcome,
    Pose,
    RngLike,
    RobotError,
    RobotGeometry,
    RobotTiming,
    Scan,
    SonarModel,
    as_rng,
    default_scan_angles,
    make_sonar,
    wrap_angle,
)
from ..world.arrays import FloatArray
from .command_checks import finite_command
from .running_totals import RunningTotals

__all__ = ["MotionNoise", "RobotTiming", "SimRobot", "simulated_sonar"]


NoiseModelName = Literal["botsim", "absolute"]


def simulated_sonar(sonar: SonarModel | str, sensor_noise: float = 1.0) -> SonarModel:
    """The sonar model a simulated robot reads with: `sonar` itself when it is a model, else the
    registered model of that name. `sensor_noise` (cm) is the noise of the ``ideal`` sonar only; the
    ``nxt`` sonar's noise is part of its model (its defaults, or a fitted profile passed as a model).

    >>> simulated_sonar("ideal", 2.0).to_dict()
    {'name': 'ideal', 'noise_sd': 2.0}
    >>> simulated_sonar("nxt", 2.0).noise_sd == simulated_sonar("nxt").noise_sd  # not the option's 2 cm
    True
    """
    if not isinstance(sonar, str):
        return sonar
    return make_sonar(sonar, noise_sd=sensor_noise) if sonar == "ideal" else make_sonar(sonar)


class SimRobot(RunningTotals):
    """A simulated NXT robot in a map (implements `toolkit.world.Robot`).

    Parameters
    ----------
    map : Map
        The world.
    pose : Pose
        True start pose; must be collision-free.
    geometry : RobotGeometry
        Robot constants; the disc radius is used for true collisions.
    noise : MotionNoise
        Motion and turn noise (the paper's values by default).
    sonar : SonarModel or str
        The sonar model, or its name (`simulated_sonar`; ``ideal`` with `sensor_noise` by default).
    sensor_noise : float
        Noise (cm) of the ``ideal`` sonar given by name (the paper: 1 cm); the ``nxt`` sonar's comes
        from its model.
    watchdog_cm : float or None
        Forward reading (cm) under which a move stops; default radius + 4 cm.
    watchdog_step_cm : float
        Commanded distance between watchdog readings (cm).
    backoff_cm : float
        How far `turnback` reverses (cm).
    timing : RobotTiming
        The robot-time model; `robot_time_s` is split into `sweep_s`, `turret_return_s`, `drive_s`
        and `turn_s` (s), and `readings` counts the sonar readings of the sweeps.
    rng : None, int or Generator
        Seed of every noise draw.
    """

    def __init__(
        self,
        map: Map,
        pose: Pose,
        *,
        geometry: RobotGeometry | None = None,
        noise: MotionNoise | None = None,
        sonar: SonarModel | str = "ideal",
        sensor_noise: float = 1.0,
        watchdog_cm: float | None = None,
        watchdog_step_cm: float = 1.0,
        backoff_cm: float = 10.0,
        timing: RobotTiming | None = None,
        rng: RngLike = None,
        checker: CollisionChecker | None = None,
    ) -> None:
        self.map = map
        self.geometry = geometry or RobotGeometry()
        self.noise = noise or MotionNoise()
        self.sonar = simulated_sonar(sonar, sensor_noise)
        self.watchdog_cm = self.geometry.radius_cm + 4.0 if watchdog_cm is None else float(watchdog_cm)
        if watchdog_step_cm <= 0:
            raise ConfigError(f"watchdog_step_cm must be > 0, got {watchdog_step_cm}")
        self.watchdog_step_cm = float(watchdog_step_cm)
        self.backoff_cm = float(backoff_cm)
        self.timing = timing or RobotTiming()
        self.rng = as_rng(rng)
        if checker is not None and checker.robot_radius != self.geometry.radius_cm:
            raise ConfigError("checker radius differs from the robot geometry radius")
        self.checker = checker or CollisionChecker(map, self.geometry.radius_cm)
        if not self.checker.point_free(pose.xy):
            raise RobotError(
                f"start pose ({pose.x:.1f}, {pose.y:.1f}) puts the robot (radius {self.geometry.radius_cm} cm) "
                f"in collision or outside map {map.name!r}"
            )
        self._pose = pose
        self._time = 0.0
        self.collisions = 0
        self.reset_totals()
        self.last_scan_times_s: FloatArray | None = None  # robot time of each reading of the last sweep
        self.closed = False

    # -- truth (evaluation only) ------------------------------------------------------------------
    @property
    def true_pose(self) -> Pose:
        """The true pose, for evaluation and plots only (never for the localiser)."""
        return self._pose

    @property
    def watchdog_distance_cm(self) -> float:
        """The distance (cm) at which the watchdog stops a move (`watchdog_cm`)."""
        return self.watchdog_cm

    @property
    def backoff_distance_cm(self) -> float:
        """How far (cm) `turnback` reverses (`backoff_cm`)."""
        return self.backoff_cm

    def teleport(self, pose: Pose) -> None:
        """Put the robot at `pose` (kidnapped-robot experiments)."""
        if not self.checker.point_free(pose.xy):
            raise RobotError(f"cannot teleport into collision at ({pose.x:.1f}, {pose.y:.1f})")
        self._pose = pose

    @property
    def robot_time_s(self) -> float:
        """Modelled time a real NXT would have spent on the actions so far (s)."""
        return self._time

    # -- the paper's functions --------------------------------------------------------------------
    def _check_open(self) -> None:
        if self.closed:
            raise RobotError("robot is closed")

    def read_forward(self) -> float:
        """One sonar reading straight ahead (cm), as the watchdog sees it."""
        p = self._pose
        origin = p.xy + self.geometry.sensor_offset_cm * np.array([math.cos(p.theta), math.sin(p.theta)])
        return float(self.sonar.measure(self.map.walls, origin, np.array([p.theta]), self.rng)[0])

    def turn(self, angle_rad: float) -> None:
        """Spin in place by `angle_rad` (counter-clockwise positive) with turn noise."""
        self._check_open()
        a = finite_command(angle_rad, "turn angle")
        eps = self.rng.standard_normal() * self.noise.turn
        actual = a + (a * eps if self.noise.model == "botsim" else eps)
        self._pose = Pose(self._pose.x, self._pose.y, wrap_angle(self._pose.theta + actual))
        dt = self.timing.turn(a)
        self.turn_s += dt
        self._time += dt

    def move(self, distance_cm: float) -> MoveOutcome:
        """Drive `distance_cm` straight (negative = backwards); forward moves run the watchdog."""
        self._check_open()
        d = finite_command(distance_cm, "move distance")
        if d == 0.0:
            return MoveOutcome(0.0, 0.0, False)
        heading = wrap_angle(self._pose.theta + self.rng.standard_normal() * self.noise.turn)
        eps = self.rng.standard_normal() * self.noise.motion
        true_d = d + (d * eps if self.noise.model == "botsim" else eps)
        scale = true_d / d  # true cm per commanded cm
        direction = np.array([math.cos(heading), math.sin(heading)])
        self._pose = Pose(self._pose.x, self._pose.y, heading)
        done = 0.0
        watchdog = False
        step = self.watchdog_step_cm
        while abs(d) - done > 1e-9:
            # a low reading is read again before the robot stops: the NXT sensor gives short readings now
            # and then (about one in eight), and a watchdog that trusts one would stop most long moves
            if d > 0 and self.read_forward() < self.watchdog_cm and self.read_forward() < self.watchdog_cm:
                watchdog = True
                break
            cmd = min(step, abs(d) - done)
            start = self._pose.xy
            end = start + math.copysign(cmd * scale, d) * direction
            frac = self.checker.first_contact(start, end)
            if frac < 1.0:
                end = start + frac * (end - start)
                self._pose = Pose(end[0], end[1], heading)
                done += cmd * frac
                self.collisions += 1
                break
            self._pose = Pose(end[0], end[1], heading)
            done += cmd
        if watchdog:
            self.watchdog_stops += 1
        believed = math.copysign(done, d)
        self.odometry_cm += done
        dt = self.timing.move(done)
        self.drive_s += dt
        self._time += dt
        return MoveOutcome(d, believed, watchdog)

    def turnback(self) -> MoveOutcome:
        """Reverse `backoff_cm` to regain a safe distance after a watchdog stop."""
        return self.move(-self.backoff_cm)

    def ultrascan(self, angles: ArrayLike | None = None) -> Scan:
        """Sweep the turret over `angles` (rad, relative to the heading; default 360 at 1 degree)."""
        self._check_open()
        rel = default_scan_angles() if angles is None else np.asarray(angles, dtype=float).ravel()
        p = self._pose
        absolute = p.theta + rel
        off = self.geometry.sensor_offset_cm
        origins = p.xy[None, :] + off * np.column_stack([np.cos(absolute), np.sin(absolute)])
        ranges = self.sonar.measure(self.map.walls, origins, absolute[:, None], self.rng)[:, 0]
        sweep, back = self.timing.sweep(rel)
        self.last_scan_times_s = self._time + self.timing.reading_times(rel)
        self.sweep_s += sweep
        self.turret_return_s += back
        self.readings += int(rel.size)
        self._time += sweep + back
        return self.sonar.to_scan(rel, ranges)

    def stop(self) -> None:
        """Nothing moves between calls in the simulator; present for the protocol."""

    def close(self) -> None:
        """Mark the robot closed; later commands raise `RobotError`."""
        self.closed = True
