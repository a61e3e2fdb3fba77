"""The paper's particle filter (``paper-pf``), made fast.

The paper fills the map with random particles, weighs each by a Gaussian likelihood of the difference
between the ranges it would read and the robot's readings, reallocates particles around the heavy ones
and iterates until the cloud narrows. This implementation keeps that loop and makes it quick and
robust:

* weights live in log space (`RangeLikelihood`), so hundreds of beams never underflow;
* expected ranges come from a precomputed `RangeTable` (1 cm cells x 360 directions per map, built
  once and cached), vectorised over particles and beams;
* a global start scores every pose of a 2 cm x 1 degree lattice against the scan at once (an FFT
  correlation, `RangeLattice`) and starts from the best lattice poses: the paper's uniform
  particles made exhaustive, so that the narrow likelihood peak (and every twin) is found;
* the iterations on one scan are an annealing schedule: iteration ``m`` weighs the particles by the
  likelihood raised to ``beta_m`` (chosen so that the effective sample size stays near a target),
  resamples (systematic by default) and jitters the copies with a kernel that shrinks with the cloud.
  ``beta`` reaches 1 (the true sensor noise) before the filter may declare convergence;
* distinct modes (symmetric places, such as the identical rooms of map3) are kept apart: each mode is
  resampled on its own and the filter reports ``converged = False`` while more than one mode is
  plausible, so the localisation procedure moves and rescans.

Beyond the paper: a kidnapped robot is detected when no particle explains the scan (mean squared
normalised residual above a threshold) and the filter restarts globally.
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np

from toolkit.world import (
    NO_ECHO,
    ConfigError,
    LocalisationError,
    Map,
    Options,
    Pose,
    RngLike,
    Scan,
    wrap_angle,
)
from toolkit.world.arrays import FloatArray, IntArray

from .ambiguity import mass_near, other_candidates
from .annealing import GaussianPrior, best_lattice_poses, heading_gaussian, log_prior, next_beta, predicted_prior
from .base import HeadingPrior, Localiser, Mode, Motion, PoseEstimate, Prior, RobotMapping, Snapshot
from .beam_model import BeamLikelihood, MeasurementModel, echo_mask, lattice_costs, scan_readings
from .clusters import cloud_stats, describe_modes, mode_stds, spread
from .declarations import PF_ROBOT, PfOptions
from .models import MotionModel, RangeLattice, RangeLikelihood, RangeTable, exact_ranges
from .pf_ranges import outlier_fraction, range_setup
from .pf_steps import ModeSplit, MoveKernel, metropolis_move, resample_modes, split_modes
from .resampling import log_normalise, systematic_resample

__all__ = ["Mode", "ParticleFilter", "Snapshot"]

log = logging.getLogger(__name__)


class ParticleFilter(Localiser):
    """The paper's particle filter with annealed iterations on each scan (see the module docstring).

    Parameters
    ----------
    map : Map
    options : PfOptions, optional
        The options (`localisation.declarations.PfOptions`, in groups; None: the defaults), e.g.
        ``ParticleFilter(m, PfOptions(n_particles=2000, ranges=PfRanges(use_table=False)))``.
    rng : None, int or Generator
    **overrides
        Options on top of `options`, by dotted path (``**{"ranges.use_table": False}``) or by the name of
        one field (``use_table=False``).

    Notes
    -----
    What the options mean beyond their one-line descriptions (``nxtnav localisers show paper-pf``):

    n_particles : int
        Particles kept between scans and in the refining iterations.
    n_global : int
        Particles drawn uniformly over the free space for a global start.
    clearance_cm : float
        Particles are drawn at least this far from every wall (the robot radius).
    sensor_sigma_cm : float
        Standard deviation of a range reading (cm); the paper's simulations use 1 cm.
    residual_cap : float
        Largest residual one beam may contribute, in standard deviations (robustness to outliers).
    noise_model, motion_noise, turn_noise : str, float, float
        Motion noise as the robot's (`MotionModel`): ``botsim`` (proportional, the paper's 0.1 and
        0.005) or ``absolute``.
    motion_inflation : float
        Factor on the motion noise when predicting (> 1 tolerates unmodelled slip).
    ess_target : float
        Fraction of the particles the effective sample size is kept at when choosing ``beta``.
    max_iterations : int
        Iterations per scan at most.
    converged_xy_cm, converged_heading_deg : float
        The cloud counts as converged when sqrt(var x + var y) and the heading standard deviation
        are below these (and only one mode is left).
    global_beams : int
        Beams (evenly chosen) used in the first iteration of a global start, where the cloud is
        widest and the tempered likelihood is coarse.
    max_modes : int
        Modes tracked at most.
    mode_radius_cm, mode_heading_deg : float
        Particles within both of a mode's best particle belong to that mode.
    ambiguity_nats : float
        At the full likelihood, a mode stays plausible while its best log-likelihood is within this
        of the best mode's (twins of a symmetric map score alike; their weights are too noisy to
        judge by). More than one plausible mode makes the belief ambiguous (not converged).
    cluster_coverage : float
        Modes are tracked separately once the `max_modes` heaviest clusters hold this fraction of the
        weight (before that the cloud is resampled as a whole).
    mode_share : float
        Fraction of the particles shared equally among the tracked modes (the rest in proportion
        to their weights): every candidate, however light, is refined before it is judged.
    per_mode_ess : bool
        Choose each ``beta`` so that every mode keeps the target ESS (slower; refines light twins as
        carefully as the heavy mode) instead of the cloud as a whole.
    recovery_threshold : float or None
        When, after the iterations on a scan, more than this fraction of the beams are off by more
        than 3 standard deviations at the best particle, no pose near the belief explains the scan
        and the filter restarts globally on the same scan (kidnapped robot); a fraction, not a mean,
        so that a sonar's occasional outliers do not trigger it. None disables it.
    global_init : {"lattice", "uniform"}
        How a global start draws its first particles. ``uniform``: `n_global` particles uniform over
        the free space and headings, as in the paper. ``lattice``: every cell of a lattice
        (`lattice_step` table cells apart) at every table direction is scored against the scan at
        once (`RangeLattice`, an FFT correlation), and the `n_particles` best lattice poses, jittered
        within their lattice cell, start the iterations. The lattice is the uniform start made
        exhaustive and deterministic; it finds every mode, including twins.
    lattice_step : int
        Lattice spacing in table cells.
    use_table : bool
        Expected ranges from the precomputed `RangeTable` (fast) or exact ray casting (slow).
    table_resolution_cm, table_angles : float, int
        Finest cell size and directions of the table.
    range_memory_mb : float, optional
        Memory budget of the table and the global-start lattice (MB); default ``$NXTNAV_RANGE_MEMORY_MB``
        or 1024. A map whose model needs more at 1 cm gets coarser cells (up to 5 cm) or uint16 ranges;
        one that cannot fit raises `LocalisationError` (see `localisation.models.range_table`).
    max_range_cm : float, optional
        The sonar's range limit: the table sees no wall beyond it (the NXT's 255 cm).
    beam_width_deg : float
        Sonar lobe width for the expected ranges (0: a thin ray, right for the ``ideal`` sonar; about
        20 for the NXT, whose reading is the nearest echo in its lobe).
    beam_rays : int
        Rays that sample the lobe when it is cast exactly (`tracking_exact`), as the sonar model
        samples it (`toolkit.world.NxtSonar`, 9); the table takes the minimum over its whole-degree
        directions instead.
    critical_incidence_deg : float, optional
        With a lobe: rays meeting a wall further than this from its normal do not echo (about 40
        for the NXT).
    tracking_exact : bool or None
        In a tracking update (the belief was not global), expected ranges come from exact ray
        casting (the indexed walls make 1000 particles x 124 beams a few milliseconds; a lobe costs
        `beam_rays` rays a beam) instead of the table. None (default): when the table's cells are
        coarser than 1 cm (a map too large for the memory budget at 1 cm), where its cells and whole
        degrees cost centimetres at long range (for a lobe, also the lobe's discrete rays).
    tracking_prior : bool
        In an update from a one-mode belief that was not global (tracking), the Metropolis moves
        target the predicted belief (a Gaussian fitted to the predicted cloud) times the tempered
        likelihood, not the likelihood alone: a scan with few readings then leaves the belief as
        predicted along the directions it does not constrain, instead of letting the moves spread
        the cloud there. An ambiguous belief (several modes) keeps the likelihood alone, unless
        `tracking_prior_modes`.
    tracking_prior_modes : bool or None
        With `tracking_prior`, an ambiguous belief's prior is a mixture of one Gaussian per mode of
        the predicted cloud (weighted by the modes' weights) instead of none: twins keep their own
        Gaussian (none is picked), and a belief that a few long readings leave spread along a wall
        (split into neighbouring modes) stays where odometry puts it along that wall instead of
        being re-fitted anywhere on it. None (default): with `tracking_exact`.
    sonar_model : NxtSonar, optional
        The sonar's beam mixture (`localisation.beam_model.BeamLikelihood`): no-echo readings count as
        evidence, wrong readings cannot outvote the rest, and the lobe, specular loss and range limit
        are the model's (they replace `beam_width_deg`, `beam_rays`, `critical_incidence_deg` and
        `max_range_cm`; `sensor_sigma_cm` and `residual_cap` are unused). None: the Gaussian of
        `sensor_sigma_cm` on the valid readings (the paper's model).
    cache_dir : path, optional
        Disk cache for the table (see `range_table`).
    snapshot_size : int
        Particles kept per iteration in `snapshots` (0 disables snapshots).
    """

    name: ClassVar[str] = "paper-pf"
    options_model: ClassVar[type[Options] | None] = PfOptions
    robot_options: ClassVar[RobotMapping | None] = PF_ROBOT

    def __init__(self, map: Map, options: PfOptions | None = None, *, rng: RngLike = None,
                 **overrides: Any) -> None:
        super().__init__(map, rng=rng)
        o: PfOptions = self.configure(options, overrides)
        if o.n_global < o.n_particles:
            raise ConfigError(f"need 10 <= n_particles <= n_global, got {o.n_particles}, {o.n_global}")
        self.options = o
        self.n_particles, self.n_global = o.n_particles, o.n_global
        self.clearance_cm = o.global_start.clearance_cm
        sonar_model, r = o.sensor.sonar_model, o.ranges
        beam_width_deg, beam_rays, critical_incidence_deg, max_range_cm = (
            r.beam_width_deg, r.beam_rays, r.critical_incidence_deg, r.max_range_cm)
        if sonar_model is not None:
            # the sonar's own beam mixture: its lobe, specular loss and range limit shape the table
            beam_width_deg, beam_rays = sonar_model.beam_width_deg, sonar_model.beam_rays
            critical_incidence_deg, max_range_cm = sonar_model.critical_incidence_deg, sonar_model.max_range_cm
        self.likelihood: MeasurementModel = (BeamLikelihood(sonar_model) if sonar_model is not None
                                             else RangeLikelihood(o.sensor.sensor_sigma_cm, o.sensor.residual_cap))
        self._likelihood = self.likelihood
        m = o.motion
        self.motion_model = MotionModel(m.noise_model, m.motion_noise, m.turn_noise, m.motion_inflation)
        self.ess_target, self.max_iterations = o.annealing.ess_target, o.annealing.max_iterations
        self.global_beams = o.annealing.global_beams
        self.converged_xy_cm = o.convergence.converged_xy_cm
        self.converged_heading_rad = math.radians(o.convergence.converged_heading_deg)
        modes = o.modes
        self.max_modes, self.mode_radius_cm = modes.max_modes, modes.mode_radius_cm
        self.mode_heading_rad = math.radians(modes.mode_heading_deg)
        self.ambiguity_nats, self.cluster_coverage = modes.ambiguity_nats, modes.cluster_coverage
        self.per_mode_ess, self.mode_share = modes.per_mode_ess, modes.mode_share
        self.recovery_threshold = o.global_start.recovery_threshold
        self.use_table = r.use_table
        self.tracking_prior, self.surprise_mass = o.tracking.tracking_prior, o.tracking.surprise_mass
        self.snapshot_size = o.snapshot_size
        ranges = range_setup(map, use_table=self.use_table, global_init=o.global_start.global_init,
                             clearance_cm=self.clearance_cm, table_resolution_cm=r.table_resolution_cm,
                             table_angles=r.table_angles, cache_dir=r.cache_dir, beam_width_deg=beam_width_deg,
                             critical_incidence_deg=critical_incidence_deg, range_memory_mb=r.range_memory_mb,
                             lattice_step=o.global_start.lattice_step, max_range_cm=max_range_cm, beam_rays=beam_rays,
                             reach_margin_cm=o.sensor.residual_cap * o.sensor.sensor_sigma_cm,
                             tracking_exact=o.tracking.tracking_exact)
        self.table: RangeTable | None = ranges.table
        self.lobe: dict[str, Any] = ranges.lobe
        self.tracking_exact = ranges.tracking_exact
        prior_modes = o.tracking.tracking_prior_modes
        self.tracking_prior_modes = self.tracking_exact if prior_modes is None else prior_modes
        self._exact = False
        self.global_init = o.global_start.global_init
        self.lattice: RangeLattice | None = ranges.lattice
        self.particles: FloatArray = np.zeros((0, 3))
        self.log_weights: FloatArray = np.zeros(0)
        self.snapshots: list[Snapshot] = []
        self.iterations = 0
        self.restarts = 0
        self._global = True
        self._converged = False
        self._outliers_at_best = 0.0  # share of the beams the best particle cannot explain
        self._modes: list[Mode] = []
        self._alternatives: list[Mode] = []  # the scan's other poses after a surprise (`_judge_surprise`)
        self._estimate: PoseEstimate | None = None
        self.reset()

    # -- the resampling scheme (filterpy variants override this) ---------------------------------
    def resample(self, weights: FloatArray, n: int) -> IntArray:
        """`n` indices drawn according to normalised `weights` (systematic resampling)."""
        return systematic_resample(weights, n, self.rng)

    # -- Localiser interface ------------------------------------------------------------------------
    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        self.snapshots = []
        self.iterations = 0
        self._converged = False
        self._modes, self._alternatives = [], []
        if prior is None or isinstance(prior, HeadingPrior):
            self._reset_global(prior)
        else:
            cov = np.asarray(prior.cov, dtype=float)
            p = self.rng.multivariate_normal(prior.mean.as_array(), 0.5 * (cov + cov.T), self.n_particles)
            p[:, 2] = wrap_angle(p[:, 2])
            self.particles = p
            self.log_weights = np.full(self.n_particles, -math.log(self.n_particles))
            self._global = False
            self._heading_prior = None
        self._estimate = self._make_estimate()

    _move_cap: tuple[float, float] = (math.inf, math.inf)

    _heading_prior: HeadingPrior | None = None

    def _reset_global(self, heading: HeadingPrior | None = None) -> None:
        """A uniform belief over the free space; with `heading`, the headings drawn from it, and the
        global start's fix weighed by it (see `HeadingPrior`)."""
        # with the lattice start the uniform cloud only stands for the belief until the first scan
        n = self.n_particles if self.global_init == "lattice" else self.n_global
        xy = self._sample_free(n)
        theta = self.rng.uniform(-math.pi, math.pi, n) if heading is None else heading.sample(n, self.rng)
        self.particles = np.column_stack([xy, theta])
        self.log_weights = np.full(n, -math.log(n))
        self._global = True
        self._heading_prior = heading

    def _sample_free(self, n: int) -> FloatArray:
        if self.table is None:
            return self.map.sample_free(n, self.clearance_cm, self.rng)
        xmin, ymin, xmax, ymax = self.map.bounds
        frac = max(self.map.free_space(0).area / ((xmax - xmin) * (ymax - ymin)), 1e-3)
        out: list[FloatArray] = []
        have = 0
        while have < n:
            m = int((n - have) / frac * 1.5) + 64
            cand = self.rng.uniform([xmin, ymin], [xmax, ymax], size=(m, 2))
            keep = cand[self.table.free(cand, self.clearance_cm)]
            out.append(keep)
            have += len(keep)
        return np.vstack(out)[:n]

    def predict(self, motion: Motion) -> None:
        if motion.turn_rad == 0.0 and motion.distance_cm == 0.0:
            return
        if self._global:
            if self._heading_prior is not None:  # the heading prior turns with the robot
                self._heading_prior = self._heading_prior.turned(motion.turn_rad)
            return  # a uniform belief stays uniform; the first scan will start the global search
        self.particles = self.motion_model.sample(self.particles, motion, self.rng)
        # the modes move with the cloud: an ambiguous belief's estimate is its best mode's pose, which
        # otherwise stayed where the last scan left it while the robot drove on (a blind depot track
        # reported a pose 38 cm and 166 degrees off while its cloud was 3 cm wide around the truth)
        self._modes, self._alternatives = (
            [replace(md, pose=Pose.from_array(self.motion_model.mean(md.pose.as_array(), motion))) for md in group]
            for group in (self._modes, self._alternatives))
        self._converged = False
        self._estimate = self._make_estimate()

    def update(self, scan: Scan) -> None:
        rel, meas, self.likelihood = scan_readings(scan, self._likelihood, self.map)
        if not np.any(echo_mask(meas, self.likelihood)):
            log.warning("scan without usable readings: belief unchanged")
            return
        tracking = not self._global
        if tracking and not self._any_inside():
            # every particle drove into a wall: the belief was wrong (or the robot was moved)
            log.info("no particle inside the free space: restarting global localisation")
            self.restarts += 1
            self._reset_global()
            tracking = False
        predicted = (self.particles, self.log_weights) if tracking else None
        self._alternatives = []
        if self._global and self.lattice is not None:
            self._lattice_start(rel, meas)
        self._exact = tracking and self.tracking_exact
        try:
            # one Gaussian stands for a one-mode belief only: twins keep the uniform prior (or, with
            # tracking_prior_modes, one Gaussian each), so that a fit to their joint cloud cannot pick
            # one of them
            unimodal = len(self._modes) <= 1
            use_prior = tracking and self.tracking_prior and (unimodal or self.tracking_prior_modes)
            prior = self._predicted_prior(not unimodal) if use_prior else None
            heading = None if tracking else self._heading_prior  # a first fix's heading prior
            if heading is not None:
                prior = [heading_gaussian(heading)]
            self._iterate(rel, meas, prior, rank_by_prior=heading is not None)
        finally:
            self._exact = False
            self._heading_prior = None  # a heading prior weighs the first fix only
        if tracking and self.recovery_threshold is not None and self._outliers_at_best > self.recovery_threshold:
            # no pose near the belief explains the scan: the robot was kidnapped (or the belief was wrong)
            log.info("%.0f %% of the beams are outliers at the best particle: restarting global localisation",
                     100 * self._outliers_at_best)
            self.restarts += 1
            self._reset_global()
            if self.lattice is not None:
                self._lattice_start(rel, meas)
            self._iterate(rel, meas)
            predicted = None
        if predicted is not None:
            self._judge_surprise(predicted, rel, meas)

    def _judge_surprise(self, predicted: tuple[FloatArray, FloatArray], rel: FloatArray, meas: FloatArray) -> None:
        """A tracking update that converged where the `predicted` cloud (particles, log weights) held less than
        `surprise_mass` of its weight within one mode: the motion told the filter something else (a
        twin won because the odometry or a heading was wrong). If the scan alone explains other poses
        within `ambiguity_nats`, the belief is then called ambiguous with those as the other candidates
        (the estimate stays the tracked pose); if it singles this one out, the fix stands."""
        est = self.estimate()
        if not est.converged or self.surprise_mass <= 0.0 or self.lattice is None or self.table is None:
            return
        held = mass_near(predicted[0], log_normalise(predicted[1]), est.pose, self.mode_radius_cm,
                         self.mode_heading_rad)
        if held >= self.surprise_mass:
            return
        self._alternatives = other_candidates(
            self.lattice.xy, self.table.n_angles, lattice_costs(self.lattice, rel, meas, self.likelihood), est.pose,
            within_nats=self.ambiguity_nats, radius_cm=self.mode_radius_cm, heading_rad=self.mode_heading_rad,
            max_candidates=self.max_modes)
        if self._alternatives:
            log.info("the scan put the belief where the motion had put %.2g %% of it, and fits %d other poses: "
                     "ambiguous", 100 * held, len(self._alternatives))
            self._converged = False
            self._estimate = self._make_estimate()

    def _lattice_start(self, rel: FloatArray, meas: FloatArray) -> None:
        """Replace the uniform cloud by the best lattice poses for this scan (see `global_init`)."""
        assert self.lattice is not None and self.table is not None
        costs = lattice_costs(self.lattice, rel, meas, self.likelihood)
        if self._heading_prior is not None:
            costs = costs + self._heading_prior.direction_costs(costs.shape[1])[None, :]
        self.particles, self._move_cap = best_lattice_poses(self.lattice, self.table, costs, self.n_particles,
                                                            self.mode_radius_cm, self.mode_heading_rad, self.rng)
        k = len(self.particles)
        self.log_weights = np.full(k, -math.log(k))
        self._global = False

    def estimate(self) -> PoseEstimate:
        """The belief: mean pose and covariance of the cloud; when several modes are plausible, the
        best-fitting mode's pose with the whole cloud's covariance and ``converged=False``."""
        if self._estimate is None:
            self._estimate = self._make_estimate()
        return self._estimate

    # -- extras -------------------------------------------------------------------------------------
    @property
    def modes(self) -> list[Mode]:
        """The plausible modes after the last update (more than one: the belief is ambiguous): the tracked
        ones, then after a surprise (`surprise_mass`) the other poses the scan allows."""
        return self._modes + self._alternatives

    @property
    def ambiguous(self) -> bool:
        return len(self.modes) > 1

    @property
    def weights(self) -> FloatArray:
        return log_normalise(self.log_weights)

    def cloud(self) -> tuple[FloatArray, FloatArray] | None:
        return self.particles, self.weights

    # -- internals ----------------------------------------------------------------------------------
    def _sq_residuals(self, poses: FloatArray, rel: FloatArray, meas: FloatArray, exact: bool = False) -> FloatArray:
        """Summed capped squared normalised residuals per pose; inf for poses outside the free space."""
        if self.table is None or exact or self._exact:
            expected = exact_ranges(self.map, poses, rel, **self.lobe)
            s = self.likelihood.sq_residuals(expected, meas)
            inside = np.asarray(self.map.contains(poses[:, :2]), dtype=bool)
        else:
            expected32, inside = self.table.lookup(poses, rel)
            s = self.likelihood.sq_residuals(expected32, meas)
        return np.where(inside, s, np.inf)

    def _predicted_prior(self, per_mode: bool = False) -> GaussianPrior:
        """The predicted belief as Gaussians (one, or one per mode): see `annealing.predicted_prior`."""
        return predicted_prior(self.particles, self.log_weights, per_mode, self.mode_radius_cm,
                               self.mode_heading_rad, self.max_modes)

    def _iterate(self, rel: FloatArray, meas: FloatArray, prior: GaussianPrior | None = None,
                 rank_by_prior: bool = False) -> None:
        """Annealed SMC on one scan: reweigh by a likelihood increment, resample, move (Metropolis).

        With a `prior` (Gaussians of `_predicted_prior`; see `tracking_prior`) the moves target the prior
        times the tempered likelihood; without, the tempered likelihood alone (a uniform prior). With
        `rank_by_prior` (a first fix weighed by a `HeadingPrior`) the modes' best fits, by which the
        estimate picks one, include the log prior too.
        """
        p, log_w = self.particles, self.log_weights
        s, subset = self._start_residuals(p, rel, meas)
        kernel = self._move_kernel(meas)
        beta = 0.0
        self._converged = False
        self._modes = []
        groups: IntArray | None = None
        for _ in range(self.max_iterations):
            new_beta = next_beta(log_w, s, beta, self.ess_target, groups if self.per_mode_ess else None)
            log_w = log_w - 0.5 * (new_beta - beta) * s
            beta = new_beta
            log_w = log_w - np.max(log_w)
            self.iterations += 1
            split = split_modes(p, log_w, s, beta, prior, radius_cm=self.mode_radius_cm,
                                heading_rad=self.mode_heading_rad, max_modes=self.max_modes,
                                coverage=self.cluster_coverage, ambiguity_nats=self.ambiguity_nats)
            w = log_normalise(split.log_w)
            mean, cov = cloud_stats(p, w)
            self.particles, self.log_weights = p, np.log(np.maximum(w, 1e-300))
            s_kept = s  # residuals of the particles kept (p and s are resampled below)
            stds = mode_stds(p, w, split.labels, split.keep) if split.clustered else np.zeros((0, 2))
            if beta >= 1.0 and split.clustered and self._judge_modes(p, w, s, prior, rank_by_prior, split, stds):
                self._record(p, w, beta, mean, cov)
                break
            self._record(p, w, beta, mean, cov)
            idx, log_w, j_std, groups = self._resample_step(w, split, stds, cov)
            p, s = p[idx], s[idx]
            if subset:
                s = self._sq_residuals(p, rel, meas)
                subset = False
            p, s = metropolis_move(p, s, kernel.scale(beta, j_std), beta, prior,
                                   lambda q: self._proposal_residuals(q, rel, meas), self.rng)
        self._finish_scan(rel, meas, s_kept)

    def _start_residuals(self, p: FloatArray, rel: FloatArray, meas: FloatArray) -> tuple[FloatArray, bool]:
        """The particles' residuals on the scan, and whether they come from a subset of its beams (the
        first iterations of a global start use `global_beams` of them, scaled to the whole scan)."""
        n_beams = meas.size
        if self._global and n_beams > self.global_beams:
            sub = np.linspace(0, n_beams - 1, self.global_beams).round().astype(np.int64)
            s = self._sq_residuals(p, rel[sub], meas[sub]) * (n_beams / sub.size)
            subset = True
        else:
            s = self._sq_residuals(p, rel, meas)
            subset = False
        if not np.isfinite(s).any():
            raise LocalisationError("every particle lies outside the free space of the map")
        return s, subset

    def _move_kernel(self, meas: FloatArray) -> MoveKernel:
        """The Metropolis jitter's bounds on the scan `meas` (cm)."""
        near = meas[meas < NO_ECHO]  # a laser's readings may all lie beyond the sonar's 255 cm
        typical_range = float(np.median(near if near.size else meas[echo_mask(meas, self.likelihood)]))
        # after a lattice start the particles sit next to the lattice's optima: keep the moves local
        # (within a lattice cell and a table direction) so that narrow optima are not diffused away
        cap_xy, cap_th = self._move_cap
        return MoveKernel(self.likelihood.sigma_cm, meas.size, typical_range, cap_xy, cap_th)

    def _proposal_residuals(self, q: FloatArray, rel: FloatArray, meas: FloatArray) -> FloatArray:
        """Residuals of proposed poses `q`; inf for those closer than the clearance (less 1 cm) to a wall."""
        clear = max(self.clearance_cm - 1.0, 0.0)
        s_q = self._sq_residuals(q, rel, meas)
        if self.table is not None and clear > 0:
            s_q = np.where(self.table.free(q[:, :2], clear), s_q, np.inf)
        return s_q

    def _judge_modes(self, p: FloatArray, w: FloatArray, s: FloatArray, prior: GaussianPrior | None,
                     rank_by_prior: bool, split: ModeSplit, stds: FloatArray) -> bool:
        """At the full likelihood: describe the kept modes; whether every one is narrow enough to stop
        (converged when only one is left)."""
        self._modes = describe_modes(p, w, s - 2.0 * log_prior(prior, p) if rank_by_prior else s, split.labels,
                                     split.keep)
        narrow = bool(np.all(stds[:, 0] < self.converged_xy_cm) and np.all(stds[:, 1] < self.converged_heading_rad))
        if narrow:
            self._converged = split.keep.size == 1
        return narrow

    def _resample_step(self, w: FloatArray, split: ModeSplit, stds: FloatArray,
                       cov: FloatArray) -> tuple[IntArray, FloatArray, FloatArray, IntArray | None]:
        """Resample (each mode on its own once the cloud has split into modes): the indices, the new log
        weights, each copy's spread for the jitter (cm, rad) and the copies' modes (None: no modes)."""
        if split.clustered:
            idx, log_w, j_std = resample_modes(w, split, stds, n_particles=self.n_particles,
                                               mode_share=self.mode_share, resample=self.resample)
            return idx, log_w, j_std, split.labels[idx]
        idx = self.resample(w, self.n_particles)
        log_w = np.full(idx.size, -math.log(idx.size))
        j_std = np.array([spread(cov)])
        return idx, log_w, j_std, None

    def _finish_scan(self, rel: FloatArray, meas: FloatArray, s_kept: FloatArray) -> None:
        """After the iterations: drop the particles of no weight, note how well the best one explains
        the scan (`recovery_threshold`), and form the estimate."""
        keep_p = self.log_weights > math.log(1e-300)
        if not keep_p.all():
            self.particles, self.log_weights = self.particles[keep_p], self.log_weights[keep_p]
            s_kept = s_kept[keep_p]
        self._outliers_at_best = self._outlier_fraction(self.particles[int(np.argmin(s_kept))], rel, meas) \
            if np.isfinite(s_kept).any() else 1.0
        self._global = False
        self._move_cap = (math.inf, math.inf)
        self._estimate = self._make_estimate()

    def _any_inside(self) -> bool:
        xy = self.particles[:, :2]
        inside = self.table.free(xy, 0.0) if self.table is not None else np.asarray(self.map.contains(xy), dtype=bool)
        return bool(np.any(inside & np.isfinite(self.log_weights)))

    def _outlier_fraction(self, pose: FloatArray, rel: FloatArray, meas: FloatArray) -> float:
        """Fraction of the beams more than 3 sigma off at `pose`."""
        return outlier_fraction(self.map, self.table, self.lobe, self._exact, self.likelihood, pose, rel, meas)

    def _record(self, p: FloatArray, w: FloatArray, beta: float, mean: FloatArray, cov: FloatArray) -> None:
        if self.snapshot_size <= 0:
            return
        est = PoseEstimate(Pose.from_array(mean), cov, self._converged, self.iterations)
        if p.shape[0] > self.snapshot_size:
            pick = np.linspace(0, p.shape[0] - 1, self.snapshot_size).round().astype(np.int64)
            sp, sw = p[pick], w[pick] / max(w[pick].sum(), 1e-300)
        else:
            sp, sw = p, w
        self.snapshots.append(Snapshot(sp.copy(), sw.copy(), float(beta), est))

    def _estimate_from(self, p: FloatArray, w: FloatArray) -> PoseEstimate:
        mean, cov = cloud_stats(p, w)
        return PoseEstimate(Pose.from_array(mean), cov, self._converged, self.iterations)

    def _make_estimate(self) -> PoseEstimate:
        est = self._estimate_from(self.particles, log_normalise(self.log_weights))
        if len(self._modes) > 1:
            # ambiguous: the mean of distant twins is no place at all; report the best-fitting mode's
            # pose with the covariance of the whole cloud (which shows the ambiguity)
            best = max(self._modes, key=lambda md: (md.best_log_likelihood, md.weight))
            est = PoseEstimate(best.pose, est.cov, False, est.iterations)
        return est
