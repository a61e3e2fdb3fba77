"""The checks every robot makes of the commands it is given, worded once."""

from __future__ import annotations

import math
from typing import Any

from ..world import RobotError

__all__ = ["finite_command"]


def finite_command(value: Any, what: str) -> float:
    """`value` as a float, or a `RobotError` saying that `what` (``move distance``, ``turn angle``) must be finite.

    >>> finite_command(float("nan"), "turn angle")
    Traceback (most recent call last):
    ...
    toolkit.world.errors.RobotError: turn angle must be finite, got nan
    """
    number = float(value)
    if not math.isfinite(number):
        raise RobotError(f"{what} must be finite, got {value!r}")
    return number
