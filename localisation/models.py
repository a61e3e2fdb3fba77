"""Motion and measurement models shared by the localisers.

Motion model
    `MotionModel` samples where a set of poses ends up after a commanded `Motion` (turn in place, then
    drive), with the simulator's two noise semantics given as plain floats and a model name, so that
    localisers need not import `toolkit.robots`:

    ``botsim`` (proportional)
        turn(a): heading += a + a * N(0,1) * turn; move(d): heading += N(0,1) * turn, then the robot
        drives d + d * N(0,1) * motion.
    ``absolute``
        turn(a): heading += a + N(0,1) * turn; move(d): heading += N(0,1) * turn, then d + N(0,1) * motion.

Measurement model
    Expected ranges by ray casting from `toolkit.world` (`exact_ranges`) or from a precomputed
    `RangeTable` (a grid of positions x absolute directions, built once per map with `ray_cast`,
    cached in memory and optionally on disk), and `RangeLikelihood`, a Gaussian likelihood of
    (expected - measured) range evaluated in log space, optionally tempered and with each beam's
    penalty capped (a robust floor for outliers such as specular readings).
"""

from __future__ import annotations

import logging
import math
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field, field_validator

from toolkit.world import Map, RngLike, as_rng, ray_cast, wrap_angle
from toolkit.world.arrays import FloatArray
from toolkit.world.typed import Real, typed_dataclass, worded

from .base import Motion
from .range_table import (
    DEFAULT_RANGE_MEMORY_MB,
    RANGE_MEMORY_ENV,
    RESOLUTION_LADDER_CM,
    RangeLattice,
    RangeTable,
    TablePlan,
    clear_range_table_cache,
    lobe_minimum,
    plan_range_table,
    range_lattice,
    range_memory_budget,
    range_table,
)

__all__ = [
    "DEFAULT_RANGE_MEMORY_MB",
    "NOISE_MODELS",
    "RANGE_MEMORY_ENV",
    "RESOLUTION_LADDER_CM",
    "MotionModel",
    "RangeLattice",
    "RangeLikelihood",
    "RangeTable",
    "TablePlan",
    "clear_range_table_cache",
    "exact_ranges",
    "lobe_minimum",
    "plan_range_table",
    "range_lattice",
    "range_memory_budget",
    "range_table",
]

log = logging.getLogger(__name__)

NOISE_MODELS = ("botsim", "absolute")


@typed_dataclass()
class MotionModel:
    """Sampling motion model with the simulator's noise semantics (see the module docstring).

    Attributes
    ----------
    model : {"botsim", "absolute"}
        Proportional (BotSim) or absolute noise.
    motion : float
        botsim: fraction of each move (the paper: 0.1); absolute: cm per move.
    turn : float
        botsim: fraction of each turn and rad of heading noise per move (0.005); absolute: rad.
    inflation : float
        Factor applied to both noise levels (> 1 makes the filter more tolerant of unmodelled error).
    """

    model: Literal["botsim", "absolute"] = "botsim"
    motion: Real = Field(default=0.1, ge=0)
    turn: Real = Field(default=0.005, ge=0)
    inflation: Real = Field(default=1.0, ge=0)

    @field_validator("model", mode="before")
    @classmethod
    def _known_model(cls, value: Any) -> Any:
        if value not in NOISE_MODELS:
            raise worded(f"noise model must be one of {', '.join(NOISE_MODELS)}, got {value!r}")
        return value

    def sample(self, poses: ArrayLike, motion: Motion, rng: RngLike = None) -> FloatArray:
        """Move every pose of `poses` ((N, 3): x cm, y cm, theta rad) by `motion`, with noise.

        Returns a new (N, 3) array; headings wrapped to [-pi, pi).
        """
        gen = as_rng(rng)
        p = np.array(poses, dtype=float, copy=True).reshape(-1, 3)
        n = p.shape[0]
        a = float(motion.turn_rad)
        d = float(motion.distance_cm)
        k_turn = self.turn * self.inflation
        k_move = self.motion * self.inflation
        if a != 0.0:
            eps = gen.standard_normal(n) * k_turn
            p[:, 2] += a + (a * eps if self.model == "botsim" else eps)
        if d != 0.0:
            p[:, 2] += gen.standard_normal(n) * k_turn
            eps = gen.standard_normal(n) * k_move
            dd = d + (d * eps if self.model == "botsim" else eps)
            p[:, 0] += dd * np.cos(p[:, 2])
            p[:, 1] += dd * np.sin(p[:, 2])
        p[:, 2] = wrap_angle(p[:, 2])
        return p

    def mean(self, pose: ArrayLike, motion: Motion) -> FloatArray:
        """The noise-free result of `motion` from one pose (3,)."""
        x, y, th = np.asarray(pose, dtype=float).ravel()[:3]
        th = th + motion.turn_rad
        return np.array([x + motion.distance_cm * math.cos(th), y + motion.distance_cm * math.sin(th),
                         wrap_angle(th)])

    def covariance(self, pose: ArrayLike, motion: Motion) -> FloatArray:
        """First-order (3, 3) covariance that `motion` adds around `mean(pose, motion)` (cm^2, rad^2)."""
        th = float(np.asarray(pose, dtype=float).ravel()[2]) + motion.turn_rad
        a, d = abs(motion.turn_rad), motion.distance_cm
        k_turn = self.turn * self.inflation
        k_move = self.motion * self.inflation
        var_turn = (a * k_turn) ** 2 if self.model == "botsim" else (k_turn**2 if a else 0.0)
        var_head = var_turn + (k_turn**2 if d else 0.0)
        var_d = (d * k_move) ** 2 if self.model == "botsim" else (k_move**2 if d else 0.0)
        c, s = math.cos(th), math.sin(th)
        # x, y depend on the heading noise applied before the drive and on the distance noise
        j_head = np.array([-d * s, d * c, 1.0])
        j_dist = np.array([c, s, 0.0])
        return var_head * np.outer(j_head, j_head) + var_d * np.outer(j_dist, j_dist)

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model, "motion": self.motion, "turn": self.turn, "inflation": self.inflation}


def exact_ranges(map: Map, poses: ArrayLike, rel_angles: ArrayLike, *, beam_width_deg: float = 0.0,
                 beam_rays: int = 9, critical_incidence_deg: float | None = None,
                 max_range_cm: float | None = None) -> FloatArray:
    """Expected ranges (cm) by exact ray casting: poses (N, 3) x sensor angles (B,) relative to the heading.

    With ``beam_width_deg > 0`` each range is a lobe's nearest echo, cast as `toolkit.world.NxtSonar`
    casts it: `beam_rays` rays spread evenly over the lobe, a ray meeting its wall further than
    `critical_incidence_deg` from the normal does not echo (None: every ray echoes). Neighbouring
    beams share rays (beams a degree apart, rays 2.5 degrees apart: a window of 31 beams has 101
    distinct rays, not 279), so each distinct direction is cast once per pose. Walls beyond
    `max_range_cm` (None: no limit) are not seen, which keeps rays short on large open maps.

    Returns (N, B); ``inf`` where nothing echoes.
    """
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    rel = np.asarray(rel_angles, dtype=float).ravel()
    reach = math.inf if max_range_cm is None else float(max_range_cm)
    if not beam_width_deg > 0:
        return np.asarray(ray_cast(map.walls, p[:, :2], p[:, 2:3] + rel[None, :], max_range=reach), dtype=float)
    half = math.radians(beam_width_deg) / 2.0
    offsets = np.linspace(-half, half, beam_rays) if beam_rays > 1 else np.zeros(1)
    # the lobe's rays relative to the heading, merged where beams share them (to a nanoradian)
    rays = (rel[:, None] + offsets[None, :]).ravel()
    _, first, ray_of = np.unique(np.round(rays, 9), return_index=True, return_inverse=True)
    absolute = p[:, 2:3] + rays[first][None, :]
    t, hit = ray_cast(map.walls, p[:, :2], absolute, return_wall=True, max_range=reach)
    if critical_incidence_deg is not None:
        # specular loss: a ray meeting its wall further than the critical angle from the normal
        w = map.walls[np.maximum(hit, 0)]
        ex, ey = w[..., 2] - w[..., 0], w[..., 3] - w[..., 1]
        cos_inc = np.abs(np.cos(absolute) * ey - np.sin(absolute) * ex) / np.hypot(ex, ey)
        t = np.where(cos_inc >= math.cos(math.radians(critical_incidence_deg)), t, np.inf)
    return np.asarray(t[:, ray_of.reshape(rel.size, offsets.size)].min(axis=2), dtype=float)


@typed_dataclass()
class RangeLikelihood:
    """Gaussian likelihood of (expected - measured) range per beam, in log space.

    ``log p = -0.5 * sum_j min(((e_j - m_j) / sigma)^2, cap^2)`` (constants dropped): the cap bounds
    what one beam can cost (a robust floor for outliers); ``cap = inf`` is the pure Gaussian.
    Sums of hundreds of beams stay finite (no product of small numbers is ever formed).

    Attributes
    ----------
    sigma_cm : float
        Standard deviation of a reading (cm).
    cap : float
        Largest residual counted per beam, in units of `sigma_cm`.
    """

    sigma_cm: Real = Field(default=1.0, gt=0)
    cap: Real = Field(default=5.0, gt=0, allow_inf_nan=True)  # inf: the pure Gaussian

    def sq_residuals(self, expected: ArrayLike, measured: ArrayLike) -> FloatArray:
        """Sum over beams of the capped squared normalised residuals, (N, B) -> (N,)."""
        e = np.asarray(expected)
        m = np.asarray(measured, dtype=e.dtype if e.dtype == np.float32 else float).ravel()
        r = (e - m[None, :]) * np.asarray(1.0 / self.sigma_cm, dtype=e.dtype)
        r *= r
        with np.errstate(invalid="ignore"):
            np.minimum(r, np.asarray(self.cap**2, dtype=r.dtype), out=r)
        r[np.isnan(r)] = self.cap**2  # inf - inf: no wall expected and none measured would be nan
        return np.asarray(r.sum(axis=1, dtype=np.float64))

    def log_likelihood(self, expected: ArrayLike, measured: ArrayLike, beta: float = 1.0) -> FloatArray:
        """Log-likelihood (N,) of each row of `expected` (N, B) given `measured` (B,), tempered by `beta`."""
        return -0.5 * beta * self.sq_residuals(expected, measured)
