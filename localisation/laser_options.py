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
``grid``
    The laser's precision as amcl's (``sigma_hit`` of `SHARP_LASER`), no clearance, and a
    `GRID_LASER_STEP_CM` lattice: a lattice pose per 2 cm of a building is more than any memory holds
    (a belief over 30 M poses is refused, naming the option), and even this one needs the range table
    the field model spares amcl.
``paper-pf`` and the filterpy particle filters
    Exact ray casting instead of the table (``use_table=False``, so a global start draws uniformly),
    the laser's noise as ``sensor_sigma_cm`` and its range limit, `PF_PARTICLES` particles.
``ekf``, ``ukf``
    The laser's noise in R, up to `KALMAN_BEAMS` readings per update, a gate of `KALMAN_GATE_SD`
    standard deviations (at least `KALMAN_GATE_MIN_CM`).

The robot model (motion noise, the laser's sigma and range limit) is not set here: `localisation.robot_options`
gives it, and these options go on top of it.

Each family's options are a function registered for its class (`laser_options_for`): a subclass gets its
nearest registered base's. A localiser with none registered is an error that lists those that have
them, never another family's options nor none at all: register a function for its class (or, for a
script or a test, for the length of a ``with`` block, `laser_options_added`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from localisation.amcl import Amcl
from localisation.base import LOCALISERS
from localisation.filterpy_variants import KalmanLocaliser
from localisation.grid_bayes import GridBayes
from localisation.particle_filter import ParticleFilter
from toolkit.world import ConfigError, LaserScanner, RegistryError

__all__ = ["FIELD_RESOLUTION_CM", "GRID_LASER_STEP_CM",
           "KALMAN_BEAMS", "KALMAN_GATE_MIN_CM", "KALMAN_GATE_SD", "NAV2_LASER", "PF_PARTICLES",
           "SHARP_LASER", "LaserOptions", "laser_localiser_options", "laser_options_added", "laser_options_for"]

LaserOptions = Callable[[LaserScanner], dict[str, Any]]
"""A function giving the constructor options that fit a localiser family to a laser."""

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
GRID_LASER_STEP_CM = 5
"""Lattice spacing (range-table cells of 1 cm) of the grid on a laser's map."""
KALMAN_BEAMS = 120
KALMAN_GATE_SD = 5.0
KALMAN_GATE_MIN_CM = 10.0


_BY_CLASS: dict[type, LaserOptions] = {}


def laser_options_for(cls: type) -> Callable[[LaserOptions], LaserOptions]:
    """Register the decorated function as the laser options of localiser class `cls` and its subclasses
    (a second function for the same class is an error)."""
    def register(options: LaserOptions) -> LaserOptions:
        if cls in _BY_CLASS:
            raise RegistryError(f"laser options for {cls.__qualname__} are registered already")
        _BY_CLASS[cls] = options
        return options
    return register


@contextmanager
def laser_options_added(cls: type, options: LaserOptions) -> Iterator[None]:
    """`options` registered for `cls` for the length of a ``with`` block, then removed again."""
    laser_options_for(cls)(options)
    try:
        yield
    finally:
        _BY_CLASS.pop(cls, None)


def _options_of(cls: type) -> LaserOptions | None:
    return next((_BY_CLASS[c] for c in cls.__mro__ if c in _BY_CLASS), None)


def laser_localiser_options(localiser: str, laser: LaserScanner) -> dict[str, Any]:
    """Constructor options that fit `localiser` (a registry name) to `laser` (module docstring).

    Raises
    ------
    ConfigError
        For a localiser whose class (or a base of it) has no laser options registered; the message
        lists the localisers that have them.
    """
    options = _options_of(LOCALISERS.get(localiser))
    if options is None:
        known = [name for name in LOCALISERS.names() if _options_of(LOCALISERS.get(name)) is not None]
        raise ConfigError(f"localiser {localiser!r} has no options for a laser (localisation.laser_options); "
                          f"known: {', '.join(known) or 'none'}")
    return options(laser)


@laser_options_for(Amcl)
def _amcl(laser: LaserScanner) -> dict[str, Any]:
    return {**NAV2_LASER, **SHARP_LASER, "laser_max_range": float(laser.max_range_cm),
            "field_resolution_cm": FIELD_RESOLUTION_CM, "recovery_sampler": "uniform", "ambiguity_nats": 0.0,
            "clearance_cm": 0.0}


@laser_options_for(GridBayes)
def _grid(laser: LaserScanner) -> dict[str, Any]:
    return {"sigma_hit": SHARP_LASER["sigma_hit"], "laser_max_range": float(laser.max_range_cm), "clearance_cm": 0.0,
            "lattice_step": GRID_LASER_STEP_CM}


@laser_options_for(ParticleFilter)
def _particle_filter(laser: LaserScanner) -> dict[str, Any]:
    return {"sensor_sigma_cm": float(laser.noise_sd), "use_table": False, "global_init": "uniform",
            "n_particles": PF_PARTICLES, "max_range_cm": float(laser.max_range_cm), "clearance_cm": 0.0}


@laser_options_for(KalmanLocaliser)
def _kalman(laser: LaserScanner) -> dict[str, Any]:
    sd = float(laser.noise_sd)
    return {"sensor_sigma_cm": sd, "max_beams": KALMAN_BEAMS, "gate_cm": max(KALMAN_GATE_SD * sd, KALMAN_GATE_MIN_CM)}
