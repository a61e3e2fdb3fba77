"""``grid``: Markov localisation on a lattice of poses, the reference Bayes filter of amcl's models.

Grid localisation (Burgard, Fox et al. 1996; Thrun, Burgard and Fox, *Probabilistic Robotics*, ch. 4.1
and 8.2) keeps the belief as a probability for every pose of a fixed lattice: every `lattice_step`
cells of the range table in x and y, every table direction (1 degree) in heading, the cells at least
the robot's clearance from the walls. Nothing is sampled away: an update multiplies every pose's
probability by the scan's likelihood there, so a twin place keeps exactly the weight the sweeps give
it. It is coarse where a particle filter is continuous, and its cost grows with the map's area
rather than with the belief's spread; what it buys is the yardstick of the particle filters: it
answers "what would the Bayes posterior under these models say", the way the exact planners
(``shortest``, ``min-link``) answer "what is the best path".

Its models are amcl's, built from its own options (`localisation.declarations.GridOptions`: the part of
amcl's sensor and lobe groups a lattice is scored with, `LatticeSensor` and `LatticeLobe`, the shared
motion, convergence and mode groups, and the lattice): the
measurement model's lattice likelihood (`localisation.beam_model.lattice_costs`, every reading: the
NXT beam mixture with a `sonar_model`, else the Gaussian of `sigma_hit`), the range table, the motion
model and its noise.

predict
    Every pose holding probability within `PRUNE_NATS` of the most probable (at most
    `MAX_SUPPORT` poses) moves by `MOTION_SAMPLES` draws of the motion model (seeded by the
    localiser's rng); each draw carries its share of the pose's probability to the nearest lattice
    pose. Draws that end outside the lattice (in a wall, or nearer one than the clearance) are lost:
    the map's own prior. If every draw is lost the belief starts again uniform, with a warning.
update
    ``log b += log p(scan | pose)`` on every pose, then normalised.
support
    The poses within `PRUNE_NATS` of the most probable (at most `MAX_SUPPORT`), most probable first:
    ``particles`` (what `cloud` gives and a benchmark counts as the particles held).
estimate, modes
    The poses of the support are clustered as the particle filters' clouds are (`cluster`: within
    `mode_radius_cm` and `mode_heading_deg`); the estimate is the heaviest cluster's mean, with the
    whole belief's covariance (converged when its spread is below `converged_xy_cm` and
    `converged_heading_deg`); the modes are the clusters whose mass lies within `ambiguity_nats`
    (log ratio) of the heaviest's, so two or more make the belief ambiguous. A cluster whose mean lies
    within twice the mode radius and heading of a heavier mode is that mode's edge, not a place of its
    own.
"""

from __future__ import annotations

import logging
import math
from typing import Any, ClassVar

import numpy as np

from toolkit.world import ConfigError, Map, Options, Pose, RngLike, Scan, angle_diff
from toolkit.world.arrays import FloatArray, IntArray

from .amcl import Amcl
from .base import HeadingPrior, Localiser, Mode, Motion, PoseEstimate, Prior, RobotMapping
from .beam_model import lattice_costs
from .clusters import cloud_stats, cluster, in_mode, spread
from .declarations import GRID_ROBOT, GridOptions
from .resampling import log_normalise

__all__ = ["MAX_SUPPORT", "MOTION_SAMPLES", "PRUNE_NATS", "GridBayes"]

log = logging.getLogger(__name__)

MOTION_SAMPLES = 16
"""Draws of the motion model per pose of the support in a predict."""
PRUNE_NATS = 25.0
"""Poses less probable than the most probable by more than this (log ratio) are left out of predicts,
estimates and modes (e^-25: 1.4e-11 of the best)."""
MAX_SUPPORT = 200_000
"""At most this many of the most probable poses form the support."""
MAX_MODES = 8
"""Clusters looked at for the modes."""
MAX_POSES = 30_000_000
"""The largest lattice (cells x directions) a belief may have: 240 MB of float64, and as much again for a
predict's sums."""


class GridBayes(Localiser):
    """Markov localisation on a lattice (see the module docstring).

    Parameters
    ----------
    map : Map
    options : GridOptions, optional
        The options (None: the defaults).
    rng : None, int or Generator
        Seed of the motion draws.
    **overrides
        Options on top of `options`, by dotted path (``**{"lattice.lattice_step": 4}``) or by the name of
        one field (``lattice_step=4``).
    """

    name: ClassVar[str] = "grid"
    options_model: ClassVar[type[Options] | None] = GridOptions
    robot_options: ClassVar[RobotMapping | None] = GRID_ROBOT

    def __init__(self, map: Map, options: GridOptions | None = None, *, rng: RngLike = None,
                 **overrides: Any) -> None:
        super().__init__(map, rng=rng)
        o: GridOptions = self.configure(options, overrides)
        self.options = o
        models = Amcl(map, o.amcl(), rng=0)  # for its models alone: its own particles and seed are never used
        self.measurement, self.motion_model = models.measurement, models.motion_model
        self.table, self.lattice = models.table, models.lattice
        self.converged_xy_cm = o.convergence.converged_xy_cm
        self.converged_heading_rad = math.radians(o.convergence.converged_heading_deg)
        self.mode_radius_cm, self.ambiguity_nats = o.modes.mode_radius_cm, o.modes.ambiguity_nats
        self.mode_heading_rad = math.radians(o.modes.mode_heading_deg)
        self.iterations = 0
        self.particles: FloatArray = np.zeros((0, 3))
        self._log_belief: FloatArray = np.zeros((0, 0))
        self._support: IntArray = np.zeros(0, dtype=np.int64)
        self._grid_rows: IntArray | None = None
        self._heading_prior: HeadingPrior | None = None
        self._uniform = True
        self._estimate: PoseEstimate | None = None
        self._modes: list[Mode] = []
        self.reset()

    # -- Localiser interface ------------------------------------------------------------------------
    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        self.iterations = 0
        self._modes = []
        lat = self.lattice
        n_ang = self.table.n_angles
        if len(lat) * n_ang > MAX_POSES:
            raise ConfigError(f"grid: the lattice has {len(lat)} cells x {n_ang} directions, more than {MAX_POSES} "
                              f"poses; give a larger lattice_step (now {lat.step})")
        logb = np.zeros((len(lat), n_ang))
        self._heading_prior = prior if isinstance(prior, HeadingPrior) else None  # weighs the first update
        if isinstance(prior, Prior):
            poses = self._poses(np.arange(logb.size))
            cov = self._no_narrower_than_a_cell(np.asarray(prior.cov, dtype=float))
            d = poses - prior.mean.as_array()
            d[:, 2] = angle_diff(poses[:, 2], prior.mean.theta)
            logb = -0.5 * np.einsum("ni,ij,nj->n", d, np.linalg.inv(cov), d).reshape(logb.shape)
        self._uniform = not isinstance(prior, Prior)
        self._set_belief(logb)

    def predict(self, motion: Motion) -> None:
        if self._uniform and isinstance(self._heading_prior, HeadingPrior):
            self._heading_prior = self._heading_prior.turned(motion.turn_rad)
        if self._uniform or (motion.turn_rad == 0.0 and motion.distance_cm == 0.0):
            return  # a uniform belief stays uniform
        flat = self._log_belief.ravel()
        src = self._support
        mass = np.exp(flat[src] - flat[src].max()) / MOTION_SAMPLES
        moved = self.motion_model.sample(np.repeat(self.particles, MOTION_SAMPLES, axis=0), motion, self.rng)
        dest = self._index_of(moved)
        ok = dest >= 0
        if not ok.any():
            log.warning("grid: every motion draw left the free space; the belief starts again uniform")
            self.reset(None)
            return
        total = np.bincount(dest[ok], weights=np.repeat(mass, MOTION_SAMPLES)[ok], minlength=flat.size)
        with np.errstate(divide="ignore"):
            self._set_belief(np.log(total).reshape(self._log_belief.shape))

    def update(self, scan: Scan) -> None:
        rel, meas = self.measurement.readings(scan)
        if not np.any(self.measurement.echoes(meas)):
            log.warning("scan without usable readings: belief unchanged")
            return
        costs = lattice_costs(self.lattice, rel, meas, self.measurement.lattice_model(), max_beams=0)
        self.iterations += 1
        if self._heading_prior is not None:
            costs = costs + self._heading_prior.direction_costs(costs.shape[1])[None, :]
            self._heading_prior = None
        self._uniform = False
        self._set_belief(self._log_belief - 0.5 * costs)

    def estimate(self) -> PoseEstimate:
        assert self._estimate is not None
        return self._estimate

    @property
    def modes(self) -> list[Mode]:
        """The clusters within `ambiguity_nats` (log mass ratio) of the heaviest, heaviest first, when
        there are two or more; else none."""
        return list(self._modes) if len(self._modes) > 1 else []

    def cloud(self) -> tuple[FloatArray, FloatArray] | None:
        """The support's poses, most probable first, and their normalised probabilities."""
        return self.particles, log_normalise(self._log_belief.ravel()[self._support])

    # -- internals ----------------------------------------------------------------------------------
    def _no_narrower_than_a_cell(self, cov: FloatArray) -> FloatArray:
        """A prior's covariance (3, 3), symmetrised; where it is narrower than one lattice cell in some
        direction (a fix on one lattice pose has none: singular), widened there to the cell's own variance
        (a uniform cell: step^2 / 12, and a direction's (2 pi / n)^2 / 12); unchanged otherwise."""
        cov = 0.5 * (cov + cov.T)
        cell = np.sqrt(np.array([2 * [(self.lattice.step * self.table.resolution_cm) ** 2 / 12.0]
                                 + [(2.0 * math.pi / self.table.n_angles) ** 2 / 12.0]]).ravel())
        scaled = cov / np.outer(cell, cell)
        vals, vecs = np.linalg.eigh(scaled)
        if vals.min() >= 1.0:
            return cov
        return (vecs * np.maximum(vals, 1.0)) @ vecs.T * np.outer(cell, cell)

    def _poses(self, flat: IntArray) -> FloatArray:
        """The lattice poses (N, 3) of flat indices into the belief (cell * directions + direction)."""
        n_ang = self.table.n_angles
        cell, direction = np.divmod(np.asarray(flat, dtype=np.int64), n_ang)
        xy = self.lattice.xy[cell]
        return np.column_stack([xy, direction * (2.0 * math.pi / n_ang)])

    def _node(self, xy: FloatArray) -> IntArray:
        """The (i, j) node of the lattice's grid nearest each position (N, 2): the lattice's cells lie at the
        table's origin + (step * (i, j) + 0.5) * resolution."""
        lat, t = self.lattice, self.table
        return np.rint((xy - t.origin) / (t.resolution_cm * lat.step) - 0.5 / lat.step).astype(np.int64)

    def _cell_index(self) -> IntArray:
        """The lattice row of every (i, j) node of the lattice's grid (-1: not a lattice cell), built once."""
        grid = self._grid_rows
        if grid is None:
            ij = self._node(self.lattice.xy)
            grid = np.full(tuple(ij.max(axis=0) + 2), -1, dtype=np.int64)
            grid[ij[:, 0], ij[:, 1]] = np.arange(len(self.lattice))
            self._grid_rows = grid
        return grid

    def _index_of(self, poses: FloatArray) -> IntArray:
        """The flat belief index of the lattice pose nearest each pose (N, 3); -1 off the lattice."""
        t, grid = self.table, self._cell_index()
        ij = self._node(poses[:, :2])
        inside = (ij >= 0).all(axis=1) & (ij[:, 0] < grid.shape[0]) & (ij[:, 1] < grid.shape[1])
        row = np.full(poses.shape[0], -1, dtype=np.int64)
        row[inside] = grid[ij[inside, 0], ij[inside, 1]]
        n_ang = t.n_angles
        direction = np.mod(np.rint(poses[:, 2] * n_ang / (2.0 * math.pi)).astype(np.int64), n_ang)
        return np.where(row >= 0, row * n_ang + direction, -1)

    def _set_belief(self, logb: FloatArray) -> None:
        """Normalise the log belief, find its support and form the estimate and the modes from it."""
        flat = logb.ravel()
        top = float(flat.max())
        flat = flat - (top + math.log(float(np.exp(flat - top).sum())))
        self._log_belief = flat.reshape(logb.shape)
        keep = np.flatnonzero(flat >= flat.max() - PRUNE_NATS)
        if keep.size > MAX_SUPPORT:
            keep = keep[np.argpartition(-flat[keep], MAX_SUPPORT)[:MAX_SUPPORT]]
        self._support = keep[np.argsort(-flat[keep], kind="stable")]
        self.particles = self._poses(self._support)  # the poses the belief carries (benchmarks count them)
        self._estimate, self._modes = self._judge()

    def _judge(self) -> tuple[PoseEstimate, list[Mode]]:
        """The estimate (the heaviest cluster's mean, the whole belief's covariance) and the modes."""
        p, lw = self.particles, self._log_belief.ravel()[self._support]
        w = log_normalise(lw)
        _, cov = cloud_stats(p, w)
        labels, log_masses = cluster(p, lw, self.mode_radius_cm, self.mode_heading_rad, MAX_MODES)
        modes: list[Mode] = []
        for k in np.argsort(-log_masses):
            if log_masses[k] < log_masses.max() - self.ambiguity_nats:
                break
            members = labels == k
            mean, _ = cloud_stats(p[members], w[members] / float(w[members].sum()))
            if any(in_mode(mean[None, :], m.pose.as_array(), 2 * self.mode_radius_cm, 2 * self.mode_heading_rad)[0]
                   for m in modes):
                continue  # the edge of a heavier mode, cut off by the clusters' radius: the same place
            modes.append(Mode(Pose.from_array(mean), float(math.exp(log_masses[k])), float(lw[members].max()),
                              int(members.sum())))
        spread_xy, spread_th = spread(cov)
        converged = (not self._uniform and spread_xy < self.converged_xy_cm
                     and spread_th < self.converged_heading_rad)
        return PoseEstimate(modes[0].pose, cov, bool(converged), self.iterations), modes
