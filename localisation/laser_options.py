"""Localiser options for a laser scanner (`toolkit.world.LaserScanner`), by registry name.

The localisers were built for 20-72 readings of a sonar on a metre-sized map; a laser gives hundreds
of precise readings over a building. What changes, per family:

``amcl``
    nav2's laser defaults in cm (`NAV2_LASER`: the likelihood field, ``model="field"``, each reading's end
    point against the distance to the nearest wall, so no range table and a large map costs nothing
    to set up; ``z_hit`` = ``z_rand`` = 0.5, distances capped at 200 cm, KLD bins of 50 cm and 10
    degrees, an update only after 25 cm of driving or 0.2 rad of turning), sharpened for a precise
    laser (`SHARP_LASER`): ``sigma_hit`` 5 cm instead of 20, 120 beams instead of 60, and 3000 to
    5000 particles instead of 500 to 2000, enough that a field this sharp keeps many survivors per
    update. The field on a `FIELD_RESOLUTION_CM` grid. Fresh particles are drawn uniformly (a draw
    from the scan would cast the whole range table) and there is no ambiguity check (its lattice
    needs the table as well). No clearance: a bag's robot size is not known.
``paper-pf`` and the filterpy particle filters
    Exact ray casting instead of the table (``use_table=False``, so a global start draws uniformly),
    the laser's noise as ``sensor_sigma_cm`` and its range limit, `PF_PARTICLES` particles.
``ekf``, ``ukf``
    The laser's noise in R, up to `KALMAN_BEAMS` readings per update, a gate of `KALMAN_GATE_SD`
    standard deviations (at least `KALMAN_GATE_MIN_CM`).

The robot model (motion noise, the laser's sigma and range limit) is not set here: `localisation.robot_options`
gives it, and these options go on top of it.
"""

from __future__ import annotations

from typing import Any

from localisation.base import LOCALISERS
from toolkit.world import LaserScanner

__all__ = ["FIELD_RESOLUTION_CM", "KALMAN_BEAMS", "KALMAN_GATE_MIN_CM", "KALMAN_GATE_SD", "NAV2_LASER", "PF_PARTICLES",
           "SHARP_LASER", "laser_localiser_options"]

FIELD_RESOLUTION_CM = 2.0
"""Node spacing of amcl's distance field for a laser (cm): 1.5 M free cm^2 (a 20 x 7 m room) in 2 s."""
NAV2_LASER = {"model": "field", "sigma_hit": 20.0, "z_hit": 0.5, "z_short": 0.0, "z_rand": 0.5,
              "laser_likelihood_max_dist": 200.0, "max_beams": 60, "min_particles": 500, "max_particles": 2000,
              "kld_bin_cm": 50.0, "kld_bin_deg": 10.0, "update_min_d": 25.0, "update_min_a": 0.2}
"""nav2 amcl's defaults for a laser, lengths in cm."""
SHARP_LASER = {"sigma_hit": 5.0, "max_beams": 120, "min_particles": 3000, "max_particles": 5000}
"""What amcl changes from `NAV2_LASER` for a precise laser (cm): measured in docs/ros-bags.md."""
PF_PARTICLES = 300
"""Particles of the paper's filters on a laser (their exact ray casting costs particles x readings)."""
KALMAN_BEAMS = 120
KALMAN_GATE_SD = 5.0
KALMAN_GATE_MIN_CM = 10.0


def laser_localiser_options(localiser: str, laser: LaserScanner) -> dict[str, Any]:
    """Constructor options that fit `localiser` (a registry name) to `laser` (module docstring); {} for a
    localiser this module does not know."""
    from .amcl import Amcl
    from .filterpy_variants import KalmanLocaliser
    from .particle_filter import ParticleFilter

    cls = LOCALISERS.get(localiser)
    sd = float(laser.noise_sd)
    if issubclass(cls, Amcl):
        return {**NAV2_LASER, **SHARP_LASER, "laser_max_range": float(laser.max_range_cm),
                "field_resolution_cm": FIELD_RESOLUTION_CM, "recovery_sampler": "uniform", "ambiguity_nats": 0.0,
                "clearance_cm": 0.0}
    if issubclass(cls, ParticleFilter):
        return {"sensor_sigma_cm": sd, "use_table": False, "global_init": "uniform", "n_particles": PF_PARTICLES,
                "max_range_cm": float(laser.max_range_cm), "clearance_cm": 0.0}
    if issubclass(cls, KalmanLocaliser):
        return {"sensor_sigma_cm": sd, "max_beams": KALMAN_BEAMS,
                "gate_cm": max(KALMAN_GATE_SD * sd, KALMAN_GATE_MIN_CM)}
    return {}
