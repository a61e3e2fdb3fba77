"""The localiser interface: `Localiser` (a registry of plug-ins), `Motion` and `PoseEstimate`.

A localiser is built for one map (``Localiser(map, rng=..., **options)``) and then driven by
``reset(prior)``, ``predict(motion)`` after every robot action and ``update(scan)`` after every scan;
``estimate()`` reports the current belief. Global localisers accept ``prior=None`` (uniform over the
free space); pose trackers (EKF, UKF) need a prior and raise `LocalisationError` without one.
A `HeadingPrior` is a global start that knows the heading roughly and the position not at all (a
robot that drove somewhere by odometry from a known start): the global localisers weigh their first
fix by it; the pose trackers refuse it.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeAlias

import numpy as np

from toolkit.world import (
    ConfigError,
    Configurable,
    Map,
    Options,
    Pose,
    Registry,
    RngLike,
    Scan,
    angle_diff,
    as_rng,
    wrap_angle,
)
from toolkit.world.arrays import FloatArray

__all__ = [
    "LOCALISERS",
    "HeadingPrior",
    "Localiser",
    "Mode",
    "Motion",
    "PoseEstimate",
    "Prior",
    "RobotMapping",
    "Snapshot",
    "make_localiser",
]

RobotMapping: TypeAlias = Mapping[str, tuple[str | None, ...] | str]
"""A localiser's ``robot_options``: for every facet of the robot model, the dotted options its values become
(in the facet's order; None for a value the localiser does not use), or a sentence saying why it does not
use the facet at all."""


LOCALISERS: Registry[Localiser] = Registry("localiser")

@dataclass(frozen=True)
class Motion:
    """A commanded action, as the robot executed it: turn in place by `turn_rad`, then drive `distance_cm`.

    `distance_cm` is what the robot reports it drove (its `MoveOutcome.distance_cm`), negative
    for reversing.
    """

    turn_rad: float = 0.0
    distance_cm: float = 0.0

    def to_dict(self) -> dict[str, float]:
        return {"turn_rad": self.turn_rad, "distance_cm": self.distance_cm}


@dataclass(frozen=True)
class Prior:
    """A Gaussian prior on the pose: `mean` and 3x3 `cov` (cm^2, rad^2)."""

    mean: Pose
    cov: FloatArray = field(default_factory=lambda: np.diag([4.0, 4.0, math.radians(5.0) ** 2]))


@dataclass(frozen=True)
class HeadingPrior:
    """Position unknown (uniform over the free space), heading Gaussian: mean `heading_rad`, standard
    deviation `sd_rad` (wrapped).

    A global localiser given one (``reset(HeadingPrior(...))``) weighs the poses of its first fix by
    it, so that a twin place the sweep alone cannot tell apart, seen at another heading, loses to the
    place at the heading the robot believes it has. It acts on that first fix only: from there on the
    motion history carries the heading.

    >>> hp = HeadingPrior(0.0, math.radians(20.0))
    >>> tuple(round(float(c), 2) for c in hp.cost(np.radians([0.0, 20.0, -40.0, 340.0])))
    (0.0, 1.0, 4.0, 1.0)
    """

    heading_rad: float
    sd_rad: float

    def __post_init__(self) -> None:
        if not math.isfinite(self.heading_rad):
            raise ConfigError(f"heading prior: the heading must be a finite angle, got {self.heading_rad!r}")
        if not (math.isfinite(self.sd_rad) and self.sd_rad > 0.0):
            raise ConfigError(f"heading prior: the standard deviation must be > 0, got {self.sd_rad!r}")

    @classmethod
    def parse(cls, text: str) -> HeadingPrior:
        """``"H:SD"`` in degrees (e.g. ``"0:20"``), as the command line takes it."""
        parts = text.split(":")
        try:
            h, sd = (float(x) for x in parts)
            return cls(math.radians(h), math.radians(sd))
        except (ValueError, ConfigError):
            raise ConfigError(f"heading prior: expected HEADING:SD in degrees, SD > 0 (e.g. 0:20), "
                              f"got {text!r}") from None

    def cost(self, theta: Any) -> FloatArray:
        """``-2 log p(theta)`` up to a constant: the squared wrapped distance to the mean in standard
        deviations."""
        d = np.asarray(angle_diff(np.asarray(theta, dtype=float), self.heading_rad), dtype=float) / self.sd_rad
        return np.asarray(d * d)

    def direction_costs(self, n_angles: int) -> FloatArray:
        """`cost` of the `n_angles` headings ``2 pi k / n_angles`` of a lattice (its columns)."""
        return self.cost(np.arange(n_angles) * (2.0 * math.pi / n_angles))

    def turned(self, turn_rad: float) -> HeadingPrior:
        """The prior after the robot turned by `turn_rad` (the turn's noise left out)."""
        return HeadingPrior(float(wrap_angle(self.heading_rad + turn_rad)), self.sd_rad)

    def sample(self, n: int, rng: np.random.Generator) -> FloatArray:
        """`n` headings drawn from the prior (rad, wrapped to [-pi, pi))."""
        return np.asarray(wrap_angle(self.heading_rad + self.sd_rad * rng.standard_normal(n)), dtype=float)

    def to_dict(self) -> dict[str, float]:
        return {"heading_deg": math.degrees(self.heading_rad), "sd_deg": math.degrees(self.sd_rad)}


@dataclass(frozen=True, eq=False)
class PoseEstimate:
    """A localiser's belief.

    Attributes
    ----------
    pose : Pose
        Mean pose (circular mean for the heading).
    cov : (3, 3) ndarray
        Covariance of (x cm, y cm, heading rad).
    converged : bool
        Whether the localiser considers the belief narrow enough to act on.
    iterations : int
        Filter iterations (updates) since the last reset.
    """

    pose: Pose
    cov: FloatArray
    converged: bool
    iterations: int = 0

    @property
    def std_xy_cm(self) -> float:
        """Root of the summed x and y variances (cm): one number for the position spread."""
        return float(math.sqrt(max(self.cov[0, 0] + self.cov[1, 1], 0.0)))

    @property
    def std_heading_rad(self) -> float:
        return float(math.sqrt(max(self.cov[2, 2], 0.0)))

    def to_dict(self) -> dict[str, Any]:
        return {
            "pose": self.pose.to_list_deg(),
            "cov": np.asarray(self.cov).tolist(),
            "converged": self.converged,
            "iterations": self.iterations,
        }


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The cloud after one filter iteration (for plots and traces).

    Attributes
    ----------
    particles : (n, 3) ndarray
        x cm, y cm, theta rad (a subsample of at most the requested size).
    weights : (n,) ndarray
        Normalised weights of those particles.
    beta : float
        Tempering exponent of the iteration (1 = the full likelihood).
    estimate : PoseEstimate
    """

    particles: FloatArray
    weights: FloatArray
    beta: float
    estimate: PoseEstimate

    def to_dict(self) -> dict[str, Any]:
        return {
            "particles": np.column_stack([self.particles[:, :2], np.degrees(self.particles[:, 2])]).tolist(),
            "weights": self.weights.tolist(),
            "beta": self.beta,
            "estimate": self.estimate.to_dict(),
        }


@dataclass(frozen=True)
class Mode:
    """One cluster of the particle cloud: its mean pose, total weight and best log-likelihood."""

    pose: Pose
    weight: float
    best_log_likelihood: float
    count: int

    def to_dict(self) -> dict[str, Any]:
        return {"pose": self.pose.to_list_deg(), "weight": self.weight,
                "best_log_likelihood": self.best_log_likelihood, "count": self.count}


class Localiser(Configurable, ABC):
    """Base class of localisers; subclasses set `name`, declare `options_model` and `robot_options` and
    implement the four methods.

    The suite's localiser tests are parametrised over `LOCALISERS`, so a registered localiser must:

    - set ``name`` in the class body (that registers it) and implement `reset`, `predict`, `update`
      and `estimate`; a pose tracker sets ``needs_prior = True`` and raises `LocalisationError` from
      ``reset(None)``;
    - declare its options once, as a `toolkit.world.Options` model in ``options_model``, and take them
      as ``__init__(map, options=None, *, rng=None, **overrides)`` through `configure` (the model, or
      None for its defaults, with keyword overrides on top); among them a ``converged_xy_cm`` (cm,
      ``ge=0``) and a ``motion_inflation`` (a factor that reaches the motion model: 4 gives other
      estimates than the default), at any depth of the model;
    - map in ``robot_options`` every facet of `toolkit.world.RobotModel` (`toolkit.world.FACETS`) to
      options declared with ``robot=True`` (dotted paths, in the facet's order) or to a sentence why it
      is not used;
      motion and sensor sigma always, and, but for the Kalman filters ``ekf`` and ``ukf``, the lobe, the
      range limit, the beam mixture and the clearance too;
    - draw every random number from ``self.rng`` (the same seed gives the same estimate).

    `localisation.conformance.check_localiser` (``nxtnav localisers check MODULE:CLASS``) runs these
    checks on a class and says what is missing; ``docs/howto/localiser.md`` writes one that passes.

    Parameters
    ----------
    map : Map
        The map the robot is in.
    rng : None, int or Generator
        Seed of every random draw.
    """

    name: ClassVar[str]
    needs_prior: ClassVar[bool] = False
    options_model: ClassVar[type[Options] | None] = None
    """The options (a `toolkit.world.Options` model; `configure` builds one); None for a plug-in that
    declares none (its constructor then checks what it is given)."""
    robot_options: ClassVar[RobotMapping | None] = None
    """For every facet of `toolkit.world.RobotModel`, the options it becomes (in the facet's order, None
    for a value not used) or why the localiser does not use it (`RobotMapping`,
    `localisation.robot_options.localiser_options`); None: the localiser cannot be told a robot model."""
    snapshots: Sequence[Snapshot] = ()
    """The cloud after each iteration, for localisers that keep it (the particle filters); empty otherwise."""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "name" in cls.__dict__:
            LOCALISERS.add(cls.name, cls)

    def __init__(self, map: Map, *, rng: RngLike = None) -> None:
        self.map = map
        self.rng = as_rng(rng)

    @abstractmethod
    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        """Forget everything; start from `prior` (None: uniform over the free space; a `HeadingPrior`:
        the position unknown, the heading roughly known)."""

    @abstractmethod
    def predict(self, motion: Motion) -> None:
        """Move the belief by a commanded action."""

    @abstractmethod
    def update(self, scan: Scan) -> None:
        """Weigh the belief by a scan (angles relative to the robot heading)."""

    @abstractmethod
    def estimate(self) -> PoseEstimate:
        """The current belief."""

    @property
    def modes(self) -> list[Mode]:
        """The belief's plausible modes, heaviest first (two or more: ambiguous); empty for localisers
        that do not track modes."""
        return []

    def cloud(self) -> tuple[FloatArray, FloatArray] | None:
        """The particle cloud behind the belief: poses (n, 3: x cm, y cm, theta rad) and their
        normalised weights (n,); None for localisers without particles (the Kalman filters)."""
        return None


def make_localiser(name: str, map: Map, *, rng: RngLike = None, **options: Any) -> Localiser:
    """A localiser by registry name for `map`, with its options (dotted paths, ``sensor.z_hit``, or the
    name of one field, as its constructor takes them)."""
    return LOCALISERS.get(name)(map, rng=rng, **options)
