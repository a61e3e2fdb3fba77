"""What the test suite demands of a localiser plug-in, as a check its author can run: `check_localiser`.

``nxtnav localisers check MODULE:CLASS`` runs it on a class in the user's own module. Each problem is
one line that says what is missing or wrong; an empty list means the class passes the checks below,
which mirror the suite's tests parametrised over `LOCALISERS` (``tests/test_localisation_options.py``):

- the class subclasses `Localiser`, sets ``name``, is registered under it and implements ``reset``,
  ``predict``, ``update`` and ``estimate``;
- it declares its options once, as a `toolkit.world.Options` model (``options_model``), among them a
  ``converged_xy_cm`` (>= 0) and a ``motion_inflation`` at any depth, and takes them as
  ``cls(map, options, rng=..., **overrides)``;
- ``robot_options`` names every facet of `toolkit.world.RobotModel` (`toolkit.world.FACETS`): each
  becomes options of the model marked ``robot=True`` (dotted paths), or a sentence says why the
  localiser does not use it;
  motion and the range sigma are always taken, and, as the suite expects of every localiser but the two
  Kalman filters, so are the lobe, the range limit, the beam mixture and the clearance;
- a localiser given its model's defaults as ``options`` tracks exactly as one given none, one with
  ``motion_inflation`` 4 (a keyword override) differently, and the same seed gives the same estimate;
- the tracking run of those tests (from a prior on ``map1``: two noiseless 72-reading scans, one move
  of 8 cm) runs without an error (how close it ends to the truth is the benchmarks' business:
  ``nxtnav bench localisers``);
- a global start (``reset(None)``) works, or raises `LocalisationError` when ``needs_prior`` is set.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel

from toolkit.world import FACETS, ConfigError, LocalisationError, Options, Pose, Scan, configure, load_map, ray_cast
from toolkit.world.params import describe
from toolkit.world.plugin_checks import call_noting, class_problems

from .base import LOCALISERS, Localiser, Motion, Prior

__all__ = ["check_localiser", "tracking_run"]

_REQUIRED = ("converged_xy_cm", "motion_inflation")
_ALWAYS_MAPPED = ("motion", "sensor_sigma")
_KALMAN = ("ekf", "ukf")
"""The localisers the suite lets refuse the lobe, the range limit, the beam mixture and the clearance."""


def _class_problems(cls: Any) -> list[str]:
    return class_problems(cls, Localiser, LOCALISERS, "localisation.Localiser")


def _model_of(cls: type[Localiser]) -> type[Options] | None:
    model = getattr(cls, "options_model", None)
    return model if isinstance(model, type) and issubclass(model, Options) else None


def _path_of(model: type[BaseModel], leaf: str) -> str | None:
    """The dotted path of the option called `leaf` in `model` (at any depth), if there is one."""
    return next((o.name for o in describe(model) if o.name.rpartition(".")[2] == leaf), None)


def _params_problems(cls: type[Localiser]) -> list[str]:
    model = _model_of(cls)
    if model is None or not model.model_fields:
        return [f"{cls.__qualname__} declares no options: set `options_model` to a `toolkit.world.Options` model "
                "with each option's type, default, range and description (Field(...) through `option`)"]
    problems = [f"{cls.__qualname__}.options_model lacks {key!r} (the suite sets it on every localiser)"
                for key in _REQUIRED if _path_of(model, key) is None]
    converged = _path_of(model, "converged_xy_cm")
    if converged is not None:
        try:
            configure(model, None, {converged: -1.0})
            problems.append(f"{converged} accepts -1: declare it with ge=0.0")
        except ConfigError:
            pass
    return problems


def _robot_problems(cls: type[Localiser]) -> list[str]:
    mapping = cls.robot_options
    if mapping is None:
        return [f"{cls.__qualname__} sets no `robot_options`: map every facet of the robot model "
                f"({', '.join(FACETS)}) to options or to a sentence saying why it is not used"]
    model = _model_of(cls)
    robot = {o.name for o in describe(model) if o.robot} if model is not None else set()
    problems = []
    if set(mapping) != set(FACETS):
        missing, extra = sorted(set(FACETS) - set(mapping)), sorted(set(mapping) - set(FACETS))
        problems.append(f"robot_options must name exactly the facets {', '.join(FACETS)}"
                        + (f"; missing: {', '.join(missing)}" if missing else "")
                        + (f"; unknown: {', '.join(extra)}" if extra else ""))
    for facet, how in mapping.items():
        if isinstance(how, str):
            if len(how) <= 20:
                problems.append(f"robot_options[{facet!r}] = {how!r}: say in a sentence why the facet is not used")
            if facet in _ALWAYS_MAPPED:
                problems.append(f"robot_options[{facet!r}] is refused: every localiser takes the motion noise "
                                "and the range sigma")
            elif cls.__dict__.get("name") not in _KALMAN:
                problems.append(f"robot_options[{facet!r}] is refused, but the suite expects every localiser "
                                "except ekf and ukf to take it (map it to options declared with robot=True)")
            continue
        problems += [f"robot_options[{facet!r}] names {own!r}, which options_model does not declare with "
                     "robot=True (give the dotted path of an option marked robot=True)"
                     for own in how if own not in robot]
    return problems


def tracking_run(cls: type[Localiser], options: dict[str, Any], model: Any = None) -> tuple[np.ndarray, Pose, bool]:
    """A short tracking run on map1 from a known prior, as the suite's (the localiser given `model`, an
    options model or None, and the keyword overrides `options`): the final estimate as a vector (pose
    in cm and rad, and covariance), the true pose, and whether the localiser called itself converged."""
    m = load_map("map1")
    build: Any = cls  # a plug-in's constructor takes (map, options, *, rng, **overrides)
    loc = build(m, model, rng=3, **options) if model is not None else build(m, rng=3, **options)
    truth = Pose(60.0, 50.0, 0.4)
    loc.reset(Prior(truth, np.diag([4.0, 4.0, 0.01])))
    angles = np.radians(np.arange(0.0, 360.0, 5.0))
    for turn, move in ((0.0, 0.0), (0.3, 8.0)):
        if move:
            loc.predict(Motion(turn_rad=turn, distance_cm=move))
            truth = Pose(truth.x + move * math.cos(truth.theta + turn), truth.y + move * math.sin(truth.theta + turn),
                         truth.theta + turn)
        loc.update(Scan.from_readings(angles, ray_cast(m.walls, truth.xy, truth.theta + angles)))
    est = loc.estimate()
    return np.concatenate([[est.pose.x, est.pose.y, est.pose.theta], np.ravel(est.cov)]), truth, bool(est.converged)


def _behaviour_problems(cls: type[Localiser]) -> list[str]:
    problems: list[str] = []
    base = call_noting("tracking on map1", problems, tracking_run, cls, {})
    if base is None:
        return problems
    vector = base[0]
    if not np.all(np.isfinite(vector)):
        problems.append(f"the estimate after tracking on map1 is not finite: {vector[:3].tolist()}")
    again = call_noting("tracking on map1 (same seed)", problems, tracking_run, cls, {})
    if again is not None and not np.array_equal(vector, again[0]):
        problems.append("the same seed gave two different estimates: draw every random number from self.rng")
    model = _model_of(cls)
    inflation = None if model is None else _path_of(model, "motion_inflation")
    if model is None or inflation is None:
        return problems
    defaults = call_noting(f"{model.__name__}() (its defaults)", problems, model)
    with_defaults = call_noting("tracking given its model's defaults as options", problems, tracking_run, cls, {},
                                defaults) if defaults is not None else None
    if with_defaults is not None and not np.array_equal(vector, with_defaults[0]):
        problems.append("given its model's defaults as options it tracks otherwise than given none: take the "
                        "options through Localiser.configure(options, overrides)")
    inflated = call_noting(f"tracking with {inflation}=4", problems, tracking_run, cls, {inflation: 4.0})
    if inflated is not None and np.array_equal(vector, inflated[0]):
        problems.append(f"{inflation}=4 changes nothing: the option does not reach the motion model")
    return problems


def _global_start_problems(cls: type[Localiser]) -> list[str]:
    loc = cls(load_map("map1"), rng=0)
    try:
        loc.reset(None)
    except LocalisationError:
        return [] if cls.needs_prior else [f"{cls.__qualname__}.reset(None) raised LocalisationError: set "
                                           "needs_prior = True for a pose tracker"]
    return [f"{cls.__qualname__} has needs_prior = True but reset(None) did not raise LocalisationError"] \
        if cls.needs_prior else []


def check_localiser(cls: Any) -> list[str]:
    """The problems that keep localiser class `cls` from passing the suite's localiser tests (none: it
    passes).

    Parameters
    ----------
    cls : type
        A `Localiser` subclass (imported, hence registered).

    Returns
    -------
    list of str
        One sentence per problem, saying what is missing or wrong.
    """
    problems = _class_problems(cls)
    if problems:
        return problems
    problems = _params_problems(cls) + _robot_problems(cls)
    problems += call_noting("a global start", problems, _global_start_problems, cls) or []
    return problems + _behaviour_problems(cls)
