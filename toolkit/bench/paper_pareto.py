"""Accuracy against robot time: the Pareto front of the mission's sweep options.

A mission buys accuracy with sonar sweeps, and sweeps are most of a real robot's time. Each named
setting of `MISSION_SETTINGS` is a set of `MissionConfig` options, from the paper's habit (sweep the
full turn, align, sweep again, after every leg) to lean ones; `pareto_tasks` runs the same seeded
trials (common random numbers) for every setting and sonar model, `pareto_points` reduces them to
one point per setting, sonar and map (mean true final error, median robot time, success, collisions)
and `pareto_front` marks the points no other point of the same sonar and map beats in both.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from toolkit.world import ConfigError, NxtSonar

from .paper import PAPER_MAPS, PaperResult, PaperTrial, paper_tasks

__all__ = ["MISSION_SETTINGS", "ParetoPoint", "pareto_front", "pareto_points", "pareto_tasks"]

MISSION_SETTINGS: dict[str, dict[str, Any]] = {
    "paper-habit": {"global_localisation.align": True, "global_localisation.scan_step_deg": 1.0,
                    "sweeps.track_align": True, "fix.rule": "always", "fix.relocalise_every_cm": 40.0},
    "full-sweeps": {"sweeps.track_window_deg": 180.0, "sweeps.final_window_deg": 180.0,
                    "sweeps.track_scan_step_deg": 2.0, "sweeps.final_scan_step_deg": 2.0},
    "fix-every-leg": {"fix.rule": "always", "fix.relocalise_every_cm": 40.0},
    "default": {},
    "dense-windows": {"sweeps.track_scan_step_deg": 1.0},
    "axes-windows": {"sweeps.track_windows": "axes"},
    "lean": {"sweeps.track_scan_step_deg": 3.0, "sweeps.final_scan_step_deg": 2.0, "fix.first_leg_cm": None},
}
"""Named mission settings (`MissionConfig` options over the sonar model's defaults), from the
paper's habit to the leanest; ``default`` is `MissionConfig`'s own."""


def pareto_tasks(trials: int, seed: int = 0, *, settings: Sequence[str] = tuple(MISSION_SETTINGS),
                 sonars: Sequence[str] = ("ideal", "nxt"), maps: Sequence[str] = PAPER_MAPS,
                 noise_models: Sequence[str] = ("botsim",), random_start: bool = False,
                 sonar_model: NxtSonar | None = None, collision: str = "index") -> list[PaperTrial]:
    """The trials of every setting (by name) and sonar model, with the same mission seeds (`sonar_model`:
    the ``nxt`` sonar's model, a fitted profile's, for the ``nxt`` trials; `collision`: the backend)."""
    unknown = [s for s in settings if s not in MISSION_SETTINGS]
    if unknown:
        raise ConfigError(f"unknown mission setting(s) {', '.join(unknown)}; known: {', '.join(MISSION_SETTINGS)}")
    return [t for so in sonars for name in settings
            for t in paper_tasks(trials, seed, maps=maps, noise_models=noise_models, sonar=so,
                                 random_start=random_start, options=MISSION_SETTINGS[name],
                                 sonar_model=sonar_model if so == "nxt" else None, collision=collision)]


def _setting_name(options: tuple[tuple[str, Any], ...]) -> str:
    for name, opts in MISSION_SETTINGS.items():
        if tuple(sorted(opts.items())) == options:
            return name
    return ", ".join(f"{k}={v}" for k, v in options) or "default"


@dataclass(frozen=True)
class ParetoPoint:
    """One setting on one map with one sonar model.

    Attributes
    ----------
    setting, sonar, map : str
    trials : int
    final_error_cm : float
        Mean true final error (cm) over the trials.
    robot_time_median_s : float
        Median robot time (s).
    success_rate : float
    collisions : int
        Total true collisions.
    completion_median_s : float
        Median wall-clock time of a mission's computation and simulation (s).
    on_front : bool
        No other setting on this map and sonar has both a lower (or equal) error and a lower (or
        equal) median robot time, one of them strictly.
    """

    setting: str
    sonar: str
    map: str
    trials: int
    final_error_cm: float
    robot_time_median_s: float
    success_rate: float
    collisions: int
    completion_median_s: float = math.nan
    on_front: bool = False

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def pareto_front(points: Sequence[tuple[float, float]]) -> list[bool]:
    """Which (cost, error) pairs no other pair dominates (lower or equal in both, lower in one).

    >>> pareto_front([(1.0, 2.0), (2.0, 1.0), (2.0, 2.0)])
    [True, True, False]
    """
    a = np.asarray(points, dtype=float).reshape(-1, 2)
    out = []
    for p in a:
        if not np.all(np.isfinite(p)):
            out.append(False)
            continue
        dominated = np.any(np.all(a <= p, axis=1) & np.any(a < p, axis=1))
        out.append(not bool(dominated))
    return out


def pareto_points(results: Iterable[PaperResult]) -> list[ParetoPoint]:
    """One point per setting, sonar and map, with the front marked among each sonar and map's points."""
    groups: dict[tuple[str, str, str], list[PaperResult]] = {}
    for r in results:
        groups.setdefault((_setting_name(r.task.options), r.task.sonar, r.task.map), []).append(r)
    raw = []
    for (name, sonar, m), rs in groups.items():
        err = [r.final_error_cm for r in rs if not math.isnan(r.final_error_cm)]
        times = [r.robot_time_s for r in rs if not math.isnan(r.robot_time_s)]
        raw.append(ParetoPoint(name, sonar, m, len(rs), float(np.mean(err)) if err else math.nan,
                               float(np.median(times)) if times else math.nan,
                               sum(r.success for r in rs) / len(rs), int(sum(r.collisions for r in rs)),
                               float(np.nanmedian([r.completion_s for r in rs]))))
    out = []
    for sonar, m in sorted({(p.sonar, p.map) for p in raw}):
        same = [p for p in raw if p.sonar == sonar and p.map == m]
        # a setting that fails or collides is not a choice: it stays off the front
        ok = [(p.robot_time_median_s, p.final_error_cm) if p.success_rate == 1.0 and p.collisions == 0
              else (math.nan, math.nan) for p in same]
        for p, front in zip(same, pareto_front(ok), strict=True):
            out.append(ParetoPoint(**{**p.to_dict(), "on_front": front}))
    return out
