"""Parsers for the option values people type (points, poses, lists) shared by the commands."""

from __future__ import annotations

import math

from ..world import NxtnavError, Pose

__all__ = ["parse_floats", "parse_list", "parse_pose", "parse_xy"]


def parse_floats(text: str, option: str, count: tuple[int, ...]) -> list[float]:
    """Comma-separated finite numbers, as many as one of `count`."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise NxtnavError(f"{option}: expected {' or '.join(map(str, count))} comma-separated numbers, "
                          f"got {text!r}") from None
    if len(values) not in count:
        raise NxtnavError(f"{option}: expected {' or '.join(map(str, count))} comma-separated numbers, "
                          f"got {len(values)} in {text!r}")
    for v in values:
        if not math.isfinite(v):
            raise NxtnavError(f"{option}: values must be finite, got {text!r}")
    return values


def parse_xy(text: str, option: str) -> tuple[float, float]:
    """``X,Y`` in cm."""
    x, y = parse_floats(text, option, (2,))
    return x, y


def parse_pose(text: str, option: str, heading_required: bool = True) -> Pose | tuple[float, float]:
    """``X,Y,HEADING_DEG`` as a Pose (or ``X,Y`` as a tuple when the heading is optional)."""
    values = parse_floats(text, option, (3,) if heading_required else (2, 3))
    if len(values) == 2:
        return values[0], values[1]
    return Pose.from_deg(*values)


def parse_list(text: str, option: str, known: list[str] | None = None) -> list[str]:
    """Comma-separated names; with `known`, unknown names are an error that lists the known ones."""
    names = [p.strip() for p in str(text).split(",") if p.strip()]
    if not names:
        raise NxtnavError(f"{option}: expected a comma-separated list, got {text!r}")
    if known is not None:
        bad = [n for n in names if n not in known]
        if bad:
            raise NxtnavError(f"{option}: unknown {', '.join(bad)}; known: {', '.join(known)}")
    return names
