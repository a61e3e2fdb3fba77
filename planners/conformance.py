"""What the test suite demands of a planner plug-in, as a check its author can run: `check_planner`.

``nxtnav planners check MODULE:CLASS`` runs it on a class in the user's own module. Each problem is one
line that says what is missing or wrong; an empty list means the class passes the checks below, which
mirror the suite's tests parametrised over `PLANNERS` (``tests/test_planners.py``,
``tests/test_plugin_options.py``, ``tests/test_planners_reproducible.py``):

- the class subclasses `Planner`, sets ``name`` and is registered under it;
- it declares its options once (``options_model``: a `toolkit.world.Options` model with at least one
  option) and takes them as ``cls(options, **overrides)``: a planner given its model's defaults plans
  the same path as one given none;
- it solves the preset queries of ``map1``, ``map2``, ``map3`` and ``pillars`` (a disc of 8 cm, a 5 s
  budget) with an exact path from the start to the goal that the shared collision checker finds free,
  never shorter than the exact shortest path;
- the same seed gives the same path (on map1);
- a goal inside an obstacle comes back as a failed result (`PlanStatus.GOAL_IN_COLLISION`), not an
  exception.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from toolkit.world import CollisionChecker, Map, Options, load_map
from toolkit.world.plugin_checks import call_noting, class_problems

from .base import PLANNERS, Planner, PlanningProblem, PlanResult, PlanStatus

__all__ = ["check_planner"]

_RADIUS_CM = 8.0
_BUDGET_S = 5.0
_SEED = 7
_MAPS = ("map1", "map2", "map3", "pillars")
_GOAL_IN_WALL = (100.0, 0.0)
"""A goal on map1's bottom wall: every disc there overlaps the wall."""


def _class_problems(cls: Any) -> list[str]:
    problems = class_problems(cls, Planner, PLANNERS, "planners.Planner")
    if isinstance(cls, type) and issubclass(cls, Planner) and _model_of(cls) is None:
        problems.append(f"{cls.__qualname__} declares no options: set `options_model` to a `toolkit.world.Options` "
                        "model with each option's type, default, range and description (Field(...) through `option`)")
    return problems


def _model_of(cls: type[Planner]) -> type[Options] | None:
    model = getattr(cls, "options_model", None)
    ok = isinstance(model, type) and issubclass(model, Options) and bool(model.model_fields)
    return model if ok else None


def _plan(planner: Planner, m: Map, checker: CollisionChecker, goal: Any = None, seed: int = _SEED) -> PlanResult:
    """`planner` on the preset query of `m` (or to `goal`, cm) with a 5 s budget and `seed`."""
    assert m.start is not None and m.target is not None  # the bundled maps have a preset query
    return planner.plan(PlanningProblem.create(m, checker.robot_radius, m.start, m.target if goal is None else goal,
                                               _BUDGET_S, seed, checker))


def _path_problems(result: PlanResult, m: Map, checker: CollisionChecker, shortest_cm: float | None) -> list[str]:
    if not result.success or result.status is not PlanStatus.EXACT:
        return [f"the preset query of {m.name} failed: {result.message}"]
    path = result.path
    if path.ndim != 2 or path.shape[1] != 2 or len(path) < 2:
        return [f"the path has shape {path.shape}; expected (k, 2) with k >= 2 waypoints in cm"]
    problems = []
    assert m.start is not None and m.target is not None
    if not np.allclose(path[0], m.start, atol=1e-9) or not np.allclose(path[-1], m.target, atol=1e-9):
        problems.append(f"the path runs from {path[0].tolist()} to {path[-1].tolist()}; it must start at the "
                        f"query's start {m.start.tolist()} and end at its goal {m.target.tolist()}")
    if not checker.path_free(path):
        free = checker.segments_free(path[:-1], path[1:])
        problems.append(f"segment {int(np.argmin(free))} of the path on {m.name} is not free for the collision "
                        "checker (validate every motion with problem.checker)")
    if shortest_cm is not None and result.length < shortest_cm:
        problems.append(f"the path on {m.name} is {result.length:.3f} cm long, shorter than the shortest "
                        f"possible {shortest_cm:.3f} cm: it cuts through a wall")
    return problems


def _preset_problems(cls: type[Planner], planner: Planner, map_name: str) -> tuple[list[str], PlanResult | None]:
    """The problems of the preset query of `map_name`, and its result (None when planning raised)."""
    problems: list[str] = []
    m = load_map(map_name)
    checker = CollisionChecker(m, _RADIUS_CM)
    shortest = call_noting("the shortest path (reference)", [], _plan, PLANNERS.create("shortest"), m, checker)
    result = call_noting(f"plan ({map_name} preset query)", problems, _plan, planner, m, checker)
    if result is not None:
        problems += _path_problems(result, m, checker, None if shortest is None else shortest.length -
                                   shortest.info.get("length_tolerance_cm", 0.0) - 1e-9)
    return problems, result


def _declared_defaults_problems(cls: type[Planner], m: Map, checker: CollisionChecker) -> list[str]:
    model = _model_of(cls)
    if model is None:
        return []  # told already
    problems: list[str] = []
    plain = call_noting(f"{cls.__qualname__}()", problems, cls)
    defaults = call_noting(f"{model.__name__}() (its defaults)", problems, model)
    declared = call_noting(f"{cls.__qualname__}({model.__name__}())", problems, cls, defaults)
    if plain is None or declared is None:
        return problems
    a = call_noting("plan (no options)", problems, _plan, plain, m, checker)
    b = call_noting("plan (its model's defaults)", problems, _plan, declared, m, checker)
    if a is not None and b is not None and not np.array_equal(a.path, b.path):
        problems.append("given its model's defaults as options it plans otherwise than given none: take the "
                        "options through Planner.configure(options, overrides)")
    return problems


def check_planner(cls: Any) -> list[str]:
    """The problems that keep planner class `cls` from passing the suite's planner tests (none: it passes).

    Parameters
    ----------
    cls : type
        A `Planner` subclass (imported, hence registered).

    Returns
    -------
    list of str
        One sentence per problem, saying what is missing or wrong.
    """
    problems = _class_problems(cls)
    if not (isinstance(cls, type) and issubclass(cls, Planner)) or getattr(cls, "__abstractmethods__", None):
        return problems
    planner = call_noting(f"{cls.__qualname__}()", problems, cls)
    if planner is None:
        return problems
    results = {}
    for map_name in _MAPS:
        found, results[map_name] = _preset_problems(cls, planner, map_name)
        problems += found
    m = load_map("map1")
    checker = CollisionChecker(m, _RADIUS_CM)
    result = results["map1"]
    again = call_noting("plan (same seed again)", problems, _plan, cls(), m, checker)
    if result is not None and again is not None and not np.array_equal(result.path, again.path):
        problems.append(f"the same seed ({_SEED}) gave two different paths: draw every random number from "
                        "problem.rng")
    blocked = call_noting("plan (goal in a wall)", problems, _plan, planner, m, checker, _GOAL_IN_WALL)
    if blocked is not None and (blocked.success or blocked.status is not PlanStatus.GOAL_IN_COLLISION):
        problems.append(f"a goal inside a wall gave {blocked.message!r}, not a failed result with status "
                        "'goal in collision'")
    return problems + _declared_defaults_problems(cls, m, checker)
