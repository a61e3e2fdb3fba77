"""The ``laser`` sensor model: a scanning range finder's narrow beam, as a ROS ``LaserScan`` reports it.

Each reading is one thin ray (no lobe, no specular loss): the distance to the first wall plus Gaussian
noise of ``noise_sd`` cm. A reading is an echo only inside ``[min_range_cm, max_range_cm]`` (the
message's ``range_min`` and ``range_max``); anything else, and a ray that meets nothing, is no echo
(``inf``), as the ROS message's rule says (readings outside the limits are to be discarded). Two
small shares of the readings go wrong: ``miss_prob`` of the echoes within reach are lost (no echo; a
black or glancing surface), ``rand_prob`` are uniformly random within the limits (glass, passers-by).

`LaserScanner.log_pdf` is the model's likelihood of a reading given the noise-free distance: a
density (per cm) for an echo, a probability for no echo; `LaserScanner.sample` draws readings from
the same mixture, so simulating and weighing agree.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import Field, model_validator

from .arrays import FloatArray, normal_cdf
from .errors import ConfigError
from .geometry import RngLike, as_rng, ray_cast
from .robot import Scan
from .sonar import SonarModel
from .typed import Real, typed_dataclass, worded

__all__ = ["LaserScanner"]


@typed_dataclass(frozen=False)
class LaserScanner(SonarModel):
    """A laser range finder's beam (module docstring); each parameter's range, unit and meaning is in its
    declaration."""

    name: ClassVar[str] = "laser"
    no_echo: ClassVar[float] = float("inf")
    noise_sd: Real = Field(default=1.0, ge=0.0, json_schema_extra={"unit": "cm"},
                           description="Standard deviation of an echo's reading.")
    min_range_cm: Real = Field(default=0.0, ge=0.0, json_schema_extra={"unit": "cm"}, description=(
        "Readings below this are no echo (a ROS LaserScan's range_min)."))
    max_range_cm: Real = Field(default=3000.0, ge=0.0, json_schema_extra={"unit": "cm"}, description=(
        "Readings beyond this are no echo (a ROS LaserScan's range_max)."))
    miss_prob: Real = Field(default=0.0, ge=0.0, le=1.0, json_schema_extra={"unit": "probability"},
                            description="Probability that an echo within the limits is lost.")
    rand_prob: Real = Field(default=0.0, ge=0.0, le=1.0, json_schema_extra={"unit": "probability"}, description=(
        "Probability that a reading is uniformly random within the limits (also where nothing echoes)."))

    @model_validator(mode="after")
    def _window(self) -> LaserScanner:
        if not self.max_range_cm > self.min_range_cm:
            raise worded(f"laser max_range_cm ({self.max_range_cm:g}) must exceed min_range_cm "
                         f"({self.min_range_cm:g})")
        return self

    @property
    def span_cm(self) -> float:
        """Width of the window of echoes (cm)."""
        return float(self.max_range_cm - self.min_range_cm)

    def in_window(self, r: ArrayLike) -> NDArray[np.bool_]:
        """Whether readings (cm) are echoes: finite and within ``[min_range_cm, max_range_cm]``."""
        rr = np.asarray(r, dtype=float)
        with np.errstate(invalid="ignore"):
            return np.isfinite(rr) & (rr >= self.min_range_cm) & (rr <= self.max_range_cm)

    def to_scan(self, angles: ArrayLike, readings: ArrayLike) -> Scan:
        """Readings along relative `angles` (rad) as a `Scan`; echoes are the readings within the limits."""
        a = np.asarray(angles, dtype=float).ravel()
        r = np.asarray(readings, dtype=float).ravel()
        if a.shape != r.shape:
            raise ConfigError(f"{a.size} angles but {r.size} ranges")
        ok = self.in_window(r)
        return Scan(a, np.where(ok, r, np.inf), ok)

    def log_pdf(self, d: ArrayLike, readings: ArrayLike) -> FloatArray:
        """log p(reading | noise-free distance `d`): a density (1/cm) for an echo, the log probability of
        no echo for a reading outside the limits (inf, nan, too near or too far). `d` (cm; inf where the
        ray meets nothing) and `readings` broadcast together."""
        dd, r = np.broadcast_arrays(np.asarray(d, dtype=float), np.asarray(readings, dtype=float))
        seen = self.in_window(dd)
        echo = self.in_window(r)
        sd = max(self.noise_sd, 1e-6)
        de = np.where(seen, dd, 0.0)
        with np.errstate(invalid="ignore", over="ignore"):
            z = (np.where(echo, r, 0.0) - de) / sd
            gauss = np.exp(-0.5 * z * z) / (sd * math.sqrt(2.0 * math.pi))
            kept = normal_cdf((self.max_range_cm - de) / sd) - normal_cdf((self.min_range_cm - de) / sd)
        uniform = self.rand_prob / self.span_cm
        hit = 1.0 - self.rand_prob
        p_echo = np.where(seen, (1.0 - self.miss_prob) * hit * gauss, 0.0) + uniform
        p_none = np.where(seen, self.miss_prob * hit + (1.0 - self.miss_prob) * hit * (1.0 - kept), hit)
        with np.errstate(divide="ignore"):
            return np.asarray(np.log(np.where(echo, p_echo, p_none)))

    def sample(self, d: ArrayLike, rng: RngLike = None) -> FloatArray:
        """Readings (cm; inf = no echo) drawn for noise-free distances `d` (cm; inf: nothing met)."""
        gen = as_rng(rng)
        dd = np.asarray(d, dtype=float)
        shape = dd.shape
        seen = self.in_window(dd)
        noisy = np.where(seen, dd, np.inf) + gen.standard_normal(shape) * self.noise_sd
        lost = gen.random(shape) < self.miss_prob
        reading = np.where(seen & ~lost, noisy, np.inf)
        rand = self.min_range_cm + gen.random(shape) * self.span_cm
        reading = np.where(gen.random(shape) < self.rand_prob, rand, reading)
        return np.asarray(np.where(self.in_window(reading), reading, np.inf))

    def measure(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike, rng: RngLike = None) -> Any:
        # walls beyond the range limit plus a generous noise margin cannot give an echo
        reach = self.max_range_cm + 8.0 * self.noise_sd
        d = np.asarray(ray_cast(walls, origins, angles, max_range=reach), dtype=float)
        return self.sample(d, rng)
