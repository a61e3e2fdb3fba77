"""``amcl``: adaptive Monte Carlo localisation as nav2's AMCL does it, for a rotating sonar.

Three things the paper's filter does not do (Thrun, Burgard and Fox, *Probabilistic Robotics*,
ch. 8; nav2 ``amcl``), and one step nav2 does not take (the refinement of a new fix):

KLD-sampling (Fox 2003)
    Resampling draws particles one at a time and stops as soon as their number exceeds the bound
    ``n(k) = (k - 1) / (2 pf_err) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) pf_z)^3`` for the
    ``k`` histogram bins (`kld_bin_cm` x `kld_bin_cm` x `kld_bin_deg`) the drawn particles occupy,
    clamped to [`min_particles`, `max_particles`]: a tight belief needs few particles, a spread one
    many. As in nav2, `pf_z` enters the formula as it is (0.99, where Fox's 1 - delta = 0.99 would
    be the normal quantile 2.33); unlike nav2, whose code asks for `max_particles` when all particles
    share one bin, one bin needs `min_particles` (Fox's bound is 0 there). Drawing is vectorised:
    `max_particles` candidates are drawn at once and the bound is evaluated on every prefix.
Augmented MCL (recovery)
    Short- and long-term averages of the particles' likelihood, ``w_fast += recovery_alpha_fast *
    (w_avg - w_fast)`` and ``w_slow += recovery_alpha_slow * (w_avg - w_slow)`` (both start at the
    first average, as in nav2, and are not reset after an injection, as in Thrun's table 8.3); every
    resampled particle is
    replaced, with probability ``max(0, 1 - w_fast / w_slow)``, by a fresh one. The averages use
    each particle's likelihood per beam (the scan's likelihood to the power 1 / beams), so that scans
    with different numbers of readings compare and the averages stay within floating-point range
    (nav2's beam weights, a sum of cubes, have the same effect). Fresh particles are drawn from the
    scan (`recovery_sampler="scan"`: sensor resetting, Lenser and Veloso 2000) or uniformly over the
    free space (``"uniform"``, Thrun's table 8.3). There is no other kidnap detection: recovery is
    this mechanism alone (with the fresh draws of an ambiguous fix, `ambiguity_injection`).
A new fix is refined (resample-move)
    When the belief has no fix yet (a global start) or jumps (fresh particles took over), its
    particles came from the scan, not from a motion history, and one weighting collapses them onto
    the one or two that happened to fall nearest the truth: a spread of 0, a heading a few degrees
    off. Such an update then draws `refine_particles` particles from the weights and makes
    `refine_steps` Metropolis moves on this scan's likelihood (Gilks and Berzuini 2001), with a
    proposal of the cloud's own covariance (scaled by 2.38^2 / 3) plus a floor shrinking from 2 cm /
    2 degrees to 0.1 cm / 0.1 degrees, so the cloud samples the likelihood around its mode and its
    spread tells how well the scan pins the pose. While tracking (a motion history) nothing changes.
Measurement models, registered by name (`model`, nav2's ``laser_model_type``)
    ``beam`` (Thrun's beam model around a precomputed `RangeTable`, which can model the NXT's lobe and
    specular loss), ``nxt-beam`` (the same expected ranges weighed by the sonar's own beam mixture, for a
    `sonar_model`) and ``field`` (the likelihood field of the beams' end points): classes of
    `localisation.amcl_models`, chosen once at construction; ``auto`` picks for the sensor.

A global start (``reset(None)``) draws `max_particles` particles from the first scan (the paper-pf
lattice of poses scored against the scan, tempered to keep about `scan_sample_ess` distinct
candidates, each weighed by the inverse of its draw's probability so that the scan's weighting gives
every place its posterior mass; ``global_init="uniform"`` draws them uniformly, as nav2 does). One
update weighs the particles once by the scan (no annealing) and resamples every `resample_interval`
updates.

Parameter names follow nav2 where they mean the same (lengths in cm, not m).
"""

from __future__ import annotations

import logging
import math
from dataclasses import replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from toolkit.world import (
    ConfigError,
    LocalisationError,
    Map,
    Options,
    Pose,
    RngLike,
    Scan,
    angle_diff,
    wrap_angle,
)
from toolkit.world.arrays import FloatArray

from .adaptive import kld_bound, log_blend, log_mean_exp
from .ambiguity import lattice_candidates
from .amcl_models import MEASUREMENT_MODELS, MeasurementModel, model_class
from .amcl_sampling import ParticleDraws
from .base import HeadingPrior, Localiser, Mode, Motion, PoseEstimate, Prior, RobotMapping
from .beam_model import lattice_costs
from .clusters import cloud_stats, cluster, spread
from .declarations import AMCL_ROBOT, AmclOptions
from .likelihood_field import DistanceField
from .models import MotionModel, RangeLattice, RangeLikelihood, RangeTable, range_lattice, range_table
from .resampling import log_normalise

__all__ = ["MEASUREMENT_MODELS", "Amcl", "DistanceField", "kld_bound"]

log = logging.getLogger(__name__)

ESTIMATE_CLUSTERS = 8
"""Clusters the estimate of a spread cloud looks among for the heaviest (`mode_radius_cm`, `mode_heading_deg`)."""


def _check_options(o: AmclOptions) -> None:
    """`ConfigError` for amcl's options that do not fit together (each option's own range is the model's)."""
    if o.min_particles > o.max_particles:
        raise ConfigError(f"need 1 <= min_particles <= max_particles, got {o.min_particles}, {o.max_particles}")
    if o.sensor.z_hit + o.sensor.z_short + o.sensor.z_rand <= 0:
        raise ConfigError("sigma_hit and laser_max_range must be > 0 and the z weights >= 0 with a positive sum")
    if o.lobe.lobe_rays == 1:
        raise ConfigError(f"lobe_rays must be 0 (off) or >= 2 (the lobe's edges and inside), got {o.lobe.lobe_rays}")


class Amcl(ParticleDraws, Localiser):
    """Adaptive MCL: KLD-sampling, augmented-MCL recovery, beam or likelihood-field model.

    Parameters
    ----------
    map : Map
    options : AmclOptions, optional
        The options (`localisation.declarations.AmclOptions`, grouped as nav2 groups them; None: the
        defaults), e.g. ``Amcl(m, AmclOptions(sensor=AmclSensor(z_hit=0.9)))``.
    rng : None, int or Generator
    **overrides
        Options on top of `options`, by dotted path (``**{"sensor.z_hit": 0.9}``) or by the name of one
        field (``z_hit=0.9``).

    Notes
    -----
    What the options mean beyond their one-line descriptions (``nxtnav localisers show amcl``):

    model : {"auto", "beam", "field", "nxt-beam"} or the name of a registered model
        Measurement model (`localisation.amcl_models`, `MEASUREMENT_MODELS`); ``auto``: the NXT beam model
        with a `sonar_model`, else the likelihood field (nav2's default) for a thin ray and the beam model
        when a sonar lobe is given (`beam_width_deg` > 0), which the field cannot represent; ``beam``
        with a `sonar_model` is the NXT beam model.
    min_particles, max_particles : int
        Bounds of the KLD particle count (nav2: 500, 2000). The default minimum is 150: while tracking,
        one sonar scan leaves the particles in a few KLD bins, so the bound asks fewer than any minimum
        and the minimum is the count held; 150 keeps the tracking RMSE at paper-pf's with its 1000
        (nav2's 500 is sized for metre-scale rooms and a laser; measured in docs/localisers.md).
    pf_err, pf_z : float
        KLD error bound and quantile (nav2: 0.05, 0.99).
    kld_bin_cm, kld_bin_deg : float
        KLD histogram bin (nav2 hard-codes 50 cm x 50 cm x 10 degrees for metre-scale rooms; scaled
        here to the paper's 1 m maps).
    recovery_alpha_slow, recovery_alpha_fast : float
        Averaging rates of the long- and short-term likelihood (0 disables recovery).
    recovery_sampler : {"scan", "uniform"}
        Where injected particles come from.
    resample_interval : int
        Updates between resamplings (nav2: 1).
    update_min_d, update_min_a : float
        A scan updates the filter only once the robot has driven `update_min_d` cm or turned
        `update_min_a` rad since the last update (nav2: 25 cm, 0.2 rad); in between, the belief follows
        the odometry alone. 0 and 0: every scan updates (the sonar's sweeps are far apart).
    sigma_hit, z_hit, z_short, z_rand, lambda_short : float
        Measurement mixture: reading standard deviation (cm), weights, short-reading rate (1/cm).
    laser_max_range : float
        Largest reading (cm; 255 on the NXT): the uniform part's support.
    laser_likelihood_max_dist : float
        Field model: distances to the walls are capped at this (cm).
    max_beams : int
        Readings used per update at most (evenly chosen; 0 = all).
    field_resolution_cm : float
        Node spacing of the distance field (cm).
    noise_model, motion_noise, turn_noise, motion_inflation
        Motion model, as the robot's (`MotionModel`).
    clearance_cm : float
        Fresh particles keep this far from the walls (the robot radius).
    global_init : {"scan", "uniform"}
        A global start draws from the first scan or uniformly.
    scan_sample_ess : float
        Scan draws: the lattice is tempered to keep about this many effective candidate poses.
    converged_xy_cm, converged_heading_deg : float
        Converged when sqrt(var x + var y) and the heading standard deviation are below these ...
    ambiguity_nats, mode_radius_cm, mode_heading_deg : float
        ... and, for a new fix (after a global start, or when the estimate jumped by more than
        `mode_radius_cm` or `mode_heading_deg` in one update), no lattice pose that far from the
        estimate explains the scan within `ambiguity_nats` of the best one near it (the twin rooms of
        map3: the procedure then moves and rescans). Once a fix passes, tracking relies on the motion
        history, which tells the twins apart. 0 disables the check.
    ambiguity_injection : float
        While a fix is ambiguous (the check finds a converged fix ambiguous, or a fix that has not
        converged has two or more candidates), at least this fraction of the resampled particles is
        drawn fresh from the scan (as augmented MCL draws them), so a twin the weights dropped can come
        back when a later scan tells the twins apart.
    beam_width_deg, critical_incidence_deg : float
        Sonar lobe and specular loss of the beam model's range table (see `RangeTable`).
    lattice_step : int
        Lattice spacing (table cells) of the scan draws.
    refine_steps, refine_particles : int
        Metropolis moves and particles of the refinement of a new fix (0 steps: no refinement).
    beam_interpolation : bool
        Beam model: interpolate the range table's expected ranges (False: the nearest cell and direction).
    sonar_model : NxtSonar, optional
        Beam model with the sonar's own beam mixture (`localisation.beam_model.BeamLikelihood`: no-echo
        readings are evidence, wrong readings are bounded) instead of the nav2 mixture of `sigma_hit`
        and the `z` weights; its lobe, specular loss and range limit replace `beam_width_deg` and
        `critical_incidence_deg`.
    cast_exact : bool
        Beam model: every beam is ray cast exactly (`exact_ranges`, a thin ray up to `laser_max_range`)
        instead of read from the range table, which is then never built: for a laser's precise readings
        on a building-size map, whose table would take minutes to cast and more memory than it is worth.
    lobe_rays : int
        Beam model with a lobe (and `beam_interpolation`): where the table nodes around a pose differ
        by more than a smooth reading can (a wall entering the lobe, a corner), the lobe is cast
        exactly with this many rays, its edges included (`_lobe_ranges`); 0: the table everywhere.
    """

    name: ClassVar[str] = "amcl"
    options_model: ClassVar[type[Options] | None] = AmclOptions
    _heading_prior: HeadingPrior | None = None
    robot_options: ClassVar[RobotMapping | None] = AMCL_ROBOT

    def __init__(self, map: Map, options: AmclOptions | None = None, *, rng: RngLike = None,
                 **overrides: Any) -> None:
        super().__init__(map, rng=rng)
        o: AmclOptions = self.configure(options, overrides)
        _check_options(o)
        self.options = o
        sensor, lobe, sonar_model = o.sensor, o.lobe, o.sensor.sonar_model
        model_cls = model_class(o.model, sonar_model, lobe.beam_width_deg if sonar_model is None
                                else sonar_model.beam_width_deg)
        beam_width_deg, critical_incidence_deg = lobe.beam_width_deg, lobe.critical_incidence_deg
        max_range_cm: float | None = None
        if sonar_model is not None:
            beam_width_deg, critical_incidence_deg = sonar_model.beam_width_deg, sonar_model.critical_incidence_deg
            max_range_cm = sonar_model.max_range_cm
        self.min_particles, self.max_particles = o.min_particles, o.max_particles
        self.pf_err, self.pf_z = o.kld.pf_err, o.kld.pf_z
        self.kld_bin = np.array([o.kld.kld_bin_cm, o.kld.kld_bin_cm, math.radians(o.kld.kld_bin_deg)])
        self.alpha_slow, self.alpha_fast = o.recovery.recovery_alpha_slow, o.recovery.recovery_alpha_fast
        self.recovery_sampler = o.recovery.recovery_sampler
        self.resample_interval = o.update.resample_interval
        self.update_min_d, self.update_min_a = o.update.update_min_d, o.update.update_min_a
        self._driven_cm = self._turned_rad = 0.0  # since the last update
        z = sensor.z_hit + sensor.z_short + sensor.z_rand  # normalised so the mixture is a density
        self.z_hit, self.z_short, self.z_rand = sensor.z_hit / z, sensor.z_short / z, sensor.z_rand / z
        self.sigma_hit, self.lambda_short = sensor.sigma_hit, sensor.lambda_short
        self.laser_max_range = sensor.laser_max_range
        self.laser_likelihood_max_dist = sensor.laser_likelihood_max_dist
        self.field_resolution_cm, self.max_beams = sensor.field_resolution_cm, sensor.max_beams
        m = o.motion
        self.motion_model = MotionModel(m.noise_model, m.motion_noise, m.turn_noise, m.motion_inflation)
        start = o.global_start
        self.clearance_cm, self.global_init, self.scan_sample_ess = (start.clearance_cm, start.global_init,
                                                                     start.scan_sample_ess)
        self.converged_xy_cm = o.convergence.converged_xy_cm
        self.converged_heading_rad = math.radians(o.convergence.converged_heading_deg)
        self.ambiguity_nats, self.mode_radius_cm = o.modes.ambiguity_nats, o.modes.mode_radius_cm
        self.mode_heading_rad = math.radians(o.modes.mode_heading_deg)
        # the range table (and its lattice) is built on first use: the likelihood field needs neither
        # while tracking, and a building-size map's table takes minutes to cast
        self.beam_width_deg = float(beam_width_deg)
        self._table_args = (self.beam_width_deg, critical_incidence_deg, max_range_cm)
        self.cast_exact = sensor.cast_exact
        self._table: RangeTable | None = None
        self._lattice: RangeLattice | None = None
        self._lattice_step = start.lattice_step
        self.gaussian = RangeLikelihood(self.sigma_hit)
        """The Gaussian of `sigma_hit` that scores the lattice for a model without a mixture of its own."""
        self.refine_steps, self.refine_particles = start.refine_steps, start.refine_particles
        self.beam_interpolation, self.lobe_rays = sensor.beam_interpolation, lobe.lobe_rays
        self.ambiguity_injection = o.recovery.ambiguity_injection
        self.measurement: MeasurementModel = model_cls(self, sonar_model)
        """The measurement model, chosen once (`localisation.amcl_models`)."""
        self.model = model_cls.name
        self._reset_state()

    def _reset_state(self) -> None:
        """The belief's bookkeeping before its first `reset`."""
        self._ambiguous_fix = False
        self.particles: FloatArray = np.zeros((0, 3))
        self.log_weights: FloatArray = np.zeros(0)
        self.particle_counts: list[int] = []
        self.injected = 0
        self.iterations = 0
        self._weighed = np.zeros(0, dtype=bool)
        self._uniform = True
        self._fixing = True
        self._updates = 0
        self._log_w_slow = self._log_w_fast = -math.inf
        self._estimate: PoseEstimate | None = None
        self._modes: list[Mode] = []
        self._ssd: FloatArray | None = None
        self.reset()

    # -- Localiser interface ------------------------------------------------------------------------
    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        self.iterations = 0
        self._updates = 0
        self._driven_cm = self._turned_rad = 0.0
        self.particle_counts = []
        self._log_w_slow = self._log_w_fast = -math.inf
        n = self.max_particles
        self._heading_prior = prior if isinstance(prior, HeadingPrior) else None
        self._fixing = prior is None or self._heading_prior is not None
        if prior is None or isinstance(prior, HeadingPrior):
            self.particles = self.uniform_poses(n)
            self._uniform = True
        else:
            cov = np.asarray(prior.cov, dtype=float)
            p = self.rng.multivariate_normal(prior.mean.as_array(), 0.5 * (cov + cov.T), n)
            p[:, 2] = wrap_angle(p[:, 2])
            self.particles = p
            self._uniform = False
        self.log_weights = np.full(n, -math.log(n))
        self._weighed = np.ones(n, dtype=bool)
        self._estimate = self._make_estimate()

    def predict(self, motion: Motion) -> None:
        if self._uniform and self._heading_prior is not None:  # the heading prior turns with the robot
            self._heading_prior = self._heading_prior.turned(motion.turn_rad)
        if self._uniform or (motion.turn_rad == 0.0 and motion.distance_cm == 0.0):
            return  # a uniform belief stays uniform
        self.particles = self.motion_model.sample(self.particles, motion, self.rng)
        self._driven_cm += abs(motion.distance_cm)
        self._turned_rad += abs(motion.turn_rad)
        self._estimate = self._make_estimate()

    def _still(self) -> bool:
        """Whether the robot has moved too little since the last update for a scan to update the filter
        (`update_min_d`, `update_min_a`; never while the belief is uniform or before the first update)."""
        if self._uniform or self._updates == 0 or (self.update_min_d <= 0 and self.update_min_a <= 0):
            return False
        return self._driven_cm < self.update_min_d and self._turned_rad < self.update_min_a

    def update(self, scan: Scan) -> None:
        if self._still():
            return
        self._driven_cm = self._turned_rad = 0.0
        rel, meas = self.measurement.readings(scan)
        if not np.any(self.measurement.echoes(meas)):
            log.warning("scan without usable readings: belief unchanged")
            return
        self._ssd = None
        before = self.estimate().pose
        if 0 < self.max_beams < meas.size:
            pick = np.linspace(0, meas.size - 1, self.max_beams).round().astype(np.int64)
            rel, meas = rel[pick], meas[pick]
        lik, post = self._weigh(rel, meas)
        # augmented MCL: short- and long-term averages of the per-beam likelihood (log domain)
        per_beam = np.where(np.isfinite(lik), lik / meas.size, -np.inf)
        log_w_avg = log_mean_exp(per_beam)
        if self._log_w_slow == -math.inf:
            self._log_w_slow = self._log_w_fast = log_w_avg
        else:
            self._log_w_slow = log_blend(self._log_w_slow, log_w_avg, self.alpha_slow)
            self._log_w_fast = log_blend(self._log_w_fast, log_w_avg, self.alpha_fast)
        self._estimate = self._make_estimate()
        after = self._estimate.pose
        if (after.distance_to(before) > self.mode_radius_cm
                or abs(float(angle_diff(after.theta, before.theta))) > self.mode_heading_rad):
            self._fixing = True  # the belief jumped (fresh particles took over): a new fix, to be checked
        self._check_fix(rel, meas, post)
        if self._updates % self.resample_interval == 0:
            self.kld_resample(rel, meas)
        self.particle_counts.append(int(self.particles.shape[0]))
        self._heading_prior = None  # a heading prior weighs the first fix only

    def _weigh(self, rel: FloatArray, meas: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Weigh the particles by the scan (drawn first when the belief is uniform, again from the scan
        when none is inside the free space); the likelihood and the posterior a refinement targets."""
        # particles drawn uniformly carry a heading prior already (they are drawn from it); those drawn
        # from the scan's lattice are weighed by it
        from_prior = False
        if self._uniform:
            n = self.max_particles
            from_prior = self.global_init != "scan"
            if from_prior:
                self.particles, self.log_weights = self.uniform_poses(n), np.full(n, -math.log(n))
            else:
                self._draw_from_scan(n, rel, meas)
            self._weighed = np.ones(n, dtype=bool)
            self._uniform = False
        lik = self.log_likelihood(self.particles, rel, meas)
        if not np.isfinite(lik).any():  # every particle left the free space: nothing to weigh
            log.info("no particle inside the free space: drawing the belief from the scan")
            self._draw_from_scan(self.max_particles, rel, meas)
            lik = self.log_likelihood(self.particles, rel, meas)
            self._fixing = True
            from_prior = False
        post = lik + self._log_heading_prior(self.particles)  # the posterior the refinement targets
        self.iterations += 1
        self._updates += 1
        self.log_weights = self.log_weights + (lik if from_prior else post)
        self._weighed = np.ones(self.particles.shape[0], dtype=bool)
        return lik, post

    def _draw_from_scan(self, n: int, rel: FloatArray, meas: FloatArray) -> None:
        """A belief of `n` particles drawn from the scan (`scan_draws`), weighed by the inverse of the
        probability of their draw, so that the scan's weighting then gives each place its posterior mass
        instead of the draw's times the posterior's."""
        self.particles, log_q = self.scan_draws(n, rel, meas)
        self.log_weights = -log_q - np.logaddexp.reduce(-log_q)

    def _check_fix(self, rel: FloatArray, meas: FloatArray, post: FloatArray) -> None:
        """A new fix refined, checked for a twin explaining the scan as well, and its modes listed."""
        if self._fixing and self.refine_steps > 0:
            self.refine(rel, meas, post)
            self._estimate = self._make_estimate()
        assert self._estimate is not None
        self._ambiguous_fix = False
        self._modes = []
        if self._fixing and self._estimate.converged and self.ambiguity_nats > 0:
            self._ambiguous_fix = self._ambiguous(rel, meas, self._estimate.pose)
            if self._ambiguous_fix:
                self._estimate = replace(self._estimate, converged=False)
            else:
                self._fixing = False  # a fix the scan singles out; from here on the motion history does
        if self._fixing and self.ambiguity_nats > 0:
            self._modes = self._candidates(rel, meas)
            # a fix that has not converged yet with several candidates is ambiguous too: without fresh
            # draws the resampling keeps the heaviest candidate alone, and the next scan cannot bring back
            # a twin the weights of this one dropped
            self._ambiguous_fix = self._ambiguous_fix or len(self._modes) > 1

    def estimate(self) -> PoseEstimate:
        if self._estimate is None:
            self._estimate = self._make_estimate()
        return self._estimate

    # -- extras -------------------------------------------------------------------------------------
    @property
    def injection_probability(self) -> float:
        """``max(0, 1 - w_fast / w_slow)``: the chance that a resampled particle is replaced by a fresh one."""
        if self.alpha_slow <= 0 or not math.isfinite(self._log_w_slow) or not math.isfinite(self._log_w_fast):
            return 0.0
        return max(0.0, 1.0 - math.exp(self._log_w_fast - self._log_w_slow))

    def log_likelihood(self, poses: FloatArray, rel: FloatArray, meas: FloatArray) -> FloatArray:
        """Log-likelihood (N,) of the readings `meas` (B,) at angles `rel` (B,) from each pose (N, 3) under
        the measurement model; ``-inf`` for poses outside the free area."""
        return self.measurement.log_likelihood(np.asarray(poses, dtype=float).reshape(-1, 3), rel, meas)

    # -- internals ----------------------------------------------------------------------------------
    @property
    def table(self) -> RangeTable:
        """The beam model's range table (built on first use)."""
        if self._table is None:
            width, crit, reach = self._table_args
            self._table = range_table(self.map, 1.0, 360, None, width, crit, max_range_cm=reach)
        return self._table

    @property
    def lattice(self) -> RangeLattice:
        """The lattice of poses that scan draws and ambiguity checks score (built on first use)."""
        if self._lattice is None:
            self._lattice = range_lattice(self.table, self._lattice_step, max(self.clearance_cm - 1.0, 0.0))
        return self._lattice

    def _free(self, xy: FloatArray, clearance: float) -> NDArray[np.bool_]:
        """Positions inside the free area at least `clearance` cm from the walls, as the measurement model
        sees them (from the map for the likelihood field, from the range table's cells for the beam model)."""
        return self.measurement.free(xy, clearance)

    def _lattice_costs(self, rel: FloatArray, meas: FloatArray) -> FloatArray:
        """``-2 log-likelihood`` of every lattice pose for this update's scan (computed once per update) by
        the measurement model's lattice likelihood: the beam mixture of a `sonar_model`, else the Gaussian
        of `sigma_hit` (`lattice_costs`)."""
        if self._ssd is None:
            self._ssd = lattice_costs(self.lattice, rel, meas, self.measurement.lattice_model())
            if self._heading_prior is not None:
                self._ssd += self._heading_prior.direction_costs(self._ssd.shape[1])[None, :]
        return self._ssd

    def _log_heading_prior(self, poses: FloatArray) -> FloatArray | float:
        """log p(heading) of `poses` (N, 3) under the heading prior of a first fix (0 without one)."""
        if self._heading_prior is None:
            return 0.0
        return -0.5 * self._heading_prior.cost(poses[:, 2])

    def _ambiguous(self, rel: FloatArray, meas: FloatArray, pose: Pose) -> bool:
        """Whether a lattice pose away from `pose` (further than `mode_radius_cm` or `mode_heading_deg`)
        explains the scan within `ambiguity_nats` of the best lattice pose near it."""
        ssd = self._lattice_costs(rel, meas)  # (cells, directions), -2 log-likelihood
        n_ang = self.table.n_angles
        close = np.hypot(self.lattice.xy[:, 0] - pose.x, self.lattice.xy[:, 1] - pose.y) <= self.mode_radius_cm
        if not close.any():
            return False
        heads = np.arange(n_ang) * (2.0 * math.pi / n_ang)
        aligned = np.abs(angle_diff(heads, pose.theta)) <= self.mode_heading_rad
        near = ssd[close][:, aligned].min()
        far = min(ssd[~close].min() if (~close).any() else math.inf,
                  ssd[close][:, ~aligned].min() if (~aligned).any() else math.inf)
        return bool(0.5 * (far - near) <= self.ambiguity_nats)

    @property
    def modes(self) -> list[Mode]:
        """While a new fix is ambiguous (or has not converged), the distinct lattice poses that explain
        the scan within `ambiguity_nats` of the best (`lattice_candidates`), best first; else none."""
        return list(self._modes)

    def _candidates(self, rel: FloatArray, meas: FloatArray) -> list[Mode]:
        found = lattice_candidates(self.lattice.xy, self.table.n_angles, self._lattice_costs(rel, meas),
                                   within_nats=self.ambiguity_nats, radius_cm=self.mode_radius_cm,
                                   heading_rad=self.mode_heading_rad)
        return [Mode(pose, 0.0, ll, 0) for pose, ll in found] if len(found) > 1 else []

    def cloud(self) -> tuple[FloatArray, FloatArray] | None:
        """The particles and the weights the estimate uses (particles not yet weighed by a scan weigh 0)."""
        if self.particles.shape[0] == 0:
            return None
        return self.particles, self._estimate_weights()

    def _estimate_weights(self) -> FloatArray:
        lw = np.where(self._weighed, self.log_weights, -np.inf)
        if not np.isfinite(lw).any():
            lw = np.zeros(self.particles.shape[0])
        return log_normalise(lw)

    def _make_estimate(self) -> PoseEstimate:
        if self.particles.shape[0] == 0:
            raise LocalisationError("amcl has no particles")
        w = self._estimate_weights()
        p = self.particles
        mean, cov = cloud_stats(p, w)
        spread_xy, spread_th = spread(cov)
        converged = not self._uniform and spread_xy < self.converged_xy_cm and spread_th < self.converged_heading_rad
        if not self._uniform and (spread_xy > self.mode_radius_cm or spread_th > self.mode_heading_rad):
            # a cloud of several places: the mean of them all is no place at all; as nav2, report the
            # heaviest cluster's mean (with the whole cloud's covariance, which shows the spread)
            with np.errstate(divide="ignore"):
                labels, log_masses = cluster(p, np.log(w), self.mode_radius_cm, self.mode_heading_rad,
                                             ESTIMATE_CLUSTERS)
            members = labels == int(np.argmax(log_masses))
            mean, _ = cloud_stats(p[members], w[members] / float(w[members].sum()))
        return PoseEstimate(Pose.from_array(mean), cov, bool(converged), self.iterations)
