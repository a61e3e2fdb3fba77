"""Sonar models: what a sensor at a position reads along given absolute directions.

Two models, both seeded through an ``rng`` argument:

``ideal``
    BotSim's ``ultraScan``: every ray is intersected with the walls, Gaussian noise of ``noise_sd`` cm
    is added to the x and to the y of each crossing point, and the reading is the smallest distance
    from the sensor to a noisy crossing point. No range limit; ``inf`` when the ray meets no wall.
    On maps of more than 256 walls only the crossings within ``8 * noise_sd`` of the first one (at
    most four) get noise: a farther crossing wins with a probability below 1e-8, and the cost stays
    that of indexed ray casting; smaller maps draw noise for every (ray, wall) pair as BotSim does.
``nxt``
    A LEGO NXT ultrasonic sensor: a lobe of ``beam_width_deg`` sampled by ``beam_rays`` rays; a ray that
    meets a flat wall at more than ``critical_incidence_deg`` from the wall's normal is reflected away
    (specular loss), so the lobe's echo comes from the nearest surface another of its rays meets square
    enough, or from nothing. A beam mixture then gives the reading (Thrun, Burgard and Fox,
    *Probabilistic Robotics*, ch. 6): the echo plus Gaussian noise growing with range, rounded to whole
    centimetres; or a reading nearer than the echo; or a random one; or no echo (255), whose probability
    rises from ``dropout_prob`` to ``far_dropout_prob`` around ``reach_cm``, and is ``1 - phantom_prob``
    where the lobe meets nothing. `NxtSonar.log_pmf` is that distribution and `NxtSonar.sample` draws from
    it, so a model fitted to real sweeps (``toolkit.real_sonar.fit``) is the model the simulator uses. Its
    defaults are fitted to real sweeps; `NxtSonar.hardware_facts` is the model from the published facts.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import asdict, is_dataclass, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field, model_validator

from .arrays import FloatArray, normal_cdf
from .edge_index import edge_index
from .geometry import RngLike, as_rng
from .registry import Registry
from .robot import NO_ECHO, Scan
from .typed import Real, Whole, typed_dataclass, with_unit, worded

__all__ = ["SONAR_MODELS", "IdealSonar", "NxtSonar", "SonarModel", "make_sonar"]


SONAR_MODELS: Registry[SonarModel] = Registry("sonar model")


def _flatten(origins: ArrayLike, angles: ArrayLike) -> tuple[FloatArray, FloatArray, tuple[int, ...]]:
    o = np.asarray(origins, dtype=float)
    a = np.asarray(angles, dtype=float)
    if o.ndim == 1:
        return np.broadcast_to(o, (a.size, 2)).copy(), a.ravel(), a.shape
    if a.ndim == 1:
        a = np.broadcast_to(a[None, :], (o.shape[0], a.size))
    shape = a.shape
    return np.repeat(o.reshape(-1, 2), shape[-1], axis=0), a.ravel(), shape


class SonarModel(ABC):
    """A sonar: `measure(walls, origins, angles, rng)` returns readings in cm.

    Subclasses set ``name`` (their registry key, in the class body) and ``no_echo`` (the reading that
    means no echo: `to_scan` marks readings at or above it invalid). What the suite and the toolkit
    demand of a registered model: ``make_sonar(name)`` builds it with no arguments (every parameter has
    a default); `measure` takes the shapes of `toolkit.world.geometry.ray_cast` and gives the same
    readings for the same `rng` (``tests/test_world_sonar.py`` measures every registered model twice);
    a model with a lobe has ``beam_width_deg``, ``critical_incidence_deg`` and ``beam_rays``, one with
    a range limit ``max_range_cm``, and one with noise ``noise_sd`` (cm): `RobotModel` reads these
    attributes to tell the localisers the lobe, the limit and the sigma. ``docs/howto/sonar-model.md``
    writes one.
    """

    name: ClassVar[str]
    no_echo: ClassVar[float]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            SONAR_MODELS.add(cls.name, cls)

    @abstractmethod
    def measure(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike, rng: RngLike = None) -> Any:
        """Readings (cm) from sensors at `origins` along absolute `angles` (rad).

        Shapes as in `toolkit.world.geometry.ray_cast`: a (2,) origin with (A,) angles gives (A,);
        (P, 2) origins with (A,) or (P, A) angles give (P, A).
        """

    def to_scan(self, angles: ArrayLike, readings: ArrayLike) -> Scan:
        """`readings` along the relative `angles` (rad) as a `Scan`: an echo is a finite reading below
        the model's ``no_echo`` (so the ideal model keeps every hit, however far; the NXT none at 255)."""
        return Scan.from_readings(angles, readings, max_range=self.no_echo)

    def to_dict(self) -> dict[str, Any]:
        """The model's name and parameters."""
        params: dict[str, Any] = asdict(self) if is_dataclass(self) else {}
        return {"name": self.name, **params}



def _probability(default: float, text: str) -> Any:
    return Field(default, ge=0.0, le=1.0, json_schema_extra=with_unit("probability"), description=text)


@typed_dataclass(frozen=False)
class IdealSonar(SonarModel):
    """BotSim's ultraScan (see the module docstring)."""

    name: ClassVar[str] = "ideal"
    no_echo: ClassVar[float] = float("inf")
    noise_sd: Real = Field(default=1.0, ge=0.0, json_schema_extra=with_unit("cm"), description=(
        "Gaussian noise added to the x and to the y of each crossing point (the paper: 1 cm)."))

    crossings: ClassVar[int] = 4
    """Crossings per ray that receive noise (the nearest ones within ``slack_sd * noise_sd``)."""
    slack_sd: ClassVar[float] = 8.0
    per_wall_draws_up_to: ClassVar[int] = 256
    """Maps with at most this many walls draw one noise pair per (ray, wall), as BotSim does."""

    def measure(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike, rng: RngLike = None) -> Any:
        ox_oy, a, shape = _flatten(origins, angles)
        index = edge_index(walls)
        noisy = self.noise_sd > 0
        t, w = index.cast(ox_oy[:, 0], ox_oy[:, 1], a, k=self.crossings if noisy else 1,
                          slack=self.slack_sd * self.noise_sd if noisy else 0.0)
        if not noisy:
            return t[:, 0].reshape(shape)
        gen = as_rng(rng)
        hit = np.isfinite(t)
        n_walls = len(index.walls)
        if n_walls <= self.per_wall_draws_up_to:
            # BotSim draws noise for every (ray, wall) pair: so do we on small maps, so that a seed
            # gives the same readings as a brute-force ultraScan
            rows = np.arange(a.size)[:, None]
            col = np.maximum(w, 0)
            ex = (gen.standard_normal((a.size, n_walls)) * self.noise_sd)[rows, col]
            ey = (gen.standard_normal((a.size, n_walls)) * self.noise_sd)[rows, col]
        else:
            ex = gen.standard_normal(t.shape) * self.noise_sd
            ey = gen.standard_normal(t.shape) * self.noise_sd
        tt = np.where(hit, t, 0.0)
        d = np.hypot(tt * np.cos(a)[:, None] + ex, tt * np.sin(a)[:, None] + ey)
        return np.where(hit, d, np.inf).min(axis=1).reshape(shape)


@typed_dataclass(frozen=False)
class NxtSonar(SonarModel):
    """A LEGO NXT ultrasonic sensor: a lobe with specular loss and a beam mixture (module docstring); each
    parameter's range, unit and meaning is in its declaration.

    The defaults are the parameters fitted by maximum likelihood to the real sweeps of
    ``docs/real-sonar.md`` (``nxtnav sonar fit``); `NxtSonar.hardware_facts()` gives the model
    built from the published hardware facts alone. The same values are in
    ``maps/real-nxt/sonar-profiles/nxt-fitted.yaml``, and a test keeps the two equal.
    """

    name: ClassVar[str] = "nxt"
    no_echo: ClassVar[float] = NO_ECHO
    noise_sd: Real = Field(default=1.188316, ge=0.0, le=100.0, json_schema_extra=with_unit("cm"), description=(
        "Standard deviation of a true echo's reading at zero range, before rounding."))
    noise_per_m: Real = Field(default=0.925943, ge=0.0, le=100.0, json_schema_extra=with_unit("cm/m"), description=(
        "Growth of that standard deviation per metre of range."))
    bias_cm: Real = Field(default=-0.480274, ge=-50.0, le=50.0, json_schema_extra=with_unit("cm"), description=(
        "Mean offset of a true echo's reading from the echo distance."))
    beam_width_deg: Real = Field(default=40.0, ge=0.0, le=120.0, json_schema_extra=with_unit("deg"),
                                 description="Full width of the lobe.")
    beam_rays: Whole = Field(default=17, ge=1, le=1001,
                             description="Rays sampling the lobe (odd, so one lies on the axis).")
    critical_incidence_deg: Real = Field(default=30.0, ge=0.0, le=90.0, json_schema_extra=with_unit("deg"),
                                         description=(
        "Largest angle between a ray and a wall's normal that still echoes back."))
    min_range_cm: Real = Field(default=6.0, ge=0.0, le=255.0, json_schema_extra=with_unit("cm"), description=(
        "Below this echo distance readings are unreliable: 255 with probability close_no_echo_prob, otherwise "
        "a uniform whole number in [0, min_range_cm)."))
    max_range_cm: Real = Field(default=255.0, ge=1.0, le=10_000.0, json_schema_extra=with_unit("cm"),
                               description="Readings at or beyond this are reported as 255.")
    dropout_prob: Real = _probability(0.00795, "Probability that an echo within reach is lost (255) at short range.")
    far_dropout_prob: Real = _probability(0.334932, (
        "The same far beyond reach_cm: the loss probability rises from dropout_prob to this along a logistic "
        "curve centred on reach_cm, reach_width_cm wide."))
    reach_cm: Real = Field(default=57.853445, ge=0.0, le=10_000.0, json_schema_extra=with_unit("cm"),
                           description="Centre of the rise of the loss probability (see far_dropout_prob).")
    reach_width_cm: Real = Field(default=1.0, ge=0.1, le=10_000.0, json_schema_extra=with_unit("cm"),
                                 description="Width of the rise of the loss probability (see far_dropout_prob).")
    phantom_prob: Real = _probability(0.716444, "Probability of a (uniformly random) reading when nothing in the "
                                                "lobe echoes.")
    short_prob: Real = _probability(0.123682, (
        "Share of the readings of an echo that come from something nearer than the wall (uniform between 0 and "
        "the echo distance: a passer-by, crosstalk, the lobe's edge)."))
    outlier_prob: Real = _probability(0.079517, "Share of the readings of an echo that are uniformly random in "
                                                "[0, max_range_cm).")
    close_no_echo_prob: Real = _probability(0.5, "See min_range_cm.")
    correlation_deg: Real = Field(default=29.47, ge=0.0, le=360.0, json_schema_extra=with_unit("deg"), description=(
        "Readings closer than this in turret angle are not independent evidence (neighbouring lobes overlap "
        "and share their errors): a localiser counts each reading of a sweep step degrees apart with weight "
        "min(1, step / correlation_deg)."))
    turret_offset_deg: Real = Field(default=0.0, ge=-180.0, le=180.0, json_schema_extra=with_unit("deg"),
                                    description=(
        "Where this model finds the turret's zero, counter-clockwise from the forward direction, on the robot "
        "whose real sweeps it describes (a turret set by hand, or the model aligning sweeps differently from "
        "their heading_deg): bench routes and bench sweeps turn that source's readings by it into the robot's "
        "frame. Measured by nxtnav sonar turret against the sweeps' heading_deg (sonar fit leaves it as "
        "it was); the simulator's turret has none."))

    @model_validator(mode="after")
    def _shares_add_up(self) -> NxtSonar:
        if self.short_prob + self.outlier_prob > 1.0:
            raise worded(f"short_prob + outlier_prob must be <= 1, got {self.short_prob + self.outlier_prob:g}")
        return self

    @classmethod
    def hardware_facts(cls, **overrides: Any) -> NxtSonar:
        """The model from the published hardware facts alone (the toolkit's `nxt` default before any
        real sweep was fitted): 1 cm noise, a 20-degree lobe, specular loss beyond 40 degrees, 2 %
        dropouts, no wrong readings."""
        base = {"noise_sd": 1.0, "noise_per_m": 0.0, "bias_cm": 0.0, "beam_width_deg": 20.0, "beam_rays": 9,
                "critical_incidence_deg": 40.0, "min_range_cm": 6.0, "max_range_cm": 255.0, "dropout_prob": 0.02,
                "far_dropout_prob": 0.02, "reach_cm": 200.0, "reach_width_cm": 20.0, "phantom_prob": 0.0,
                "short_prob": 0.0, "outlier_prob": 0.0, "close_no_echo_prob": 0.5, "correlation_deg": 0.0}
        return cls(**{**base, **overrides})

    def simulated(self) -> NxtSonar:
        """The model of this sensor's *simulated* readings, as a localiser facing them should use it: the
        simulator and the virtual brick draw every reading independently (`sample`), so no reading
        shares another's error (`correlation_deg` 0). Real readings keep the fitted correlation."""
        return replace(self, correlation_deg=0.0)

    def ray_hits(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike) -> tuple[Any, Any]:
        """Every ray of the lobe of each (origin, angle): the distance to the first wall it meets (inf:
        none) and the cosine of its incidence on that wall, each (..., beam_rays) in `angles`' shape."""
        index = edge_index(walls)
        w = index.walls
        o, a, shape = _flatten(origins, angles)
        half = np.radians(self.beam_width_deg) / 2.0
        offsets = np.linspace(-half, half, self.beam_rays) if self.beam_rays > 1 else np.zeros(1)
        ang = (a[:, None] + offsets[None, :]).ravel()
        out_shape = (*shape, offsets.size)
        if len(w) == 0:
            return np.full(out_shape, np.inf), np.ones(out_shape)
        t, hit = index.cast(np.repeat(o[:, 0], offsets.size), np.repeat(o[:, 1], offsets.size), ang)
        first, idx = t[:, 0], np.maximum(hit[:, 0], 0)
        # incidence: angle between the ray and the normal of the wall it meets first
        ex, ey = w[idx, 2] - w[idx, 0], w[idx, 3] - w[idx, 1]
        norm = np.hypot(ex, ey)
        cos_inc = np.abs(np.cos(ang) * ey - np.sin(ang) * ex) / np.where(norm > 0, norm, 1.0)
        return first.reshape(out_shape), cos_inc.reshape(out_shape)

    def echo_distance(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike) -> Any:
        """Noise-free distance of the nearest echo in the lobe (inf when every ray is lost)."""
        first, cos_inc = self.ray_hits(walls, origins, angles)
        return self.echoes(first, cos_inc).min(axis=-1)

    def echoes(self, first: Any, cos_inc: Any) -> Any:
        """`ray_hits`' distances where the ray's echo comes back (inf where it meets its wall beyond the
        critical incidence, or none)."""
        echo = np.isfinite(first) & (cos_inc >= np.cos(np.radians(self.critical_incidence_deg)))
        return np.where(echo, first, np.inf)

    # -- the beam mixture ---------------------------------------------------------------------------
    def loss_probability(self, d: ArrayLike) -> FloatArray:
        """Probability (same shape as `d`) that an echo from distance `d` (cm) is lost (reads 255)."""
        dd = np.asarray(d, dtype=float)
        z = np.clip((dd - self.reach_cm) / self.reach_width_cm, -50.0, 50.0)
        rise = 1.0 / (1.0 + np.exp(-np.where(np.isfinite(z), z, 50.0)))
        return np.asarray(self.dropout_prob + (self.far_dropout_prob - self.dropout_prob) * rise)

    def reading_sd(self, d: ArrayLike) -> FloatArray:
        """Standard deviation (cm) of a true echo's reading from distance `d` (before rounding)."""
        dd = np.where(np.isfinite(np.asarray(d, dtype=float)), np.asarray(d, dtype=float), 0.0)
        return np.asarray(np.maximum(self.noise_sd + self.noise_per_m * dd / 100.0, 0.05))

    def _levels(self) -> int:
        return max(math.ceil(self.max_range_cm), 1)

    def log_pmf(self, d: ArrayLike, readings: ArrayLike) -> FloatArray:
        """log P(reading | echo distance): the probability of each whole-cm reading (255: no echo).

        `d` (cm, inf where nothing in the lobe echoes) and `readings` broadcast together. Readings
        are rounded to whole centimetres; any reading at or beyond `max_range_cm` counts as no echo.
        This is the distribution `measure` draws from, so fitting and simulating agree.
        """
        dd, r = np.broadcast_arrays(np.asarray(d, dtype=float), np.rint(np.asarray(readings, dtype=float)))
        levels = self._levels()
        silent = r >= self.max_range_cm
        echo = np.isfinite(dd) & (dd < self.max_range_cm)
        close = echo & (dd < self.min_range_cm)
        mu = dd + self.bias_cm
        sd = self.reading_sd(dd)
        with np.errstate(invalid="ignore"):
            lower = np.where(r <= 0, -np.inf, r - 0.5)  # the simulator clips at 0: reading 0 takes what lies below
            hit = normal_cdf((r + 0.5 - mu) / sd) - normal_cdf((lower - mu) / sd)
            beyond = 1.0 - normal_cdf((self.max_range_cm - 0.5 - mu) / sd)
        n_short = np.maximum(np.floor(np.where(echo, dd, 1.0)), 1.0)
        short = np.where(r < n_short, 1.0 / n_short, 0.0)
        z_hit = 1.0 - self.short_prob - self.outlier_prob
        valid = z_hit * hit + self.short_prob * short + self.outlier_prob / levels
        lost = self.loss_probability(dd)
        p_echo = np.where(silent, lost + (1.0 - lost) * z_hit * beyond, (1.0 - lost) * valid)
        n_close = max(math.ceil(self.min_range_cm), 1)
        p_close = np.where(silent, self.close_no_echo_prob, np.where(r < n_close, (1.0 - self.close_no_echo_prob)
                                                                     / n_close, 0.0))
        p_none = np.where(silent, 1.0 - self.phantom_prob, self.phantom_prob / levels)
        p = np.where(close, p_close, np.where(echo, p_echo, p_none))
        with np.errstate(divide="ignore"):
            return np.asarray(np.log(np.maximum(p, 0.0)))

    def sample(self, d: ArrayLike, rng: RngLike = None) -> FloatArray:
        """Readings (whole cm, 255 = no echo) drawn for echo distances `d` (cm, inf: nothing echoes)."""
        gen = as_rng(rng)
        dd = np.asarray(d, dtype=float)
        shape = dd.shape
        levels = self._levels()
        echo = np.isfinite(dd) & (dd < self.max_range_cm)
        de = np.where(echo, dd, 0.0)
        hit = np.rint(np.clip(de + self.bias_cm + gen.standard_normal(shape) * self.reading_sd(de), 0.0, None))
        n_short = np.maximum(np.floor(de), 1.0)
        short = np.floor(gen.random(shape) * n_short)
        rand = np.floor(gen.random(shape) * levels)
        pick = gen.random(shape)
        reading = np.where(pick < self.short_prob, short,
                           np.where(pick < self.short_prob + self.outlier_prob, rand, hit))
        reading = np.where(gen.random(shape) < self.loss_probability(de), NO_ECHO, reading)
        reading = np.where(echo, reading, np.where(gen.random(shape) < self.phantom_prob, rand, NO_ECHO))
        close = echo & (dd < self.min_range_cm)
        if close.any():
            junk = np.where(gen.random(shape) < self.close_no_echo_prob, NO_ECHO,
                            np.floor(gen.random(shape) * max(math.ceil(self.min_range_cm), 1)))
            reading = np.where(close, junk, reading)
        return np.asarray(np.where(reading >= self.max_range_cm, NO_ECHO, reading))

    def measure(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike, rng: RngLike = None) -> Any:
        d = np.asarray(self.echo_distance(walls, origins, angles), dtype=float)
        return self.sample(d, rng)

    def reading_weight(self, step_rad: float) -> float:
        """Weight of one reading of a sweep whose readings are `step_rad` apart (see `correlation_deg`)."""
        if self.correlation_deg <= 0:
            return 1.0
        return float(min(1.0, math.degrees(abs(step_rad)) / self.correlation_deg))


def make_sonar(name: str, **params: Any) -> SonarModel:
    """A sonar model by registry name (``ideal``, ``nxt``) with its parameters."""
    return SONAR_MODELS.get(name)(**params)

