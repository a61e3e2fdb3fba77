"""The paper's scan processing (docs/localisers.md, "The paper's scan processing").

A sonar reads well only when it faces a wall nearly perpendicularly. The paper therefore turns the
robot toward the minimum reading of a 360-degree scan (the nearest wall is then close to
perpendicular), rescans, and keeps the readings within +-15 degrees of 0, 90, 180 and 270 degrees,
dropping those out of range (the sensor's own range: a scan's `valid` mask; optionally a limit of the
processing). Readings without an echo (255 on the NXT, ``inf`` in the simulator) in the windows stay
in the processed scan marked invalid: a localiser with a model of the sensor's silence
(`localisation.beam_model`) uses them, the others skip invalid readings. `stuck_mask` finds a
sensor that stopped refreshing (a run of equal readings the map's walls do not explain:
`localisation.stuck`), `garbage_share` one that answers at random; `sweep_fault` says either.

`process_scan` does the selection on a scan already aligned (the robot has turned), or aligns
virtually (``reference="min"``: the windows are centred on the minimum reading's direction), which is
what a localiser can do with a scan it cannot ask the robot to repeat.

>>> import numpy as np
>>> from toolkit.world import Scan, default_scan_angles
>>> scan = Scan.from_readings(default_scan_angles(), np.full(360, 50.0))
>>> len(process_scan(scan).scan)
124
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from toolkit.world import NO_ECHO, ConfigError, Map, NxtSonar, Scan, angle_diff

from .stuck import NO_MAP_STUCK_ARC_DEG, STUCK_ARC_DEG, judge_runs, runs_mask, sweep_step

__all__ = [
    "GARBAGE_JUMP_CM",
    "GARBAGE_SHARE",
    "NO_MAP_STUCK_ARC_DEG",
    "PAPER_CENTRES_DEG",
    "PAPER_WINDOW_DEG",
    "STUCK_ARC_DEG",
    "ProcessedScan",
    "ScanProcessing",
    "drop_stuck",
    "garbage_share",
    "min_reading",
    "process_scan",
    "raw_scan",
    "stuck_mask",
    "sweep_angles",
    "sweep_fault",
    "sweep_step",
    "window_mask",
]

log = logging.getLogger(__name__)

PAPER_CENTRES_DEG = (0.0, 90.0, 180.0, 270.0)
PAPER_WINDOW_DEG = 15.0


def min_reading(scan: Scan, min_range_cm: float = 0.0, tolerance_cm: float = 1.0) -> tuple[float, float]:
    """Direction (rad, relative to the heading) and value (cm) of the smallest valid reading.

    A wide sonar lobe reads the same perpendicular distance over several degrees; the direction
    returned is the middle of the run of consecutive readings within `tolerance_cm` of the minimum
    around it (the wall normal), not the run's first reading. Readings below `min_range_cm`
    (unreliable on the NXT) are ignored. Returns ``(0.0, inf)`` when the scan has no usable reading.
    """
    ok = scan.valid & np.isfinite(scan.ranges) & (scan.ranges >= min_range_cm)
    if not ok.any():
        return 0.0, math.inf
    r = np.where(ok, scan.ranges, np.inf)
    k = int(np.argmin(r))
    low = r <= r[k] + tolerance_cm
    n = r.size
    lo = hi = 0
    while lo < n - 1 and low[(k - lo - 1) % n]:
        lo += 1
    while hi < n - 1 - lo and low[(k + hi + 1) % n]:
        hi += 1
    if lo + hi >= n - 1:  # the whole sweep is flat: keep the argmin
        return float(angle_diff(scan.angles[k], 0.0)), float(r[k])
    a0 = scan.angles[(k - lo) % n]
    span = angle_diff(scan.angles[(k + hi) % n], a0)
    return float(angle_diff(a0 + 0.5 * span, 0.0)), float(r[k])


@dataclass(frozen=True)
class ScanProcessing:
    """Settings of the paper's scan processing.

    Parameters
    ----------
    centres_deg : sequence of float
        Window centres, relative to the reference direction (the paper: 0, 90, 180, 270).
    window_deg : float
        Half-width of each window (the paper: 15 degrees).
    min_range_cm : float
        Readings below this are dropped (the NXT is unreliable under about 5-7 cm).
    max_range_cm : float or None
        Readings at or above this are dropped; default none (None or inf): the scan's `valid` mask
        already says which readings are echoes (255 is none on the NXT; the ideal simulated sonar
        has no range limit).
    reference : {"heading", "min"}
        ``heading``: windows around the robot's heading (the robot has turned toward the minimum
        and rescanned); ``min``: windows around the minimum reading's direction of this scan.
    """

    centres_deg: Sequence[float] = PAPER_CENTRES_DEG
    window_deg: float = PAPER_WINDOW_DEG
    min_range_cm: float = 0.0
    max_range_cm: float | None = math.inf
    reference: Literal["heading", "min"] = "heading"

    def __post_init__(self) -> None:
        if self.max_range_cm is None:
            object.__setattr__(self, "max_range_cm", math.inf)
        object.__setattr__(self, "centres_deg", tuple(float(c) for c in self.centres_deg))
        if not self.centres_deg:
            raise ConfigError("ScanProcessing needs at least one window centre")
        if not (0.0 <= self.window_deg <= 180.0):
            raise ConfigError(f"window_deg must be in [0, 180], got {self.window_deg!r}")
        if not (0.0 <= self.min_range_cm < self.range_limit_cm):
            raise ConfigError(f"need 0 <= min_range_cm < max_range_cm, got {self.min_range_cm}, {self.max_range_cm}")
        if self.reference not in ("heading", "min"):
            raise ConfigError(f"reference must be 'heading' or 'min', got {self.reference!r}")

    @property
    def range_limit_cm(self) -> float:
        """`max_range_cm` as a number (inf: no limit)."""
        return math.inf if self.max_range_cm is None else float(self.max_range_cm)

    def to_dict(self) -> dict[str, Any]:
        return {
            "centres_deg": list(self.centres_deg),
            "window_deg": self.window_deg,
            "min_range_cm": self.min_range_cm,
            "max_range_cm": self.range_limit_cm if math.isfinite(self.range_limit_cm) else None,
            "reference": self.reference,
        }


@dataclass(frozen=True, eq=False)
class ProcessedScan:
    """The outcome of `process_scan`.

    Attributes
    ----------
    scan : Scan
        The kept readings, angles relative to the robot heading: the valid ones (`kept`) and the
        windows' no-echo readings (invalid, for localisers that model the sensor's silence).
    raw : Scan
        The scan that was processed.
    reference_rad : float
        Direction (rad, relative to the heading) the window centres were measured from.
    min_angle_rad, min_range_cm : float
        Direction and value of the scan's minimum usable reading.
    kept : (n,) bool ndarray
        Which readings of `raw` were kept.
    in_window, dropped_invalid, dropped_range : int
        Readings inside the windows, and of those the ones dropped as no echo and as out of range.
    settings : ScanProcessing
    """

    scan: Scan
    raw: Scan
    reference_rad: float
    min_angle_rad: float
    min_range_cm: float
    kept: NDArray[np.bool_]
    in_window: int
    dropped_invalid: int
    dropped_range: int
    settings: ScanProcessing = field(default_factory=ScanProcessing)

    def __len__(self) -> int:
        return int(self.kept.sum())

    def to_dict(self) -> dict[str, Any]:
        return {
            "kept": int(self.kept.sum()),
            "raw": len(self.raw),
            "in_window": self.in_window,
            "dropped_invalid": self.dropped_invalid,
            "dropped_range": self.dropped_range,
            "reference_deg": math.degrees(self.reference_rad),
            "min_angle_deg": math.degrees(self.min_angle_rad),
            "min_range_cm": self.min_range_cm if math.isfinite(self.min_range_cm) else None,
            "settings": self.settings.to_dict(),
            "scan": self.scan.to_dict(),
        }


def window_mask(angles: NDArray[np.float64], reference_rad: float = 0.0,
                centres_deg: Sequence[float] = PAPER_CENTRES_DEG,
                window_deg: float = PAPER_WINDOW_DEG) -> NDArray[np.bool_]:
    """Which `angles` (rad) lie within `window_deg` of a centre (degrees from `reference_rad`)."""
    a = np.asarray(angles, dtype=float)
    centres = reference_rad + np.radians(np.asarray(centres_deg, dtype=float))
    off = np.abs(angle_diff(a[:, None], centres[None, :]))
    return np.asarray((off <= math.radians(window_deg) + 1e-9).any(axis=1))


def process_scan(scan: Scan, settings: ScanProcessing | None = None, **overrides: Any) -> ProcessedScan:
    """The paper's processing of one scan: keep valid readings within the windows around 0/90/180/270.

    Parameters
    ----------
    scan : Scan
        A sweep, angles relative to the robot heading.
    settings : ScanProcessing, optional
        The processing (the paper's by default); keyword `overrides` replace its fields.

    Returns
    -------
    ProcessedScan
        The kept subset and what was dropped.
    """
    s = settings or ScanProcessing()
    if overrides:
        s = ScanProcessing(**{**s.to_dict(), **overrides})
    a_min, r_min = min_reading(scan, s.min_range_cm)
    reference = a_min if s.reference == "min" else 0.0
    in_win = window_mask(scan.angles, reference, s.centres_deg, s.window_deg)
    r = scan.ranges
    usable = scan.valid & np.isfinite(r) & (r != NO_ECHO)
    in_range = (r >= s.min_range_cm) & (r < s.range_limit_cm)
    kept = in_win & usable & in_range
    # no-echo readings in the windows travel with the kept ones, marked invalid: a localiser that models
    # the sensor's silence uses them, the others skip invalid readings
    silent = in_win & ~scan.valid & ((r >= NO_ECHO) | ~np.isfinite(r))
    return ProcessedScan(
        scan=scan.subset(kept | silent),
        raw=scan,
        reference_rad=float(reference),
        min_angle_rad=a_min,
        min_range_cm=r_min,
        kept=kept,
        in_window=int(in_win.sum()),
        dropped_invalid=int((in_win & ~usable).sum()),
        dropped_range=int((in_win & usable & ~in_range).sum()),
        settings=s,
    )


def raw_scan(scan: Scan, min_range_cm: float = 0.0, max_range_cm: float = math.inf) -> Scan:
    """All usable readings of `scan` (no window selection): the baseline the processing is compared with."""
    r = scan.ranges
    ok = scan.valid & np.isfinite(r) & (r != NO_ECHO) & (r >= min_range_cm) & (r < max_range_cm)
    return scan.subset(ok)



def stuck_mask(scan: Scan, map: Map | None = None, *, sonar: NxtSonar | None = None,
               position: ArrayLike | None = None, min_arc_deg: float = STUCK_ARC_DEG) -> NDArray[np.bool_]:
    """Readings that belong to a stuck run: a run of equal echo readings spanning at least `min_arc_deg`
    of turret angle that the map's walls do not explain (`localisation.stuck.judge_runs`: `map`, the
    `sonar` whose lobe echoes, the sweep's `position` where known). Without a map, runs of at least
    `NO_MAP_STUCK_ARC_DEG`. No-echo readings are never stuck (a long silent arc is a real answer)."""
    stuck, _ = judge_runs(scan, map, sonar=sonar, position=position, min_arc_deg=min_arc_deg)
    return runs_mask(len(scan), stuck)


def drop_stuck(scan: Scan, map: Map | None = None, *, sonar: NxtSonar | None = None,
               position: ArrayLike | None = None) -> tuple[Scan, int]:
    """`scan` without its stuck readings (`stuck_mask`, same arguments) and how many were dropped; says
    so in the log, once per sweep (every localiser of a replay weighs the same sweep, and the challenge
    turns one real sweep by whole bins at every visit: the key is the readings as a multiset)."""
    stuck = stuck_mask(scan, map, sonar=sonar, position=position)
    k = int(stuck.sum())
    if not k:
        return scan, 0
    key = hash((len(scan), np.sort(scan.ranges).tobytes(), k))
    if key not in _WARNED:
        _WARNED[key] = None
        if len(_WARNED) > 256:
            _WARNED.pop(next(iter(_WARNED)))
        why = "which the map's walls do not explain at the sweep's pose" if map is not None else "without a map"
        log.warning("stuck sonar: %d readings repeat %s cm over %.0f degrees or more, %s; not used", k,
                    "/".join(f"{v:g}" for v in np.unique(scan.ranges[stuck])),
                    STUCK_ARC_DEG if map is not None else NO_MAP_STUCK_ARC_DEG, why)
    return scan.subset(~stuck), k


_WARNED: dict[int, None] = {}
"""Sweeps `drop_stuck` has warned about (their hashes, the last 256)."""


def sweep_angles(step_deg: float = 1.0, window_deg: float = 180.0,
                 centres_deg: Sequence[float] = PAPER_CENTRES_DEG) -> NDArray[np.float64]:
    """Turret angles (rad, relative to the heading) of one sweep, in the order the turret visits them.

    ``window_deg >= 180`` is the full turn from straight ahead at `step_deg` steps (360 readings at
    1 degree); smaller windows read only the windows of +-`window_deg` around `centres_deg`
    (degrees from the heading, visited in the order given). Around the four axes that is what the
    paper's scan processing keeps: 124 readings for 15-degree windows at 1 degree, and 600 degrees
    of turret travel (out and back) instead of 720; the three windows ahead and to the sides
    (-90, 0, 90) take 420.

    >>> sweep_angles(1.0, 15.0).size, sweep_angles(2.0).size, sweep_angles(2.0, 15.0, (-90, 0, 90)).size
    (124, 180, 45)
    """
    if window_deg >= 180.0:
        return np.radians(np.arange(0.0, 360.0 - 1e-9, step_deg))
    half = np.arange(0.0, window_deg + 1e-9, step_deg)
    off = np.concatenate([-half[:0:-1], half])
    return np.radians(np.concatenate([c + off for c in centres_deg]))


GARBAGE_JUMP_CM = 20.0
"""A reading that differs by more than this (cm) from both its neighbours on the turret is out of line."""
GARBAGE_SHARE = 0.6
"""A sweep with more than this share of its readings out of line (`garbage_share`) is garbage.

Measured by ``docs/garbage_share.py`` (300 sweeps at random poses of maps 1-3 per row; full sweeps of
180 readings at 2 degrees, tracking windows of 62): clean sweeps of the simulated ``nxt`` sonar, which
draws every reading on its own, reach 0.34 (full) and 0.60 (windows, none above), of the ``ideal``
sonar 0.03 and 0.10, and the real sweeps of the real-nxt sweep sets 0.19. A sensor that replaces each
reading by a random value with probability 0.9 is caught in 99-100 % of full sweeps and 87-89 % of
window sweeps; with probability 0.5 in 0-20 % and 6-31 %: fewer random readings are left to the
localisers, whose ``nxt`` sonar model expects some."""


def garbage_share(scan: Scan, jump_cm: float = GARBAGE_JUMP_CM) -> float:
    """The share of the readings (those with a neighbour one sweep step away on each side) that differ
    by more than `jump_cm` from both neighbours; no echo counts as 255 cm. 0 for a sweep without such
    readings."""
    if len(scan) < 3:
        return 0.0
    r = np.where(scan.valid, scan.ranges, NO_ECHO)
    r = np.where(np.isfinite(r), r, NO_ECHO)
    gap = np.abs(angle_diff(scan.angles[1:], scan.angles[:-1]))
    near = gap <= 1.5 * sweep_step(scan)
    jump = (np.abs(np.diff(r)) > jump_cm) & near
    inner = near[:-1] & near[1:]
    if not inner.any():
        return 0.0
    return float(np.mean((jump[:-1] & jump[1:])[inner]))


def sweep_fault(scan: Scan, map: Map | None = None, *, sonar: NxtSonar | None = None,
                position: ArrayLike | None = None) -> str | None:
    """What is wrong with the sensor by this sweep: a stuck run (`stuck_mask`, judged against `map` with
    the `sonar`'s lobe, at `position` where known) or garbage (`garbage_share` above `GARBAGE_SHARE`),
    in words; None for a sweep that looks sane."""
    stuck = stuck_mask(scan, map, sonar=sonar, position=position)
    if stuck.any():
        values = "/".join(f"{v:g}" for v in np.unique(scan.ranges[stuck]))
        detail = (f"{STUCK_ARC_DEG:.0f} degrees or more that the walls do not explain" if map is not None
                  else f"{NO_MAP_STUCK_ARC_DEG:.0f} degrees or more")
        return f"stuck: the sonar repeated {values} cm over {int(stuck.sum())} readings ({detail})"
    share = garbage_share(scan)
    if share > GARBAGE_SHARE:
        return (f"garbage: {100 * share:.0f} % of the readings differ by more than {GARBAGE_JUMP_CM:g} cm "
                "from both neighbours")
    return None
