"""The options of the bundled localisers, one typed model each (`toolkit.world.Options`), and how each
takes the robot model.

Options are grouped as nav2 groups AMCL's parameters: the motion model, the sensor model, resampling,
recovery, the global start, convergence. Build one in Python as a model, or override a few by name::

    Amcl(m, AmclOptions(sensor=AmclSensor(z_hit=0.9)))
    Amcl(m, **{"sensor.z_hit": 0.9})      # the same; ``z_hit=0.9`` too (the name of one field)
    nxtnav localise --localiser amcl --set amcl.sensor.z_hit=0.9

Each localiser class points at its model (``options_model``) and at its robot mapping
(``robot_options``: for every facet of `toolkit.world.RobotModel`, the dotted options it becomes, in the
facet's canonical order, or a sentence saying why the localiser does not use it).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, InstanceOf, WithJsonSchema

from toolkit.world import NxtSonar, Options, option
from toolkit.world.params import Choices

from .amcl_models import model_names
from .base import RobotMapping

__all__ = [
    "AMCL_ROBOT",
    "GRID_ROBOT",
    "KALMAN_ROBOT",
    "PF_ROBOT",
    "AmclGlobalStart",
    "AmclKld",
    "AmclLobe",
    "AmclOptions",
    "AmclRecovery",
    "AmclSensor",
    "AmclUpdate",
    "AnnealingOptions",
    "ConvergenceOptions",
    "EkfOptions",
    "GridLattice",
    "GridOptions",
    "KalmanOptions",
    "KalmanSensor",
    "LatticeLobe",
    "LatticeSensor",
    "ModeOptions",
    "MotionOptions",
    "PfGlobalStart",
    "PfModes",
    "PfOptions",
    "PfRanges",
    "PfSensor",
    "PfTracking",
    "SigmaPoints",
    "SonarModel",
    "UkfOptions",
]

SonarModel = Annotated[InstanceOf[NxtSonar] | None, WithJsonSchema(
    {"type": ["object", "null"], "description": "an NXT sonar model (set from the robot model's sonar profile)"})]
"""The NXT's beam mixture: an object the robot model sets (not a command-line value)."""
_SONAR_TEXT = ("The NXT's beam mixture: no-echo readings are evidence, wrong readings bounded; its lobe and range "
               "limit replace the options'")
NonNegative = Annotated[float, Field(ge=0.0)]
Positive = Annotated[float, Field(ge=1e-9)]


class MotionOptions(Options):
    """The motion model (`localisation.models.MotionModel`), as the robot's."""

    noise_model: Literal["botsim", "absolute"] = option(
        "botsim", "Motion noise model: botsim (proportional) or absolute", robot=True)
    motion_noise: float = option(0.1, "Move noise: a fraction of each move (botsim) or cm per move (absolute)",
                                 ge=0.0, robot=True)
    turn_noise: float = option(0.005, "Turn noise: a fraction of each turn (botsim) or rad per turn (absolute)",
                               ge=0.0, robot=True)
    motion_inflation: float = option(1.5, "Factor on the motion noise when predicting (> 1 tolerates unmodelled "
                                     "slip)", ge=0.0)


class ConvergenceOptions(Options):
    """When the belief counts as converged."""

    converged_xy_cm: float = option(1.5, "Converged when sqrt(var x + var y) is below this (and one mode is left)",
                                    unit="cm", ge=0.0)
    converged_heading_deg: float = option(2.0, "... and the heading's standard deviation below this", unit="deg",
                                          ge=0.0)


class ModeOptions(Options):
    """What one mode of the belief is, and when a second one makes it ambiguous."""

    mode_radius_cm: float = option(10.0, "Poses within this distance (and the heading below) are one mode",
                                   unit="cm", ge=0.0)
    mode_heading_deg: float = option(20.0, "Poses within this heading (and the distance above) are one mode",
                                     unit="deg", ge=0.0, le=180.0)
    ambiguity_nats: float = option(15.0, "A second mode within this log-likelihood of the best makes the belief "
                                   "ambiguous (0: never)", unit="nats", ge=0.0)


# -- paper-pf and its filterpy variants --------------------------------------------------------------


class PfSensor(Options):
    """The paper's measurement model: a Gaussian on each valid reading, or the NXT's beam mixture."""

    sensor_sigma_cm: float = option(1.0, "Standard deviation of a range reading (the paper's 1 cm)", unit="cm",
                                    ge=1e-6, robot=True)
    residual_cap: float = option(5.0, "Largest residual one beam contributes, in standard deviations", ge=0.0)
    sonar_model: SonarModel = option(None, _SONAR_TEXT, robot=True)


class PfRanges(Options):
    """Expected ranges: the range table and the sonar's lobe."""

    use_table: bool = option(True, "Expected ranges from the range table (fast) or exact ray casting (slow)")
    table_resolution_cm: float = option(1.0, "Finest cell size of the range table", unit="cm", ge=0.01)
    table_angles: int = option(360, "Directions per cell of the range table", ge=8)
    range_memory_mb: float | None = option(None, "Memory budget of the range table and lattice (null: "
                                           "$NXTNAV_RANGE_MEMORY_MB or 1024)", unit="MB", ge=1.0)
    max_range_cm: float | None = option(None, "The sonar's range limit: no wall is seen beyond it (null: none)",
                                        unit="cm", ge=1.0, robot=True)
    beam_width_deg: float = option(0.0, "Sonar lobe width of the expected ranges (0: a thin ray)", unit="deg",
                                   ge=0.0, le=180.0, robot=True)
    critical_incidence_deg: float | None = option(None, "With a lobe: rays further than this from a wall's normal "
                                                  "do not echo (null: all echo)", unit="deg", ge=0.0, le=90.0,
                                                  robot=True)
    beam_rays: int = option(9, "Rays that sample the lobe when it is cast exactly", ge=1, robot=True)
    cache_dir: str | None = option(None, "Disk cache of the range table (null: none)")


class AnnealingOptions(Options):
    """The annealed update of each scan."""

    ess_target: float = option(0.3, "Effective sample size kept when choosing each annealing beta (fraction)",
                               ge=1e-6, le=0.999999)
    max_iterations: int = option(40, "Annealing iterations per scan at most", ge=1)
    global_beams: int = option(48, "Beams used in the first iteration of a global start", ge=1)


class PfModes(ModeOptions):
    """Modes: how many are tracked and how the particles are shared among them."""

    max_modes: int = option(8, "Modes tracked at most", ge=1)
    cluster_coverage: float = option(0.9, "Modes are tracked once the max_modes heaviest clusters hold this share "
                                     "of the weight", ge=0.0, le=1.0)
    per_mode_ess: bool = option(False, "Keep the target ESS in every mode (slower) instead of the whole cloud")
    mode_share: float = option(0.5, "Share of the particles split equally among the tracked modes", ge=0.0, le=1.0)


class PfGlobalStart(Options):
    """A global start and the recovery to it."""

    clearance_cm: float = option(8.0, "Particles are drawn at least this far from every wall (the robot radius)",
                                 unit="cm", ge=0.0, robot=True)
    global_init: Literal["lattice", "uniform"] = option(
        "lattice", "First particles of a global start: the scored lattice or uniform")
    lattice_step: int = option(2, "Lattice spacing of the global start (table cells)", ge=1)
    recovery_threshold: float | None = option(0.5, "Restart globally when more than this share of beams is off by "
                                              "3 sigma at the best particle (null: never)", ge=0.0, le=1.0)


class PfTracking(Options):
    """Tracking updates."""

    tracking_exact: bool | None = option(None, "Tracking updates cast rays exactly instead of the table (null: "
                                         "when the table is coarser than 1 cm)")
    tracking_prior: bool = option(True, "Tracking moves target the predicted belief times the likelihood")
    tracking_prior_modes: bool | None = option(None, "An ambiguous belief's prior is one Gaussian per mode (null: "
                                               "with tracking_exact)")
    surprise_mass: float = option(0.01, "A tracking update that converges where the predicted belief held less than "
                                  "this share of its weight (within one mode) is called ambiguous, with the poses "
                                  "the scan alone allows (0: never)", ge=0.0, le=1.0)


class PfOptions(Options):
    """The paper's particle filter (``paper-pf``, `localisation.particle_filter.ParticleFilter`)."""

    n_particles: int = option(1000, "Particles kept between scans and in the refining iterations", ge=10)
    n_global: int = option(20000, "Particles drawn uniformly for a global start (global_init=uniform)", ge=10)
    snapshot_size: int = option(300, "Particles kept per iteration for plots (0: none)", ge=0)
    motion: MotionOptions = MotionOptions()
    sensor: PfSensor = PfSensor()
    ranges: PfRanges = PfRanges()
    annealing: AnnealingOptions = AnnealingOptions()
    global_start: PfGlobalStart = PfGlobalStart()
    tracking: PfTracking = PfTracking()
    convergence: ConvergenceOptions = ConvergenceOptions()
    modes: PfModes = PfModes()


PF_ROBOT: RobotMapping = {
    "motion": ("motion.noise_model", "motion.motion_noise", "motion.turn_noise"),
    "sensor_sigma": ("sensor.sensor_sigma_cm",),
    "lobe": ("ranges.beam_width_deg", "ranges.critical_incidence_deg", "ranges.beam_rays"),
    "max_range": ("ranges.max_range_cm",),
    "beam_mixture": ("sensor.sonar_model",),
    "clearance": ("global_start.clearance_cm",),
}

# -- amcl ---------------------------------------------------------------------------------------------

AmclModel = Annotated[str, Choices(model_names)]
"""The registered measurement models of amcl (`localisation.amcl_models`), and ``auto``."""


class AmclKld(Options):
    """KLD-sampling (Fox 2003): how many particles the belief needs."""

    pf_err: float = option(0.05, "KLD error bound (nav2: 0.05)", ge=1e-6, le=0.999999)
    pf_z: float = option(0.99, "KLD quantile (nav2: 0.99)", ge=1e-6)
    kld_bin_cm: float = option(2.0, "KLD histogram bin, position", unit="cm", ge=1e-6)
    kld_bin_deg: float = option(5.0, "KLD histogram bin, heading", unit="deg", ge=1e-6)


class AmclUpdate(Options):
    """When a scan updates the filter and when it resamples."""

    resample_interval: int = option(1, "Updates between resamplings (nav2: 1)", ge=1)
    update_min_d: float = option(0.0, "A scan updates the filter only after this much driving since the last "
                                 "update, or `update_min_a` of turning (nav2: 25 cm; 0: every scan)", unit="cm",
                                 ge=0.0)
    update_min_a: float = option(0.0, "... or after this much turning (nav2: 0.2 rad)", unit="rad", ge=0.0)


class LatticeSensor(Options):
    """What a lattice of poses is scored with: the readings' noise, their range limit and the sonar model."""

    sigma_hit: float = option(1.0, "Beam mixture: reading standard deviation", unit="cm", ge=1e-6, robot=True)
    laser_max_range: float = option(255.0, "Largest reading: the random part's support", unit="cm", ge=1e-6,
                                    robot=True)
    sonar_model: SonarModel = option(None, _SONAR_TEXT, robot=True)


class AmclSensor(LatticeSensor):
    """The measurement model's mixture and its inputs (nav2's laser model)."""

    z_hit: float = option(0.95, "Beam mixture: weight of the true reading", ge=0.0)
    z_short: float = option(0.0, "Beam mixture: weight of short readings", ge=0.0)
    z_rand: float = option(0.05, "Beam mixture: weight of random readings", ge=0.0)
    lambda_short: float = option(0.1, "Beam mixture: rate of short readings", unit="1/cm", ge=0.0)
    laser_likelihood_max_dist: float = option(20.0, "Field model: distances to walls capped at this", unit="cm",
                                              ge=0.0)
    max_beams: int = option(0, "Readings used per update at most (0: all)", ge=0)
    field_resolution_cm: float = option(0.5, "Node spacing of the distance field", unit="cm", ge=0.01)
    beam_interpolation: bool = option(True, "Beam model: interpolate the range table's expected ranges")
    cast_exact: bool = option(False, "Beam model: cast every beam exactly instead of reading the range table")


class LatticeLobe(Options):
    """The sonar's lobe in the range table a lattice of poses is scored with."""

    beam_width_deg: float = option(0.0, "Sonar lobe of the beam model's range table (0: a thin ray)", unit="deg",
                                   ge=0.0, le=180.0, robot=True)
    critical_incidence_deg: float | None = option(None, "With a lobe: rays further than this from a wall's normal "
                                                  "do not echo (null: all echo)", unit="deg", ge=0.0, le=90.0,
                                                  robot=True)


class AmclLobe(LatticeLobe):
    """The sonar's lobe in the beam model's range table."""

    lobe_rays: int = option(21, "Rays of an exactly cast lobe where the table cannot be trusted (0: table only)",
                            ge=0, robot=True)


class AmclRecovery(Options):
    """Augmented MCL: fresh particles when the short-term likelihood falls below the long-term one."""

    recovery_alpha_slow: float = option(0.001, "Averaging rate of the long-term likelihood (0: no recovery)",
                                        ge=0.0, le=1.0)
    recovery_alpha_fast: float = option(0.1, "Averaging rate of the short-term likelihood (0: no recovery)",
                                        ge=0.0, le=1.0)
    recovery_sampler: Literal["scan", "uniform"] = option("scan", "Where injected particles come from")
    ambiguity_injection: float = option(0.1, "While a fix is ambiguous, this share of particles is drawn from the "
                                        "scan", ge=0.0, le=1.0)


class AmclGlobalStart(Options):
    """A global start and the refinement of a new fix."""

    clearance_cm: float = option(8.0, "Fresh particles keep this far from the walls (the robot radius)", unit="cm",
                                 ge=0.0, robot=True)
    global_init: Literal["scan", "uniform"] = option("scan", "A global start draws from the first scan or uniformly")
    scan_sample_ess: float = option(50.0, "Scan draws keep about this many effective candidate poses", ge=1.0)
    lattice_step: int = option(2, "Lattice spacing of the scan draws (table cells)", ge=1)
    refine_steps: int = option(12, "Metropolis moves refining a new fix (0: none)", ge=0)
    refine_particles: int = option(200, "Particles of the refinement of a new fix", ge=1)


class AmclOptions(Options):
    """Adaptive MCL (``amcl``, `localisation.amcl.Amcl`)."""

    model: AmclModel = option("auto", "Measurement model (localisation.amcl_models), or auto: nxt-beam with a "
                              "sonar model, else beam with a lobe, field for a thin ray")
    min_particles: int = option(150, "Least KLD particle count (nav2: 500)", ge=1)
    max_particles: int = option(2000, "Largest KLD particle count (nav2: 2000)", ge=1)
    kld: AmclKld = AmclKld()
    update: AmclUpdate = AmclUpdate()
    motion: MotionOptions = MotionOptions()
    sensor: AmclSensor = AmclSensor()
    lobe: AmclLobe = AmclLobe()
    recovery: AmclRecovery = AmclRecovery()
    global_start: AmclGlobalStart = AmclGlobalStart()
    convergence: ConvergenceOptions = ConvergenceOptions()
    modes: ModeOptions = ModeOptions()


AMCL_ROBOT: RobotMapping = {
    "motion": ("motion.noise_model", "motion.motion_noise", "motion.turn_noise"),
    "sensor_sigma": ("sensor.sigma_hit",),
    "lobe": ("lobe.beam_width_deg", "lobe.critical_incidence_deg", "lobe.lobe_rays"),
    "max_range": ("sensor.laser_max_range",),
    "beam_mixture": ("sensor.sonar_model",),
    "clearance": ("global_start.clearance_cm",),
}

# -- grid -------------------------------------------------------------------------------------------


class GridLattice(Options):
    """The lattice of poses the belief is kept on."""

    lattice_step: int = option(2, "Lattice spacing in range-table cells (1 cm each)", ge=1)
    clearance_cm: float = option(8.0, "Lattice cells keep this far from the walls (the robot radius)", unit="cm",
                                 ge=0.0, robot=True)


class GridOptions(Options):
    """Markov localisation on a lattice (``grid``, `localisation.grid_bayes.GridBayes`), with the part of
    amcl's measurement model that scores a lattice (its sensor and lobe options of `LatticeSensor` and
    `LatticeLobe`) and the shared motion, convergence and mode options."""

    motion: MotionOptions = MotionOptions()
    sensor: LatticeSensor = LatticeSensor()
    lobe: LatticeLobe = LatticeLobe()
    lattice: GridLattice = GridLattice()
    convergence: ConvergenceOptions = ConvergenceOptions()
    modes: ModeOptions = ModeOptions()

    def amcl(self) -> AmclOptions:
        """amcl's options with the same models: what `GridBayes` builds its measurement model, range
        table, lattice and motion model from."""
        start = AmclGlobalStart(clearance_cm=self.lattice.clearance_cm, lattice_step=self.lattice.lattice_step)
        return AmclOptions(motion=self.motion, sensor=AmclSensor(**dict(self.sensor)), lobe=AmclLobe(**dict(self.lobe)),
                           global_start=start, convergence=self.convergence, modes=self.modes)


GRID_ROBOT: RobotMapping = {
    **AMCL_ROBOT,
    "lobe": ("lobe.beam_width_deg", "lobe.critical_incidence_deg", None),  # the lattice's table casts no lobe rays
    "clearance": ("lattice.clearance_cm",),
}


# -- Kalman trackers ----------------------------------------------------------------------------------


class KalmanSensor(Options):
    """The readings a Kalman update uses and their noise."""

    sensor_sigma_cm: float = option(1.0, "Standard deviation of a range reading", unit="cm", ge=1e-6, robot=True)
    max_beams: int = option(24, "Readings used per update at most (evenly chosen)", ge=1)
    gate_cm: float = option(10.0, "Readings further than this from the expected range are left out", unit="cm",
                            ge=0.0)


class KalmanOptions(Options):
    """Shared by the EKF and the UKF."""

    min_process_var: tuple[NonNegative, NonNegative, NonNegative] = option(
        (0.01, 0.01, 1e-6), "Least process variance per step (x cm^2, y cm^2, heading rad^2)")
    motion: MotionOptions = MotionOptions()
    sensor: KalmanSensor = KalmanSensor()
    convergence: ConvergenceOptions = ConvergenceOptions()


class EkfOptions(KalmanOptions):
    """The extended Kalman filter (``ekf``)."""

    jacobian_step: tuple[Positive, Positive, Positive] = option(
        (0.05, 0.05, 1e-3), "Central-difference steps of the measurement Jacobian (cm, cm, rad)")


class SigmaPoints(Options):
    """Merwe's scaled sigma points."""

    alpha: float = option(0.3, "Merwe sigma points: spread around the mean", ge=1e-6, le=1.0)
    beta: float = option(2.0, "Merwe sigma points: prior knowledge of the distribution (2: Gaussian)", ge=0.0)
    kappa: float = option(0.0, "Merwe sigma points: secondary scaling", ge=-3.0)


class UkfOptions(KalmanOptions):
    """The unscented Kalman filter (``ukf``)."""

    sigma_points: SigmaPoints = SigmaPoints()


KALMAN_ROBOT: RobotMapping = {
    "motion": ("motion.noise_model", "motion.motion_noise", "motion.turn_noise"),
    "sensor_sigma": ("sensor.sensor_sigma_cm",),
    "lobe": "a Kalman filter's measurement is one thin ray per reading; the lobe widens its sigma instead",
    "max_range": "readings at the range limit are no-echo readings, which the Kalman update leaves out",
    "beam_mixture": "a Kalman update is Gaussian: the mixture's sigma is given as sensor.sensor_sigma_cm",
    "clearance": "a Kalman filter draws no particles, so the robot's size does not enter it",
}
