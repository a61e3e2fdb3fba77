"""Localiser options for a laser scanner (`toolkit.world.LaserScanner`), by registry name.

The localisers were built for 20-72 readings of a sonar on a metre-sized map; a laser gives hundreds
of precise readings over a building. What changes, per family:

``amcl``
    nav2's laser set-up: the likelihood field (``model="field"``: each reading's end point against the
    distance to the nearest wall; no range table, so a large map costs nothing to set up), its
    ``sigma_hit`` the laser's reading noise (at least `FIELD_SIGMA_MIN_CM`), a 5 % uniform share for readings
    of things the map lacks, at least `AMCL_MIN_PARTICLES` particles,
    distances capped at `FIELD_MAX_DIST_CM`, the field on a `FIELD_RESOLUTION_CM` grid; KLD bins of
    `KLD_BIN_CM`; fresh particles drawn uniformly (a draw from the scan would cast the whole table);
    no ambiguity check (its lattice needs the table as well). No clearance: a bag's robot size is
    not known.
``paper-pf`` and the filterpy particle filters
    Exact ray casting instead of the table (``use_table=False``, so a global start draws uniformly),
    the laser's noise as ``sensor_sigma_cm`` and its range limit, `PF_PARTICLES` particles.
``ekf``, ``ukf``
    The laser's noise in R, up to `KALMAN_BEAMS` readings per update, a gate of `KALMAN_GATE_SD`
    standard deviations (at least `KALMAN_GATE_MIN_CM`).

The motion noise is not set here (`localisation.sonar_options.matched_localiser_options` gives it).
"""

from __future__ import annotations

from typing import Any

from localisation.base import LOCALISERS
from toolkit.world import LaserScanner

__all__ = [
    "AMCL_MIN_PARTICLES",
    "FIELD_MAX_DIST_CM",
    "FIELD_RESOLUTION_CM",
    "FIELD_SIGMA_MIN_CM",
    "KALMAN_BEAMS",
    "KALMAN_GATE_MIN_CM",
    "KALMAN_GATE_SD",
    "KLD_BIN_CM",
    "PF_PARTICLES",
    "laser_localiser_options",
]

FIELD_RESOLUTION_CM = 2.0
"""Node spacing of amcl's distance field for a laser (cm): 1.5 M free cm^2 (a 20 x 7 m room) in 2 s."""
FIELD_MAX_DIST_CM = 50.0
"""Distances to the walls are capped here (cm): farther end points are all equally wrong."""
FIELD_SIGMA_MIN_CM = 5.0
"""Smallest ``sigma_hit`` amcl is given (cm): the map's walls and the laser's mounting are not exact to the
laser's noise, and a field sharper than the particles' spacing collapses the cloud onto a few particles
(nav2's default is 20 cm)."""
AMCL_MIN_PARTICLES = 500
"""nav2's default minimum: with hundreds of precise readings the KLD bound asks for fewer, and a few
hundred particles keep the estimate from jumping between the survivors of each update."""
KLD_BIN_CM = 5.0
"""amcl's KLD bin for a laser (cm; the bins' heading side stays 5 degrees)."""
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
        return {"model": "field", "sigma_hit": max(sd, FIELD_SIGMA_MIN_CM), "z_hit": 0.95, "z_short": 0.0,
                "z_rand": 0.05, "min_particles": AMCL_MIN_PARTICLES,
                "laser_max_range": float(laser.max_range_cm), "laser_likelihood_max_dist": FIELD_MAX_DIST_CM,
                "field_resolution_cm": FIELD_RESOLUTION_CM, "kld_bin_cm": KLD_BIN_CM, "recovery_sampler": "uniform",
                "ambiguity_nats": 0.0, "clearance_cm": 0.0}
    if issubclass(cls, ParticleFilter):
        return {"sensor_sigma_cm": sd, "use_table": False, "global_init": "uniform", "n_particles": PF_PARTICLES,
                "max_range_cm": float(laser.max_range_cm), "clearance_cm": 0.0}
    if issubclass(cls, KalmanLocaliser):
        return {"sensor_sigma_cm": sd, "max_beams": KALMAN_BEAMS,
                "gate_cm": max(KALMAN_GATE_SD * sd, KALMAN_GATE_MIN_CM)}
    return {}
