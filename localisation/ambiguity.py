"""Ambiguous beliefs said plainly: the candidate poses of a localiser whose belief has several modes.

A global localiser in a symmetric place (a point-symmetric room, map3's identical rooms) may hold
several equally good hypotheses. Its mean pose then lies between them and means nothing; the honest
answer is "ambiguous: N candidate poses" with the poses. Localisers that track modes (the particle
filters' ``modes``) report them; the others never call themselves ambiguous.
"""

from __future__ import annotations

from toolkit.world import Pose

from .base import Localiser

__all__ = ["candidate_poses", "describe_candidates"]


def candidate_poses(localiser: Localiser | None) -> list[Pose]:
    """The mean poses of the belief's plausible modes, heaviest first, when there are two or more.

    Parameters
    ----------
    localiser : Localiser
        Any localiser (None: not built yet); one that tracks no modes (or has a single mode) gives ``[]``.

    Returns
    -------
    list of Pose
        Candidate poses (cm, cm, rad); empty when the belief is not ambiguous.
    """
    found = [] if localiser is None else localiser.modes
    return [m.pose for m in found] if len(found) > 1 else []


def describe_candidates(poses: list[Pose], shown: int = 4) -> str:
    """``ambiguous: N candidate poses (x, y, h deg), ...`` (at most `shown` listed); empty for none."""
    if not poses:
        return ""
    listed = ", ".join(f"({p.x:.1f}, {p.y:.1f}, {p.heading_deg:.0f} deg)" for p in poses[:shown])
    more = f" and {len(poses) - shown} more" if len(poses) > shown else ""
    return f"ambiguous: {len(poses)} candidate poses {listed}{more}"
