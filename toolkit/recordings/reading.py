"""Reading a recording for `toolkit.recordings.replay`: `read_recording` parses and checks it.

`read_recording` checks every line against the format of ``docs/recording.md`` and raises
`RecordingError` naming the file, the line and the field at fault. A recording cut short (the last
line incomplete, or no ``end`` line) is not an error: it is read up to the break and
`Recording.truncated` says where it broke.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import LOCALISERS, HeadingPrior

from ..world import (
    Map,
    MapError,
    NxtnavError,
    Pose,
    Scan,
    SonarModel,
    map_from_dict,
)
from .recorder import (
    FORMAT_NAME,
    FORMAT_VERSION,
    decode_floats,
    decode_options,
    scan_from_fields,
    sonar_from_dict,
)

__all__ = ["CALLS", "ROBOT_EVENTS", "LocaliserSpec", "Recording", "RecordingError", "heading_prior_of",
           "read_recording", "truth_of"]

CALLS = ("reset", "predict", "update")
ROBOT_EVENTS = ("turn", "move", "turnback", "scan", "recovery")


class RecordingError(NxtnavError):
    """A recording that does not follow the format (the message names the file and the line)."""


@dataclass(frozen=True)
class LocaliserSpec:
    """The localiser a recording was made with: name, constructor options and its random stream."""

    name: str
    options: dict[str, Any]
    rng: dict[str, Any] | None

    def generator(self) -> np.random.Generator | None:
        """The Generator the live localiser was built with (None when the recording does not say)."""
        if self.rng is None:
            return None
        seq = np.random.SeedSequence(self.rng["entropy"], spawn_key=tuple(self.rng["spawn_key"]))
        return np.random.Generator(np.random.PCG64(seq))


@dataclass(frozen=True, eq=False)
class Recording:
    """A parsed recording.

    Attributes
    ----------
    path : Path
    header : dict
        The header line.
    map : Map
    localiser : LocaliserSpec or None
    events : list of (line number, event dict)
        Every event after the header, in order (1-based line numbers).
    truncated : str or None
        Where and how the recording was cut short, or None for a complete one.
    """

    path: Path
    header: dict[str, Any]
    map: Map
    localiser: LocaliserSpec | None
    events: list[tuple[int, dict[str, Any]]]
    truncated: str | None = None

    @property
    def calls(self) -> int:
        """Localiser calls recorded."""
        return sum(1 for _, e in self.events if e["type"] in CALLS)


# -- reading ------------------------------------------------------------------------------------------

_NUM = (int, float)


def _need(obj: dict[str, Any], key: str, types: Any, where: str, nullable: bool = False) -> Any:
    if key not in obj:
        raise RecordingError(f"{where}: missing field '{key}'")
    v = obj[key]
    if v is None and nullable:
        return v
    if isinstance(v, bool) and bool not in (types if isinstance(types, tuple) else (types,)):
        raise RecordingError(f"{where}: field '{key}' must be {_tname(types)}, got {v!r}")
    if not isinstance(v, types):
        raise RecordingError(f"{where}: field '{key}' must be {_tname(types)}, got {json.dumps(v)[:40]}")
    return v


def _tname(types: Any) -> str:
    names = {int: "a number", float: "a number", str: "a string", list: "a list", dict: "an object", bool: "true/false"}
    ts = types if isinstance(types, tuple) else (types,)
    return " or ".join(dict.fromkeys(names.get(t, t.__name__) for t in ts))


def _floats(obj: dict[str, Any], key: str, where: str, n: int | None = None) -> np.ndarray:
    v = _need(obj, key, list, where)
    try:
        a = decode_floats(v)
    except ValueError as exc:
        raise RecordingError(f"{where}: field '{key}': {exc}") from None
    if n is not None and a.size != n:
        raise RecordingError(f"{where}: field '{key}' must have {n} values, got {a.size}")
    return a


def _pose_field(obj: dict[str, Any], key: str, where: str) -> Pose | None:
    if obj.get(key) is None:
        return None
    a = _floats(obj, key, where, 3)
    return Pose(float(a[0]), float(a[1]), float(a[2]))


def _truth_field(e: dict[str, Any], where: str, version: int) -> None:
    """Check a robot event's ``true_pose``: null, a pose, or (version 2) ``[x, y, null]``."""
    v = e.get("true_pose")
    if isinstance(v, list) and len(v) == 3 and v[2] is None:
        if version < 2:
            raise RecordingError(f"{where}: field 'true_pose' has a null heading, which needs format version 2 "
                                 f"(the header says {version})")
        _floats({"true_pose": v[:2]}, "true_pose", where, 2)
    else:
        _pose_field(e, "true_pose", where)


def truth_of(e: dict[str, Any]) -> tuple[Pose, bool] | None:
    """A checked robot event's true pose and whether its heading is known (a pose of heading 0 when not)."""
    a = e.get("true_pose")
    if a is None:
        return None
    known = a[2] is not None
    return Pose(float(a[0]), float(a[1]), float(a[2]) if known else 0.0), known


def _cov(obj: dict[str, Any], key: str, where: str) -> np.ndarray:
    rows = _need(obj, key, list, where)
    if len(rows) != 3 or not all(isinstance(r, list) for r in rows):
        raise RecordingError(f"{where}: field '{key}' must be a 3x3 matrix")
    return np.vstack([_floats({key: r}, key, where, 3) for r in rows])


def _scan(e: dict[str, Any], where: str) -> Scan:
    for key in ("angles_rad", "ranges_cm", "invalid"):
        _need(e, key, (list, dict) if key == "angles_rad" else list, where)
    try:
        return scan_from_fields(e)
    except (ValueError, KeyError, TypeError) as exc:
        raise RecordingError(f"{where}: bad scan: {' '.join(str(exc).split())}") from None


def _check_event(e: dict[str, Any], where: str, scans: dict[int, int], version: int) -> None:
    """Check one event line `e` of a recording of format `version` (`where` names the file and line);
    `scans` maps the ids of the scans read so far to their number of readings (a scan line adds its own)."""
    kind = e["type"]
    if kind in ("turn", "move", "turnback", "scan"):
        _need(e, "t", _NUM, where, nullable=kind == "scan" and version >= 2)
        _truth_field(e, where, version)
    if kind == "turn":
        _need(e, "angle_rad", _NUM, where)
    elif kind in ("move", "turnback"):
        _need(e, "requested_cm", _NUM, where)
        _need(e, "driven_cm", _NUM, where)
        _need(e, "watchdog", bool, where)
    elif kind == "scan":
        sid = _need(e, "id", int, where)
        _need(e, "t_start", _NUM, where, nullable=version >= 2)
        if "label" in e:
            _need(e, "label", str, where)
        n = len(_scan(e, where))
        if "times_s" in e:
            _floats(e, "times_s", where, n)
        scans[sid] = n
    elif kind == "localiser":
        _localiser_event(e, where)
    elif kind == "reset":
        prior = _need(e, "prior", dict, where, nullable=True)
        if prior is not None and "heading_deg" in prior:
            heading_prior_of(prior, where)
        elif prior is not None:
            if _pose_field(prior, "mean", where) is None:
                raise RecordingError(f"{where}: field 'prior' needs a 'mean'")
            _cov(prior, "cov", where)
    elif kind == "predict":
        _need(e, "turn_rad", _NUM, where)
        _need(e, "distance_cm", _NUM, where)
    elif kind == "update":
        _update_event(e, where, scans)
    elif kind == "estimate":
        if _pose_field(e, "pose", where) is None:
            raise RecordingError(f"{where}: field 'pose' must not be null")
        _cov(e, "cov", where)
        _need(e, "converged", bool, where)
        _need(e, "iterations", int, where)
        if "particles" in e:
            _since(3, "field 'particles'", where, version)
            _particles(_need(e, "particles", dict, where), where)
    elif kind == "plan":
        _since(3, "a 'plan' event", where, version)
        path = _need(e, "path", list, where)
        if len(path) < 2 or not all(isinstance(p, list) for p in path):
            raise RecordingError(f"{where}: field 'path' must list at least two [x, y] points")
        for p in path:
            _floats({"path": p}, "path", where, 2)
    elif kind in ("fault", "recovery"):
        _fault_event(e, where, version)
    elif kind == "end":
        pass
    else:
        raise RecordingError(f"{where}: unknown event type {kind!r}")


def _localiser_event(e: dict[str, Any], where: str) -> None:
    """Check a ``localiser`` line: a known localiser, its options, and its random stream (or null)."""
    name = _need(e, "name", str, where)
    if name not in LOCALISERS:
        raise RecordingError(f"{where}: unknown localiser {name!r}; known: {', '.join(LOCALISERS.names())}")
    _decoded(_need(e, "options", dict, where), where)
    rng = _need(e, "rng", dict, where, nullable=True)
    if rng is not None:
        ent = rng.get("entropy")
        key = rng.get("spawn_key")
        if not (isinstance(ent, int) or (isinstance(ent, list) and all(isinstance(x, int) for x in ent))) \
                or not (isinstance(key, list) and all(isinstance(x, int) and x >= 0 for x in key)):
            raise RecordingError(f"{where}: field 'rng' must hold an integer 'entropy' and a 'spawn_key' list")


def _update_event(e: dict[str, Any], where: str, scans: dict[int, int]) -> None:
    """Check an ``update`` line: readings of its own, or indices into an earlier scan line's."""
    if "scan" in e:
        sid = _need(e, "scan", int, where)
        if sid not in scans:
            raise RecordingError(f"{where}: update refers to scan {sid}, which no earlier line holds")
        idx = _need(e, "index", list, where)
        if not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < scans[sid] for i in idx):
            raise RecordingError(f"{where}: field 'index' must hold indices of scan {sid} (0..{scans[sid] - 1})")
    else:
        _scan(e, where)


def heading_prior_of(prior: dict[str, Any], where: str) -> HeadingPrior:
    """A reset's heading prior (``{"heading_deg", "sd_deg"}``); `RecordingError` naming `where` if it is not one."""
    h, sd = float(_need(prior, "heading_deg", _NUM, where)), float(_need(prior, "sd_deg", _NUM, where))
    if not (math.isfinite(h) and math.isfinite(sd) and sd > 0.0):
        raise RecordingError(f"{where}: field 'prior': a heading prior needs a finite heading_deg and sd_deg > 0, "
                             f"got {h!r} and {sd!r}")
    return HeadingPrior(math.radians(h), math.radians(sd))


def _since(version: int, what: str, where: str, got: int) -> None:
    if got < version:
        raise RecordingError(f"{where}: {what} needs format version {version} (the header says {got})")


def _particles(cloud: dict[str, Any], where: str) -> None:
    """Check an estimate's ``particles``: ``n`` (the whole cloud's size), ``poses`` and ``weights``."""
    n = _need(cloud, "n", int, where + ": particles")
    poses = _need(cloud, "poses", list, where + ": particles")
    if not all(isinstance(p, list) for p in poses):
        raise RecordingError(f"{where}: particles: field 'poses' must list [x, y, theta] triples")
    for p in poses:
        _floats({"poses": p}, "poses", where + ": particles", 3)
    _floats(cloud, "weights", where + ": particles", len(poses))
    if n < len(poses):
        raise RecordingError(f"{where}: particles: field 'n' ({n}) is smaller than the {len(poses)} poses")


def _fault_event(e: dict[str, Any], where: str, version: int) -> None:
    """Check a ``fault`` or ``recovery`` line (format version 3)."""
    if version < 3:
        raise RecordingError(f"{where}: a '{e['type']}' line needs format version 3 (the header says {version})")
    _need(e, "kind", str, where)
    _need(e, "detail", str, where)
    if e["type"] == "fault":
        _need(e, "t", _NUM, where)
        return
    _need(e, "robot_time_s", _NUM, where)
    _need(e, "recovered", bool, where)
    _need(e, "outage_s", _NUM, where)
    _need(e, "recovery_robot_s", _NUM, where)
    back = _need(e, "resumption", dict, where, nullable=True)
    if back is not None:
        _need(back, "action", str, where + ": resumption")
        _need(back, "requested", _NUM, where + ": resumption")
        _need(back, "done", _NUM, where + ": resumption")
    _truth_field(e, where, version)


def read_recording(path: str | Path) -> Recording:
    """Parse and check a recording (see the module docstring); raises `RecordingError` naming the line."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise RecordingError(f"{p}: cannot read the recording ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise RecordingError(f"{p}: not a text file (not UTF-8)") from None
    lines = text.split("\n")
    complete_last = text.endswith("\n")
    if complete_last:
        lines = lines[:-1]
    if not lines or not lines[0].strip():
        raise RecordingError(f"{p}: empty file, expected a {FORMAT_NAME} header on line 1")
    events: list[tuple[int, dict[str, Any]]] = []
    truncated: str | None = None
    header: dict[str, Any] | None = None
    scans: dict[int, int] = {}
    for i, line in enumerate(lines, start=1):
        where = f"{p} line {i}"
        last = i == len(lines)
        try:
            obj = json.loads(line)
        except json.JSONDecodeError as exc:
            if last and not complete_last and i > 1:
                truncated = f"{where}: cut short ({exc.msg} at column {exc.colno}); read up to line {i - 1}"
                break
            raise RecordingError(f"{where}: not valid JSON ({exc.msg} at column {exc.colno})") from None
        if not isinstance(obj, dict) or not isinstance(obj.get("type"), str):
            raise RecordingError(f"{where}: expected a JSON object with a string field 'type'")
        if i == 1:
            header = _check_header(obj, where)
            continue
        if obj["type"] == "header":
            raise RecordingError(f"{where}: a second header")
        assert header is not None
        _check_event(obj, where, scans, header["version"])
        events.append((i, obj))
        if obj["type"] == "end" and not last:
            raise RecordingError(f"{p} line {i + 1}: lines after the 'end' line")
    assert header is not None
    if truncated is None and not (events and events[-1][1]["type"] == "end"):
        truncated = f"{p} line {len(lines)}: the recording stops without an 'end' line (cut short)"
    try:
        m = map_from_dict(header["map"], source=p)
    except MapError as exc:
        raise RecordingError(f"{p} line 1: field 'map': {exc}") from None
    specs = [LocaliserSpec(e["name"], decode_options(e["options"]), e["rng"]) for _, e in events
             if e["type"] == "localiser"]
    return Recording(p, header, m, specs[0] if specs else None, events, truncated)


def _decoded(options: dict[str, Any], where: str) -> dict[str, Any]:
    """A localiser event's options with its sonar model rebuilt (`toolkit.recordings.recorder.decode_options`)."""
    try:
        return decode_options(options)
    except NxtnavError as exc:
        raise RecordingError(f"{where}: options.sonar_model: {exc}") from None


def _sonar_params(sonar: dict[str, Any], where: str) -> SonarModel:
    """The model of the header's ``sonar.params`` (its ``to_dict``)."""
    try:
        return sonar_from_dict(sonar["params"])
    except NxtnavError as exc:
        raise RecordingError(f"{where}: sonar.params: {exc}") from None


def _check_header(obj: dict[str, Any], where: str) -> dict[str, Any]:
    if obj.get("type") != "header" or obj.get("format") != FORMAT_NAME:
        raise RecordingError(f"{where}: expected the header (type 'header', format '{FORMAT_NAME}')")
    version = _need(obj, "version", int, where)
    if version > FORMAT_VERSION or version < 1:
        raise RecordingError(f"{where}: format version {version} is not supported (this nxtnav reads "
                             f"{FORMAT_NAME} versions 1 to {FORMAT_VERSION})")
    _need(obj, "map", dict, where)
    robot = _need(obj, "robot", dict, where)
    _need(robot, "kind", str, where + ": robot")
    sonar = _need(obj, "sonar", dict, where)
    _need(sonar, "model", str, where + ": sonar")
    if "params" in sonar:
        _sonar_params(sonar, where)
    _need(obj, "seed", int, where, nullable=True)
    _need(obj, "versions", dict, where)
    return obj
