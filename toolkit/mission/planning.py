"""Planning a mission's path: from the estimate to the target, with the safety margin where it fits."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import shapely
from shapely.ops import nearest_points

from planners.base import Planner, PlanningProblem, PlanResult

from ..world import CollisionChecker
from ..world.arrays import FloatArray
from .checkers import Checkers
from .context import MissionContext
from .report import Action, Outcome
from .states import MissionEnded


class PathPlanner:
    """Plans the paths of `mission` with `planner` (`PlanningConfig`); tells `on_plan` every path."""

    def __init__(self, mission: MissionContext, planner: Planner, checkers: Checkers, rng: Any,
                 on_plan: Callable[[FloatArray], None] | None = None) -> None:
        self.mission = mission
        self.planner = planner
        self.checkers = checkers
        self.rng = rng
        self.on_plan = on_plan
        self.planned_length = 0.0
        """Length of the first path (cm)."""

    def plan(self) -> FloatArray:
        """A path from the estimate to the target; ends the mission when none exists.

        Planned with the safety margin when it can be (a start or target closer to a wall than the
        margin joins the path by a short straight leg to the nearest point with the margin), else with
        the bare robot radius. An estimate inside a wall first escapes to the nearest free point.
        """
        mission = self.mission
        assert mission.estimate is not None
        start = mission.estimate.pose.xy
        prefix: list[FloatArray] = []
        if not self.checkers.bare.point_free(start):
            escape = self._nearest_free(start, self.checkers.bare, self.checkers.radius + 0.5)
            if escape is None:
                raise MissionEnded(Outcome.LOST, f"robot lost: estimate ({start[0]:.1f}, {start[1]:.1f}) is in a "
                                   "wall and no free space is near")
            prefix = [start]
            start = escape
        path, result = self._search(start)
        if path is None:
            t = mission.target
            mission.record(Action.PLAN, note=f"failed: {result.message}")
            raise MissionEnded(Outcome.UNREACHABLE, f"target unreachable: planner {self.planner.name} found no "
                               f"path from ({start[0]:.1f}, {start[1]:.1f}) to ({t[0]:.1f}, {t[1]:.1f}) "
                               f"({result.message})")
        if prefix:
            path = np.vstack([*prefix, path])
        self._accept(path, result)
        return mission.plans[-1]

    def _search(self, start: FloatArray) -> tuple[FloatArray | None, PlanResult]:
        """A path from `start` with the full margin, half of it, then the bare radius (None: none found)."""
        target = self.mission.target
        time_s = self.mission.cfg.planning.time_s
        result: PlanResult | None = None
        for checker in self.checkers.safe:
            s2 = self._nearest_free(start, checker, checker.robot_radius + 0.1)
            g2 = self._nearest_free(target, checker, checker.robot_radius + 0.1)
            if s2 is None or g2 is None:
                continue
            result = self.planner.plan(PlanningProblem(self.mission.map, checker, s2, g2, time_s, self.rng))
            if result.success:
                return np.vstack([start, result.path, target]), result
        bare = self.checkers.bare
        result = self.planner.plan(PlanningProblem(self.mission.map, bare, start, target, time_s, self.rng))
        return (result.path if result.success else None), result

    def _accept(self, path: FloatArray, result: PlanResult) -> None:
        """Keep `path` (repeated points dropped) as the mission's current plan, and say so."""
        mission = self.mission
        keep = np.ones(len(path), dtype=bool)
        keep[1:] = np.hypot(*np.diff(path, axis=0).T) > 1e-6
        path = path[keep]
        mission.plans.append(path)
        if self.on_plan is not None:
            self.on_plan(path)
        length = float(np.sum(np.hypot(*np.diff(path, axis=0).T)))
        if len(mission.plans) == 1:
            self.planned_length = length
        mission.record(Action.PLAN, note=f"{len(path) - 2} intermediate point(s), {length:.1f} cm, "
                                         f"{result.time_s * 1e3:.1f} ms")

    def _nearest_free(self, xy: FloatArray, checker: CollisionChecker, buffer: float) -> FloatArray | None:
        """`xy` when `checker` finds it free, else the nearest point of the c-space of radius `buffer`
        reachable from `xy` in a straight line with the bare radius (None when there is none)."""
        if checker.point_free(xy):
            return xy
        region = self.mission.map.free_space(buffer)
        if region.is_empty:
            return None
        _, near = nearest_points(shapely.Point(xy), region)
        p = np.array([near.x, near.y])
        if not checker.point_free(p):
            return None
        bare = self.checkers.bare
        if checker is not bare and not bare.segment_free(xy, p):
            return None
        return p
