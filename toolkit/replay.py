"""Compare localisers offline on a recording: read it (`read_recording`), replay it (`replay`).

`read_recording` checks every line against the format of ``docs/recording.md`` and raises
`RecordingError` naming the file, the line and the field at fault. A recording cut short (the last
line incomplete, or no ``end`` line) is not an error: it is read up to the break and
`Recording.truncated` says where it broke.

`replay` runs each localiser through the recorded localiser calls (``reset``, ``predict``,
``update``) in order, offline, and reports after every call its estimate, its spread and, where the
recording knows the true pose, its error; without a truth, the localisers' agreement (distance to
the first one's estimate). A truth without a heading (a real sweep at a known waypoint, format
version 2) scores the position only: the heading error is NaN (null in JSON), never a number. The
localiser used live is rebuilt with its recorded options and random stream, so its replayed
estimates equal the recorded ones bit for bit (`ReplayReport.reproduced`);
the others get the options `localisation.robot_options.localiser_options` gives them for the recorded
sonar and motion noise, and the replay's seed.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import LOCALISERS, HeadingPrior, Localiser, Motion, PoseEstimate, Prior, make_localiser
from localisation.robot_options import localiser_options

from .recording import (
    FORMAT_NAME,
    FORMAT_VERSION,
    _estimate,
    decode_floats,
    decode_options,
    scan_from_fields,
    sonar_from_dict,
)
from .trajectory_scores import TrajectoryScores, score_trajectory
from .world import (
    LaserScanner,
    Map,
    MapError,
    NxtnavError,
    NxtSonar,
    Pose,
    RobotModel,
    Scan,
    SonarModel,
    angle_diff,
    map_from_dict,
)

__all__ = ["LocaliserSpec", "Recording", "RecordingError", "ReplayReport", "ReplayStep", "read_recording", "replay"]

CALLS = ("reset", "predict", "update")
_ROBOT_EVENTS = ("turn", "move", "turnback", "scan", "recovery")


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


def _truth(e: dict[str, Any]) -> tuple[Pose, bool] | None:
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
    elif kind == "reset":
        prior = _need(e, "prior", dict, where, nullable=True)
        if prior is not None and "heading_deg" in prior:
            _heading_prior(prior, where)
        elif prior is not None:
            if _pose_field(prior, "mean", where) is None:
                raise RecordingError(f"{where}: field 'prior' needs a 'mean'")
            _cov(prior, "cov", where)
    elif kind == "predict":
        _need(e, "turn_rad", _NUM, where)
        _need(e, "distance_cm", _NUM, where)
    elif kind == "update":
        if "scan" in e:
            sid = _need(e, "scan", int, where)
            if sid not in scans:
                raise RecordingError(f"{where}: update refers to scan {sid}, which no earlier line holds")
            idx = _need(e, "index", list, where)
            if not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < scans[sid] for i in idx):
                raise RecordingError(f"{where}: field 'index' must hold indices of scan {sid} (0..{scans[sid] - 1})")
        else:
            _scan(e, where)
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


def _heading_prior(prior: dict[str, Any], where: str) -> HeadingPrior:
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
    """A localiser event's options with its sonar model rebuilt (`toolkit.recording.decode_options`)."""
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


# -- replaying ----------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ReplayStep:
    """One localiser call of the recording and every localiser's estimate after it.

    Attributes
    ----------
    index : int
        0-based call index.
    line : int
        Line of the call in the recording.
    call : {"reset", "predict", "update"}
    truth : Pose or None
        The true pose at the call (the last robot event's), when recorded.
    estimates : dict
        Per localiser, its `PoseEstimate` (None once it has failed).
    live : PoseEstimate or None
        The estimate recorded live after this call.
    truth_heading : bool
        Whether the truth's heading is known; when not, ``truth.theta`` means nothing and only the
        position is scored.
    label : str or None
        Where the last scan came from, when the recording says (an imported sweep's ``repo/file``).
    """

    index: int
    line: int
    call: str
    truth: Pose | None
    estimates: dict[str, PoseEstimate | None]
    live: PoseEstimate | None
    truth_heading: bool = True
    label: str | None = None

    def error_cm(self, name: str) -> float:
        """Distance (cm) from the estimate of `name` to the true position (NaN without either)."""
        e = self.estimates.get(name)
        return math.nan if e is None or self.truth is None else e.pose.distance_to(self.truth)

    def heading_error_deg(self, name: str) -> float:
        """Absolute heading error (degrees); NaN without an estimate, a truth or the truth's heading."""
        e = self.estimates.get(name)
        if e is None or self.truth is None or not self.truth_heading:
            return math.nan
        return abs(math.degrees(float(angle_diff(e.pose.theta, self.truth.theta))))

    def agreement_cm(self, name: str, reference: str) -> float:
        a, b = self.estimates.get(name), self.estimates.get(reference)
        return math.nan if a is None or b is None else a.pose.distance_to(b.pose)

    def to_dict(self, reference: str) -> dict[str, Any]:
        truth: list[float | None] | None = None
        if self.truth is not None:
            truth = [self.truth.x, self.truth.y, self.truth.heading_deg if self.truth_heading else None]
        out: dict[str, Any] = {"index": self.index, "line": self.line, "call": self.call, "truth": truth,
                               "label": self.label, "estimates": {}}
        for name, e in self.estimates.items():
            out["estimates"][name] = None if e is None else {
                "pose": e.pose.to_list_deg(), "spread_cm": e.std_xy_cm,
                "spread_deg": math.degrees(e.std_heading_rad), "converged": e.converged,
                "error_cm": _nan_none(self.error_cm(name)),
                "heading_error_deg": _nan_none(self.heading_error_deg(name)),
                "agreement_cm": _nan_none(self.agreement_cm(name, reference))}
        return out


def _nan_none(v: float) -> float | None:
    return v if math.isfinite(v) else None


@dataclass(frozen=True, eq=False)
class ReplayReport:
    """What `replay` found.

    Attributes
    ----------
    recording : Recording
    localisers : list of str
        In the order asked (the first is the reference for agreement).
    steps : list of ReplayStep
    reproduced : dict
        For the localiser used live: whether every replayed estimate equals the recorded one exactly
        (None when the recording lacks its random stream or holds no live estimate); the first
        differing line is in `diverged`.
    failures : dict
        Per localiser that raised: the line and the message.
    compared : int
        Live estimates the recording holds (each compared with the replay of the live localiser).
    cpu_s : dict
        Per localiser, the process time (s) of its construction and of all its calls.
    """

    recording: Recording
    localisers: list[str]
    steps: list[ReplayStep]
    reproduced: dict[str, bool | None] = field(default_factory=dict)
    diverged: dict[str, int] = field(default_factory=dict)
    failures: dict[str, str] = field(default_factory=dict)
    compared: int = 0
    cpu_s: dict[str, float] = field(default_factory=dict)

    @property
    def has_truth(self) -> bool:
        return any(s.truth is not None for s in self.steps)

    @property
    def truth_heading(self) -> bool:
        """Whether every true pose of the replay has a heading (False: some errors are of position only)."""
        return all(s.truth_heading for s in self.steps if s.truth is not None)

    def summary(self) -> dict[str, dict[str, float]]:
        """Per localiser: over the updates, RMSE / median / final error against the truth, or the
        median and largest distance to the reference localiser; the median spread; the final spread."""
        ups = [s for s in self.steps if s.call == "update"]
        out: dict[str, dict[str, float]] = {}
        ref = self.localisers[0]
        for name in self.localisers:
            spread = np.array([_spread(s.estimates.get(name)) for s in ups])
            row: dict[str, float] = {"updates": float(len(ups)), "median_spread_cm": _fin_median(spread),
                                     "final_spread_cm": float(spread[-1]) if spread.size else math.nan}
            if self.has_truth:
                err = np.array([s.error_cm(name) for s in ups])
                fin = err[np.isfinite(err)]
                row.update({"rmse_cm": float(np.sqrt(np.mean(fin**2))) if fin.size else math.nan,
                            "median_error_cm": _fin_median(err),
                            "final_error_cm": float(err[-1]) if err.size else math.nan,
                            "final_heading_error_deg": ups[-1].heading_error_deg(name) if ups else math.nan})
                scores = self.trajectory_scores(name)
                row.update({"ape_rmse_cm": scores.ape_rmse_cm, "ape_heading_rmse_deg": scores.ape_heading_rmse_deg,
                            "rpe_per_m_cm": scores.rpe_per_m_cm, "scored_updates": float(scores.poses)})
            else:
                agr = np.array([s.agreement_cm(name, ref) for s in ups])
                row.update({"median_agreement_cm": _fin_median(agr),
                            "max_agreement_cm": float(np.nanmax(agr)) if np.isfinite(agr).any() else math.nan})
            row["cpu_s"] = self.cpu_s.get(name, math.nan)
            out[name] = row
        return out

    def trajectory_scores(self, name: str) -> TrajectoryScores:
        """evo's APE (after rigid alignment) and RPE per metre of `name`'s estimates after the updates,
        against the true poses (`toolkit.trajectory_scores`); NaN without true headings."""
        cache: dict[str, TrajectoryScores] = self.__dict__.setdefault("_scores", {})
        if name not in cache:
            pairs = [(s.truth.as_array(), s.estimates[name].pose.as_array())  # type: ignore[union-attr]
                     for s in self.steps if s.call == "update" and s.truth is not None and s.truth_heading
                     and s.estimates.get(name) is not None]
            if not pairs:
                cache[name] = TrajectoryScores.unscored(0, "no estimate after an update has a true pose with a heading")
            else:
                truth, est = (np.array(x) for x in zip(*pairs, strict=True))
                cache[name] = score_trajectory(truth, est)
        return cache[name]

    def score_notes(self, name: str) -> dict[str, str | None]:
        """Why `name`'s APE (``ape_note``) or RPE (``rpe_note``) is missing (None where it is there); empty
        without true poses."""
        if not self.has_truth:
            return {}
        scores = self.trajectory_scores(name)
        return {"ape_note": scores.ape_note, "rpe_note": scores.rpe_note}

    def to_dict(self) -> dict[str, Any]:
        ref = self.localisers[0]
        return {"recording": str(self.recording.path), "truncated": self.recording.truncated,
                "localisers": self.localisers, "reference": ref, "truth": self.has_truth,
                "truth_heading": self.has_truth and self.truth_heading,
                "live_localiser": None if self.recording.localiser is None else self.recording.localiser.name,
                "reproduced": self.reproduced, "live_estimates_compared": self.compared,
                "diverged_at_line": self.diverged, "failures": self.failures,
                "summary": {k: {**{kk: _nan_none(vv) for kk, vv in v.items()}, **self.score_notes(k)}
                            for k, v in self.summary().items()},
                "steps": [s.to_dict(ref) for s in self.steps]}


def _spread(e: PoseEstimate | None) -> float:
    return math.nan if e is None else e.std_xy_cm


def _fin_median(a: np.ndarray) -> float:
    f = a[np.isfinite(a)]
    return float(np.median(f)) if f.size else math.nan


def robot_model_of(rec: Recording) -> RobotModel:
    """The robot model a recording describes: its sonar (the recorded model, a profile's say), motion
    noise and radius; readings are real for a real NXT or imported real sweeps, else simulated."""
    sonar = str(rec.header["sonar"].get("model", "ideal"))
    noise = rec.header.get("noise") or {}
    robot = rec.header.get("robot") or {}
    kw: dict[str, Any] = {}
    for key, src in (("noise_model", "model"), ("motion_noise", "motion"), ("turn_noise", "turn")):
        if src in noise:
            kw[key] = noise[src]
    if isinstance(rec.header["sonar"].get("sensor_noise"), int | float):
        kw["sensor_noise"] = float(rec.header["sonar"]["sensor_noise"])
    radius = (robot.get("geometry") or {}).get("radius_cm")
    if isinstance(radius, int | float) and not isinstance(radius, bool):
        kw["radius_cm"] = float(radius)
    named: str | SonarModel = "nxt" if sonar in ("nxt", "real") else "ideal"
    if sonar == "laser":  # a bag's laser: its recorded model, real readings
        model = sonar_from_dict(rec.header["sonar"].get("params", {"name": "laser"}))
        named = model if isinstance(model, LaserScanner) else LaserScanner()
    elif named == "nxt" and "params" in rec.header["sonar"]:
        model = sonar_from_dict(rec.header["sonar"]["params"])
        if isinstance(model, NxtSonar):
            named = model
    real = sonar in ("real", "laser") or (robot.get("kind") == "nxt" and not robot.get("virtual"))
    return RobotModel.build(named, readings="real" if real else "simulated", **kw)


def _options_for(rec: Recording, name: str) -> dict[str, Any]:
    """The recording's robot model as options of localiser `name`; for a laser, with the localiser fitted
    to a laser on top (`localisation.laser_options`)."""
    from localisation.laser_options import laser_localiser_options

    robot = robot_model_of(rec)
    opts = localiser_options(name, robot)
    if isinstance(robot.sonar, LaserScanner):
        opts.update(laser_localiser_options(name, robot.sonar))
    return opts


def _build(rec: Recording, name: str, seed: int, extra: Mapping[str, Any]) -> tuple[Localiser, bool]:
    """The localiser `name` for the recording's map, with the options `extra` on top of those it would
    get; True when it is the live one, as it ran, with its own stream."""
    spec = rec.localiser
    if spec is not None and spec.name == name:
        gen = None if extra else spec.generator()
        return (make_localiser(name, rec.map, rng=gen if gen is not None else seed, **{**spec.options, **extra}),
                gen is not None)
    return make_localiser(name, rec.map, rng=seed, **{**_options_for(rec, name), **extra}), False


def replay(rec: Recording, localisers: list[str], *, seed: int = 0, initial: Prior | None = None,
           heading: HeadingPrior | None = None, options: Mapping[str, Mapping[str, Any]] | None = None,
           on_step: Callable[[], None] | None = None) -> ReplayReport:
    """Run `localisers` (registry names) over the recorded localiser calls; see the module docstring.

    `initial` replaces the prior of the recording's first ``reset`` (a pose to start tracking from, for
    data recorded without one, such as an imported bag). `heading` replaces every global reset's (prior
    null, after `initial`): the heading known roughly, the position not (each sweep of an imported
    sweep set is one). `options` gives, per localiser name, constructor
    options that go on top of the ones it would get (a live localiser given any is a new run, not a
    reproduction; options its constructor refuses raise `NxtnavError`). Each localiser's CPU time
    (process time of its construction and its calls) is in `ReplayReport.cpu_s`. `on_step` is called
    after each of the recording's localiser calls (`Recording.calls` in all), for a progress bar.
    """
    if not localisers:
        raise NxtnavError("replay: no localiser given")
    for name in localisers:
        LOCALISERS.get(name)  # unknown names fail here, listing the known ones
    stray = sorted(set(options or {}) - set(localisers))
    if stray:
        raise NxtnavError(f"replay: options for {', '.join(stray)}, which is not among {', '.join(localisers)}")
    locs: dict[str, Localiser | None] = {}
    exact: dict[str, bool] = {}
    failures: dict[str, str] = {}
    cpu: dict[str, float] = {}
    first_reset = True
    for name in dict.fromkeys(localisers):
        started = time.process_time()
        extra = (options or {}).get(name, {})
        try:
            locs[name], exact[name] = _build(rec, name, seed, extra)
        except (NxtnavError, ValueError, TypeError) as exc:
            if extra:  # the caller's own choice: said at once, not as a failed row
                given = ", ".join(f"{k}={v!r}" for k, v in extra.items())
                raise NxtnavError(f"replay: {name} refuses {given}: {' '.join(str(exc).split())}") from None
            locs[name], exact[name] = None, False
            failures[name] = f"not built: {' '.join(str(exc).split())}"
        cpu[name] = time.process_time() - started
    scans: dict[int, Scan] = {}
    truth: tuple[Pose, bool] | None = None
    label: str | None = None
    steps: list[ReplayStep] = []
    reproduced = {n: True for n, ok in exact.items() if ok}
    diverged: dict[str, int] = {}
    pending: tuple[int, str] | None = None  # (step index, call) waiting for its live estimate
    for line, e in rec.events:
        kind = e["type"]
        if kind in _ROBOT_EVENTS and e.get("true_pose") is not None:
            truth = _truth(e)
        if kind == "scan":
            scans[int(e["id"])] = scan_from_fields(e)
            label = e.get("label")
        elif kind == "estimate" and pending is not None:
            k = pending[0]
            steps[k] = dataclasses.replace(steps[k], live=_live_estimate(e))
            for n in reproduced:
                got = steps[k].estimates.get(n)
                if reproduced[n] and (got is None or _estimate(got) != _strip(e)):
                    reproduced[n] = False
                    diverged[n] = line
            pending = None
        elif kind in CALLS:
            arg: Any
            if kind == "reset":
                pr = e["prior"]
                if pr is None:
                    arg = None
                elif "heading_deg" in pr:
                    arg = _heading_prior(pr, f"{rec.path}:{line}")
                else:
                    arg = Prior(Pose(*[float(v) for v in pr["mean"]]), np.vstack([decode_floats(r) for r in pr["cov"]]))
                if first_reset and initial is not None:
                    arg = initial
                elif arg is None and heading is not None:
                    arg = heading
                first_reset = False
            elif kind == "predict":
                arg = Motion(float(e["turn_rad"]), float(e["distance_cm"]))
            elif "scan" in e:
                raw = scans[int(e["scan"])]
                ix = np.asarray(e["index"], dtype=np.int64)
                arg = Scan(raw.angles[ix], raw.ranges[ix], raw.valid[ix])
            else:
                arg = scan_from_fields(e)
            ests: dict[str, PoseEstimate | None] = {}
            for name, loc in locs.items():
                if loc is None:
                    ests[name] = None
                    continue
                started = time.process_time()
                try:
                    getattr(loc, kind)(arg)
                    ests[name] = loc.estimate()
                except (NxtnavError, ValueError, np.linalg.LinAlgError) as exc:
                    failures[name] = f"line {line}: {' '.join(str(exc).split())}"
                    locs[name] = None
                    ests[name] = None
                cpu[name] += time.process_time() - started
            steps.append(ReplayStep(len(steps), line, kind, None if truth is None else truth[0], ests, None,
                                    truth_heading=truth is None or truth[1], label=label))
            pending = (len(steps) - 1, kind)
            if on_step is not None:
                on_step()
    compared = sum(1 for s in steps if s.live is not None)
    out_reproduced: dict[str, bool | None] = {
        n: reproduced[n] if n in reproduced and compared else None
        for n in locs if rec.localiser is not None and n == rec.localiser.name}
    return ReplayReport(rec, list(dict.fromkeys(localisers)), steps, out_reproduced, diverged, failures, compared,
                        cpu)


def _strip(e: dict[str, Any]) -> dict[str, Any]:
    return {k: e[k] for k in ("pose", "cov", "converged", "iterations")}


def _live_estimate(e: dict[str, Any]) -> PoseEstimate:
    a = e["pose"]
    return PoseEstimate(Pose(float(a[0]), float(a[1]), float(a[2])), np.vstack([decode_floats(r) for r in e["cov"]]),
                        bool(e["converged"]), int(e["iterations"]))
