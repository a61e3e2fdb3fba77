"""A sonar backed by a sweep set: the simulated robot sweeps with real readings where real sweeps exist.

`SweepSetSonar` answers a full turret sweep with one of the real sweeps of a sweep set
(`toolkit.real_sonar.sweeps`) when the robot stands within `SweepSetSonar.radius_cm` (10 cm) of a waypoint
that has sweeps, and refuses anywhere else (`SweepRefused`, naming the nearest such waypoint and how
far it is): a real sweep is evidence of its own waypoint only, and no reading is made up between
waypoints. Where several sweeps of one source were taken at the waypoint, a seeded draw picks one.

Rotation. A sweep was taken at an unmeasured heading; ``heading_deg`` of ``sweeps.csv`` is the
heading that aligns it with the map. Seen from a robot whose true heading is ``theta``, a reading
taken at turret angle ``a`` looks at ``a + heading_deg - theta``. A full turret sweep
(``n_bins * step_deg`` = 360 degrees) is a ring, so it is rotated by whole bins: its turret angles
turn by ``round((heading_deg - theta) / step_deg)`` bins (every angle by that many steps) and the
readings keep the order they were taken in, so a run of them stays one run. The readings then lie
within half a bin (0.5 degree for 1-degree sweeps, 2.5 degrees
for 5-degree ones) of where a sensor on the robot would have taken them. A sweep that is not a full
ring, or has no ``heading_deg``, cannot be rotated: the set is refused when it is loaded (given
`headings`, `load_challenge_set` takes them in its place: ``--headings aligned``, the heading that aligns
each sweep with the map at its waypoint, as the column was found,
`toolkit.real_sonar.sweeps.aligned_heading_deg`).

Offset. A real sweep was taken at its waypoint, while the robot stands up to `SweepSetSonar.radius_cm`
away from it; replayed as taken, the sweep would tell the robot it stands on the waypoint wherever it
is, and the drift of its odometry could never show (a real robot's sweep shows it). With
`SweepSetSonar.offset_correction` (off by default: ``--set challenge.sonar.offset_correction=true``) every
echo is moved by what the map says the offset changes along its direction: the nearest surface of a
40-degree lobe (`NxtSonar`'s beam width, any incidence) by exact ray casting at the robot's true pose,
less the same at the waypoint with the same heading (`offset_corrected`). Whatever the real sensor did
that the map does not explain (a missing or wrong echo, a held run) stays as it was; only the geometry
of where it stands is the map's.

`SweepSetRobot` is the simulator (`toolkit.robots.sim.SimRobot`: motion noise, exact collisions,
robot time) with that sonar for its sweeps. Its collision watchdog reads one reading straight ahead
every centimetre of a move, which no sweep set holds: those single readings are drawn from the fitted
`nxt` model (`toolkit.world.NxtSonar`) at the robot's true pose, as the simulator draws them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..robots.sim import SimRobot
from ..world import NO_ECHO, Map, NxtSonar, Pose, RngLike, RobotError, Scan, as_rng, load_map, wrap_angle
from .sweeps import Sweep, SweepSet, SweepSetError, load_sweep_set, warn_once

__all__ = ["SWEEPS_PREFIX", "SweepRefused", "SweepSetRobot", "SweepSetSonar", "course_waypoints",
           "load_challenge_set", "offset_corrected", "sweeps_folder"]

SWEEPS_PREFIX = "sweeps:"
"""``--sonar sweeps:DIR``: the sweep set in DIR backs the simulated robot's sweeps."""

WAYPOINT_RADIUS_CM = 10.0
"""The robot must stand this close (cm) to a waypoint for one of its real sweeps to answer: the
challenge's reach. With `offset_correction` a wider radius (``--set challenge.sonar.radius_cm=20``) lets a
robot that ended a leg outside the reach still sweep, see its offset and correct it; the readings are
then partly the map's."""


class SweepRefused(RobotError):
    """The sweeps-backed sonar has no real sweep where the robot stands."""


def sweeps_folder(sonar: str) -> Path | None:
    """The folder of a ``sweeps:DIR`` sonar value, or None for any other value."""
    if not sonar.startswith(SWEEPS_PREFIX):
        return None
    text = sonar[len(SWEEPS_PREFIX):].strip()
    if not text:
        raise SweepSetError(f"--sonar {sonar!r}: name the sweep set's folder after 'sweeps:'")
    return Path(text)


def course_waypoints(sweeps: SweepSet, repo: str) -> list[tuple[float, float]]:
    """The waypoints of `repo` with sweeps, in the course's order (the order of their first sweep in
    ``sweeps.csv``, which lists a source's files as the course numbers its waypoints)."""
    return list(dict.fromkeys((s.x_cm, s.y_cm) for s in sweeps if s.repo == repo))


ARENA_TOLERANCE_CM = 2.0
"""A folder's arena is the map when no wall of either lies farther than this (cm) from the other's walls:
a free-standing wall drawn with zero thickness in one and 1 cm thick in the other is the same arena."""


def arena_distance_cm(a: Map, b: Map) -> float:
    """The Hausdorff distance (cm) between the walls of `a` and those of `b` (inf when either has none)."""
    import shapely

    def lines(m: Map) -> shapely.MultiLineString:
        w = np.asarray(m.walls, dtype=float)
        return shapely.MultiLineString([[(x0, y0), (x1, y1)] for x0, y0, x1, y1 in w])

    if len(a.walls) == 0 or len(b.walls) == 0:
        return math.inf
    return float(shapely.hausdorff_distance(lines(a), lines(b), densify=0.05))


Headings = Mapping[str, float] | Callable[[SweepSet], Mapping[str, float] | None]
"""Sweeps' headings (degrees, by sweep label) in place of their ``heading_deg``, or what finds them from the
set once it is read (``--headings aligned|model``; None from it: the column's)."""


def load_challenge_set(folder: Path, map: Map | str, headings: Headings | None = None) -> SweepSet:
    """The sweep set in `folder` for a challenge in `map`, checked: the folder exists, its arena (its
    ``arena.yaml``, when it has one) is `map`, every sweep has a ``heading_deg`` (`headings`, given: in its
    place) and is a full ring, and some source has sweeps at two or more waypoints. Raises `SweepSetError`
    naming the problem."""
    m = map if isinstance(map, Map) else load_map(map)
    if not folder.is_dir():
        raise SweepSetError(f"sweeps:{folder}: no such folder")
    arena = folder / "arena.yaml"
    if arena.is_file():
        own = load_map(arena)
        gap = arena_distance_cm(own, m)
        if gap > ARENA_TOLERANCE_CM:
            raise SweepSetError(f"sweeps:{folder}: its arena {own.name!r} ({arena}) differs from the map {m.name!r} "
                                f"(walls up to {gap:.0f} cm apart); give --map {arena}")
    sweeps = load_sweep_set(folder, m)
    given = headings(sweeps) if callable(headings) else headings
    if given is not None:
        sweeps = replace(sweeps, sweeps=tuple(replace(s, heading_deg=float(given[s.label])) for s in sweeps))
    for s in sweeps:
        if math.isnan(s.heading_deg):
            raise SweepSetError(f"{folder / 'sweeps.csv'}: sweep {s.label} has no heading_deg; a sweep "
                                "cannot be turned to the robot's heading without it (--headings aligned finds it "
                                "as heading_deg is made)")
        if not math.isclose(s.readings.size * s.step_deg, 360.0, abs_tol=1e-6):
            raise SweepSetError(f"{folder / 'sweeps.csv'}: sweep {s.label} covers {s.readings.size * s.step_deg:g} "
                                "degrees; only a full turn (n_bins x step_deg = 360) can be turned by whole bins")
    if not any(len(course_waypoints(sweeps, r)) >= 2 for r in sweeps.repos):
        counts = ", ".join(f"{r}: {len(course_waypoints(sweeps, r))}" for r in sweeps.repos)
        raise SweepSetError(f"sweeps:{folder}: no source has sweeps at two or more waypoints ({counts})")
    for repo in sweeps.repos:
        (x, y), *more = course_waypoints(sweeps, repo)
        if not more:
            warn_once(f"sweeps:{folder}: source {repo} has sweeps at one waypoint only ({x:g}, {y:g}); a "
                      "challenge needs two: it is left out")
    return sweeps


def offset_corrected(scan: Scan, m: Map, waypoint: Pose, pose: Pose, beam_width_deg: float) -> Scan:
    """`scan`, read at `waypoint`, as read at `pose` (same heading; module docstring): each echo plus
    the change (cm) of the lobe's nearest surface between the two poses, rounded to whole cm as the
    sensor reads, kept within 0..254; no-echo readings, and echoes whose lobe meets nothing at either
    pose, unchanged."""
    from localisation.models import exact_ranges

    poses = np.array([[waypoint.x, waypoint.y, pose.theta], [pose.x, pose.y, pose.theta]])
    at_waypoint, here = exact_ranges(m, poses, scan.angles, beam_width_deg=beam_width_deg)
    delta = here - at_waypoint
    move = scan.valid & np.isfinite(scan.ranges) & np.isfinite(delta)
    ranges = scan.ranges.copy()
    ranges[move] = np.clip(np.round(ranges[move] + delta[move]), 0.0, NO_ECHO - 1.0)
    return replace(scan, ranges=ranges)


def rotated(sweep: Sweep, heading_rad: float) -> Scan:
    """`sweep` as a robot whose true heading is `heading_rad` reads it: the ring of its turret angles
    turned by whole bins (module docstring), its readings in the order taken. Each reading keeps the
    direction in the arena it was taken in, and a run of readings stays a run, whatever the turn (turning
    the readings round the ring instead would split a run at the ring's seam). The readings are the
    sensor's as it gave them: a run the sweep set reads as held echoes (``held_runs`` ``no-echo``) comes
    back as read, and the localisers judge such runs themselves (`localisation.scan.drop_stuck`)."""
    delta_deg = math.degrees(wrap_angle(math.radians(sweep.heading_deg) - heading_rad))
    shift = round(delta_deg / sweep.step_deg)
    return replace(sweep, angles=sweep.angles + math.radians(shift * sweep.step_deg), held=None).scan()


@dataclass(frozen=True)
class SweepSetSonar:
    """Real sweeps of one source of a sweep set, answered where the robot stands (module docstring).

    Parameters
    ----------
    sweeps : SweepSet
        The set (checked by `load_challenge_set`).
    repo : str
        The source whose sweeps answer (a robot reads with its own sensor).
    radius_cm : float
        How close (cm) to a waypoint the robot must be.
    offset_correction : bool
        Move each echo by the robot's offset from the waypoint (module docstring); False: the sweep as
        taken at the waypoint, wherever within `radius_cm` the robot stands.
    """

    sweeps: SweepSet
    repo: str
    radius_cm: float = WAYPOINT_RADIUS_CM
    offset_correction: bool = False

    @property
    def waypoints(self) -> list[tuple[float, float]]:
        return course_waypoints(self.sweeps, self.repo)

    def sweep_at(self, pose: Pose, rng: RngLike = None) -> tuple[Scan, Sweep]:
        """The scan a robot at the true `pose` reads, and the real sweep behind it; `SweepRefused` when
        no waypoint with sweeps is within `radius_cm`."""
        points = np.array(self.waypoints)
        d = np.hypot(points[:, 0] - pose.x, points[:, 1] - pose.y)
        i = int(np.argmin(d))
        wx, wy = points[i]
        if d[i] > self.radius_cm:
            raise SweepRefused(f"no real sweep where the robot stands ({pose.x:.1f}, {pose.y:.1f}): the nearest "
                               f"waypoint with sweeps of {self.repo}, ({wx:g}, {wy:g}), is {d[i]:.1f} cm away "
                               f"(more than {self.radius_cm:g} cm)")
        here = [s for s in self.sweeps if s.repo == self.repo and (s.x_cm, s.y_cm) == (wx, wy)]
        chosen = here[int(as_rng(rng).integers(len(here)))]
        scan = rotated(chosen, pose.theta)
        if self.offset_correction:
            scan = offset_corrected(scan, self.sweeps.map, Pose(float(wx), float(wy), pose.theta), pose,
                                    NxtSonar().beam_width_deg)
        return scan, chosen


class SweepSetRobot(SimRobot):
    """`SimRobot` whose sweeps are real ones (`SweepSetSonar`); its watchdog's readings are simulated
    (module docstring).

    `last_sweep` is the real sweep behind the last scan."""

    def __init__(self, map: Map, pose: Pose, sonar: SweepSetSonar, **kwargs: object) -> None:
        super().__init__(map, pose, sonar="nxt", **kwargs)  # type: ignore[arg-type]
        self.sweep_sonar = sonar
        self.last_sweep: Sweep | None = None

    def ultrascan(self, angles: ArrayLike | None = None) -> Scan:
        """A full real sweep at the robot's true pose (the requested `angles` are ignored: the sweep's own
        turret angles come back); `SweepRefused` away from the waypoints. Robot time as for those angles."""
        self._check_open()
        scan, sweep = self.sweep_sonar.sweep_at(self.true_pose, self.rng)
        sweep_s, back = self.timing.sweep(sweep.angles)
        self.last_scan_times_s = self.robot_time_s + self.timing.reading_times(sweep.angles)
        self.sweep_s += sweep_s
        self.turret_return_s += back
        self.readings += int(sweep.angles.size)
        self._time += sweep_s + back
        self.last_sweep = sweep
        return scan
