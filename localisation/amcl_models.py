"""amcl's measurement models, registered by name as nav2 registers its ``laser_model_type``.

``beam``: `BeamModel`
    Thrun's beam model, the mixture ``z_hit N(r; e, sigma_hit) + z_short lambda_short exp(-lambda_short r)
    [r < e] + z_rand / laser_max_range`` around the expected range ``e`` of a precomputed `RangeTable`
    (which can model the NXT's lobe and specular loss), interpolated trilinearly between the table's 1 cm
    cells and 1-degree directions (`beam_interpolation`) so the likelihood does not step at every cell
    edge. With a lobe, where the 8 table nodes around a pose differ by more than a smooth reading can (a
    wall entering the lobe at its edge, a corner), the lobe is cast exactly instead (`lobe_rays` rays):
    interpolation would smear the reading's step that the sensor takes where the geometry puts it.
``nxt-beam``: `NxtBeamModel`
    The beam model's expected ranges with the sonar's own beam mixture (`BeamLikelihood` of a
    `sonar_model`: no-echo readings are evidence, wrong readings are bounded) instead of the nav2 mixture.
``field``: `LikelihoodFieldModel`
    The likelihood field, ``z_hit N(d; 0, sigma_hit) + z_rand / laser_max_range`` of the distance ``d``
    from each beam's end point to the nearest wall, read from a distance transform of the walls (exact
    distances at the nodes of a `field_resolution_cm` grid, bilinear in between): O(1) per beam whatever
    the map's size, no ray casting. It knows nothing of a lobe: a wide sonar's nearest echo, taken
    off-axis, puts the end point in front of the wall (measured in docs/localisers.md).

`Amcl` chooses its model once, at construction (`model_class`), and asks it for the readings a scan
gives, their likelihood and where a pose is free. A model of one's own is a `MeasurementModel` subclass
with a ``name`` (that registers it in `MEASUREMENT_MODELS`); ``model=NAME`` then selects it, and an
unknown name is an error listing the known ones.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from toolkit.world import ConfigError, Map, NxtSonar, Registry, Scan
from toolkit.world.arrays import FloatArray

from .beam_model import BeamLikelihood, echo_mask, scan_readings
from .likelihood_field import DistanceField
from .models import RangeLikelihood, RangeTable, exact_ranges

__all__ = ["AUTO", "MEASUREMENT_MODELS", "AmclOptions", "BeamModel", "LikelihoodFieldModel", "MeasurementModel",
           "NxtBeamModel", "model_class", "model_names"]

AUTO = "auto"
"""The `model` that picks for the sensor: the NXT beam model with a `sonar_model`, else the beam model with
a lobe, the likelihood field for a thin ray."""
_SQRT_2PI = math.sqrt(2.0 * math.pi)


class AmclOptions(Protocol):
    """What a measurement model reads of the filter it serves (`localisation.amcl.Amcl`): its map, range
    table and options (lengths in cm, angles in degrees)."""

    map: Map
    laser_max_range: float
    beam_width_deg: float
    lobe_rays: int
    cast_exact: bool
    beam_interpolation: bool
    z_hit: float
    z_short: float
    z_rand: float
    sigma_hit: float
    lambda_short: float
    field_resolution_cm: float
    laser_likelihood_max_dist: float
    gaussian: RangeLikelihood

    @property
    def table(self) -> RangeTable:
        """The range table of expected ranges (built on first use)."""


class MeasurementModel(ABC):
    """How likely a scan's readings are from each pose: one of amcl's measurement models.

    A subclass sets ``name`` in its body (registering it in `MEASUREMENT_MODELS`) and implements
    `log_likelihood`; it may narrow `readings`, `echoes`, `free` and `lattice_model`.

    Parameters
    ----------
    amcl : AmclOptions
        The filter it serves (its map, range table, options).
    sonar_model : NxtSonar, optional
        The sonar's own beam mixture, for a model that `uses_sonar_model`.
    """

    name: ClassVar[str]
    title: ClassVar[str] = "measurement model"
    """What messages call it ("the likelihood field")."""
    uses_sonar_model: ClassVar[bool] = False
    """Whether it weighs the readings by a `sonar_model`'s beam mixture (which it then needs)."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            MEASUREMENT_MODELS.add(cls.name, cls)

    def __init__(self, amcl: AmclOptions, sonar_model: NxtSonar | None = None) -> None:
        self.amcl = amcl

    def readings(self, scan: Scan) -> tuple[FloatArray, FloatArray]:
        """The angles (rad) and readings (cm) of `scan` the model weighs: the valid finite readings below
        the range limit (`laser_max_range`)."""
        ok = scan.valid & np.isfinite(scan.ranges) & (scan.ranges < self.amcl.laser_max_range)
        return np.asarray(scan.angles[ok], dtype=float), np.asarray(scan.ranges[ok], dtype=float)

    def echoes(self, meas: FloatArray) -> NDArray[np.bool_]:
        """Which of the readings `readings` gave are echoes (an update needs one)."""
        return echo_mask(meas, None)

    def free(self, xy: FloatArray, clearance: float) -> NDArray[np.bool_]:
        """Positions inside the free area at least `clearance` cm from the walls, from the map itself."""
        amcl = self.amcl
        ok = np.asarray(amcl.map.contains(xy), dtype=bool)
        if clearance > 0 and ok.any():
            ok[ok] = np.asarray(amcl.map.wall_distance(xy[ok]), dtype=float) >= clearance
        return ok

    def lattice_model(self) -> Any:
        """The likelihood the scan draws and the ambiguity check score the lattice with
        (`localisation.beam_model.lattice_costs`): the Gaussian of `sigma_hit` by default."""
        return self.amcl.gaussian

    @abstractmethod
    def log_likelihood(self, poses: FloatArray, rel: FloatArray, meas: FloatArray) -> FloatArray:
        """Log-likelihood (N,) of the readings `meas` (B,) at angles `rel` (B,) from each pose (N, 3);
        ``-inf`` for poses outside the free area."""


MEASUREMENT_MODELS: Registry[MeasurementModel] = Registry("amcl measurement model")
"""amcl's measurement models (`MeasurementModel` subclasses), by name."""


def model_names() -> tuple[str, ...]:
    """What amcl's `model` option takes: ``auto`` and every registered model."""
    return (AUTO, *MEASUREMENT_MODELS.names())


def model_class(model: str, sonar_model: NxtSonar | None, beam_width_deg: float) -> type[MeasurementModel]:
    """The model class amcl's options choose: `model` by name, ``auto`` picked for the sensor (`AUTO`);
    ``beam`` told a `sonar_model` is the NXT beam model, the beam model with the sonar's mixture.

    Raises
    ------
    ConfigError
        For an unknown name (the message lists the known ones), a model that cannot use the
        `sonar_model` given, or one that needs a `sonar_model` and has none.
    """
    if model not in model_names():
        raise ConfigError(f"amcl model must be one of {', '.join(model_names())}, got {model!r}")
    if model == AUTO:
        model = NxtBeamModel.name if sonar_model is not None else "beam" if beam_width_deg > 0 else "field"
    elif model == BeamModel.name and sonar_model is not None:
        model = NxtBeamModel.name
    cls = MEASUREMENT_MODELS.get(model)
    if sonar_model is not None and not cls.uses_sonar_model:
        raise ConfigError(f"amcl: the {cls.title} cannot use a sonar_model (its lobe); use model='beam'")
    if sonar_model is None and cls.uses_sonar_model:
        raise ConfigError(f"amcl: the {cls.title} needs a sonar_model (its beam mixture)")
    return cls


class BeamModel(MeasurementModel):
    """Thrun's beam model around the range table's expected ranges (module docstring)."""

    name = "beam"
    title = "beam model"

    def __init__(self, amcl: AmclOptions, sonar_model: NxtSonar | None = None) -> None:
        super().__init__(amcl, sonar_model)
        self._lobe: dict[str, Any] | None = None
        half = round(max(amcl.beam_width_deg, 0.0) / 2.0)  # lobe half-width in the table's whole degrees
        if amcl.lobe_rays > 0 and half >= 1:
            table = amcl.table
            crit = table.critical_incidence_deg
            self._lobe = {"beam_width_deg": 2.0 * half * 360.0 / table.n_angles, "beam_rays": amcl.lobe_rays,
                          "critical_incidence_deg": crit}
            cos_crit = max(math.cos(math.radians(90.0 if crit is None else crit)), 0.1)
            # how far a smooth lobe reading can change across one table cell and one direction
            self._step_cm = math.sqrt(2.0) * table.resolution_cm / cos_crit
            self._step_per_cm = math.sqrt(1.0 / cos_crit**2 - 1.0) * 2.0 * math.pi / table.n_angles

    def free(self, xy: FloatArray, clearance: float) -> NDArray[np.bool_]:
        """From the range table's cells (from the map when every beam is cast exactly: no table)."""
        if self.amcl.cast_exact:
            return super().free(xy, clearance)
        return self.amcl.table.free(xy, clearance)

    def log_likelihood(self, poses: FloatArray, rel: FloatArray, meas: FloatArray) -> FloatArray:
        a = self.amcl
        e, inside = self.expected_ranges(poses, rel)
        rand = a.z_rand / a.laser_max_range
        norm = a.z_hit / (_SQRT_2PI * a.sigma_hit)
        with np.errstate(invalid="ignore", over="ignore"):
            r = (meas[None, :] - e) / a.sigma_hit
            dens = norm * np.exp(-0.5 * np.where(np.isfinite(r), r * r, np.inf)) + rand
            if a.z_short > 0:
                short = meas[None, :] < e
                lam = a.lambda_short
                eta = 1.0 / np.maximum(1.0 - np.exp(-lam * np.minimum(e, 1e6)), 1e-12)
                dens += np.where(short, a.z_short * eta * lam * np.exp(-lam * meas[None, :]), 0.0)
        return np.where(inside, np.log(dens).sum(axis=1), -np.inf)

    def expected_ranges(self, p: FloatArray, rel: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Expected ranges (N, B) and the poses inside the table: with `beam_interpolation`, trilinear
        between the 8 surrounding table nodes (cell centres x table directions) where all 8 are free and
        see a wall, the nearest node elsewhere; with `cast_exact`, exact ray casting."""
        a = self.amcl
        if a.cast_exact:
            cast = exact_ranges(a.map, p, rel, max_range_cm=a.laser_max_range)
            return cast, self.free(p[:, :2], 0.0)
        near, inside = a.table.lookup(p, rel)
        if not a.beam_interpolation:
            return near.astype(float), inside
        expected, ok, spread = self._interpolated(p, rel, near)
        if self._lobe is not None:
            with np.errstate(invalid="ignore"):
                smooth = spread[1] - spread[0] <= self._step_cm + self._step_per_cm * spread[0]
            self._lobe_ranges(p, rel, expected, inside[:, None] & ~(ok & smooth))
        return expected, inside

    def _interpolated(self, p: FloatArray, rel: FloatArray, near: NDArray[np.floating[Any]]
                      ) -> tuple[FloatArray, NDArray[np.bool_], tuple[FloatArray, FloatArray]]:
        """The trilinear ranges (the nearest node's where a node is outside or sees no wall), where all 8
        nodes count, and the least and largest of the 8 nodes' ranges."""
        t = self.amcl.table
        u = (p[:, :2] - t.origin) / t.resolution_cm - 0.5
        g = np.floor(u)
        f = u - g
        k = t.n_angles / (2.0 * math.pi)
        h = np.floor(p[:, 2] * k)
        fh = p[:, 2] * k - h
        total = np.zeros(near.shape)
        ok = np.ones(near.shape, dtype=bool)
        lo, hi = np.full(near.shape, np.inf), np.full(near.shape, -np.inf)
        for di, dj, dh in np.ndindex(2, 2, 2):
            node = np.column_stack([t.origin + (g + (di, dj) + 0.5) * t.resolution_cm, (h + dh) / k])
            e, ins = t.lookup(node, rel)
            w = (f[:, 0] if di else 1 - f[:, 0]) * (f[:, 1] if dj else 1 - f[:, 1]) * (fh if dh else 1 - fh)
            ok &= ins[:, None] & np.isfinite(e)
            total += w[:, None] * np.where(np.isfinite(e), e, 0.0)
            lo, hi = np.minimum(lo, e), np.maximum(hi, e)
        return np.where(ok, total, near), ok, (lo, hi)

    def _lobe_ranges(self, p: FloatArray, rel: FloatArray, out: FloatArray, where: NDArray[np.bool_]) -> None:
        """Cast the lobe exactly (`exact_ranges` with `lobe_rays` rays and the specular loss) for the
        beams `where` (N, B) of poses `p` and write the nearest echoes into `out`.

        Used where the table's nodes around a pose disagree by more than a smooth reading can change
        across one cell and one direction: there a wall enters the lobe at its edge or a corner passes
        through it, and interpolating the table would smear the reading's step over a whole cell and
        direction, while the sensor's reading steps where the geometry does (the likelihood would then
        prefer a pose where no step falls between the beams).
        """
        i, j = np.nonzero(where)
        if i.size == 0:
            return
        assert self._lobe is not None
        along = np.column_stack([p[i, :2], p[i, 2] + rel[j]])  # each beam as a pose facing its axis
        out[i, j] = exact_ranges(self.amcl.map, along, np.zeros(1), **self._lobe)[:, 0]


class NxtBeamModel(BeamModel):
    """The beam model's expected ranges weighed by the sonar's own beam mixture (`BeamLikelihood`)."""

    name = "nxt-beam"
    title = "NXT beam model"
    uses_sonar_model = True

    def __init__(self, amcl: AmclOptions, sonar_model: NxtSonar | None = None) -> None:
        super().__init__(amcl, sonar_model)
        assert sonar_model is not None
        self.beam = BeamLikelihood(sonar_model)
        self._scan_beam: BeamLikelihood = self.beam

    def readings(self, scan: Scan) -> tuple[FloatArray, FloatArray]:
        """The echoes and the no-echo readings (255) after stuck runs (judged against the map) are dropped
        (`scan_readings`); the mixture is weighted for this sweep's step from here on."""
        rel, meas, self._scan_beam = scan_readings(scan, self.beam, self.amcl.map)
        return rel, meas

    def echoes(self, meas: FloatArray) -> NDArray[np.bool_]:
        return echo_mask(meas, self._scan_beam)

    def lattice_model(self) -> Any:
        return self._scan_beam

    def log_likelihood(self, poses: FloatArray, rel: FloatArray, meas: FloatArray) -> FloatArray:
        e, inside = self.expected_ranges(poses, rel)
        return np.where(inside, self._scan_beam.log_likelihood(e, meas), -np.inf)


class LikelihoodFieldModel(MeasurementModel):
    """The likelihood field of the beams' end points (module docstring)."""

    name = "field"
    title = "likelihood field"

    def __init__(self, amcl: AmclOptions, sonar_model: NxtSonar | None = None) -> None:
        super().__init__(amcl, sonar_model)
        self.field = DistanceField(amcl.map, amcl.field_resolution_cm, amcl.laser_likelihood_max_dist)

    def log_likelihood(self, poses: FloatArray, rel: FloatArray, meas: FloatArray) -> FloatArray:
        a = self.amcl
        p = poses
        inside = self.free(p[:, :2], 0.0)
        ang = p[:, 2:3] + rel[None, :]
        ends = np.stack([p[:, 0:1] + meas * np.cos(ang), p[:, 1:2] + meas * np.sin(ang)], axis=-1)
        d = self.field(ends) / a.sigma_hit
        dens = a.z_hit / (_SQRT_2PI * a.sigma_hit) * np.exp(-0.5 * d * d) + a.z_rand / a.laser_max_range
        return np.where(inside, np.log(dens).sum(axis=1), -np.inf)
