"""Motions that are free wherever the robot may truly be: a checker over rigid copies of the plane.

A robot unsure where it started (two places its first sweep fits, say) drives by relative motions: a
path planned from the place it believes is, in truth, the same path moved rigidly to each other place
it may be at. `ConformantChecker` answers a check as free only when it is free in every such copy:
the point or segment as asked (the belief) and moved by each `RigidMove` (each other hypothesis).
Rigid motions keep a disc a disc and a segment a segment, so every answer stays exact; planners see
an ordinary checker and plan paths that are safe under every hypothesis (conformant planning).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .collision import CollisionChecker, segment_arrays
from .geometry import Pose, angle_diff, wrap_angle

__all__ = ["ConformantChecker", "RigidMove"]


@dataclass(frozen=True)
class RigidMove:
    """The rigid motion of the plane that takes pose `source` to pose `target`: where a point planned
    around `source` truly lies when the robot is at `target` instead.

    >>> move = RigidMove(Pose(0, 0, 0), Pose(10, 0, math.pi / 2))
    >>> move.points([[1.0, 0.0]]).round(6).tolist(), round(move.pose(Pose(0, 0, 0)).heading_deg, 6)
    ([[10.0, 1.0]], 90.0)
    """

    source: Pose
    target: Pose

    @property
    def turn(self) -> float:
        """The rotation (rad) from `source`'s heading to `target`'s."""
        return float(angle_diff(self.target.theta, self.source.theta))

    def points(self, xy: ArrayLike) -> NDArray[np.float64]:
        """(n, 2) points (cm) moved rigidly: their offset from `source`, turned and put at `target`."""
        c, s = math.cos(self.turn), math.sin(self.turn)
        d = np.asarray(xy, dtype=float).reshape(-1, 2) - self.source.xy
        return np.column_stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]]) + self.target.xy

    def pose(self, p: Pose) -> Pose:
        """`p` moved rigidly (its position as `points`, its heading turned)."""
        x, y = self.points([p.x, p.y])[0]
        return Pose(float(x), float(y), float(wrap_angle(p.theta + self.turn)))


class ConformantChecker(CollisionChecker):
    """`base`'s checks, answered free only when free as asked and in every copy moved by `moves` (module
    docstring). Counters, radius and map are `base`'s; any other attribute is read from `base`.

    >>> from toolkit.world import load_map, make_checker
    >>> base = make_checker(load_map("co333-arena"), 8.0)
    >>> both = ConformantChecker(base, [RigidMove(Pose(30, 30, 0), Pose(180, 30, 0))])
    >>> bool(base.segment_free([30, 30], [100, 30])), bool(both.segment_free([30, 30], [100, 30]))
    (True, False)
    >>> bool(both.segment_free([30, 30], [30, 60]))
    True
    """

    def __init__(self, base: CollisionChecker, moves: Sequence[RigidMove]) -> None:
        # no super().__init__: the walls' index and rasters are base's, read through __getattr__
        self.base = base
        self.moves = list(moves)
        self.map = base.map
        self.robot_radius = base.robot_radius
        self.backend = f"{base.backend}+conformant"

    def __getattr__(self, name: str) -> Any:
        return getattr(self.base, name)

    @property
    def checks(self) -> int:
        return self.base.checks

    def reset_counters(self) -> None:
        self.base.reset_counters()

    def connected(self, a: ArrayLike, b: ArrayLike) -> bool:
        return self.base.connected(a, b)

    def point_free(self, xy: ArrayLike) -> Any:
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        out = np.asarray(self.base.point_free(pts), dtype=bool)
        for move in self.moves:
            out = out & np.asarray(self.base.point_free(move.points(pts)), dtype=bool)
        return bool(out[0]) if p.ndim == 1 else out

    def segments_free(self, a: ArrayLike, b: ArrayLike) -> NDArray[np.bool_]:
        pa, pb = segment_arrays(a, b)
        out = np.asarray(self.base.segments_free(pa, pb), dtype=bool)
        for move in self.moves:
            out = out & np.asarray(self.base.segments_free(move.points(pa), move.points(pb)), dtype=bool)
        return out

    def clearance(self, xy: ArrayLike) -> Any:
        p = np.asarray(xy, dtype=float)
        pts = p.reshape(-1, 2)
        out = np.asarray(self.base.clearance(pts), dtype=float)
        for move in self.moves:
            out = np.minimum(out, np.asarray(self.base.clearance(move.points(pts)), dtype=float))
        return float(out[0]) if p.ndim == 1 else out

    def first_contact(self, a: ArrayLike, b: ArrayLike, tol: float = 1e-3) -> float:
        pa, pb = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        fractions = [self.base.first_contact(pa, pb, tol)]
        fractions += [self.base.first_contact(m.points(pa)[0], m.points(pb)[0], tol) for m in self.moves]
        return float(min(fractions))
