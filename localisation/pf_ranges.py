"""Where the paper's particle filter (`localisation.particle_filter`) gets its expected ranges from.

`range_setup` builds the precomputed `RangeTable` (and the global start's `RangeLattice`), or none
for exact ray casting, and the sonar lobe an exact cast samples; `outlier_fraction` tells how many
readings one pose cannot explain. Distances in cm, angles in degrees where the name says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from toolkit.world import ConfigError, Map
from toolkit.world.arrays import FloatArray

from .beam_model import BeamLikelihood, MeasurementModel
from .models import RangeLattice, RangeTable, exact_ranges, range_lattice, range_table

__all__ = ["RangeSetup", "outlier_fraction", "range_setup"]


@dataclass(frozen=True)
class RangeSetup:
    """The filter's range model.

    Attributes
    ----------
    table : RangeTable or None
        Precomputed expected ranges (None: exact ray casting only).
    lattice : RangeLattice or None
        The global start's lattice (``global_init="lattice"``).
    lobe : dict
        Keyword arguments of `exact_ranges` for the sonar's lobe (width and rays, critical incidence
        in degrees, the reach of a cast in cm).
    tracking_exact : bool
        Whether a tracking update casts its rays exactly instead of looking them up.
    """

    table: RangeTable | None
    lattice: RangeLattice | None
    lobe: dict[str, Any]
    tracking_exact: bool


def range_setup(map: Map, *, use_table: bool, global_init: str, clearance_cm: float, table_resolution_cm: float,
                table_angles: int, cache_dir: str | None, beam_width_deg: float, critical_incidence_deg: float | None,
                range_memory_mb: float | None, lattice_step: int, max_range_cm: float | None, beam_rays: int,
                reach_margin_cm: float, tracking_exact: bool | None) -> RangeSetup:
    """The range model of a `ParticleFilter` with these options (see its parameters); `reach_margin_cm`
    is how far beyond `max_range_cm` an exact cast may still stop (the capped residual, in cm)."""
    table = (range_table(map, table_resolution_cm, table_angles, cache_dir, beam_width_deg, critical_incidence_deg,
                         range_memory_mb, lattice_step if global_init == "lattice" else None, max_range_cm)
             if use_table else None)
    if beam_rays < 1:
        raise ConfigError(f"beam_rays must be >= 1, got {beam_rays}")
    # exact casts may stop a cap beyond the range limit: a wall farther than that costs a reading
    # below the limit the capped residual anyway
    reach = None if max_range_cm is None else float(max_range_cm) + reach_margin_cm
    lobe: dict[str, Any] = {"beam_width_deg": max(float(beam_width_deg), 0.0), "beam_rays": int(beam_rays),
                            "critical_incidence_deg": critical_incidence_deg, "max_range_cm": reach}
    if tracking_exact is None:
        tracking_exact = table is not None and table.resolution_cm > 1.0
    if global_init not in ("lattice", "uniform"):
        raise ConfigError(f"global_init must be 'lattice' or 'uniform', got {global_init!r}")
    if global_init == "lattice" and table is None:
        raise ConfigError("global_init='lattice' needs use_table=True")
    lattice = (range_lattice(table, lattice_step, max(clearance_cm - 1.0, 0.0))
               if table is not None and global_init == "lattice" else None)
    return RangeSetup(table, lattice, lobe, bool(tracking_exact))


def outlier_fraction(map: Map, table: RangeTable | None, lobe: dict[str, Any], exact: bool,
                     likelihood: MeasurementModel, pose: FloatArray, rel: FloatArray, meas: FloatArray) -> float:
    """Fraction of the readings `meas` (cm, at angles `rel` rad from the heading) more than 3 sigma
    off at `pose` (x, y cm, heading rad): looked up in the `table` unless `exact` (or no table),
    else cast with the sonar `lobe` (`RangeSetup.lobe`)."""
    p = pose.reshape(1, 3)
    if table is not None and not exact:
        e, inside = table.lookup(p, rel)
        if not inside[0]:
            return 1.0
        expected = e[0].astype(float)
    else:
        expected = exact_ranges(map, p, rel, **lobe)[0]
    if isinstance(likelihood, BeamLikelihood):
        return float(np.mean(likelihood.outliers(expected, meas)))
    with np.errstate(invalid="ignore"):
        off = ~(np.abs(expected - meas) <= 3.0 * likelihood.sigma_cm)
    return float(np.mean(off))
