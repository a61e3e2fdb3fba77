"""The options of the bundled planners, one typed model each (`toolkit.world.Options`), and OMPL's own.

A planner class points at its model (``options_model``) and takes ``(options=None, **overrides)``:
``MinTurnPlanner(MinTurnOptions(n_samples=60))``, ``make_planner("min-turn", n_samples=60)`` and
``nxtnav plan --planner min-turn --set min-turn.n_samples=60`` are the same planner. `planner_options`
answers for any planner name, ``ompl:NAME`` included: an OMPL planner's model is the wrapper's options
(`OmplOptions`) and, as OMPL declares them, each parameter with a setter and a getter on its class
(``GoalBias``, ``RewireFactor``, ...; default null: OMPL's own choice). `planner_kwargs` turns checked
options into constructor keywords (OMPL's own parameters go into the wrapper's ``settings``).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Literal

from pydantic import create_model

from toolkit.world import Options, option

from .base import PLANNERS

__all__ = ["AStarOptions", "FastestOptions", "MinLinkOptions", "MinTurnOptions", "OmplOptions", "ReferenceOptions",
           "ShortestOptions", "ompl_class_options", "planner_kwargs", "planner_options"]


class MinTurnOptions(Options):
    """The paper's min-turn planner (``min-turn``)."""

    n_samples: int = option(30, "Random configuration-space points per round (the paper's 30)", ge=1)
    max_intermediate: int | None = option(None, "Most intermediate points tried per round (null: all the samples)",
                                          ge=1)
    max_rounds: int | None = option(None, "Stop after this many rounds of samples (null: at the time budget)", ge=1)
    deterministic: bool = option(True, "Count the budget in rounds (reproducible) rather than seconds")
    rounds_per_s: float = option(50.0, "Rounds per second of budget when deterministic", ge=1e-6)
    objective: str = option("turns", "What the planner minimises (turns, robot-time)")


class ReferenceOptions(Options):
    """What the references over the visibility graph share (`ShortestOptions`, `FastestOptions`,
    `MinLinkOptions`)."""

    n_sides: int = option(64, "Sides of the polygon standing in for the robot disc when growing the walls", ge=8)
    eps: float = option(1e-4, "Extra clearance so boundary edges pass the checker despite rounding", unit="cm",
                        ge=0.0)
    objective: str = option("length", "What the planner minimises (each reference one objective)")


class ShortestOptions(ReferenceOptions):
    """The exact shortest path (``shortest``, a reference)."""

    objective: str = option("length", "What the planner minimises (length)")


class FastestOptions(ReferenceOptions):
    """The least robot time path (``fastest``, a reference)."""

    objective: str = option("robot-time", "What the planner minimises (robot-time)")


class MinLinkOptions(ReferenceOptions):
    """The fewest-links path (``min-link``, a reference)."""

    boundary_spacing: float = option(3.0, "Spacing of the nodes along the configuration space's boundary",
                                     unit="cm", ge=1e-6)
    grid_spacing: float | None = option(10.0, "Spacing of an interior grid of nodes (null: none)", unit="cm",
                                        ge=1e-6)
    refine: bool = option(True, "Shorten the path by moving its bends, keeping the number of links")
    objective: str = option("turns", "What the planner minimises (turns)")


class AStarOptions(Options):
    """Grid A* (``astar``)."""

    resolution: float | None = option(2.0, "Grid spacing (null: the map's own cells, for a map imported from a grid)",
                                      unit="cm", ge=1e-6)
    connect_radius: float | None = option(None, "Start and goal join free nodes within this (null: two spacings)",
                                          unit="cm", ge=1e-6)
    corner_cutting: bool | None = option(None, "A diagonal move may pass a blocked corner (null: on a spaced grid "
                                         "only)")
    objective: str = option("length", "What the planner minimises (length, robot-time, turns)")


class OmplOptions(Options):
    """The wrapper round any OMPL geometric planner (``rrtstar``, ``prm``, ``ompl:NAME``)."""

    simplify: bool = option(False, "Run OMPL's path simplifier on the solution (its time counts)")
    polish: bool | None = option(None, "Polish an optimising planner's solution under its objective: headings "
                                       "lined up, checked shortcuts that lower its cost, time and checks counted "
                                       "(null: under robot-time only, whose sampled headings need it)")
    range: float | None = option(None, "Longest edge of the RRT family (null: OMPL's default)", unit="cm", ge=1e-6)
    stop_at_first: bool = option(False, "Stop at the first exact solution, even for optimising planners")
    log_level: Literal["none", "error", "warn", "info", "debug"] = option("none", "OMPL's console log level while "
                                                                         "planning")
    deterministic: bool = option(True, "Count the budget in iterations (reproducible) rather than seconds")
    iterations_per_s: float | None = option(None, "Iterations per second of budget when deterministic (null: the "
                                            "planner's calibrated rate)", ge=1e-6)
    progress_interval: float = option(0.01, "Seconds of budget between two best-cost samples (besides one at "
                                      "every improvement)", unit="s", ge=1e-6)
    objective: str = option("length", "What the planner minimises (length, robot-time; a planner that stops at "
                                      "its first path: length only)")
    objective_impl: Literal["auto", "python", "compiled"] = option(
        "auto", "The robot-time objective's code: compiled when built (make compiled), else Python; python or "
                "compiled force one (compiled unbuilt: an error)")


_OMPL_CLASSES = {"rrtstar": "RRTstar", "prm": "PRM"}
"""Registered planners that are one OMPL planner each (the others are ``ompl:NAME``)."""


def _ompl_class(name: str) -> str | None:
    if name.startswith("ompl:"):
        return name.split(":", 1)[1]
    return _OMPL_CLASSES.get(name)


def _fresh_values(planner: str) -> dict[str, bool | int | float]:
    """What a fresh OMPL `planner` on a unit square reports for every ``setX`` with a ``getX`` returning a
    number or a truth value."""
    import ompl.base as ob
    import ompl.geometric as og
    import ompl.util as ou

    space = ob.RealVectorStateSpace(2)
    bounds = ob.RealVectorBounds(2)
    bounds.setLow(0.0)
    bounds.setHigh(1.0)
    space.setBounds(bounds)
    previous = ou.getLogLevel()
    ou.setLogLevel(ou.LogLevel.LOG_NONE)  # some getters warn that their option no longer has any effect
    try:
        info = ob.SpaceInformation(space)
        info.setup()
        instance = getattr(og, planner)(info)
        found: dict[str, bool | int | float] = {}
        for attr in sorted(dir(instance)):
            key = attr[3:]
            if not attr.startswith("set") or not key or not hasattr(instance, "get" + key):
                continue
            try:
                value = getattr(instance, "get" + key)()
            except Exception:  # a getter that needs a problem first: not a plain parameter
                continue
            if isinstance(value, bool | int | float):
                found[key] = value
        # OMPL 2.0.1's AORRTC crashes (SIGSEGV) when destroyed before its setup: set every probe up
        instance.setProblemDefinition(ob.ProblemDefinition(info))
        instance.setup()
    finally:
        ou.setLogLevel(previous)
    return found


@lru_cache(maxsize=64)
def ompl_class_options(planner: str) -> type[OmplOptions]:
    """The wrapper's options and OMPL's own parameters of geometric planner `planner` as one model.

    OMPL's parameters default to null (OMPL's own choice, left alone): a fresh planner's getter does not
    always report what it uses (PRM's ``MaxNearestNeighbors`` reads 0 while its default connection
    strategy takes 10 neighbours, and setting 0 back leaves the roadmap unconnected), so the description
    gives the value a fresh planner on a unit square reports."""
    fields: dict[str, Any] = {}
    for key, value in _fresh_values(planner).items():
        kind = type(value)
        shown = str(value).lower() if isinstance(value, bool) else f"{value:g}"
        fields[key] = (kind | None, option(None, f"OMPL's set{key} (null: OMPL's default; a fresh planner reports "
                                           f"{shown})"))
    return create_model(f"Ompl{planner}Options", __base__=OmplOptions, __doc__=f"OMPL's {planner}", **fields)


def planner_options(name: str) -> type[Options] | None:
    """The options model of planner `name` (a registered name or ``ompl:NAME``); None: it declares none."""
    ompl = _ompl_class(name)
    if ompl is not None:
        return ompl_class_options(ompl)
    model: type[Options] | None = getattr(PLANNERS.get(name), "options_model", None)
    return model


def planner_kwargs(name: str, options: dict[str, Any]) -> dict[str, Any]:
    """Checked `options` of planner `name` as its constructor's keywords: an OMPL planner's own
    parameters go into the wrapper's ``settings`` (a null one stays OMPL's default)."""
    if _ompl_class(name) is None:
        return dict(options)
    own = {k: v for k, v in options.items() if k in OmplOptions.model_fields}
    settings = {k: v for k, v in options.items() if k not in OmplOptions.model_fields and v is not None}
    return {**own, **({"settings": settings} if settings else {})}
