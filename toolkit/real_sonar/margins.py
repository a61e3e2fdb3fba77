"""How well one real sweep can tell its waypoint from every other place, under a sonar model.

A localiser that reads one sweep can only find the right place if the model explains the sweep better
there than anywhere else. `sweep_margins` measures that without any localiser: it scores every pose of
the map's lattice (2 cm cells x 1 degree headings, the lattice the particle filters start from) with the
model's beam likelihood, and compares the best pose near the waypoint (within `near_cm`, any heading)
with the best pose further than `far_cm` from it. A positive margin (nats) means the waypoint is the most
likely place; a negative one means some other place explains the sweep better, and no estimator using
this model can pick the waypoint from this sweep alone: the share of positive margins bounds the share
of sweeps any such localiser gets right. With a `HeadingPrior` the lattice is weighed by it too (the
bound for a localiser that knows the heading roughly).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
from numpy.typing import NDArray

from localisation.base import HeadingPrior
from localisation.beam_model import BeamLikelihood, lattice_costs, scan_readings
from localisation.range_table import range_lattice, range_table

from ..world import NxtSonar
from .sweeps import SweepSet

__all__ = ["LATTICE_STEP_CM", "place_costs", "sweep_margins"]

LATTICE_STEP_CM = 2
"""Cell step of the scored lattice (cm); headings every degree."""


def place_costs(model: NxtSonar, sweeps: SweepSet, heading_prior: HeadingPrior | None = None
                ) -> tuple[NDArray[np.float64], Iterator[NDArray[np.float64]]]:
    """The lattice's cell centres (P, 2) and, per sweep, ``-2 log L`` of every cell x heading (P, 360), every
    usable reading (stuck runs left out) weighed as the localisers weigh it, and with `heading_prior`
    ``-2 log p(heading)`` added."""
    table = range_table(sweeps.map, 1.0, 360, None, model.beam_width_deg, model.critical_incidence_deg,
                        max_range_cm=model.max_range_cm)
    lattice = range_lattice(table, LATTICE_STEP_CM, 0.0)
    likelihood = BeamLikelihood(model)

    def each() -> Iterator[NDArray[np.float64]]:
        for s in sweeps:
            rel, meas, weighed = scan_readings(s.scan(), likelihood, sweeps.map)
            costs = lattice_costs(lattice, rel, meas, weighed, max_beams=0)
            if heading_prior is not None:
                costs = costs + heading_prior.direction_costs(costs.shape[1])[None, :]
            yield costs

    return lattice.xy, each()


def sweep_margins(model: NxtSonar, sweeps: SweepSet, *, near_cm: float = 6.0, far_cm: float = 20.0,
                  heading_prior: HeadingPrior | None = None,
                  on_sweep: Callable[[], None] | None = None) -> list[float]:
    """Per sweep, ``log L(best pose within near_cm of the waypoint) - log L(best pose beyond far_cm)`` (nats),
    with every usable reading (stuck runs left out) weighed as the localisers weigh it, and with
    `heading_prior` the log prior of each lattice heading added; `on_sweep` is called as each sweep is
    done (a progress display)."""
    if not 0.0 < near_cm < far_cm:
        raise ValueError(f"need 0 < near_cm < far_cm, got {near_cm} and {far_cm}")
    xy, per_sweep = place_costs(model, sweeps, heading_prior)
    out = []
    for s, costs in zip(sweeps, per_sweep, strict=True):
        if on_sweep is not None:
            on_sweep()
        dist = np.hypot(xy[:, 0] - s.x_cm, xy[:, 1] - s.y_cm)
        near, far = dist <= near_cm, dist > far_cm
        if not near.any() or not far.any():
            out.append(float("nan"))
            continue
        out.append(0.5 * float(costs[far].min() - costs[near].min()))
    return out
