"""Where to drive to break an ambiguous belief, from one scan."""

from __future__ import annotations

import numpy as np

from localisation.procedure import open_direction

from ..world import (
    Scan,
)


def explore_direction(scan: Scan, clearance_cm: float, rng: np.random.Generator | None = None,
                      avoid_rad: float | None = None, max_step_cm: float = 30.0) -> tuple[float, float]:
    """The mission's exploration move from one scan: `localisation.procedure.open_direction` with a
    45-degree cone behind, any run over 2 cm counting as open and the free run not clipped to the
    readings, then half the run, at most `max_step_cm`.

    Returns
    -------
    (float, float)
        Turn (rad, relative to the heading) and distance (cm); (0, 0) when no direction is open.
    """
    turn, free = open_direction(scan, clearance_cm, rng, avoid_rad, avoid_deg=45.0, open_cm=2.0,
                                clip_to_readings=False, need_open=True)
    return turn, float(min(max_step_cm, 0.5 * free))
