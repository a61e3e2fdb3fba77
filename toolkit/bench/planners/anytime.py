"""Cost over time: the best-cost samples of anytime planners as curves, and the time to a target length.

A run's best-cost curve is a step function: at time ``t`` it is the cost of its last sample taken
at or before ``t`` (inf before its first solution), and after the run ended it keeps its final
value. Curves are compared as ratios to the query's `shortest` length. A planner without samples
(min-turn, grid A*) has one solution: its planning time and length.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ...world.arrays import FloatArray
from ..common import finite_median
from .records import BenchmarkResult, RunRecord

__all__ = ["WITHIN", "CurveBand", "cost_band", "has_curve", "reference_lengths", "time_within", "time_within_median"]

WITHIN = 0.05
"""The default target: a path at most 5 % longer than `shortest`."""


def reference_lengths(result: BenchmarkResult) -> dict[tuple[str, int], float]:
    """`shortest`'s length (cm) per (map, query index); NaN where it failed."""
    return {(r.query.map, r.query.index): r.shortest_length_cm for r in result.references}


def _in_units(record: RunRecord, reference: float) -> float:
    """The reference a run's best costs compare with: `reference` (a length, cm) for a run that minimised
    length, else the query's reference under the run's own objective (``record.reference_cost``)."""
    return reference if record.objective == "length" else record.reference_cost


def has_curve(record: RunRecord) -> bool:
    """Whether a run reported an anytime curve: more than one sample with a solution (a planner
    that stops at its first solution has one)."""
    return sum(1 for _, _, c in record.progress if math.isfinite(c)) > 1


def time_within(record: RunRecord, reference: float, within: float = WITHIN) -> float:
    """Seconds until the run had a path at most ``(1 + within) * reference`` long; NaN if never.

    From the best-cost samples when the run has them, else the planning time of its one path. A run
    that minimised another objective than length is measured in that objective (`_in_units`).
    """
    reference = _in_units(record, reference)
    if not (record.success and math.isfinite(reference) and reference > 0):
        return math.nan
    target = (1.0 + within) * reference
    if record.progress:
        return next((t for t, _, c in record.progress if c <= target), math.nan)
    cost = record.length_cm if record.objective == "length" else record.objective_cost
    return record.time_s if cost <= target else math.nan


def time_within_median(records: Sequence[RunRecord], refs: dict[tuple[str, int], float],
                       within: float = WITHIN) -> tuple[float, int]:
    """Median `time_within` over the runs that got there, and how many did."""
    times = [time_within(r, refs.get((r.map, r.query), math.nan), within) for r in records]
    reached = [t for t in times if math.isfinite(t)]
    return finite_median(reached), len(reached)


def _curve(record: RunRecord, grid: FloatArray, reference: float) -> FloatArray:
    """The run's best cost over `grid` (s) as a ratio to `reference` (inf before a solution)."""
    out = np.full(len(grid), np.inf)
    reference = _in_units(record, reference)
    if not record.success or not record.progress:
        return out
    samples = np.array(record.progress, dtype=float)
    idx = np.searchsorted(samples[:, 0], grid, side="right") - 1
    ok = idx >= 0
    out[ok] = samples[idx[ok], 2] / reference
    return out


class CurveBand:
    """Median and interquartile range of the best-cost curves of some runs on a time grid."""

    def __init__(self, grid: FloatArray, curves: FloatArray) -> None:
        self.grid = grid
        big = 1e300  # stands for inf (no solution yet) so that quantiles of a mixed column stay defined;
        q = np.quantile(np.where(np.isfinite(curves), curves, big), [0.25, 0.5, 0.75], axis=0)
        q[q >= 1e200] = np.inf  # a quantile between a solved run and an unsolved one is unbounded too
        self.q25, self.median, self.q75 = q
        self.runs = len(curves)


def cost_band(records: Sequence[RunRecord], refs: dict[tuple[str, int], float],
              grid: FloatArray) -> CurveBand | None:
    """The `CurveBand` of the runs with a known reference length (None when there is none)."""
    curves = [_curve(r, grid, refs.get((r.map, r.query), math.nan)) for r in records
              if math.isfinite(refs.get((r.map, r.query), math.nan))]
    if not curves:
        return None
    return CurveBand(grid, np.array(curves))
