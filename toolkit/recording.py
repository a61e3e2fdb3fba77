"""Record a run once: every robot command, sonar scan and localiser call, as a JSON-lines stream.

A `Recorder` writes the stream documented in ``docs/recording.md`` (format ``nxtnav-recording``,
version `FORMAT_VERSION`): a header (map, robot, sonar model, seed, versions), then one line per
event. It is handed to `toolkit.mission.run_mission` (``recorder=``), which wraps its robot with
`Recorder.wrap_robot` and its localiser with `Recorder.wrap_localiser`; the wrappers pass every
call through unchanged and write what went in and what came out:

* robot commands (``turn``, ``move``, ``turnback``) with what odometry measured (the distance the
  robot reported; on an NXT the wheels' and turret's tacho counts before and after) and the robot
  clock;
* scans (``scan``): every reading with its turret angle and its time;
* localiser calls (``localiser``, ``reset``, ``predict``, ``update``) with the exact inputs, each
  followed by the ``estimate`` it produced;
* the true pose after each robot event where one is known (the simulator, or a `truth` callable such
  as the virtual brick's world);
* (version 3) each path the mission plans (``plan``), and with ``particles=N`` a thinned copy of the
  localiser's particle cloud with each estimate (`thin_cloud`).

Every line also goes, as the dict it was written from, to the recorder's `listeners` (a live view of
the run); a recorder made with ``out=None`` writes no file and only feeds them.
* faults and recoveries (``fault``, ``recovery``): a lost link and what the tachometers said of the
  interrupted motion once it was back, a sweep taken again for a stuck or garbage sonar
  (`toolkit.mission.recovery`).

Data taken elsewhere is written with the same `Recorder`: `Recorder.known_scan` writes a scan taken
without a robot clock at a known position, perhaps without a known heading (format version 2), as
`toolkit.imports.import_sweep_set` does for each real sweep of a sweep set.

Floats are written with Python's shortest round-trip representation, so replaying the calls with the
same localiser and seed (`toolkit.replay`) reproduces the live estimates bit for bit.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import math
import platform
from collections.abc import Callable, Sequence
from importlib import metadata
from pathlib import Path
from typing import IO, Any

import numpy as np

from localisation.base import HeadingPrior, Localiser, Mode, Motion, PoseEstimate, Prior, Snapshot

from .world import SONAR_MODELS, ConfigError, LinkLostError, Map, NxtnavError, Pose, Scan, SonarModel

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "Recorder", "decode_floats", "decode_options", "encode_floats",
           "encode_options", "scan_fields", "scan_from_fields", "sonar_from_dict", "thin_cloud", "versions"]

FORMAT_NAME = "nxtnav-recording"
FORMAT_VERSION = 3
"""Version 2 adds to version 1: a ``true_pose`` whose heading is null (the position is known, the
heading is not), scans whose ``t_start`` and ``t`` are null (no robot clock) and a scan's ``label``.
Version 3 adds the ``plan`` event, an estimate's optional ``particles``, the ``fault`` and ``recovery``
events (a lost link, a sonar swept again) and an ``odometry`` whose ``tacho_after`` is null (the link
broke right after the command). Readers read every version up to theirs and refuse later ones by
their version."""


def encode_floats(values: Any) -> list[float | str]:
    """Floats for JSON, exactly: finite values as numbers, non-finite ones as ``"inf"``, ``"-inf"``, ``"nan"``."""
    out: list[float | str] = []
    for v in np.asarray(values, dtype=float).ravel().tolist():
        out.append(v if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")))
    return out


def decode_floats(values: list[Any]) -> np.ndarray:
    """The inverse of `encode_floats` (raises ValueError on anything else)."""
    out = np.empty(len(values))
    for i, v in enumerate(values):
        if isinstance(v, bool) or not isinstance(v, int | float | str):
            raise ConfigError(f"item {i}: expected a number, got {v!r}")
        out[i] = float(v)
    return out


def encode_options(options: dict[str, Any]) -> dict[str, Any]:
    """A localiser's constructor options for JSON: a sonar model (the ``sonar_model`` option) as its
    ``to_dict`` (name and parameters); everything else as it is."""
    return {k: (v.to_dict() if isinstance(v, SonarModel) else v) for k, v in options.items()}


def sonar_from_dict(d: Any) -> SonarModel:
    """The sonar model a ``to_dict`` describes (``{"name": "nxt", "noise_sd": 1.0, ...}``); `ConfigError`
    says what is wrong with it."""
    if not isinstance(d, dict) or not isinstance(d.get("name"), str):
        raise ConfigError(f"a sonar model is a mapping with a 'name' and its parameters, got {d!r}")
    params = {k: v for k, v in d.items() if k != "name"}
    try:
        cls = SONAR_MODELS.get(d["name"])
    except NxtnavError as exc:  # an unknown name: the message lists the known ones
        raise ConfigError(str(exc)) from None
    known: set[str] = {f.name for f in dataclasses.fields(cls)} if dataclasses.is_dataclass(cls) else set()
    unknown = sorted(set(params) - known)
    if unknown:
        raise ConfigError(f"sonar model {d['name']!r} has no parameter {', '.join(unknown)}")
    try:
        return cls(**params)
    except NxtnavError as exc:
        raise ConfigError(f"sonar model {d['name']!r}: {exc}") from None


def decode_options(options: dict[str, Any]) -> dict[str, Any]:
    """The inverse of `encode_options`: a ``sonar_model`` option (at any depth of the options' groups,
    ``sensor.sonar_model``) rebuilt as its model."""
    return {k: sonar_from_dict(v) if k.rpartition(".")[2] == "sonar_model" and isinstance(v, dict) else v
            for k, v in options.items()}


def scan_fields(scan: Scan) -> dict[str, Any]:
    """A scan's JSON fields: ``angles_rad`` (a list, or ``{"n": n, "step": s}`` when the angles are exactly
    ``i * s`` for i = 0..n-1 in float64), ``ranges_cm`` and ``invalid`` (indices of the invalid readings)."""
    a = np.asarray(scan.angles, dtype=float)
    n = a.size
    step = float(a[1]) if n > 1 else 0.0
    regular = n > 1 and np.array_equal(np.arange(n, dtype=np.float64) * step, a)
    return {"angles_rad": {"n": n, "step": step} if regular else encode_floats(a),
            "ranges_cm": encode_floats(scan.ranges), "invalid": np.flatnonzero(~np.asarray(scan.valid)).tolist()}


def scan_from_fields(e: dict[str, Any]) -> Scan:
    """The inverse of `scan_fields` (raises ValueError, KeyError or TypeError on malformed fields)."""
    spec = e["angles_rad"]
    if isinstance(spec, dict):
        n, step = spec["n"], spec["step"]
        if not (isinstance(n, int) and n >= 2 and isinstance(step, int | float) and not isinstance(step, bool)):
            raise ConfigError("'angles_rad' must be a list or {\"n\": integer >= 2, \"step\": number}")
        angles = np.arange(n, dtype=np.float64) * float(step)
    else:
        angles = decode_floats(spec)
    ranges = decode_floats(e["ranges_cm"])
    if ranges.size != angles.size:
        raise ConfigError(f"'ranges_cm' has {ranges.size} values for {angles.size} angles")
    valid = np.ones(angles.size, dtype=bool)
    bad = e["invalid"]
    if not (isinstance(bad, list) and all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < angles.size
                                         for i in bad)):
        raise ConfigError(f"'invalid' must list indices 0..{angles.size - 1}")
    valid[bad] = False
    return Scan(angles, ranges, valid)


def thin_cloud(poses: Any, weights: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """At most `n` particles of a cloud, chosen without drawing a random number: evenly spaced
    indices (a cloud's order carries no meaning), with their weights renormalised to sum to 1.

    >>> p, w = thin_cloud(np.zeros((10, 3)), np.full(10, 0.1), 4)
    >>> p.shape, w.round(3).tolist()
    ((4, 3), [0.25, 0.25, 0.25, 0.25])
    """
    p = np.asarray(poses, dtype=float).reshape(-1, 3)
    w = np.asarray(weights, dtype=float).ravel()
    if n < p.shape[0]:
        keep = np.unique(np.linspace(0, p.shape[0] - 1, max(int(n), 1)).round().astype(np.int64))
        p, w = p[keep], w[keep]
    total = float(w.sum())
    return p, (w / total if total > 0 and np.isfinite(total) else np.full(w.size, 1.0 / max(w.size, 1)))


def versions() -> dict[str, str]:
    """Versions of nxtnav, numpy and Python (the header's ``versions``)."""
    try:
        own = metadata.version("nxtnav")
    except metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
        own = "unknown"
    return {"nxtnav": own, "numpy": np.__version__, "python": platform.python_version()}


def _pose(p: Pose | None) -> list[float] | None:
    return None if p is None else [float(p.x), float(p.y), float(p.theta)]


def _estimate(e: PoseEstimate) -> dict[str, Any]:
    return {"pose": _pose(e.pose), "cov": [encode_floats(row) for row in np.asarray(e.cov, dtype=float)],
            "converged": bool(e.converged), "iterations": int(e.iterations)}


def _rng_state(rng: Any) -> dict[str, Any] | None:
    """The seed sequence of a numpy Generator (entropy and spawn key), enough to rebuild it."""
    seq = getattr(getattr(rng, "bit_generator", None), "seed_seq", None)
    if not isinstance(seq, np.random.SeedSequence) or type(rng.bit_generator) is not np.random.PCG64:
        return None
    ent: Any = seq.entropy
    return {"bit_generator": "PCG64", "entropy": ent if isinstance(ent, int) else [int(e) for e in ent],
            "spawn_key": [int(k) for k in seq.spawn_key]}


class Recorder:
    """Writes a recording to `out` (a path or an open text stream); see the module docstring.

    Parameters
    ----------
    out : path or text stream
    map : Map
        The map of the run (written in full in the header).
    robot : mapping
        What the header says of the robot: ``kind`` (``sim`` or ``nxt``), and anything else (geometry,
        profile, link).
    sonar : mapping
        The sonar model: ``model`` (``ideal``, ``nxt``, or ``real`` on hardware) and its parameters.
    seed : int or None
        The run's seed.
    truth : callable, optional
        Returns the robot's true pose (or None) after each robot event, for robots that do not expose
        ``true_pose`` themselves (the virtual brick's world).
    extra : mapping, optional
        More header fields (noise model, ...).
    particles : int
        With each estimate of a localiser that keeps a particle cloud, write at most this many of its
        particles (`thin_cloud`); 0 writes none.
    listeners : sequence of callables
        Each is called with every line's dict (the header first) after it is written.
    """

    def __init__(self, out: str | Path | IO[str] | None, *, map: Map, robot: dict[str, Any],
                 sonar: dict[str, Any], seed: int | None, truth: Callable[[], Pose | None] | None = None,
                 extra: dict[str, Any] | None = None, particles: int = 0,
                 listeners: Sequence[Callable[[dict[str, Any]], None]] = ()) -> None:
        if particles < 0:
            raise ConfigError(f"particles to record must be >= 0, got {particles}")
        self._fh: IO[str] | None = out if not isinstance(out, str | Path) else Path(out).open("w", encoding="utf-8")
        self._own = isinstance(out, str | Path)
        self._closed = False
        self._truth = truth
        self.particles = int(particles)
        self.listeners = list(listeners)
        self._scans = 0
        self._last_scan: Scan | None = None
        self.lines = 0
        header = {"type": "header", "format": FORMAT_NAME, "version": FORMAT_VERSION,
                  "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
                  "map": map.to_dict(), "robot": dict(robot), "sonar": dict(sonar), "seed": seed,
                  "versions": versions(), **dict(extra or {})}
        self._write(header)

    # -- writing --------------------------------------------------------------------------------
    def _write(self, obj: dict[str, Any]) -> None:
        if self._fh is not None:
            self._fh.write(json.dumps(obj, allow_nan=False, separators=(",", ":")) + "\n")
            self._fh.flush()
        self.lines += 1
        for listen in self.listeners:
            listen(obj)

    def event(self, kind: str, /, **fields: Any) -> None:
        """Write one event line ``{"type": kind, ...}``."""
        self._write({"type": kind, **fields})

    def close(self, status: str | None = None, success: bool | None = None, *, end: bool = True) -> None:
        """Write the ``end`` line (unless `end` is False: the run broke off) and close the file."""
        if self._closed or (self._fh is not None and self._fh.closed):
            return
        if end:
            self._write({"type": "end", "status": status, "success": success})
        self._closed = True
        if self._own and self._fh is not None:
            self._fh.close()

    def true_pose(self, robot: Any) -> list[float] | None:
        p = getattr(robot, "true_pose", None)
        if not isinstance(p, Pose) and self._truth is not None:
            p = self._truth()
        return _pose(p if isinstance(p, Pose) else None)

    # -- wrappers -------------------------------------------------------------------------------
    def wrap_robot(self, robot: Any) -> _RecordingRobot:
        """`robot` with its commands and scans recorded."""
        return _RecordingRobot(robot, self)

    def wrap_localiser(self, localiser: Localiser, *, options: dict[str, Any] | None = None,
                       rng: Any = None) -> _RecordingLocaliser:
        """`localiser` with its calls recorded; `options` and `rng` (the Generator it was built with)
        let a replay rebuild it exactly."""
        self.event("localiser", name=getattr(localiser, "name", type(localiser).__name__),
                   options=encode_options(dict(options or {})), rng=_rng_state(rng))
        return _RecordingLocaliser(localiser, self)

    def scan_event(self, scan: Scan, robot: Any, t0: float) -> None:
        t1 = float(robot.robot_time_s)
        times = getattr(robot, "last_scan_times_s", None)
        timed = {} if times is None or len(times) != len(scan) else {"times_s": encode_floats(times)}
        self._scan_line(scan, t0, t1, **timed, true_pose=self.true_pose(robot))

    def known_scan(self, scan: Scan, xy: tuple[float, float], heading: float | None = None,
                   label: str | None = None) -> int:
        """A scan taken without a robot clock (``t_start`` and ``t`` null) at a known position `xy` (cm),
        with a known `heading` (rad) or none (the true pose's heading is null); `label` says where it
        comes from. Returns the scan's id (for the update that uses it)."""
        x, y = float(xy[0]), float(xy[1])
        truth = [x, y, None if heading is None else float(heading)]
        return self._scan_line(scan, None, None, true_pose=truth, **({} if label is None else {"label": str(label)}))

    def stamped_scan(self, scan: Scan, t_start: float, t: float, true_pose: Pose | None,
                     times_s: Any = None, label: str | None = None) -> int:
        """A scan taken elsewhere with its own clock (a ROS bag's stamps): readings between `t_start` and
        `t` (s), each at `times_s` when given, the true pose when known. Returns the scan's id."""
        fields: dict[str, Any] = {"true_pose": _pose(true_pose)}
        if times_s is not None:
            fields["times_s"] = encode_floats(times_s)
        if label is not None:
            fields["label"] = str(label)
        return self._scan_line(scan, float(t_start), float(t), **fields)

    def _scan_line(self, scan: Scan, t_start: float | None, t: float | None, **fields: Any) -> int:
        sid = self._scans
        self.event("scan", id=sid, t_start=t_start, t=t, **scan_fields(scan), **fields)
        self._last_scan = scan
        self._scans += 1
        return sid

    def plan_event(self, path: Any) -> None:
        """A path the mission planned (cm), from the robot's estimate to the target (version 3)."""
        self.event("plan", path=[encode_floats(p) for p in np.asarray(path, dtype=float).reshape(-1, 2)])

    def estimate_event(self, estimate: PoseEstimate, localiser: Localiser) -> None:
        """An estimate, with the localiser's thinned particle cloud when `particles` asks for one."""
        fields = _estimate(estimate)
        cloud = localiser.cloud() if self.particles else None
        if cloud is not None:
            poses, weights = thin_cloud(cloud[0], cloud[1], self.particles)
            fields["particles"] = {"n": int(np.asarray(cloud[1]).size), "poses": [encode_floats(p) for p in poses],
                                   "weights": encode_floats(weights)}
        self.event("estimate", **fields)

    def reset_event(self, prior: Prior | HeadingPrior | None) -> None:
        """A reset of the localiser: global (`prior` None), with the heading known roughly (a
        `HeadingPrior`) or around a prior."""
        if isinstance(prior, HeadingPrior):
            self.event("reset", prior=prior.to_dict())
            return
        self.event("reset", prior=None if prior is None else {
            "mean": _pose(prior.mean), "cov": [encode_floats(r) for r in np.asarray(prior.cov, dtype=float)]})

    def update_event(self, scan: Scan) -> None:
        """An update: as indices into the last scan when it is a subset of it (the usual case), else in full."""
        last = self._last_scan
        if last is not None and len(scan) <= len(last):
            pos = {float(a): i for i, a in enumerate(last.angles.tolist())}
            idx = [pos.get(float(a), -1) for a in scan.angles.tolist()]
            if all(i >= 0 for i in idx):
                ix = np.asarray(idx, dtype=np.int64)
                if (np.array_equal(last.angles[ix], scan.angles) and
                        np.array_equal(last.ranges[ix], scan.ranges, equal_nan=True) and
                        np.array_equal(last.valid[ix], scan.valid)):
                    self.event("update", scan=self._scans - 1, index=idx)
                    return
        self.event("update", **scan_fields(scan))


class _RecordingRobot:
    """A robot whose commands and scans are written to a `Recorder`; everything else passes through."""

    def __init__(self, robot: Any, recorder: Recorder) -> None:
        self._robot = robot
        self._rec = recorder

    def __getattr__(self, name: str) -> Any:
        return getattr(self._robot, name)

    def _tacho(self, after: bool = False) -> dict[str, int] | None:
        fn = getattr(self._robot, "tacho_counts", None)
        if not callable(fn):
            return None
        try:
            return dict(fn())
        except LinkLostError:
            if not after:
                raise  # nothing was commanded yet
            return None  # the command was carried out; the next one finds the link lost

    def _command(self, kind: str, before: dict[str, int] | None, **fields: Any) -> None:
        after = self._tacho(after=True)
        odo = None if after is None and before is None else {"tacho_before": before, "tacho_after": after}
        self._rec.event(kind, t=float(self._robot.robot_time_s), **fields, odometry=odo,
                        true_pose=self._rec.true_pose(self._robot))

    def turn(self, angle_rad: float) -> None:
        before = self._tacho()
        self._robot.turn(angle_rad)
        self._command("turn", before, angle_rad=float(angle_rad))

    def move(self, distance_cm: float) -> Any:
        before = self._tacho()
        out = self._robot.move(distance_cm)
        self._command("move", before, requested_cm=float(distance_cm), driven_cm=float(out.distance_cm),
                      watchdog=bool(out.watchdog))
        return out

    def turnback(self) -> Any:
        before = self._tacho()
        out = self._robot.turnback()
        self._command("turnback", before, requested_cm=float(out.requested_cm), driven_cm=float(out.distance_cm),
                      watchdog=bool(out.watchdog))
        return out

    def ultrascan(self, angles: Any = None) -> Scan:
        t0 = float(self._robot.robot_time_s)
        scan = self._robot.ultrascan(angles)
        self._rec.scan_event(scan, self._robot, t0)
        return scan


class _RecordingLocaliser(Localiser):
    """A localiser whose calls (and the estimates they produce) are written to a `Recorder`."""

    def __init__(self, localiser: Localiser, recorder: Recorder) -> None:  # no super().__init__: a pure proxy
        self._inner = localiser
        self._rec = recorder

    def __getattr__(self, name: str) -> Any:
        return getattr(self._inner, name)

    # what the base class defines would hide the inner localiser's own from `__getattr__`
    @property
    def modes(self) -> list[Mode]:
        return self._inner.modes

    @property
    def snapshots(self) -> Sequence[Snapshot]:  # type: ignore[override]
        return self._inner.snapshots

    @property
    def needs_prior(self) -> bool:  # type: ignore[override]
        return self._inner.needs_prior

    def _after(self) -> None:
        self._rec.estimate_event(self._inner.estimate(), self._inner)

    def reset(self, prior: Prior | HeadingPrior | None = None) -> None:
        self._rec.reset_event(prior)
        self._inner.reset(prior)
        self._after()

    def predict(self, motion: Motion) -> None:
        self._rec.event("predict", turn_rad=float(motion.turn_rad), distance_cm=float(motion.distance_cm))
        self._inner.predict(motion)
        self._after()

    def update(self, scan: Scan) -> None:
        self._rec.update_event(scan)
        self._inner.update(scan)
        self._after()

    def estimate(self) -> PoseEstimate:
        return self._inner.estimate()

    def cloud(self) -> tuple[np.ndarray, np.ndarray] | None:
        return self._inner.cloud()
