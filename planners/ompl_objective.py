"""The robot-time objective for OMPL's planners: an `OptimizationObjective` over SE(2).

Robot time is not a sum over the segments of a 2-D path: a turn's cost depends on the segment before
it. Over SE(2) it is. A state is a position and a heading; a motion from ``(x1, y1, h1)`` to
``(x2, y2, h2)`` turns in place from ``h1`` to the segment's heading ``phi``, drives the segment and
turns from ``phi`` to ``h2``, and costs the robot time of those commands (`toolkit.world.RobotTiming`:
the fixed stop-and-turn time is charged once per vertex, with the turn that leaves it). The start's
heading and the goal's are free: no turn is charged leaving the start or arriving at the goal.

Any SE(2) path costs at least the robot time of its 2-D polyline (the turns at a vertex add up to at
least the heading change there), and a polyline costs exactly its robot time when every vertex's
heading lies between the headings of its two segments, so the minimum over SE(2) paths is the minimum
robot time over polylines: OMPL's optimising planners minimise the right quantity. The cost is
evaluated by a Python subclass of OMPL's `OptimizationObjective` (OMPL's nanobind bindings dispatch
``motionCost``, ``stateCost``, ``motionCostHeuristic`` and ``isSymmetric`` to Python); its admissible
heuristic is the straight-line drive time. It is not symmetric (a motion and its reverse turn by
different angles), and says so: OMPL's default takes the space's symmetric interpolation for a symmetric
cost, and RRT* would rewire with the reverse motion's cost.

Cost per call. OMPL's RRT* calls ``motionCost`` for every neighbour of a new state, once to choose its
parent and once to rewire, hundreds of times per iteration; a call costs about 1 us in Python (the
dispatch and the state getters about half of it) against 0.01 us for OMPL's compiled path length. So
the callback reads plain floats only, and the RRT* family keeps the plane's neighbour count under this
objective (`PLANE_NEIGHBOURS`).

Compiled. ``make compiled`` builds the same objective in C++ against the installed wheel
(`planners._compiled`, an opt-in: it needs a compiler and OMPL's headers); `robot_time_objective` then
gives that one (the same costs, to 1e-13 s), and this Python class otherwise or when asked for.
"""

from __future__ import annotations

import math
from typing import Any

import ompl.base as ob

from toolkit.world import CollisionChecker, ConfigError, RobotTiming

from ._compiled import compiled_objective, load

__all__ = ["PLANE_NEIGHBOURS", "RobotTimeObjective", "box_bounds", "check_objective_impl", "robot_time_objective",
           "se2_space"]

_TAU = 2.0 * math.pi
PLANE_NEIGHBOURS = (2.0**3 * 1.5) / (2.0**4 * (4.0 / 3.0))
"""The rewire factor's scale of the RRT* family under the robot-time objective: OMPL's k-nearest RRT*
connects a new state to ``k = rewire * 2**(d+1) * e * (1 + 1/d) * log(n)`` neighbours, 1.78 times more
over SE(2) (d = 3) than over the plane (d = 2), each one a Python `motionCost` call each way; this factor
brings ``k`` back to the plane's (9/16), about halving the planning time. It is below the constant of
RRT*'s proof of asymptotic optimality over SE(2); at a 1 s budget it costs a few percent of robot time
(map1, 3 runs: x1.06 of the optimum against x1.035 with OMPL's factor)."""


class RobotTimeObjective(ob.OptimizationObjective):
    """Robot time (s) of SE(2) motions: turn to the segment's heading, drive, turn to the state's heading.

    Parameters
    ----------
    si : ompl.base.SpaceInformation
        Of an `ompl.base.SE2StateSpace` (cm, rad).
    timing : RobotTiming
    start, goal : (float, float)
        Positions (cm) whose heading is free: no turn is charged leaving `start` or arriving at `goal`.
    """

    def __init__(self, si: Any, timing: RobotTiming, start: tuple[float, float], goal: tuple[float, float]) -> None:
        super().__init__(si)
        self._speed = float(timing.drive_speed_cm_s)
        # the constants of `motionCost` in one tuple: one attribute read per call
        self._constants = (1.0 / self._speed, math.degrees(1.0) / float(timing.turn_rate_deg_s),
                           float(timing.stop_turn_s), float(start[0]), float(start[1]), float(goal[0]), float(goal[1]))

    def isSymmetric(self) -> bool:
        # a motion and its reverse turn by different angles: OMPL's default (the space's interpolation
        # is symmetric) would let RRT* rewire with the reverse motion's cost
        return False

    def stateCost(self, s: Any) -> Any:
        return ob.Cost(0.0)

    def motionCost(self, s1: Any, s2: Any, hypot: Any = math.hypot, atan2: Any = math.atan2,
                   remainder: Any = math.remainder, cost_of: Any = ob.Cost) -> Any:
        # the hot path (hundreds of calls per iteration of RRT*): locals and float arithmetic only,
        # the math functions bound as defaults
        x1 = s1.getX()
        y1 = s1.getY()
        x2 = s2.getX()
        y2 = s2.getY()
        s_per_cm, s_per_rad, stop_s, start_x, start_y, goal_x, goal_y = self._constants
        dx = x2 - x1
        dy = y2 - y1
        leaves_start = x1 == start_x and y1 == start_y
        reaches_goal = x2 == goal_x and y2 == goal_y
        if dx == 0.0 and dy == 0.0:
            if leaves_start or reaches_goal:
                return cost_of(0.0)
            return cost_of(abs(remainder(s2.getYaw() - s1.getYaw(), _TAU)) * s_per_rad)
        phi = atan2(dy, dx)
        cost = hypot(dx, dy) * s_per_cm
        if not leaves_start:
            leave = abs(remainder(phi - s1.getYaw(), _TAU))
            if leave > 1e-9:
                cost += leave * s_per_rad + stop_s
        if not reaches_goal:
            cost += abs(remainder(s2.getYaw() - phi, _TAU)) * s_per_rad
        return cost_of(cost)

    def motionCostHeuristic(self, s1: Any, s2: Any) -> Any:
        return ob.Cost(math.hypot(s2.getX() - s1.getX(), s2.getY() - s1.getY()) / self._speed)


def check_objective_impl(impl: str) -> None:
    """Raise `ConfigError` (one line, with `planners._compiled.load`'s reason) when `impl` is
    ``compiled`` and the compiled objective cannot be loaded."""
    if impl == "compiled" and load()[0] is None:
        raise ConfigError(f"objective_impl 'compiled': the compiled robot-time objective is unavailable: {load()[1]}")


def robot_time_objective(si: Any, timing: RobotTiming, start: tuple[float, float], goal: tuple[float, float],
                         impl: str = "auto") -> tuple[Any, str]:
    """The robot-time objective (`RobotTimeObjective`'s arguments) in the implementation `impl` asks for,
    and the one it is: ``"compiled"`` or ``"python"``.

    Parameters
    ----------
    si, timing, start, goal
        As `RobotTimeObjective`.
    impl : {"auto", "python", "compiled"}
        ``auto``: the compiled one when `planners._compiled.load` gives it, else Python; ``compiled``
        when it cannot be loaded: `ConfigError` (`check_objective_impl`).
    """
    check_objective_impl(impl)
    if impl != "python" and load()[0] is not None:
        return compiled_objective(si, timing, start, goal), "compiled"
    return RobotTimeObjective(si, timing, start, goal), "python"


class _SegmentValidatorSE2(ob.MotionValidator):
    """SE(2) motions validated by the shared checker's swept-disc check of their 2-D segment (a disc
    robot turning in place sweeps nothing)."""

    def __init__(self, si: Any, checker: CollisionChecker) -> None:
        super().__init__(si)
        self._checker = checker

    def checkMotion(self, s1: Any, s2: Any, *rest: Any) -> bool:
        return self._checker.segment_free((s1.getX(), s1.getY()), (s2.getX(), s2.getY()))


def box_bounds(bounds: tuple[float, float, float, float]) -> Any:
    """OMPL's bounds of the plane's box ``(xmin, ymin, xmax, ymax)`` (cm), for a 2-D or an SE(2) space."""
    box = ob.RealVectorBounds(2)
    xmin, ymin, xmax, ymax = bounds
    box.setLow(0, xmin)
    box.setLow(1, ymin)
    box.setHigh(0, xmax)
    box.setHigh(1, ymax)
    return box


def se2_space(bounds: tuple[float, float, float, float], checker: CollisionChecker) -> tuple[Any, Any]:
    """OMPL's SE(2) space on the box `bounds` (cm) and its space information, states and motions
    validated by the shared checker."""
    space = ob.SE2StateSpace()
    space.setBounds(box_bounds(bounds))
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda s: bool(checker.point_free((s.getX(), s.getY()))))
    si.setMotionValidator(_SegmentValidatorSE2(si, checker))
    return space, si
