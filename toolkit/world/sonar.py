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
    (specular loss), so the reading comes from a farther surface seen by another ray of the lobe, or is
    255 (no echo). Readings are the nearest echo plus Gaussian noise, rounded to whole centimetres,
    255 beyond ``max_range_cm``, unreliable below ``min_range_cm`` and dropped (255) with probability
    ``dropout_prob``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import asdict, dataclass, is_dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .edge_index import edge_index
from .errors import ConfigError
from .geometry import RngLike, as_rng
from .registry import Registry
from .robot import NO_ECHO, Scan

__all__ = ["SONAR_MODELS", "IdealSonar", "NxtSonar", "SonarModel", "make_sonar"]

FloatArray = NDArray[np.float64]

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

    Subclasses set ``name`` (their registry key) and ``no_echo`` (the reading that means no echo).
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


@dataclass
class IdealSonar(SonarModel):
    """BotSim's ultraScan (see the module docstring). `noise_sd` in cm (the paper: 1 cm)."""

    name: ClassVar[str] = "ideal"
    no_echo: ClassVar[float] = float("inf")
    noise_sd: float = 1.0

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


@dataclass
class NxtSonar(SonarModel):
    """A LEGO NXT ultrasonic sensor (see the module docstring); defaults from the hardware facts.

    Parameters
    ----------
    noise_sd : float
        Gaussian noise (cm) before rounding; the sensor is good to about +-3 cm.
    beam_width_deg : float
        Full width of the lobe (about 20 cm wide at 40-70 cm away, i.e. ~20 degrees).
    beam_rays : int
        Rays sampling the lobe (odd, so one lies on the axis).
    critical_incidence_deg : float
        Largest angle between a ray and a wall's normal that still echoes back.
    min_range_cm : float
        Below this true distance readings are unreliable: 255 with probability `close_no_echo_prob`,
        otherwise a uniform value in [0, min_range_cm).
    max_range_cm : float
        Readings at or beyond this are reported as 255.
    dropout_prob : float
        Probability that a reading is lost (255) for no geometric reason.
    close_no_echo_prob : float
        See `min_range_cm`.
    """

    name: ClassVar[str] = "nxt"
    no_echo: ClassVar[float] = NO_ECHO
    noise_sd: float = 1.0
    beam_width_deg: float = 20.0
    beam_rays: int = 9
    critical_incidence_deg: float = 40.0
    min_range_cm: float = 6.0
    max_range_cm: float = 255.0
    dropout_prob: float = 0.02
    close_no_echo_prob: float = 0.5

    def __post_init__(self) -> None:
        if self.beam_rays < 1:
            raise ConfigError(f"beam_rays must be >= 1, got {self.beam_rays}")
        for k in ("noise_sd", "beam_width_deg", "critical_incidence_deg", "min_range_cm", "max_range_cm"):
            if not np.isfinite(getattr(self, k)) or getattr(self, k) < 0:
                raise ConfigError(f"{k} must be a non-negative number, got {getattr(self, k)!r}")
        for k in ("dropout_prob", "close_no_echo_prob"):
            if not 0.0 <= getattr(self, k) <= 1.0:
                raise ConfigError(f"{k} must be a probability in [0, 1], got {getattr(self, k)!r}")

    def echo_distance(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike) -> Any:
        """Noise-free distance of the nearest echo in the lobe (inf when every ray is lost)."""
        index = edge_index(walls)
        w = index.walls
        o, a, shape = _flatten(origins, angles)
        half = np.radians(self.beam_width_deg) / 2.0
        offsets = np.linspace(-half, half, self.beam_rays) if self.beam_rays > 1 else np.zeros(1)
        ang = (a[:, None] + offsets[None, :]).ravel()
        dx, dy = np.cos(ang), np.sin(ang)
        t, hit = index.cast(np.repeat(o[:, 0], offsets.size), np.repeat(o[:, 1], offsets.size), ang)
        first, idx = t[:, 0], np.maximum(hit[:, 0], 0)
        if len(w) == 0:
            return np.full(shape, np.inf)
        # incidence: angle between the ray and the normal of the wall it meets first
        ex, ey = w[idx, 2] - w[idx, 0], w[idx, 3] - w[idx, 1]
        norm = np.hypot(ex, ey)
        cos_inc = np.abs(dx * ey - dy * ex) / np.where(norm > 0, norm, 1.0)
        echo = np.isfinite(first) & (cos_inc >= np.cos(np.radians(self.critical_incidence_deg)))
        per_ray = np.where(echo, first, np.inf).reshape(-1, offsets.size)
        return per_ray.min(axis=1).reshape(shape)

    def measure(self, walls: ArrayLike, origins: ArrayLike, angles: ArrayLike, rng: RngLike = None) -> Any:
        gen = as_rng(rng)
        d = np.asarray(self.echo_distance(walls, origins, angles), dtype=float)
        noisy = d + gen.standard_normal(d.shape) * self.noise_sd
        reading = np.rint(np.clip(noisy, 0.0, None))
        reading = np.where(np.isfinite(d) & (reading < self.max_range_cm), reading, NO_ECHO)
        close = np.isfinite(d) & (d < self.min_range_cm)
        if close.any():
            junk = np.where(
                gen.random(d.shape) < self.close_no_echo_prob,
                NO_ECHO,
                np.floor(gen.uniform(0.0, self.min_range_cm, d.shape)),
            )
            reading = np.where(close, junk, reading)
        if self.dropout_prob > 0:
            reading = np.where(gen.random(d.shape) < self.dropout_prob, NO_ECHO, reading)
        return reading


def make_sonar(name: str, **params: Any) -> SonarModel:
    """A sonar model by registry name (``ideal``, ``nxt``) with its parameters."""
    return SONAR_MODELS.get(name)(**params)
