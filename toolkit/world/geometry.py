"""Poses, angles, random generators and vectorised ray casting.

Conventions (see docs/conventions.md): centimetres and radians, x right, y up, angle 0 along +x,
counter-clockwise positive, angles wrapped to [-pi, pi).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .arrays import FloatArray
from .edge_index import ALONG_CM, edge_index
from .errors import ConfigError

__all__ = [
    "Pose",
    "RngLike",
    "angle_diff",
    "as_rng",
    "circular_mean",
    "ray_cast",
    "ray_wall_distances",
    "wrap_angle",
]

RngLike = None | int | np.random.Generator
"""Anything `as_rng` accepts: None (fresh entropy), an integer seed or a numpy Generator."""


def as_rng(rng: RngLike = None) -> np.random.Generator:
    """Normalise `rng` to a numpy Generator (the one rule for randomness in nxtnav)."""
    if isinstance(rng, np.random.Generator):
        return rng
    return np.random.default_rng(rng)


def wrap_angle(angle: ArrayLike) -> Any:
    """Wrap angles (rad) to [-pi, pi); scalars stay Python floats, arrays stay arrays.

    >>> wrap_angle(3 * math.pi / 2)
    -1.5707963267948966
    """
    a = np.asarray(angle, dtype=float)
    w = (a + np.pi) % (2.0 * np.pi) - np.pi
    return float(w) if w.ndim == 0 else w


def angle_diff(a: ArrayLike, b: ArrayLike) -> Any:
    """The signed difference a - b (rad), wrapped to [-pi, pi)."""
    return wrap_angle(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))


def circular_mean(angles: ArrayLike, weights: ArrayLike | None = None, axis: int = 0) -> Any:
    """Weighted mean direction (rad) of `angles` along `axis`."""
    a = np.asarray(angles, dtype=float)
    w = np.ones_like(a) if weights is None else np.broadcast_to(np.asarray(weights, dtype=float), a.shape)
    return wrap_angle(np.arctan2((w * np.sin(a)).sum(axis=axis), (w * np.cos(a)).sum(axis=axis)))


@dataclass(frozen=True)
class Pose:
    """A planar pose: position (cm) and heading (rad, wrapped to [-pi, pi))."""

    x: float
    y: float
    theta: float = 0.0

    def __post_init__(self) -> None:
        for field in ("x", "y", "theta"):
            value = float(getattr(self, field))
            if not math.isfinite(value):
                raise ConfigError(f"Pose.{field} must be finite, got {value}")
            object.__setattr__(self, field, value)
        object.__setattr__(self, "theta", wrap_angle(self.theta))

    @classmethod
    def from_deg(cls, x: float, y: float, heading_deg: float = 0.0) -> Pose:
        """A pose from a heading in degrees (as people type it)."""
        return cls(x, y, math.radians(heading_deg))

    @classmethod
    def from_array(cls, a: ArrayLike) -> Pose:
        """A pose from [x, y, theta] (theta optional)."""
        v = np.asarray(a, dtype=float).ravel()
        return cls(v[0], v[1], v[2] if v.size > 2 else 0.0)

    @property
    def xy(self) -> FloatArray:
        """Position as a (2,) array (cm)."""
        return np.array([self.x, self.y])

    @property
    def heading_deg(self) -> float:
        """Heading in degrees."""
        return math.degrees(self.theta)

    def as_array(self) -> FloatArray:
        """[x, y, theta] as a (3,) array."""
        return np.array([self.x, self.y, self.theta])

    def distance_to(self, other: Pose | ArrayLike) -> float:
        """Euclidean distance (cm) between positions."""
        o = other.xy if isinstance(other, Pose) else np.asarray(other, dtype=float)[:2]
        return float(np.hypot(*(self.xy - o)))

    def to_dict(self) -> dict[str, float]:
        """JSON-ready form: x and y in cm, heading in degrees."""
        return {"x": self.x, "y": self.y, "heading_deg": self.heading_deg}

    def to_list_deg(self) -> list[float]:
        """[x, y, heading_deg], the form the CLI and JSON files use."""
        return [self.x, self.y, self.heading_deg]


def ray_wall_distances(
    walls: FloatArray, ox: FloatArray, oy: FloatArray, dx: FloatArray, dy: FloatArray
) -> FloatArray:
    """Distance along each of n rays (origin ox, oy; unit direction dx, dy) to each of W walls.

    Returns an (n, W) array, ``inf`` where the ray misses the wall. A ray parallel to a wall misses it
    unless it runs along it (within `toolkit.world.edge_index.ALONG_CM` of its line): then it stops
    at the wall's nearer end, so a thin wall seen end-on is hit.
    """
    x1, y1 = walls[:, 0], walls[:, 1]
    ex, ey = walls[:, 2] - x1, walls[:, 3] - y1
    rx, ry = dx[:, None], dy[:, None]
    qx, qy = x1[None, :] - ox[:, None], y1[None, :] - oy[:, None]
    denom = rx * ey[None, :] - ry * ex[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qx * ey[None, :] - qy * ex[None, :]) / denom
        u = (qx * ry - qy * rx) / denom
    ok = (np.abs(denom) > 1e-12) & (t >= 0.0) & (u >= 0.0) & (u <= 1.0)
    t1 = qx * rx + qy * ry
    t2 = t1 + ex[None, :] * rx + ey[None, :] * ry
    along = ~(np.abs(denom) > 1e-12) & (np.abs(qx * ry - qy * rx) <= ALONG_CM) & (np.maximum(t1, t2) >= 0.0)
    return np.where(ok, t, np.where(along, np.maximum(np.minimum(t1, t2), 0.0), np.inf))


def ray_cast(
    walls: ArrayLike,
    origins: ArrayLike,
    angles: ArrayLike,
    *,
    return_wall: bool = False,
    max_range: float = math.inf,
) -> Any:
    """Distance from each origin along each absolute angle to the first wall hit.

    Compiled and indexed (`toolkit.world.edge_index`): each ray tests only the walls of the grid
    cells it crosses up to its first hit, so the cost grows with the walls near the ray, not with
    the map. The result is exactly that of testing every wall (`ray_wall_distances`).

    Parameters
    ----------
    walls : (W, 4) array_like
        Wall segments [x1, y1, x2, y2] in cm. The index is built once per array (a read-only
        array such as `Map.walls` is recognised by identity).
    origins : (2,) or (P, 2) array_like
        Ray origins in cm.
    angles : (A,) or (P, A) array_like
        Absolute ray directions in rad; a 1-D array is shared by every origin.
    return_wall : bool
        Also return the index of the wall hit (-1 where none; the lowest index on a tie).
    max_range : float
        Hits farther than this (cm) count as none (``inf``); the walk stops there, so a range-limited
        sensor costs less on open maps.

    Returns
    -------
    ranges : (P, A) ndarray (or (A,) for a single (2,) origin)
        Distances in cm; ``inf`` where the ray hits no wall.
    wall : (P, A) int ndarray, only with ``return_wall``

    Examples
    --------
    >>> ray_cast([[10, -5, 10, 5]], [0, 0], [0.0, np.pi])
    array([10., inf])
    """
    o = np.asarray(origins, dtype=float)
    single = o.ndim == 1
    o = o.reshape(-1, 2)
    a = np.asarray(angles, dtype=float)
    if a.ndim <= 1:
        a = np.broadcast_to(a.reshape(1, -1), (o.shape[0], a.size))
    if a.shape[0] != o.shape[0]:
        raise ConfigError(f"angles has {a.shape[0]} rows for {o.shape[0]} origins")
    n_p, n_a = a.shape
    index = edge_index(walls)
    t, w = index.cast(np.repeat(o[:, 0], n_a), np.repeat(o[:, 1], n_a), a.ravel(), max_range=max_range)
    ranges = t[:, 0].reshape(n_p, n_a)
    hit = w[:, 0].reshape(n_p, n_a)
    if single:
        ranges, hit = ranges[0], hit[0]
    return (ranges, hit) if return_wall else ranges
