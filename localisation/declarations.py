"""The declared options of the bundled localisers (`toolkit.world.Params`) and how each takes the robot model.

Each localiser class points at its declarations here (``params``) and at its robot mapping
(``robot_options``: for every facet of `toolkit.world.RobotModel`, the options it becomes, in the facet's
canonical order, or a sentence saying why the localiser does not use it). The constructors keep their
keyword defaults; a test checks that they equal these declarations' by building each localiser both ways.
"""

from __future__ import annotations

from toolkit.world import Param, Params

from .amcl_models import model_names

__all__ = ["AMCL_PARAMS", "AMCL_ROBOT", "EKF_PARAMS", "KALMAN_ROBOT", "PF_PARAMS", "PF_ROBOT", "UKF_PARAMS"]

_MOTION = (
    Param("noise_model", str, "botsim", "Motion noise model: botsim (proportional) or absolute",
          choices=("botsim", "absolute"), robot=True),
    Param("motion_noise", float, 0.1, "Move noise: a fraction of each move (botsim) or cm per move (absolute)",
          low=0.0, robot=True),
    Param("turn_noise", float, 0.005, "Turn noise: a fraction of each turn (botsim) or rad per turn (absolute)",
          low=0.0, robot=True),
    Param("motion_inflation", float, 1.5, "Factor on the motion noise when predicting (> 1 tolerates unmodelled slip)",
          low=0.0),
)
_SONAR_MODEL = Param("sonar_model", object, None, "The NXT's beam mixture: no-echo readings are evidence, wrong "
                     "readings bounded; its lobe and range limit replace the options'", optional=True, robot=True)
_CONVERGED = (
    Param("converged_xy_cm", float, 1.5, "Converged when sqrt(var x + var y) is below this (and one mode is left)",
          unit="cm", low=0.0),
    Param("converged_heading_deg", float, 2.0, "... and the heading's standard deviation below this", unit="deg",
          low=0.0),
)
_MODES = (
    Param("mode_radius_cm", float, 10.0, "Poses within this distance (and the heading below) are one mode",
          unit="cm", low=0.0),
    Param("mode_heading_deg", float, 20.0, "Poses within this heading (and the distance above) are one mode",
          unit="deg", low=0.0, high=180.0),
    Param("ambiguity_nats", float, 15.0, "A second mode within this log-likelihood of the best makes the belief "
          "ambiguous (0: never)", unit="nats", low=0.0),
)

PF_PARAMS = Params(
    Param("n_particles", int, 1000, "Particles kept between scans and in the refining iterations", low=10),
    Param("n_global", int, 20000, "Particles drawn uniformly for a global start (global_init=uniform)", low=10),
    Param("clearance_cm", float, 8.0, "Particles are drawn at least this far from every wall (the robot radius)",
          unit="cm", low=0.0, robot=True),
    Param("sensor_sigma_cm", float, 1.0, "Standard deviation of a range reading (the paper's 1 cm)", unit="cm",
          low=1e-6, robot=True),
    Param("residual_cap", float, 5.0, "Largest residual one beam contributes, in standard deviations", low=0.0),
    *_MOTION,
    Param("ess_target", float, 0.3, "Effective sample size kept when choosing each annealing beta (fraction)",
          low=1e-6, high=0.999999),
    Param("max_iterations", int, 40, "Annealing iterations per scan at most", low=1),
    *_CONVERGED,
    Param("global_beams", int, 48, "Beams used in the first iteration of a global start", low=1),
    Param("max_modes", int, 8, "Modes tracked at most", low=1),
    *_MODES,
    Param("cluster_coverage", float, 0.9, "Modes are tracked once the max_modes heaviest clusters hold this "
          "share of the weight", low=0.0, high=1.0),
    Param("per_mode_ess", bool, False, "Keep the target ESS in every mode (slower) instead of the whole cloud"),
    Param("mode_share", float, 0.5, "Share of the particles split equally among the tracked modes", low=0.0,
          high=1.0),
    Param("recovery_threshold", float, 0.5, "Restart globally when more than this share of beams is off by 3 "
          "sigma at the best particle (null: never)", low=0.0, high=1.0, optional=True),
    Param("global_init", str, "lattice", "First particles of a global start: the scored lattice or uniform",
          choices=("lattice", "uniform")),
    Param("lattice_step", int, 2, "Lattice spacing of the global start (table cells)", low=1),
    Param("use_table", bool, True, "Expected ranges from the range table (fast) or exact ray casting (slow)"),
    Param("table_resolution_cm", float, 1.0, "Finest cell size of the range table", unit="cm", low=0.01),
    Param("table_angles", int, 360, "Directions per cell of the range table", low=8),
    Param("range_memory_mb", float, None, "Memory budget of the range table and lattice (null: "
          "$NXTNAV_RANGE_MEMORY_MB or 1024)", unit="MB", low=1.0, optional=True),
    Param("max_range_cm", float, None, "The sonar's range limit: no wall is seen beyond it (null: none)", unit="cm",
          low=1.0, optional=True, robot=True),
    Param("beam_width_deg", float, 0.0, "Sonar lobe width of the expected ranges (0: a thin ray)", unit="deg",
          low=0.0, high=180.0, robot=True),
    Param("critical_incidence_deg", float, None, "With a lobe: rays further than this from a wall's normal do not "
          "echo (null: all echo)", unit="deg", low=0.0, high=90.0, optional=True, robot=True),
    Param("beam_rays", int, 9, "Rays that sample the lobe when it is cast exactly", low=1, robot=True),
    Param("tracking_exact", bool, None, "Tracking updates cast rays exactly instead of the table (null: when the "
          "table is coarser than 1 cm)", optional=True),
    _SONAR_MODEL,
    Param("tracking_prior", bool, True, "Tracking moves target the predicted belief times the likelihood"),
    Param("tracking_prior_modes", bool, None, "An ambiguous belief's prior is one Gaussian per mode (null: with "
          "tracking_exact)", optional=True),
    Param("cache_dir", str, None, "Disk cache of the range table (null: none)", optional=True),
    Param("snapshot_size", int, 300, "Particles kept per iteration for plots (0: none)", low=0),
)
PF_ROBOT: dict[str, tuple[str, ...] | str] = {
    "motion": ("noise_model", "motion_noise", "turn_noise"),
    "sensor_sigma": ("sensor_sigma_cm",),
    "lobe": ("beam_width_deg", "critical_incidence_deg", "beam_rays"),
    "max_range": ("max_range_cm",),
    "beam_mixture": ("sonar_model",),
    "clearance": ("clearance_cm",),
}

AMCL_PARAMS = Params(
    Param("model", str, "auto", "Measurement model (localisation.amcl_models), or auto: nxt-beam with a "
          "sonar model, else beam with a lobe, field for a thin ray", choices=model_names()),
    Param("min_particles", int, 150, "Least KLD particle count (nav2: 500)", low=1),
    Param("max_particles", int, 2000, "Largest KLD particle count (nav2: 2000)", low=1),
    Param("pf_err", float, 0.05, "KLD error bound (nav2: 0.05)", low=1e-6, high=0.999999),
    Param("pf_z", float, 0.99, "KLD quantile (nav2: 0.99)", low=1e-6),
    Param("kld_bin_cm", float, 2.0, "KLD histogram bin, position", unit="cm", low=1e-6),
    Param("kld_bin_deg", float, 5.0, "KLD histogram bin, heading", unit="deg", low=1e-6),
    Param("recovery_alpha_slow", float, 0.001, "Averaging rate of the long-term likelihood (0: no recovery)",
          low=0.0, high=1.0),
    Param("recovery_alpha_fast", float, 0.1, "Averaging rate of the short-term likelihood (0: no recovery)",
          low=0.0, high=1.0),
    Param("recovery_sampler", str, "scan", "Where injected particles come from", choices=("scan", "uniform")),
    Param("resample_interval", int, 1, "Updates between resamplings (nav2: 1)", low=1),
    Param("update_min_d", float, 0.0, "A scan updates the filter only after this much driving since the last "
          "update, or `update_min_a` of turning (nav2: 25 cm; 0: every scan)", unit="cm", low=0.0),
    Param("update_min_a", float, 0.0, "... or after this much turning (nav2: 0.2 rad)", unit="rad", low=0.0),
    Param("sigma_hit", float, 1.0, "Beam mixture: reading standard deviation", unit="cm", low=1e-6, robot=True),
    Param("z_hit", float, 0.95, "Beam mixture: weight of the true reading", low=0.0),
    Param("z_short", float, 0.0, "Beam mixture: weight of short readings", low=0.0),
    Param("z_rand", float, 0.05, "Beam mixture: weight of random readings", low=0.0),
    Param("lambda_short", float, 0.1, "Beam mixture: rate of short readings", unit="1/cm", low=0.0),
    Param("laser_max_range", float, 255.0, "Largest reading: the random part's support", unit="cm", low=1e-6,
          robot=True),
    Param("laser_likelihood_max_dist", float, 20.0, "Field model: distances to walls capped at this", unit="cm",
          low=0.0),
    Param("max_beams", int, 0, "Readings used per update at most (0: all)", low=0),
    Param("field_resolution_cm", float, 0.5, "Node spacing of the distance field", unit="cm", low=0.01),
    *_MOTION,
    Param("clearance_cm", float, 8.0, "Fresh particles keep this far from the walls (the robot radius)", unit="cm",
          low=0.0, robot=True),
    Param("global_init", str, "scan", "A global start draws from the first scan or uniformly",
          choices=("scan", "uniform")),
    Param("scan_sample_ess", float, 50.0, "Scan draws keep about this many effective candidate poses", low=1.0),
    *_CONVERGED,
    *_MODES,
    Param("beam_width_deg", float, 0.0, "Sonar lobe of the beam model's range table (0: a thin ray)", unit="deg",
          low=0.0, high=180.0, robot=True),
    Param("critical_incidence_deg", float, None, "With a lobe: rays further than this from a wall's normal do not "
          "echo (null: all echo)", unit="deg", low=0.0, high=90.0, optional=True, robot=True),
    Param("lattice_step", int, 2, "Lattice spacing of the scan draws (table cells)", low=1),
    Param("refine_steps", int, 12, "Metropolis moves refining a new fix (0: none)", low=0),
    Param("refine_particles", int, 200, "Particles of the refinement of a new fix", low=1),
    Param("beam_interpolation", bool, True, "Beam model: interpolate the range table's expected ranges"),
    Param("ambiguity_injection", float, 0.1, "While a fix is ambiguous, this share of particles is drawn from "
          "the scan", low=0.0, high=1.0),
    Param("lobe_rays", int, 21, "Rays of an exactly cast lobe where the table cannot be trusted (0: table only)",
          low=0, robot=True),
    Param("cast_exact", bool, False, "Beam model: cast every beam exactly instead of reading the range table"),
    _SONAR_MODEL,
)
AMCL_ROBOT: dict[str, tuple[str, ...] | str] = {
    "motion": ("noise_model", "motion_noise", "turn_noise"),
    "sensor_sigma": ("sigma_hit",),
    "lobe": ("beam_width_deg", "critical_incidence_deg", "lobe_rays"),
    "max_range": ("laser_max_range",),
    "beam_mixture": ("sonar_model",),
    "clearance": ("clearance_cm",),
}

_KALMAN = Params(
    Param("sensor_sigma_cm", float, 1.0, "Standard deviation of a range reading", unit="cm", low=1e-6, robot=True),
    *_MOTION,
    Param("max_beams", int, 24, "Readings used per update at most (evenly chosen)", low=1),
    Param("gate_cm", float, 10.0, "Readings further than this from the expected range are left out", unit="cm",
          low=0.0),
    Param("min_process_var", float, (0.01, 0.01, 1e-6), "Least process variance per step (x cm^2, y cm^2, "
          "heading rad^2)", low=0.0, size=3),
    *_CONVERGED,
)
KALMAN_ROBOT: dict[str, tuple[str, ...] | str] = {
    "motion": ("noise_model", "motion_noise", "turn_noise"),
    "sensor_sigma": ("sensor_sigma_cm",),
    "lobe": "a Kalman filter's measurement is one thin ray per reading; the lobe widens its sigma instead",
    "max_range": "readings at the range limit are no-echo readings, which the Kalman update leaves out",
    "beam_mixture": "a Kalman update is Gaussian: the mixture's sigma is given as sensor_sigma_cm",
    "clearance": "a Kalman filter draws no particles, so the robot's size does not enter it",
}
EKF_PARAMS = _KALMAN.extend(
    Param("jacobian_step", float, (0.05, 0.05, 1e-3), "Central-difference steps of the measurement Jacobian "
          "(cm, cm, rad)", low=1e-9, size=3),
)
UKF_PARAMS = _KALMAN.extend(
    Param("alpha", float, 0.3, "Merwe sigma points: spread around the mean", low=1e-6, high=1.0),
    Param("beta", float, 2.0, "Merwe sigma points: prior knowledge of the distribution (2: Gaussian)", low=0.0),
    Param("kappa", float, 0.0, "Merwe sigma points: secondary scaling", low=-3.0),
)
