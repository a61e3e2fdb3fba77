"""The declared options of the bundled planners (`toolkit.world.Params`), and OMPL's own.

A planner class points at its declarations here (``params``); `planner_params` answers for any planner
name, ``ompl:NAME`` included. An OMPL planner declares the wrapper's options (`OMPL_PARAMS`) and,
as OMPL declares them, each parameter with a setter and a getter on its class (``GoalBias``,
``RewireFactor``, ...; default: the value a fresh planner reports). `planner_kwargs` turns checked
options into constructor keywords (OMPL's own parameters go into the wrapper's ``settings``).
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

from toolkit.world import Param, Params

from .base import PLANNERS

__all__ = ["ASTAR_PARAMS", "FASTEST_PARAMS", "MIN_LINK_PARAMS", "MIN_TURN_PARAMS", "OMPL_PARAMS", "SHORTEST_PARAMS",
           "ompl_class_params", "planner_kwargs", "planner_params"]



def _objective(default: str, choices: tuple[str, ...]) -> Param:
    """The ``objective`` option: what the planner minimises, among the objectives it can."""
    return Param("objective", str, default, "What the planner minimises (" + ", ".join(choices) + ")",
                 choices=choices)


MIN_TURN_PARAMS = Params(
    Param("n_samples", int, 30, "Random configuration-space points per round (the paper's 30)", low=1),
    Param("max_intermediate", int, None, "Most intermediate points tried per round (null: all the samples)",
          low=1, optional=True),
    Param("max_rounds", int, None, "Stop after this many rounds of samples (null: at the time budget)", low=1,
          optional=True),
    _objective("turns", ("turns", "robot-time")),
)
_REFERENCE = (
    Param("n_sides", int, 64, "Sides of the polygon standing in for the robot disc when growing the walls", low=8),
    Param("eps", float, 1e-4, "Extra clearance so boundary edges pass the checker despite rounding", unit="cm",
          low=0.0),
)
SHORTEST_PARAMS = Params(*_REFERENCE, _objective("length", ("length",)))
FASTEST_PARAMS = Params(*_REFERENCE, _objective("robot-time", ("robot-time",)))
MIN_LINK_PARAMS = Params(
    Param("boundary_spacing", float, 3.0, "Spacing of the nodes along the configuration space's boundary",
          unit="cm", low=1e-6),
    Param("grid_spacing", float, 10.0, "Spacing of an interior grid of nodes (null: none)", unit="cm", low=1e-6,
          optional=True),
    Param("refine", bool, True, "Shorten the path by moving its bends, keeping the number of links"),
    *_REFERENCE,
    _objective("turns", ("turns",)),
)
ASTAR_PARAMS = Params(
    Param("resolution", float, 2.0, "Grid spacing (null: the map's own cells, for a map imported from a grid)",
          unit="cm", low=1e-6, optional=True),
    Param("connect_radius", float, None, "Start and goal join free nodes within this (null: two spacings)",
          unit="cm", low=1e-6, optional=True),
    Param("corner_cutting", bool, None, "A diagonal move may pass a blocked corner (null: on a spaced grid only)",
          optional=True),
    _objective("length", ("length", "robot-time", "turns")),
)
OMPL_PARAMS = Params(
    Param("simplify", bool, False, "Run OMPL's path simplifier on the solution (its time counts)"),
    Param("range", float, None, "Longest edge of the RRT family (null: OMPL's default)", unit="cm", low=1e-6,
          optional=True),
    Param("stop_at_first", bool, False, "Stop at the first exact solution, even for optimising planners"),
    Param("log_level", str, "none", "OMPL's console log level while planning",
          choices=("none", "error", "warn", "info", "debug")),
    Param("deterministic", bool, True, "Count the budget in iterations (reproducible) rather than seconds"),
    Param("iterations_per_s", float, None, "Iterations per second of budget when deterministic (null: the "
          "planner's calibrated rate)", low=1e-6, optional=True),
    _objective("length", ("length", "robot-time")),
    Param("progress_interval", float, 0.01, "Seconds of budget between two best-cost samples (besides one at "
          "every improvement)", unit="s", low=1e-6),
)
_OMPL_CLASSES = {"rrtstar": "RRTstar", "prm": "PRM"}
"""Registered planners that are one OMPL planner each (the others are ``ompl:NAME``)."""


def _ompl_class(name: str) -> str | None:
    if name.startswith("ompl:"):
        return name.split(":", 1)[1]
    return _OMPL_CLASSES.get(name)


@lru_cache(maxsize=64)
def ompl_class_params(planner: str) -> Params:
    """OMPL's own parameters of geometric planner `planner`: every ``setX`` with a ``getX`` returning a
    number or a truth value. Their default is null (OMPL's own choice, left alone): a fresh planner's
    getter does not always report what it uses (PRM's ``MaxNearestNeighbors`` reads 0 while its default
    connection strategy takes 10 neighbours, and setting 0 back leaves the roadmap unconnected), so the
    description gives the value a fresh planner on a unit square reports."""
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
        found = []
        for attr in sorted(dir(instance)):
            key = attr[3:]
            if not attr.startswith("set") or not key or not hasattr(instance, "get" + key):
                continue
            try:
                value = getattr(instance, "get" + key)()
            except Exception:  # a getter that needs a problem first: not a plain parameter
                continue
            kind = bool if isinstance(value, bool) else int if isinstance(value, int) else (
                float if isinstance(value, float) else None)
            if kind is not None:
                shown = str(value).lower() if isinstance(value, bool) else f"{value:g}"
                found.append(Param(key, kind, None, f"OMPL's set{key} (null: OMPL's default; a fresh planner "
                                   f"reports {shown})", optional=True))
        # OMPL 2.0.1's AORRTC crashes (SIGSEGV) when destroyed before its setup: set every probe up
        instance.setProblemDefinition(ob.ProblemDefinition(info))
        instance.setup()
    finally:
        ou.setLogLevel(previous)
    return Params(*found)


def planner_params(name: str) -> Params | None:
    """The declared options of planner `name` (a registered name or ``ompl:NAME``); None: it declares none."""
    ompl = _ompl_class(name)
    if ompl is not None:
        return OMPL_PARAMS.extend(*ompl_class_params(ompl))
    params: Params | None = getattr(PLANNERS.get(name), "params", None)
    return params


def planner_kwargs(name: str, options: dict[str, Any]) -> dict[str, Any]:
    """Checked `options` of planner `name` as its constructor's keywords: an OMPL planner's own
    parameters go into the wrapper's ``settings`` (a null one stays OMPL's default)."""
    if _ompl_class(name) is None:
        return dict(options)
    own = {k: v for k, v in options.items() if k in OMPL_PARAMS}
    settings = {k: v for k, v in options.items() if k not in OMPL_PARAMS and v is not None}
    return {**own, **({"settings": settings} if settings else {})}
