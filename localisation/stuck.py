"""A stuck sonar told from a wall: runs of equal readings judged against what the map's walls echo.

A LEGO NXT sensor that stops refreshing repeats its last reading over a long arc of the turret. A
healthy sensor near a wall also reads one value over a while: its 40-degree lobe hears the nearest
wall square enough, and 30 cm from the two walls of a corner that nearest echo stays within a few cm
over a wide arc. Run length alone cannot tell the two apart, so a run is judged against the map: it is
stuck only when the lobe's noise-free echo at the sweep's pose does not stay near the repeated value
over the run's arc.

How a sweep is judged (`judge_runs`):

1. Its runs: consecutive readings (sweep order) equal to each other, echoes only, spanning at least
   `STUCK_ARC_DEG` of turret angle. Shorter runs are never stuck; a long silent arc (no echo) is a
   real answer, never stuck.
2. What the map says, noise-free, at a grid of free positions (`EchoTable`, every `GRID_CM` cm within
   a stated budget) along every whole degree: the lobe's nearest surface at any incidence, and the
   sonar model's echo (`toolkit.world.NxtSonar.echo_distance`: the nearest surface square enough).
   A reading is explained where it lies within `ECHO_TOLERANCE_CM` of either.
3. One sweep, one pose. The candidates: the positions within `POSITION_RADIUS_CM` of a known position
   (a documented waypoint), else every position of the map, each at every heading (1 degree; a real
   sweep's heading was never measured). The sweep's pose is the candidate that explains the most of
   its fresh readings: every echo reading outside the runs, and the first reading of each run (a
   sensor that stops refreshing repeats a value it did measure; its repeats are what is in question,
   so they do not choose the pose they are judged at).
4. A run is stuck when that pose leaves at least `STUCK_ARC_DEG` of it unexplained.

Choosing the pose by the runs themselves would explain any run somewhere: a stuck 20 cm over 172
degrees (the virtual brick's fault, at map1's start) fits a pose in map1's small room, 20 cm from
three walls, better than the pose the rest of its sweep shows. Without a known position the check is
global localisation by counting, over every pose of the map: it finds the pose the fresh readings
point to, or a near-twin of it, and a run that pose does not explain is stuck. Without a map, only the
run length is left: `NO_MAP_STUCK_ARC_DEG`, longer than any run a wall can hold, so a physical run is
never dropped and only the longest stuck runs are caught.

Measured on the real sweeps of the project's development set (not read by the tests): the four stuck
sweeps of its ``dropped/`` folder (runs of 250, 160, 117 + 88 and 85 + 66 degrees) are caught, with
or without their waypoints. So are the long runs of the three shipped sweeps (109 readings of 33 cm,
103 of 44, 137 of 36): at their waypoints, over most of those arcs, the map has no wall within reach
or only far ones (115-170 cm), where most of the other teams' sensors at the same waypoints read no
echo (255) or those far walls. That sensor never reads 255 after its first echo (none in the 1,722
readings after it in its five sweeps, against 28 and 37 % no echo for two other teams' sensors): it
repeats its last echo while no new one arrives, as `ellasurobot/ella`'s sensor does (2.4 % no echo;
docs/real-sonar.md). A sweep set says so per source (``held_runs`` ``no-echo`` in ``sweeps.csv``,
`toolkit.real_sonar.sweeps`): the repeats of such a run are then read as no echo, not dropped as stuck.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from localisation.range_table import cache_dir_from_env, map_geometry_key, write_cache_file
from toolkit.world import NO_ECHO, Map, NxtSonar, Scan, angle_diff

log = logging.getLogger(__name__)

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
"""Without a map, a run of equal echo readings is stuck from this arc (degrees) on: more than any wall
can hold. One flat wall echoes into the lobe over at most about 100 degrees of turret (its normal within
the critical incidence, 30 degrees, plus half the 40-degree lobe, either side), a corner of two walls
at one distance over about 190; the longest run of the real development set that its map explains
spans 51 degrees. Of the real stuck runs (85-250 degrees) only the longest is caught this way."""
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
MAX_SCORED_READINGS = 180
"""A sweep's pose is chosen by at most this many of its echo readings (evenly picked): a bounded cost."""
FRESH_SLACK_SHARE = 0.05
FRESH_SLACK_MIN = 2
"""A candidate is one of the sweep's poses when it explains as many of the fresh readings as the best
candidate, but for max(`FRESH_SLACK_MIN`, `FRESH_SLACK_SHARE` of them): a real sweep has wrong
readings, and few fresh readings fit many poses equally."""
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
    """What a lobe can hear at a grid of free positions, along 360 absolute directions (noise-free).

    Attributes
    ----------
    xy : (P, 2) ndarray
        Candidate positions (cm), `spacing_cm` apart, at least `CLEARANCE_CM` from every wall.
    nearest_cm : (P, 360) float32 ndarray
        The nearest surface any ray of the lobe meets (cm; inf: none), at any incidence: no echo comes
        from nearer.
    echo_cm : (P, 360) float32 ndarray
        The nearest echo of the sonar model (`NxtSonar.echo_distance`: rays that meet a wall beyond the
        critical incidence are lost; inf where every ray is lost).
    spacing_cm : float
        Grid spacing (cm).
    """

    xy: NDArray[np.float64]
    nearest_cm: NDArray[np.float32]
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


def _lobes(map: Map, xy: NDArray[np.float64], beam_width_deg: float,
           critical_incidence_deg: float) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """At every position along 360 directions, with a lobe of `beam_width_deg` sampled every degree (one
    ray a degree, then the minimum over the lobe): the nearest surface at any incidence, and
    `NxtSonar.echo_distance` (rays lost beyond `critical_incidence_deg`); both from one cast."""
    ray = NxtSonar(beam_width_deg=0.0, beam_rays=1, critical_incidence_deg=critical_incidence_deg)
    first, cos_inc = ray.ray_hits(map.walls, xy, np.radians(np.arange(360.0)))
    any_incidence = NxtSonar(beam_width_deg=0.0, beam_rays=1, critical_incidence_deg=90.0)
    lobes = []
    for sonar in (any_incidence, ray):
        rays = sonar.echoes(first, cos_inc)[..., 0]
        lobe = rays.copy()
        for k in range(1, round(beam_width_deg / 2.0) + 1):
            lobe = np.minimum(lobe, np.minimum(np.roll(rays, k, axis=1), np.roll(rays, -k, axis=1)))
        lobes.append(lobe.astype(np.float32))
    return lobes[0], lobes[1]


_TABLES: dict[tuple[bytes, float, float], EchoTable] = {}
_LOCK = threading.Lock()
_MAX_TABLES = 4


def _cached_echo_table(map: Map, beam_width_deg: float, critical_incidence_deg: float) -> EchoTable:
    """The table built, or read from the disk cache (``$NXTNAV_CACHE_DIR``, as the range tables) when
    there; a table built is written there (atomically: processes may share the folder)."""
    folder = cache_dir_from_env()
    path = None if folder is None else \
        folder / f"echo_table_{map_geometry_key(map)}_{beam_width_deg:g}_{critical_incidence_deg:g}.npz"
    if path is not None and path.is_file():
        try:
            with np.load(path) as f:
                table = EchoTable(f["xy"], f["nearest_cm"], f["echo_cm"], float(f["spacing_cm"]))
            if table.nearest_cm.shape == table.echo_cm.shape == (len(table.xy), 360):
                return table
        except (OSError, ValueError, KeyError) as exc:
            log.warning("ignoring unreadable echo table cache %s: %s", path, exc)
    xy, spacing = _grid_positions(map)
    table = EchoTable(xy, *_lobes(map, xy, beam_width_deg, critical_incidence_deg), spacing)
    if path is not None:
        write_cache_file(path, lambda tmp: np.savez(tmp, xy=table.xy, nearest_cm=table.nearest_cm,
                                                    echo_cm=table.echo_cm, spacing_cm=table.spacing_cm),
                         "echo table")
    return table


def echo_table(map: Map, sonar: NxtSonar | None = None) -> EchoTable:
    """The `EchoTable` of `map` for `sonar`'s lobe (default `NxtSonar()`), built once and kept in memory
    (the last `_MAX_TABLES` maps)."""
    s = sonar if sonar is not None else NxtSonar()
    key = (np.ascontiguousarray(map.walls).tobytes(), float(s.beam_width_deg), float(s.critical_incidence_deg))
    with _LOCK:
        table = _TABLES.get(key)
        if table is None:
            table = _cached_echo_table(map, s.beam_width_deg, s.critical_incidence_deg)
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


def _explains(nearest: Any, echo: Any, value_cm: Any) -> Any:
    """Whether a lobe whose nearest surface is `nearest` and whose model echo is `echo` (cm) can read
    `value_cm`: within `ECHO_TOLERANCE_CM` of the model's echo (the nearest surface square enough), or of
    the nearest surface (heard at a steeper incidence than the model's critical one, as near walls are)."""
    return (np.abs(echo - value_cm) <= ECHO_TOLERANCE_CM) | (np.abs(nearest - value_cm) <= ECHO_TOLERANCE_CM)


@njit("void(float32[:, ::1], float32[:, ::1], int64[::1], float64[::1], float64, int32[:, ::1])", cache=True)
def _explained_by_pose(nearest: Any, echo: Any, dirs: Any, values: Any, tol: float,
                       out: Any) -> None:  # pragma: no cover
    """``out[p, h]``: how many readings (`values`, cm, at relative `dirs`, whole degrees in [0, 360))
    position p explains at heading h (degrees), as `_explains` says."""
    n_pos, n_ang = echo.shape
    for p in range(n_pos):
        for h in range(n_ang):
            out[p, h] = 0
        for j in range(dirs.size):
            shift, value = dirs[j], values[j]
            for h in range(n_ang):
                k = h + shift
                if k >= n_ang:
                    k -= n_ang
                if abs(echo[p, k] - value) <= tol or abs(nearest[p, k] - value) <= tol:
                    out[p, h] += 1


def _fresh_scores(scan: Scan, runs: Sequence[EqualRun], nearest: NDArray[np.float32], echo: NDArray[np.float32],
                  rel_deg: NDArray[np.int64]) -> tuple[NDArray[np.int32], int]:
    """How many fresh readings of the sweep (echoes outside the runs, and each run's first reading; at
    most `MAX_SCORED_READINGS`, evenly picked) every candidate (row, heading) explains, and how many
    were scored."""
    r = np.asarray(scan.ranges, dtype=float)
    fresh = scan.valid & np.isfinite(r) & (r < NO_ECHO)
    for run in runs:  # a run's repeats may not be measurements: its first reading is
        fresh[run.start + 1:run.start + run.length] = False
    scored = np.flatnonzero(fresh)
    if scored.size > MAX_SCORED_READINGS:
        scored = scored[np.linspace(0, scored.size - 1, MAX_SCORED_READINGS).round().astype(np.int64)]
    score = np.empty(echo.shape, dtype=np.int32)
    _explained_by_pose(nearest, echo, np.ascontiguousarray(rel_deg[scored]), np.ascontiguousarray(r[scored]),
                       ECHO_TOLERANCE_CM, score)
    return score, int(scored.size)


def _run_counts(nearest: NDArray[np.float32], echo: NDArray[np.float32], directions: NDArray[np.int64],
                value_cm: float) -> NDArray[np.int64]:
    """For every candidate (row, heading h in whole degrees), how many readings of a run (`value_cm` at
    the relative `directions`, whole degrees) the lobe can read at ``h + direction`` (a circular
    correlation, by FFT)."""
    ok = np.asarray(_explains(nearest, echo, value_cm), dtype=np.float64)
    weights = np.bincount(directions, minlength=360).astype(np.float64)
    spectrum = np.fft.rfft(ok, axis=1) * np.conj(np.fft.rfft(weights))[None, :]
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
    rows = _candidate_rows(table, position)
    nearest = np.ascontiguousarray(table.nearest_cm[rows])
    echo = np.ascontiguousarray(table.echo_cm[rows])
    rel_deg = np.mod(np.rint(np.degrees(np.asarray(scan.angles, dtype=float))), 360).astype(np.int64)
    score, n_scored = _fresh_scores(scan, runs, nearest, echo, rel_deg)
    # the sweep's poses: those its fresh readings fit as well as the best one, up to the slack
    plausible = score >= int(score.max()) - max(FRESH_SLACK_MIN, math.ceil(FRESH_SLACK_SHARE * n_scored))
    step_deg = runs[0].arc_deg / runs[0].length
    counts = [_run_counts(nearest, echo, rel_deg[r.start:r.start + r.length], r.value_cm) for r in runs]
    explained = [(r.length - c) * step_deg < min_arc_deg for r, c in zip(runs, counts, strict=True)]
    # of those, the one that explains the most runs, then the most of their readings, judges them all
    judge = np.where(plausible, np.sum(explained, axis=0) * (sum(r.length for r in runs) + 1)
                     + np.sum(counts, axis=0), -1)
    best = np.unravel_index(int(np.argmax(judge)), judge.shape)
    stuck = [r for r, ok in zip(runs, explained, strict=True) if not ok[best]]
    return stuck, [r for r in runs if r not in stuck]


def runs_mask(n: int, runs: Sequence[EqualRun]) -> NDArray[np.bool_]:
    """A boolean mask of `n` readings, True on the readings of `runs`."""
    out = np.zeros(n, dtype=bool)
    for r in runs:
        out[r.start:r.start + r.length] = True
    return out
