"""A reference particle filter: the paper's algorithm written plainly, as a test oracle for ``paper-pf``.

The paper (Liu et al., "Particle Filter Localisation") fills the map with random particles, weighs
each by the Gaussian likelihood of the difference between the range it would read and the robot's
reading (its eq. 4, sigma the sensor's noise), ranks the particles, reallocates them around the
heavy ones and repeats on the same scan until the cloud narrows. Between scans the particles move by
the commanded motion with noise.

Nothing here is fast or clever on purpose: the ranges a particle would read come from testing every
ray against every wall (`toolkit.world.ray_wall_distances`, no index, no table, no cache); weights
are normalised in log space only so that they do not underflow; resampling is multinomial; the
jitter after each resampling is a Gaussian that halves from one iteration to the next. It is not a
registered localiser: the tests run it beside ``paper-pf`` (range tables, lattice starts, annealing,
modes) on the same scans, to check that those speed-ups change the cost, not the answer.
"""

from __future__ import annotations

import math

import numpy as np

from toolkit.world import Map, Pose, RngLike, Scan, circular_mean, ray_wall_distances, wrap_angle
from toolkit.world.arrays import FloatArray

from .base import HeadingPrior, Localiser, Motion, PoseEstimate, Prior

__all__ = ["ReferenceParticleFilter"]


class ReferenceParticleFilter(Localiser):
    """The paper's particle filter without speed-ups (see the module docstring).

    Parameters
    ----------
    map : Map
    rng : None, int or Generator
    n_particles : int
        Particles in the cloud.
    sensor_sigma_cm : float
        Standard deviation of a range reading (the paper's simulations: 1 cm).
    clearance_cm : float
        Uniform starts draw particles at least this far from every wall (the robot's radius).
    motion_noise, turn_noise : float
        The simulator's proportional noise: a fraction of each move, and of each turn (plus that
        many radians of heading noise per move).
    iterations : int
        Weigh-and-reallocate rounds per scan at most.
    jitter_xy_cm, jitter_heading_deg : float
        Spread of the copies after the first reallocation (halved at each later one).
    converged_xy_cm, converged_heading_deg : float
        The cloud counts as narrow once its position and heading spreads are below these; the rounds
        on a scan stop there.
    """

    def __init__(self, map: Map, *, rng: RngLike = None, n_particles: int = 2000, sensor_sigma_cm: float = 1.0,
                 clearance_cm: float = 8.0, motion_noise: float = 0.1, turn_noise: float = 0.005,
                 iterations: int = 12, jitter_xy_cm: float = 2.0, jitter_heading_deg: float = 2.0,
                 converged_xy_cm: float = 1.5, converged_heading_deg: float = 2.0) -> None:
        super().__init__(map, rng=rng)
        self.n = n_particles
        self.sigma = sensor_sigma_cm
        self.clearance = clearance_cm
        self.motion_noise, self.turn_noise = motion_noise, turn_noise
        self.iterations = iterations
        self.jitter_xy, self.jitter_heading = jitter_xy_cm, math.radians(jitter_heading_deg)
        self.converged_xy, self.converged_heading = converged_xy_cm, math.radians(converged_heading_deg)
        self.rounds = 0
        self.reset()

    # -- the belief -------------------------------------------------------------------------------
    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        """Uniform particles over the free space (no prior; a `HeadingPrior`: headings drawn from it), or
        drawn from the Gaussian `prior`."""
        if prior is None or isinstance(prior, HeadingPrior):
            xy = self.map.sample_free(self.n, self.clearance, self.rng)
            theta = (self.rng.uniform(-math.pi, math.pi, self.n) if prior is None
                     else prior.sample(self.n, self.rng))
            self.particles = np.column_stack([xy, theta])
        else:
            mean = np.array([prior.mean.x, prior.mean.y, prior.mean.theta])
            self.particles = self.rng.multivariate_normal(mean, prior.cov, self.n)
            self.particles[:, 2] = wrap_angle(self.particles[:, 2])
        self.weights = np.full(self.n, 1.0 / self.n)
        self.rounds = 0

    def predict(self, motion: Motion) -> None:
        """Turn, then drive, every particle, each with its own draw of the simulator's noise."""
        p = self.particles
        if motion.turn_rad:
            p[:, 2] += motion.turn_rad * (1.0 + self.turn_noise * self.rng.standard_normal(self.n))
        if motion.distance_cm:
            p[:, 2] += self.turn_noise * self.rng.standard_normal(self.n)
            d = motion.distance_cm * (1.0 + self.motion_noise * self.rng.standard_normal(self.n))
            p[:, 0] += d * np.cos(p[:, 2])
            p[:, 1] += d * np.sin(p[:, 2])
        p[:, 2] = wrap_angle(p[:, 2])

    def update(self, scan: Scan) -> None:
        """Weigh by the scan, reallocate around the heavy particles, and repeat until the cloud is narrow."""
        angles, readings = _valid(scan)
        if readings.size == 0:
            return
        for k in range(self.iterations):
            self.weights = self._weigh(angles, readings)
            self.rounds += 1
            if self._narrow():
                return
            keep = self.rng.choice(self.n, size=self.n, p=self.weights)
            spread = 0.5 ** k
            self.particles = self.particles[keep] + self.rng.standard_normal((self.n, 3)) * np.array(
                [self.jitter_xy * spread, self.jitter_xy * spread, self.jitter_heading * spread])
            self.particles[:, 2] = wrap_angle(self.particles[:, 2])
        self.weights = self._weigh(angles, readings)

    def estimate(self) -> PoseEstimate:
        """Weighted mean (circular for the heading) and covariance of the cloud."""
        p, w = self.particles, self.weights
        x, y = float(w @ p[:, 0]), float(w @ p[:, 1])
        theta = float(circular_mean(p[:, 2], w))
        dev = np.column_stack([p[:, 0] - x, p[:, 1] - y, wrap_angle(p[:, 2] - theta)])
        cov = (dev * w[:, None]).T @ dev
        return PoseEstimate(Pose(x, y, theta), cov, self._narrow(), self.rounds)

    def cloud(self) -> tuple[FloatArray, FloatArray]:
        return self.particles.copy(), self.weights.copy()

    # -- the paper's likelihood -------------------------------------------------------------------
    def expected_ranges(self, poses: FloatArray, angles: FloatArray) -> FloatArray:
        """The range each pose would read along each scan angle (relative to its heading): (P, A) cm."""
        absolute = (poses[:, 2:3] + angles[None, :]).ravel()
        ox, oy = np.repeat(poses[:, 0], angles.size), np.repeat(poses[:, 1], angles.size)
        d = ray_wall_distances(self.map.walls, ox, oy, np.cos(absolute), np.sin(absolute)).min(axis=1)
        return d.reshape(len(poses), angles.size)

    def _weigh(self, angles: FloatArray, readings: FloatArray) -> FloatArray:
        """Normalised weights: the product over the readings of the Gaussian of eq. 4; particles outside
        the map weigh nothing."""
        expected = self.expected_ranges(self.particles, angles)
        residual = np.where(np.isfinite(expected), expected - readings[None, :], 1e3)
        log_w = -0.5 * np.sum((residual / self.sigma) ** 2, axis=1)
        log_w = np.where(self.map.contains(self.particles[:, :2]), log_w, -np.inf)
        w = np.exp(log_w - log_w.max())
        return np.asarray(w / w.sum())

    def _narrow(self) -> bool:
        p, w = self.particles, self.weights
        xy_var = float(w @ ((p[:, 0] - w @ p[:, 0]) ** 2 + (p[:, 1] - w @ p[:, 1]) ** 2))
        heading = float(circular_mean(p[:, 2], w))
        heading_var = float(w @ wrap_angle(p[:, 2] - heading) ** 2)
        return math.sqrt(xy_var) < self.converged_xy and math.sqrt(heading_var) < self.converged_heading


def _valid(scan: Scan) -> tuple[FloatArray, FloatArray]:
    """The scan's angles and readings where the sensor answered (no-echo readings carry no range)."""
    return np.asarray(scan.angles[scan.valid], dtype=float), np.asarray(scan.ranges[scan.valid], dtype=float)
