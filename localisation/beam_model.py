"""The NXT sonar's beam mixture as a localiser's measurement model.

`toolkit.world.NxtSonar` gives P(reading | echo distance) for whole-centimetre readings: a true echo
(Gaussian, its spread growing with range), readings nearer than the wall, random readings, and a
no-echo reading (255) whose probability rises with range (the sensor's reach) and which is almost
certain where nothing in the lobe echoes. `BeamLikelihood` tabulates ``-2 log P`` once per model on
a 0.25 cm grid of echo distances x the 256 possible readings, so a particle filter weighs 1000
particles x 360 beams by one gather. Unlike a Gaussian of (expected - measured), it

* uses no-echo readings as evidence (a pose that puts a near wall where the sensor heard nothing is
  less likely than one where the lobe meets nothing or only far walls);
* lets no wrong reading outvote the others (a wrong reading costs at most the log of its random share);
* counts the readings of a dense sweep as the evidence they are: neighbouring readings share their
  errors, so each reading of a sweep `step` apart weighs ``min(1, step / correlation_deg)``.

Its costs have the same meaning as `RangeLikelihood.sq_residuals` (``-2 log-likelihood`` up to a
constant), so the annealed particle filter and AMCL use either unchanged. `lattice_costs` scores
every pose of a `RangeLattice` with either model (the FFT sum of squares for the Gaussian, a
compiled gather for the mixture, which no correlation can express).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from typing import Any, Protocol

import numpy as np
from numba import njit
from numpy.typing import NDArray

from toolkit.world import NO_ECHO, Map, NxtSonar, Scan
from toolkit.world.arrays import FloatArray

from .range_table import RangeLattice, quantise_ranges
from .scan import drop_stuck, sweep_step

__all__ = ["BeamLikelihood", "MeasurementModel", "echo_mask", "lattice_costs", "scan_readings"]


STEP_CM = 0.25
"""Echo-distance step of the tabulated costs (cm)."""


class MeasurementModel(Protocol):
    """What the particle filters need of a measurement model (`RangeLikelihood` or `BeamLikelihood`)."""

    @property
    def sigma_cm(self) -> float: ...

    def sq_residuals(self, expected: Any, measured: Any) -> FloatArray: ...


@lru_cache(maxsize=8)
def _cost_table(params: tuple[tuple[str, Any], ...]) -> NDArray[np.float32]:
    """``-2 log P`` (relative to the most likely entry) of an `NxtSonar` given as its sorted parameters:
    (echo distances every `STEP_CM` below the range limit, then inf) x (readings 0 .. limit - 1, then 255)."""
    sonar = NxtSonar(**dict(params))
    d = np.append(np.arange(0.0, sonar.max_range_cm, STEP_CM), np.inf)
    readings = np.append(np.arange(math.ceil(sonar.max_range_cm), dtype=float), NO_ECHO)
    lp = np.maximum(sonar.log_pmf(d[:, None], readings[None, :]), -50.0)
    return np.ascontiguousarray(-2.0 * (lp - lp.max()), dtype=np.float32)


@dataclass(frozen=True)
class BeamLikelihood:
    """``-2 log P(readings | expected echo distances)`` of an `NxtSonar` beam mixture (module docstring).

    Parameters
    ----------
    sonar : NxtSonar
        The sensor model (fitted to real sweeps by default).
    weight : float
        Weight of every reading (`NxtSonar.reading_weight` of the sweep's step); set per scan with
        `with_step`.
    """

    sonar: NxtSonar
    weight: float = 1.0

    @property
    def table(self) -> NDArray[np.float32]:
        """The costs, (echo distance rows, reading columns), built once per sonar model."""
        return _cost_table(tuple(sorted(asdict(self.sonar).items())))

    @property
    def sigma_cm(self) -> float:
        """Spread of a true echo's reading at short range (cm): the scale of the filters' moves."""
        return float(max(self.sonar.noise_sd, 0.5))

    def with_step(self, step_rad: float) -> BeamLikelihood:
        """The same model weighing each reading for a sweep whose readings are `step_rad` apart."""
        return replace(self, weight=self.sonar.reading_weight(step_rad))

    def rows(self, expected: Any) -> NDArray[np.int64]:
        """Table rows of expected echo distances (cm; inf or beyond the range limit: the last row)."""
        return quantise_ranges(expected, STEP_CM, self.table.shape[0] - 1)

    def columns(self, measured: Any) -> NDArray[np.int64]:
        """Table columns of readings (whole cm; at or beyond the range limit, or inf: no echo)."""
        m = np.asarray(measured, dtype=float).ravel()
        last = self.table.shape[1] - 1
        return np.where(np.isfinite(m) & (m < self.sonar.max_range_cm), np.clip(np.rint(m), 0, last - 1),
                        last).astype(np.int64)

    def sq_residuals(self, expected: Any, measured: Any) -> FloatArray:
        """Weighted summed costs (N,) of (N, B) expected echo distances against (B,) readings."""
        cost = self.table[self.rows(expected), self.columns(measured)[None, :]]
        return np.asarray(cost.sum(axis=1, dtype=np.float64) * self.weight)

    def log_likelihood(self, expected: Any, measured: Any, beta: float = 1.0) -> FloatArray:
        """Log-likelihood (N,) up to a constant, tempered by `beta`."""
        return -0.5 * beta * self.sq_residuals(expected, measured)

    def outliers(self, expected: Any, measured: Any) -> NDArray[np.bool_]:
        """Readings (B,) that a true echo of `expected` (B,) would hardly give (beyond 3 standard
        deviations; no-echo readings never count)."""
        e = np.asarray(expected, dtype=float).ravel()
        m = np.asarray(measured, dtype=float).ravel()
        with np.errstate(invalid="ignore"):
            off = ~(np.abs(e + self.sonar.bias_cm - m) <= 3.0 * self.sonar.reading_sd(e))
        return off & (m < self.sonar.max_range_cm)


@njit("void(uint16[:, ::1], int64[::1], int64[::1], float32[:, ::1], float64[:, ::1])", cache=True)
def _lattice_gather(rows: Any, dirs: Any, cols: Any, by_reading: Any, out: Any) -> None:  # pragma: no cover
    n_cells, n_ang = rows.shape
    last = by_reading.shape[1] - 1  # echo distances beyond the table: nothing echoes
    # each cell's row, clipped to the table, twice over: a shifted window of it never wraps, and the
    # innermost loop is a plain gather (the same sums, in the same order, as shifting with a wrap)
    clipped = np.empty(2 * n_ang, dtype=np.int64)
    acc = np.empty(n_ang, dtype=np.float64)
    for c in range(n_cells):
        row = rows[c]
        for h in range(n_ang):
            clipped[h] = clipped[h + n_ang] = min(row[h], last)
        acc[:] = 0.0
        for j in range(dirs.size):
            cost = by_reading[cols[j]]
            window = clipped[dirs[j] : dirs[j] + n_ang]
            for h in range(n_ang):
                acc[h] += cost[window[h]]
        out[c] = acc


def lattice_costs(lattice: RangeLattice, rel: Any, measured: Any, model: Any, max_beams: int = 48) -> FloatArray:
    """``-2 log-likelihood`` (up to a constant) of every lattice cell x table direction: (P, n_angles).

    A `BeamLikelihood` is gathered from its table (compiled, no approximation but the table's
    0.25 cm and whole directions) on at most `max_beams` evenly chosen readings, scaled up to all
    of them (the lattice only picks where the annealing starts); any other model is the Gaussian sum
    of squares of `RangeLattice.ssd` over ``sigma_cm^2`` (readings without an echo left out).
    """
    rel = np.asarray(rel, dtype=float).ravel()
    m = np.asarray(measured, dtype=float).ravel()
    if not isinstance(model, BeamLikelihood):
        ok = np.isfinite(m) & (m < NO_ECHO)
        return np.asarray(lattice.ssd(rel[ok], m[ok]) / model.sigma_cm**2)
    scale = 1.0
    if m.size > max_beams > 0:
        pick = np.linspace(0, m.size - 1, max_beams).round().astype(np.int64)
        scale = m.size / pick.size
        rel, m = rel[pick], m[pick]
    rows = lattice.quantised(STEP_CM)
    n_ang = lattice.table.n_angles
    dirs = np.mod(np.rint(rel * n_ang / (2.0 * math.pi)).astype(np.int64), n_ang)
    out = np.empty((len(lattice), n_ang))
    _lattice_gather(rows, np.ascontiguousarray(dirs), model.columns(m), np.ascontiguousarray(model.table.T), out)
    return out * (model.weight * scale)


def scan_readings(scan: Scan, model: Any, map: Map | None = None) -> tuple[FloatArray, FloatArray, Any]:
    """The angles (rad) and readings (cm) of `scan` a measurement model uses, and the model to use for it.

    A `BeamLikelihood` takes the echoes and the no-echo readings (255), after stuck runs are dropped
    (`localisation.scan.drop_stuck`: runs of equal readings that no pose of `map` explains with the
    model's lobe; without a map, by run length alone), and is returned weighted for the sweep's step;
    any other model takes the valid finite readings only.
    """
    if not isinstance(model, BeamLikelihood):
        ok = scan.valid & np.isfinite(scan.ranges)
        return np.asarray(scan.angles[ok], dtype=float), np.asarray(scan.ranges[ok], dtype=float), model
    step = sweep_step(scan)
    kept, _ = drop_stuck(scan, map, sonar=model.sonar)
    silent = ~kept.valid & ((kept.ranges >= NO_ECHO) | ~np.isfinite(kept.ranges))
    ok = (kept.valid & np.isfinite(kept.ranges)) | silent
    meas = np.where(silent, NO_ECHO, kept.ranges)[ok]
    return np.asarray(kept.angles[ok], dtype=float), np.asarray(meas, dtype=float), model.with_step(step)


def echo_mask(meas: Any, model: Any) -> NDArray[np.bool_]:
    """Which readings `scan_readings` returned for `model` are echoes: below 255 for a `BeamLikelihood`
    (whose readings include the no-echo 255s), every one for other models (they get echoes only, and a
    laser's echoes lie far beyond 255 cm)."""
    m = np.asarray(meas, dtype=float)
    return m < NO_ECHO if isinstance(model, BeamLikelihood) else np.isfinite(m)
