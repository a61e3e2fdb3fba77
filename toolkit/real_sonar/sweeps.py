"""Sweep sets: real 360-degree sonar sweeps taken at known waypoints of a known map.

A sweep set is a folder::

    sweeps.csv        one row per sweep (columns below)
    <raw files>       one reading a line (whole cm, 255 = no echo), as `sweeps.csv`'s ``raw`` names them
    arena.yaml        the map (another file with ``--map``)

``sweeps.csv`` columns (the order does not matter; other columns are kept in `Sweep.extra`; blank lines
are skipped; a byte-order mark and CRLF line ends, as spreadsheets write them, are read; a row with more
or fewer fields than the header is an error naming its line):

==================  =========================================================================================
``repo``, ``file``  where the sweep comes from (a label; ``commit`` and ``licence`` are kept when present)
``raw``             path of the readings file, relative to the folder
``x_cm``, ``y_cm``  the waypoint (cm, map frame)
``n_bins``          readings per sweep
``step_deg``        angle between consecutive readings (degrees, > 0)
``direction``       ``cw`` or ``ccw``: the way the turret turned
``start_deg``       turret angle of the first reading relative to the robot heading (degrees)
``heading_deg``     optional: a heading aligned with the map (not a measurement; empty when unknown)
``invalid_values``  optional: readings that mean "no reading", separated by ``;`` or spaces (default 255;
                    a negative one such as -1 is allowed)
``held_runs``       optional: what a long run of one reading that the map does not explain is, for this
                    source's sensor (`HELD_RUNS`): ``stuck`` (the default, also when empty) or ``no-echo``
==================  =========================================================================================

Reading ``k`` was taken at ``start_deg + s * k * step_deg`` relative to the heading (``s`` = +1 for
``ccw``, -1 for ``cw``). A 255 is the sensor's no-echo reading and stays in the scan as an invalid
reading with range 255 (evidence: nothing echoed); any other invalid value (0 where a source marks bins
it never visited) is no reading at all and is left out of the scan.

Runs of equal readings. Some sensors (or the code that read them) give no echo as the last echo again:
after its first echo such a sensor never reads 255, and where nothing echoes it repeats one value over
a long arc. `localisation.stuck.judge_runs` finds those runs: equal echo readings over at least
`localisation.stuck.STUCK_ARC_DEG` (45) degrees of turret that the map's walls do not explain at the
sweep's waypoint. The ``held_runs`` column says what such a run is for the source's sensor:

* ``stuck`` (the default): a sensor that stopped refreshing. The sweep is read as it is; the localisers
  and the sonar fit drop the run's readings, with a warning (`localisation.scan.drop_stuck`).
* ``no-echo``: the sensor repeats its last echo while no new one arrives. The run's first reading (a
  measured echo) is kept and its repeats are read as no echo (invalid, 255) when the set is loaded
  (`Sweep.held`), so every use of the sweep (import, replay, bench, sonar fit) reads them so.

Either way a run the map explains is an echo and is kept, and the raw file is never changed.

What a set may hold that is not right. A sweep whose readings file cannot be used (missing, not text, a
line that is not a number, more or fewer readings than ``n_bins``) is left out with a warning naming the
file and the problem (`SweepSet.left_out`); a set with no usable sweep is refused. A sweep whose echoes
lie more than `MISFIT_CM` (median) from the map's at its waypoint and ``heading_deg`` is named in a
warning and kept: its waypoint is likely not where it was taken (`misfit_cm`). A set without headings
can have them found as the column's were (`aligned_heading_deg`).
"""

from __future__ import annotations

import csv
import logging
import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BeforeValidator, ConfigDict, Field, ValidationError, ValidationInfo, model_validator

from ..world import NO_ECHO, ConfigError, Map, NxtnavError, Scan, load_map
from ..world.typed import Typed, one_line, worded

__all__ = ["HELD_RUNS", "REQUIRED_COLUMNS", "Sweep", "SweepRow", "SweepSet", "SweepSetError", "UnusableSweep",
           "aligned_heading_deg", "heading_lattice_deg", "load_sweep_set", "misfit_cm", "sweep_angles",
           "thin_ray_misfits", "warn_once"]

REQUIRED_COLUMNS = ("repo", "file", "raw", "x_cm", "y_cm", "n_bins", "step_deg", "direction", "start_deg")
DEFAULT_MAP = "arena.yaml"
log = logging.getLogger(__name__)
HELD_RUNS = ("stuck", "no-echo")
"""Values of the ``held_runs`` column, the default first (module docstring)."""


class SweepSetError(NxtnavError, ValueError):
    """A sweep set that cannot be read: the message names the file, the line or field and the problem."""


class UnusableSweep(SweepSetError):
    """One sweep's readings file cannot be used (missing, not text, not numbers, not ``n_bins`` of them):
    the set is read without that sweep (`load_sweep_set`)."""


def sweep_angles(n: int, step_deg: float, direction: str = "ccw", start_deg: float = 0.0) -> NDArray[np.float64]:
    """Sensor angles (rad, relative to the heading) of `n` readings taken `step_deg` apart from `start_deg`,
    turning ``ccw`` (angles grow) or ``cw`` (angles shrink)."""
    if direction not in ("cw", "ccw"):
        raise ConfigError(f"direction must be 'cw' or 'ccw', got {direction!r}")
    s = 1.0 if direction == "ccw" else -1.0
    return np.radians(start_deg + s * np.arange(n) * step_deg)


@dataclass(frozen=True, eq=False)
class Sweep:
    """One real sweep at a known waypoint.

    Attributes
    ----------
    repo, file : str
        Where it comes from (labels).
    x_cm, y_cm : float
        The waypoint (cm).
    angles : (n,) ndarray
        Sensor angle of each reading relative to the robot heading (rad).
    readings : (n,) ndarray
        The raw readings (cm), invalid values included.
    invalid_values : tuple of float
        Readings that mean "no reading"; 255 among them is the no-echo reading.
    heading_deg : float
        A heading aligned with the map, or nan (unknown: the real heading was not measured).
    held_runs : str
        What the source's long runs of one reading that the map does not explain are (`HELD_RUNS`).
    held : (n,) bool ndarray or None
        Readings read as no echo: the repeats of such runs when `held_runs` is ``no-echo``; None: none.
    """

    repo: str
    file: str
    x_cm: float
    y_cm: float
    angles: NDArray[np.float64]
    readings: NDArray[np.float64]
    invalid_values: tuple[float, ...] = (NO_ECHO,)
    heading_deg: float = math.nan
    step_deg: float = 1.0
    direction: str = "ccw"
    raw: str = ""
    extra: dict[str, str] = field(default_factory=dict)
    held_runs: str = HELD_RUNS[0]
    held: NDArray[np.bool_] | None = None

    @property
    def label(self) -> str:
        """``repo/file``."""
        return f"{self.repo}/{self.file}"

    @property
    def missing(self) -> NDArray[np.bool_]:
        """Readings that are no reading at all (invalid values other than the no-echo 255)."""
        others = [v for v in self.invalid_values if v != NO_ECHO]
        return np.isin(self.readings, others) if others else np.zeros(self.readings.size, dtype=bool)

    def scan(self, turret_offset_deg: float = 0.0) -> Scan:
        """The sweep as a `Scan`: no-echo readings kept (invalid, 255), the `held` ones among them, missing
        ones left out; each angle turned by `turret_offset_deg` (the recording robot's turret zero,
        `toolkit.world.NxtSonar.turret_offset_deg`) into the robot's frame."""
        keep = ~self.missing
        r = self.readings[keep]
        valid = ~np.isin(r, self.invalid_values) & (r >= 0)
        if self.held is not None:
            valid &= ~self.held[keep]
        return Scan(self.angles[keep] + math.radians(turret_offset_deg), np.where(valid, r, NO_ECHO), valid)

    @property
    def held_count(self) -> int:
        """How many readings are read as no echo because the source's sensor held its last echo."""
        return 0 if self.held is None else int(self.held.sum())

    @property
    def no_echo_share(self) -> float:
        """Share of the readings (missing ones left out) that are no-echo."""
        s = self.scan()
        return float(np.mean(~s.valid)) if len(s) else math.nan

    def to_dict(self) -> dict[str, Any]:
        return {"repo": self.repo, "file": self.file, "x_cm": self.x_cm, "y_cm": self.y_cm,
                "n_bins": int(self.readings.size), "step_deg": self.step_deg, "direction": self.direction,
                "heading_deg": None if math.isnan(self.heading_deg) else self.heading_deg,
                "held_runs": self.held_runs, "held_as_no_echo": self.held_count}


@dataclass(frozen=True, eq=False)
class SweepSet:
    """The sweeps of a folder and the map they were taken in."""

    folder: Path
    map: Map
    sweeps: tuple[Sweep, ...]
    left_out: tuple[str, ...] = ()
    """The sweeps whose readings could not be used, each as its file and problem (`load_sweep_set`)."""

    def __iter__(self) -> Iterator[Sweep]:
        return iter(self.sweeps)

    def __len__(self) -> int:
        return len(self.sweeps)

    @property
    def repos(self) -> list[str]:
        """The sources, in order of first appearance."""
        return list(dict.fromkeys(s.repo for s in self.sweeps))

    def waypoints(self, repo: str | None = None) -> list[tuple[float, float]]:
        """The waypoints (cm) with sweeps of `repo` (None: of any source), in order of first appearance."""
        return list(dict.fromkeys((s.x_cm, s.y_cm) for s in self.sweeps if repo is None or s.repo == repo))

    def at(self, x_cm: float, y_cm: float, repo: str | None = None, radius_cm: float = 0.0) -> tuple[Sweep, ...]:
        """The sweeps of `repo` (None: of any source) whose waypoint lies within `radius_cm` (cm) of
        (`x_cm`, `y_cm`), in the set's order."""
        return tuple(s for s in self.sweeps if (repo is None or s.repo == repo)
                     and math.hypot(s.x_cm - x_cm, s.y_cm - y_cm) <= radius_cm)


def _number_text(value: Any, name: str, *, positive: bool = False, whole: bool = False) -> float:
    """A column's text as a finite number (> 0 when `positive`, an integer when `whole`)."""
    text = str(value if value is not None else "").strip()
    try:
        v = float(text)
    except ValueError:
        raise worded(f"field {name!r} is not a number: {text!r}") from None
    if not math.isfinite(v) or (positive and v <= 0):
        raise worded(f"field {name!r} must be a {'positive' if positive else 'finite'} number, got {text!r}")
    if whole and v != int(v):
        raise worded(f"field {name!r} must be a whole number, got {value!r}")
    return v


def _finite(value: Any, info: ValidationInfo) -> float:
    return _number_text(value, str(info.field_name))


def _positive(value: Any, info: ValidationInfo) -> float:
    return _number_text(value, str(info.field_name), positive=True)


def _whole(value: Any, info: ValidationInfo) -> int:
    return int(_number_text(value, str(info.field_name), positive=True, whole=True))


def _filled(value: Any, info: ValidationInfo) -> str:
    text = str(value if value is not None else "").strip()
    if not text:
        raise worded(f"field {info.field_name!r} is empty")
    return text


def _heading(value: Any, info: ValidationInfo) -> float | None:
    text = str(value if value is not None else "").strip()
    return _number_text(text, "heading_deg") if text else None


def _invalid_values(value: Any) -> Any:
    if isinstance(value, list | tuple):
        return value
    text = str(value if value is not None else "").replace(";", " ").replace(",", " ").split()
    if not text:
        return [NO_ECHO]
    try:
        return [float(t) for t in text]
    except ValueError:
        raise worded(f"field 'invalid_values' is not a list of numbers: {value!r}") from None


def _choice(choices: tuple[str, ...], default: str | None = None) -> Any:
    """A check that a column's text (blank: `default`, when given) is one of `choices`, in any case."""
    def check(value: Any, info: ValidationInfo) -> str:
        text = str(value if value is not None else "").strip().lower()
        if not text and default is not None:
            return default
        if text not in choices:
            raise worded(f"field {info.field_name!r} must be {' or '.join(repr(c) for c in choices)}, got {value!r}")
        return text
    return check


class SweepRow(Typed):
    """One row of ``sweeps.csv`` (module docstring): the columns as the file gives them (text), read as
    numbers, choices and names; other columns are kept as they are. Validated with the map as its
    context (``{"map": Map}``), the waypoint must lie in the map's free space."""

    model_config = ConfigDict(extra="allow")

    n_bins: Annotated[int, Field(gt=0, description="readings per sweep"), BeforeValidator(_whole)]
    step_deg: Annotated[float, Field(gt=0, description="angle between consecutive readings (degrees)"),
                        BeforeValidator(_positive)]
    start_deg: Annotated[float, BeforeValidator(_finite),
                         Field(description="turret angle of the first reading relative to the heading (degrees)")]
    direction: Annotated[Literal["cw", "ccw"], BeforeValidator(_choice(("cw", "ccw"))),
                         Field(description="the way the turret turned")]
    x_cm: Annotated[float, BeforeValidator(_finite), Field(description="the waypoint (cm, map frame)")]
    y_cm: Annotated[float, BeforeValidator(_finite), Field(description="the waypoint (cm, map frame)")]
    repo: Annotated[str, BeforeValidator(_filled), Field(min_length=1, description="where the sweep comes from")]
    file: Annotated[str, BeforeValidator(_filled), Field(min_length=1)]
    raw: Annotated[str, BeforeValidator(_filled),
                   Field(min_length=1, description="the readings file, relative to the folder")]
    heading_deg: Annotated[float | None, BeforeValidator(_heading),
                           Field(description="a heading aligned with the map (degrees); empty: unknown")] = None
    invalid_values: Annotated[tuple[float, ...], BeforeValidator(_invalid_values),
                              Field(description="readings that mean no reading (';' or spaces between)")] = (NO_ECHO,)
    held_runs: Annotated[Literal["stuck", "no-echo"], BeforeValidator(_choice(HELD_RUNS, HELD_RUNS[0])),
                         Field(description="what a long run of one reading the map does not explain is")] = "stuck"

    @model_validator(mode="after")
    def _in_free_space(self, info: ValidationInfo) -> SweepRow:
        m = (info.context or {}).get("map")
        if isinstance(m, Map) and not bool(m.contains(np.array([[self.x_cm, self.y_cm]]))[0]):
            raise worded(f"waypoint ({self.x_cm:g}, {self.y_cm:g}) lies outside the free space of map {m.name!r}")
        return self


def _held_repeats(sweep: Sweep, m: Map) -> NDArray[np.bool_]:
    """The readings of `sweep` that repeat a held echo: every reading but the first of each run of equal
    readings the walls of `m` do not explain at the waypoint (`localisation.stuck.judge_runs`)."""
    from localisation.stuck import judge_runs

    scan = sweep.scan()
    unexplained, _ = judge_runs(scan, m, position=(sweep.x_cm, sweep.y_cm))
    at = np.flatnonzero(~sweep.missing)  # scan index -> reading index
    held = np.zeros(sweep.readings.size, dtype=bool)
    for run in unexplained:
        held[at[run.start + 1:run.start + run.length]] = True
    return held


def read_readings(path: Path, n_bins: int, invalid_values: tuple[float, ...] = ()) -> NDArray[np.float64]:
    """The readings of one raw sweep file (one number a line; blank lines ignored), checked against `n_bins`:
    each a non-negative number, or one of `invalid_values` (a source may mark no reading with -1)."""
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except OSError as e:
        raise UnusableSweep(f"{path}: cannot read the sweep file ({e.strerror or e})") from None
    except UnicodeDecodeError:
        raise UnusableSweep(f"{path}: not a text file of readings (not UTF-8)") from None
    values: list[float] = []
    for i, line in enumerate(lines, 1):
        t = line.strip()
        if not t:
            continue
        try:
            v = float(t)
        except ValueError:
            raise UnusableSweep(f"{path}:{i}: not a number: {t!r}") from None
        if not math.isfinite(v) or (v < 0 and v not in invalid_values):
            raise UnusableSweep(f"{path}:{i}: a reading must be a non-negative number, got {t!r}")
        values.append(v)
    if len(values) != n_bins:
        raise UnusableSweep(f"{path}: {len(values)} readings, but sweeps.csv says n_bins = {n_bins}")
    return np.array(values)


def _sweep(folder: Path, row: dict[str, str | None], where: str, m: Map) -> Sweep:
    try:
        r = SweepRow.model_validate(row, context={"map": m})
    except ValidationError as exc:
        raise SweepSetError(one_line(exc, where)) from None
    # the count is checked before any n-sized array
    readings = read_readings((folder / r.raw).resolve(), r.n_bins, r.invalid_values)
    known = set(SweepRow.model_fields)
    sweep = Sweep(repo=r.repo, file=r.file, x_cm=r.x_cm, y_cm=r.y_cm,
                  angles=sweep_angles(r.n_bins, r.step_deg, r.direction, r.start_deg), readings=readings,
                  invalid_values=r.invalid_values,
                  heading_deg=math.nan if r.heading_deg is None else r.heading_deg,
                  step_deg=r.step_deg, direction=r.direction, raw=r.raw, held_runs=r.held_runs,
                  extra={k: v for k, v in row.items() if k not in known and v is not None})
    if r.held_runs != "no-echo":
        return sweep
    return replace(sweep, held=_held_repeats(sweep, m))


def load_sweep_set(folder: str | Path, map: str | Path | Map | None = None) -> SweepSet:
    """Read and check a sweep set (module docstring). Raises `SweepSetError` naming file, line and field.

    A sweep whose readings file cannot be used (missing, not text, a line that is not a number, more or
    fewer readings than ``n_bins``) is left out with a warning naming the file and the problem, and kept
    in `SweepSet.left_out`; the set is refused only when no sweep is left. A wrong ``sweeps.csv`` (a
    missing column, a row of the wrong length, a field that is not what its column holds) is refused."""
    root = Path(folder)
    table = root / "sweeps.csv"
    if not table.is_file():
        why = "is a folder" if table.is_dir() else "does not exist"
        raise SweepSetError(f"{table}: {why}; a sweep set is a folder with a sweeps.csv")
    if map is None:
        map_path = root / DEFAULT_MAP
        if not map_path.is_file():
            raise SweepSetError(f"{root}: no {DEFAULT_MAP}; name the map with --map")
        m = load_map(map_path)
    else:
        m = load_map(map)
    rows: list[tuple[int, dict[str, str | None]]] = []
    try:
        with table.open(newline="", encoding="utf-8-sig") as fh:  # -sig: a spreadsheet's byte-order mark
            reader = csv.reader(fh)
            header = next(reader, None)
            if header is None:
                raise SweepSetError(f"{table}: empty file, expected a header line with the columns "
                                    f"{', '.join(REQUIRED_COLUMNS)}")
            columns = [c.strip() for c in header]
            missing = [c for c in REQUIRED_COLUMNS if c not in columns]
            if missing:
                raise SweepSetError(f"{table}:1: missing column{'s' if len(missing) > 1 else ''} "
                                    f"{', '.join(missing)}")
            twice = sorted({c for c in columns if columns.count(c) > 1 and c})
            if twice:
                raise SweepSetError(f"{table}:1: column{'s' if len(twice) > 1 else ''} {', '.join(twice)} "
                                    "named more than once")
            for values in reader:
                line = reader.line_num
                if not any(v.strip() for v in values):
                    continue  # a blank line
                if len(values) != len(columns):
                    raise SweepSetError(f"{table}:{line}: {len(values)} fields, but the header has "
                                        f"{len(columns)} columns")
                rows.append((line, dict(zip(columns, values, strict=True))))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise SweepSetError(f"{table}: cannot read ({' '.join(str(e).split())})") from None
    if not rows:
        raise SweepSetError(f"{table}: no sweeps (a header and no rows)")
    return _usable(root, table, m, rows)


_WARNED: set[str] = set()
"""Warnings already given in this process (`warn_once`)."""


def _usable(root: Path, table: Path, m: Map, rows: list[tuple[int, dict[str, str | None]]]) -> SweepSet:
    """The set of the rows whose readings can be used; every other is left out with a warning naming its
    file and problem, and a set with none is a `SweepSetError` naming the first."""
    sweeps: list[Sweep] = []
    left_out: list[str] = []
    for line, row in rows:
        try:
            sweeps.append(_sweep(root, row, f"{table}:{line}", m))
        except UnusableSweep as e:
            left_out.append(f"{e} ({table.name} line {line})")
    if not sweeps:
        raise SweepSetError(f"{table}: no usable sweep: {left_out[0]}"
                            + (f", and {len(left_out) - 1} more" if len(left_out) > 1 else ""))
    for why in left_out:
        warn_once(f"{why}; that sweep is left out, the set's other {len(sweeps)} are used")
    for sw in sweeps:
        off = misfit_cm(sw, m)
        if off > MISFIT_CM:
            warn_once(f"{table}: sweep {sw.label} does not fit its waypoint ({sw.x_cm:g}, {sw.y_cm:g}) at its "
                       f"heading_deg {sw.heading_deg:g}: its echoes are {off:.0f} cm from the map's (median; a "
                       f"sweep taken there: under 10 cm); is its waypoint right?")
    return SweepSet(root, m, tuple(sweeps), tuple(left_out))


def warn_once(message: str) -> None:
    """Log `message` as a warning, once a process (a set is read again by each bench task's cache)."""
    if message not in _WARNED:
        _WARNED.add(message)
        log.warning("%s", message)


MISFIT_CM = 20.0
"""A sweep whose echoes lie farther than this (cm, median) from the map's walls at its waypoint and
``heading_deg`` was not taken there (the well-placed sweeps of the course: at most 9 cm): a warning."""


def thin_ray_misfits(m: Map, scan: Scan, poses: NDArray[np.float64]) -> NDArray[np.float64]:
    """The median distance (cm) between the echoes of `scan` and exact (thin-ray) ray casting in `m` from each
    of the (n, 3) `poses` (x, y in cm, heading in rad); a ray that meets nothing counts as 1e9 cm. nan for a
    scan without an echo. The robust score a sweep set's ``heading_deg`` is aligned by, and the challenge's
    place and heading fits (`toolkit.mission.sweep_fit.rank_places`)."""
    from localisation.models import exact_ranges

    ok = scan.valid & np.isfinite(scan.ranges)
    if not ok.any():
        return np.full(len(poses), math.nan)
    cast = exact_ranges(m, poses, scan.angles[ok])
    return np.median(np.where(np.isfinite(cast), np.abs(cast - scan.ranges[ok][None, :]), 1e9), axis=1)


def _median_misfits(sweep: Sweep, m: Map, headings_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """`thin_ray_misfits` of `sweep`, as the sensor gave it (held runs too: the fit that aligned the sets'
    ``heading_deg``), at its waypoint and each of `headings_deg`."""
    poses = np.column_stack([np.full(headings_deg.size, sweep.x_cm), np.full(headings_deg.size, sweep.y_cm),
                             np.radians(headings_deg)])
    return thin_ray_misfits(m, replace(sweep, held=None).scan(), poses)


def misfit_cm(sweep: Sweep, m: Map) -> float:
    """The median distance (cm) between the echoes of `sweep` and exact ray casting at its waypoint and
    ``heading_deg`` (the fit that aligned it); nan without a heading or an echo."""
    if math.isnan(sweep.heading_deg):
        return math.nan
    return float(_median_misfits(sweep, m, np.array([sweep.heading_deg]))[0])


ALIGN_STEP_DEG = 0.5
"""The headings `aligned_heading_deg` tries are this far apart (degrees)."""


def heading_lattice_deg(around_deg: float | None = None, span_deg: float = 180.0,
                        step_deg: float = ALIGN_STEP_DEG) -> NDArray[np.float64]:
    """The multiples of `step_deg` (degrees) within `span_deg` of `around_deg` (rounded to the lattice; None:
    every heading, -180 up to 180): the headings a sweep's alignment (`aligned_heading_deg`) and the
    challenge's fits (`toolkit.mission.sweep_fit.rank_places`) try, one lattice for both.

    >>> heading_lattice_deg(10.2, span_deg=1.0).tolist()
    [9.0, 9.5, 10.0, 10.5]
    """
    centre = 0 if around_deg is None else round(around_deg / step_deg)
    k = round((180.0 if around_deg is None else span_deg) / step_deg)
    return step_deg * np.arange(centre - k, centre + k, dtype=float)


def aligned_heading_deg(sweep: Sweep, m: Map) -> float:
    """The heading (degrees, in [-180, 180)) at which `sweep`'s echoes lie closest to the map's walls at its
    waypoint (median distance to exact thin-ray casting; `heading_lattice_deg`): how a sweep set's
    ``heading_deg`` is found (the waypoint fixed, the heading brute-forced); nan without an echo."""
    headings = heading_lattice_deg()
    misfits = _median_misfits(sweep, m, headings)
    return math.nan if np.isnan(misfits).all() else float(headings[int(np.nanargmin(misfits))])

