"""A stuck sonar told from a wall: runs of equal readings judged against what the map's walls echo.

A LEGO NXT sensor that stops refreshing repeats its last reading over a long arc of the turret. So
does a healthy sensor near walls: its 40-degree lobe hears the nearest wall square enough, and at
(180, 30) of the CO333 arena, 30 cm from two walls, that nearest echo stays at 30-35 cm for well over
100 degrees (the shipped real sweeps hold runs of one value over 103, 109 and 137 degrees). Run length
alone cannot tell the two apart: the stuck sweeps of the real data repeat one value over 85 to 250
degrees. The map can. A run of equal readings is stuck only when the map's noise-free nearest echo of
the lobe (`toolkit.world.NxtSonar.echo_distance`) does not stay near the repeated value over the run's
arc at a pose the sweep could have been taken from.

How a sweep is judged (`judge_runs`):

1. Its runs: consecutive readings (sweep order) equal to each other, echoes only, spanning at least
   `STUCK_ARC_DEG` of turret angle. Shorter runs are never stuck; a long silent arc (no echo) is a
   real answer, never stuck.
2. The candidate poses: a grid of free positions (`EchoTable`, every `GRID_CM` cm, within a stated
   budget) x every heading (1 degree). Where a position is known (a sweep at a documented waypoint,
   a fault check at a believed pose), the positions within `POSITION_RADIUS_CM` of it; otherwise the
   whole map. Headings are always all searched: the real sweeps' headings were never measured, and
   a believed heading may be the wrong one.
3. A reading is explained at a pose where the lobe's echo lies within `ECHO_TOLERANCE_CM` of it, and
   a run where less than `STUCK_ARC_DEG` of it is left unexplained.
4. One sweep, one pose: the candidate that explains the most runs (then the most of their readings)
   judges them all. The runs it leaves unexplained are stuck.

Without a known position the check is made over every pose of the map. That is the honest answer to
"could this run be a wall?" when nothing says where the robot is: it drops runs that no pose of the
map can produce (the stuck sensor the virtual brick makes repeats one value over the whole turn; a
real one repeated 55 cm over 250 degrees), and keeps a run the map could produce somewhere, as
evidence the localiser weighs: the beam model caps what one wrong reading costs and counts a dense
run as ``arc / correlation_deg`` readings, so a kept stuck run cannot outvote the rest of the sweep.
Such a run (a stuck 22 cm where a corner 22 cm from two walls exists) is caught only once a position
is known. Without a map at all, only the run length is left: `NO_MAP_STUCK_ARC_DEG`, longer than any
run a wall can hold.

Measured on the real sweeps (``/work/shared`` development set; not read by the tests): the three
shipped sweeps keep every reading, with or without their waypoint; the four stuck sweeps of its
``dropped/`` folder are all caught at their waypoints, and the one stuck over 250 degrees also
without one.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from toolkit.world import Map, NxtSonar, Scan, angle_diff

__all__ = [
    "ECHO_TOLERANCE_CM",
    "GRID_CM",
    "MAX_GRID_POSITIONS",
    "NO_MAP_STUCK_ARC_DEG",
    "POSITION_RADIUS_CM",
    "STUCK_ARC_DEG",
    "EchoTable",
    "EqualRun",
    "echo_table",
    "equal_runs",
    "judge_runs",
    "runs_mask",
    "sweep_step",
]

STUCK_ARC_DEG = 45.0
"""Turret arc (degrees): a run of equal echo readings shorter than this is never stuck, and a longer one
is stuck when the map leaves at least this much of it unexplained. A sensor that stops refreshing
repeats its last value over 50-250 degrees (the real stuck sweeps, the virtual brick's fault)."""
NO_MAP_STUCK_ARC_DEG = 200.0
"""Without a map, a run of equal echo readings is stuck from this arc (degrees) on. One flat wall echoes
into a lobe over at most about 100 degrees of turret (its normal within the critical incidence, 30
degrees, plus half the 40-degree lobe, either side), a corner of two walls at one distance over about
190; the real sweeps of healthy sensors hold runs up to 137 degrees."""
ECHO_TOLERANCE_CM = 4.0
"""A reading is explained where the lobe's noise-free echo lies within this (cm) of it: about twice the
fitted reading spread at 30-60 cm (1.2 cm + 0.9 cm per metre) plus the rounding to whole cm."""
POSITION_RADIUS_CM = 10.0
"""Where a position is known, poses within this (cm) of it are candidates: the real sweeps' waypoints
were reached by odometry, a few cm off."""
GRID_CM = 3.0
"""Spacing (cm) of the candidate positions (finer never; coarser on a map too large for the budget)."""
MAX_GRID_POSITIONS = 6000
"""Budget of the candidate positions: at most this many, x 360 directions x 4 bytes (8.6 MB) a table."""
CLEARANCE_CM = 5.0
"""Candidate positions lie at least this far (cm) from every wall (the sensor sits on the robot)."""


def sweep_step(scan: Scan) -> float:
    """The turret angle between consecutive readings of a sweep (rad; the median; 2 pi for one reading)."""
    if len(scan) < 2:
        return 2.0 * math.pi
    return float(np.median(np.abs(angle_diff(scan.angles[1:], scan.angles[:-1]))))


@dataclass(frozen=True)
class EqualRun:
    """Consecutive readings of a sweep equal to each other: indices ``start .. start + length - 1``.

    Attributes
    ----------
    start, length : int
        First reading (sweep order) and number of readings.
    value_cm : float
        The repeated reading (cm).
    arc_deg : float
        Turret arc the run spans: length x the sweep's step (degrees).
    """

    start: int
    length: int
    value_cm: float
    arc_deg: float


def equal_runs(scan: Scan, min_arc_deg: float = STUCK_ARC_DEG) -> list[EqualRun]:
    """The runs of equal echo readings of `scan` (sweep order) spanning at least `min_arc_deg` degrees.

    No-echo readings never form a run (a long silent arc is a real answer).
    """
    n = len(scan)
    step_deg = math.degrees(sweep_step(scan))
    if n < 2 or not min_arc_deg > 0 or step_deg <= 0:
        return []
    r = np.where(scan.valid & np.isfinite(scan.ranges), scan.ranges, np.nan)
    out, start = [], 0
    for i in range(1, n + 1):
        if i == n or not (r[i] == r[start]):
            if math.isfinite(r[start]) and (i - start) * step_deg >= min_arc_deg:
                out.append(EqualRun(start, i - start, float(r[start]), (i - start) * step_deg))
            start = i
    return out


@dataclass(frozen=True, eq=False)
class EchoTable:
    """The nearest echo of a lobe at a grid of free positions, along 360 absolute directions (noise-free).

    Attributes
    ----------
    xy : (P, 2) ndarray
        Candidate positions (cm), `spacing_cm` apart, at least `CLEARANCE_CM` from every wall.
    echo_cm : (P, 360) float32 ndarray
        The nearest echo of the sonar model (`NxtSonar.echo_distance`: rays that meet a wall beyond the
        critical incidence are lost; inf where every ray is lost).
    spacing_cm : float
        Grid spacing (cm).
    """

    xy: NDArray[np.float64]
    echo_cm: NDArray[np.float32]
    spacing_cm: float


def _grid_positions(map: Map) -> tuple[NDArray[np.float64], float]:
    free_area = float(map.free_space(CLEARANCE_CM).area)
    spacing = max(GRID_CM, math.sqrt(max(free_area, 1.0) / MAX_GRID_POSITIONS))
    xmin, ymin, xmax, ymax = map.bounds
    while True:
        gx, gy = np.meshgrid(np.arange(xmin + spacing / 2, xmax, spacing), np.arange(ymin + spacing / 2, ymax, spacing))
        xy = np.column_stack([gx.ravel(), gy.ravel()])
        xy = xy[np.asarray(map.is_free(xy, CLEARANCE_CM), dtype=bool)]
        if len(xy) <= MAX_GRID_POSITIONS:
            return xy, spacing
        spacing *= math.sqrt(len(xy) / MAX_GRID_POSITIONS) * 1.01


def _lobe(map: Map, xy: NDArray[np.float64], beam_width_deg: float,
          critical_incidence_deg: float) -> NDArray[np.float32]:
    """`NxtSonar.echo_distance` at every position along 360 directions with its lobe sampled every
    degree: one ray a degree (lost beyond `critical_incidence_deg`), then the minimum over the lobe."""
    ray = NxtSonar(beam_width_deg=0.0, beam_rays=1, critical_incidence_deg=critical_incidence_deg)
    per_ray = np.asarray(ray.echo_distance(map.walls, xy, np.radians(np.arange(360.0))), dtype=np.float64)
    lobe = per_ray.copy()
    for k in range(1, round(beam_width_deg / 2.0) + 1):
        lobe = np.minimum(lobe, np.minimum(np.roll(per_ray, k, axis=1), np.roll(per_ray, -k, axis=1)))
    return lobe.astype(np.float32)


_TABLES: dict[tuple[bytes, float, float], EchoTable] = {}
_LOCK = threading.Lock()
_MAX_TABLES = 4


def echo_table(map: Map, sonar: NxtSonar | None = None) -> EchoTable:
    """The `EchoTable` of `map` for `sonar`'s lobe (default `NxtSonar()`), built once and kept in memory
    (the last `_MAX_TABLES` maps)."""
    s = sonar if sonar is not None else NxtSonar()
    key = (np.ascontiguousarray(map.walls).tobytes(), float(s.beam_width_deg), float(s.critical_incidence_deg))
    with _LOCK:
        table = _TABLES.get(key)
        if table is None:
            xy, spacing = _grid_positions(map)
            table = EchoTable(xy, _lobe(map, xy, s.beam_width_deg, s.critical_incidence_deg), spacing)
            if len(_TABLES) >= _MAX_TABLES:
                _TABLES.pop(next(iter(_TABLES)))
            _TABLES[key] = table
        return table


def _candidate_rows(table: EchoTable, position: ArrayLike | None) -> NDArray[np.int64]:
    if position is None:
        return np.arange(len(table.xy))
    p = np.asarray(position, dtype=float)[:2]
    dist = np.hypot(table.xy[:, 0] - p[0], table.xy[:, 1] - p[1])
    near = np.flatnonzero(dist <= POSITION_RADIUS_CM + table.spacing_cm / 2)
    return near if near.size else np.argsort(dist)[:1]


def _run_counts(echo: NDArray[np.float32], directions: NDArray[np.int64], value_cm: float) -> NDArray[np.int64]:
    """For every candidate position (rows of `echo`) and heading h (degrees, columns), how many of the
    run's readings (relative `directions`, whole degrees) have an echo within `ECHO_TOLERANCE_CM` at
    ``h + direction`` (a circular correlation, by FFT)."""
    near = (np.abs(echo - value_cm) <= ECHO_TOLERANCE_CM).astype(np.float64)
    weights = np.bincount(np.mod(directions, 360), minlength=360).astype(np.float64)
    spectrum = np.fft.rfft(near, axis=1) * np.conj(np.fft.rfft(weights))[None, :]
    return np.rint(np.fft.irfft(spectrum, n=360, axis=1)).astype(np.int64)


def judge_runs(scan: Scan, map: Map | None = None, *, sonar: NxtSonar | None = None,
               position: ArrayLike | None = None,
               min_arc_deg: float = STUCK_ARC_DEG) -> tuple[list[EqualRun], list[EqualRun]]:
    """The long runs of equal readings of `scan`, split into (stuck, explained by the map).

    Parameters
    ----------
    scan : Scan
        One sweep, angles relative to the robot heading (rad), readings in sweep order (cm).
    map : Map, optional
        The map the sweep was taken in; None judges by run length alone (`NO_MAP_STUCK_ARC_DEG`).
    sonar : NxtSonar, optional
        Whose lobe echoes (default `NxtSonar()`, the model fitted to real sweeps).
    position : array_like, optional
        The sweep's position (x, y, cm) where known (a documented waypoint, a believed pose): poses within
        `POSITION_RADIUS_CM` of it are the candidates; None: every pose of the map.
    min_arc_deg : float
        Shortest run judged, and the unexplained arc that makes a run stuck (degrees).

    Returns
    -------
    stuck, explained : list of EqualRun
    """
    runs = equal_runs(scan, min_arc_deg)
    if not runs:
        return [], []
    if map is None:
        return ([r for r in runs if r.arc_deg >= NO_MAP_STUCK_ARC_DEG],
                [r for r in runs if r.arc_deg < NO_MAP_STUCK_ARC_DEG])
    table = echo_table(map, sonar)
    echo = table.echo_cm[_candidate_rows(table, position)]
    rel_deg = np.mod(np.rint(np.degrees(np.asarray(scan.angles, dtype=float))), 360).astype(np.int64)
    step_deg = runs[0].arc_deg / runs[0].length
    counts = [_run_counts(echo, rel_deg[r.start:r.start + r.length], r.value_cm) for r in runs]
    # a run is explained at a pose that leaves less than min_arc_deg of it over; the pose that explains
    # the most runs, then the most of their readings, judges them all
    explained = [(r.length - c) * step_deg < min_arc_deg for r, c in zip(runs, counts, strict=True)]
    score = np.sum(explained, axis=0) * (sum(r.length for r in runs) + 1) + np.sum(counts, axis=0)
    best = np.unravel_index(int(np.argmax(score)), score.shape)
    stuck = [r for r, ok in zip(runs, explained, strict=True) if not ok[best]]
    return stuck, [r for r in runs if r not in stuck]


def runs_mask(n: int, runs: Sequence[EqualRun]) -> NDArray[np.bool_]:
    """A boolean mask of `n` readings, True on the readings of `runs`."""
    out = np.zeros(n, dtype=bool)
    for r in runs:
        out[r.start:r.start + r.length] = True
    return out
