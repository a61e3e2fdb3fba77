"""The collision checkers of one mission: the robot disc, and the disc grown by a margin."""

from __future__ import annotations

import math

from ..world import CollisionChecker, Map, make_checker
from .config import MissionConfig


class Checkers:
    """The mission's checkers, built with its backend (`MissionConfig.collision`).

    Attributes
    ----------
    bare : CollisionChecker
        The robot disc.
    safe : list of CollisionChecker
        Planning checkers with the full safety margin, then half of it (empty without a margin).
    leg : CollisionChecker
        The disc grown by `DriveConfig.leg_margin_cm`, for cutting legs (the bare one without it).
    """

    def __init__(self, m: Map, radius_cm: float, config: MissionConfig) -> None:
        self.map = m
        self.radius = float(radius_cm)
        self.backend = config.collision
        self.bare = make_checker(m, self.radius, self.backend)
        margin = config.planning.safety_margin_cm
        self.safe = [make_checker(m, self.radius + f * margin, self.backend) for f in (1.0, 0.5) if margin > 0]
        lm = config.drive.leg_margin_cm
        self.leg = make_checker(m, self.radius + lm, self.backend) if lm > 0 else self.bare
        self._grown: dict[float, CollisionChecker] = {}

    def grown(self, extra_cm: float) -> CollisionChecker:
        """The disc grown by `extra_cm` (rounded up to 0.5 cm; cached)."""
        key = math.ceil(max(extra_cm, 0.0) * 2.0) / 2.0
        if key == 0.0:
            return self.bare
        if key not in self._grown:
            self._grown[key] = make_checker(self.map, self.radius + key, self.backend)
        return self._grown[key]
