"""Compare localisers offline on a recording: read it (`read_recording`, `toolkit.recordings.reading`),
replay it (`replay`, its report in `toolkit.recordings.replay_report`).

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
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from localisation.ambiguity import candidate_poses
from localisation.base import LOCALISERS, HeadingPrior, Localiser, Motion, PoseEstimate, Prior, make_localiser
from localisation.robot_options import localiser_options

from ..world import (
    LaserScanner,
    NxtnavError,
    NxtSonar,
    Pose,
    RobotModel,
    Scan,
    SonarModel,
)
from .reading import (
    CALLS,
    ROBOT_EVENTS,
    LocaliserSpec,
    Recording,
    RecordingError,
    heading_prior_of,
    read_recording,
    truth_of,
)
from .recorder import (
    _estimate,
    decode_floats,
    scan_from_fields,
    sonar_from_dict,
)
from .replay_report import ReplayReport, ReplayStep

__all__ = ["LocaliserSpec", "Recording", "RecordingError", "ReplayReport", "ReplayStep", "read_recording", "replay",
           "robot_model_of"]

# -- replaying ----------------------------------------------------------------------------------------


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
    run = _Replayer(rec, initial, heading)
    for name in dict.fromkeys(localisers):
        run.build(name, seed, (options or {}).get(name, {}))
    for line, e in rec.events:
        if run.feed(line, e) and on_step is not None:
            on_step()
    return run.report(list(dict.fromkeys(localisers)))


class _Replayer:
    """The state of one replay: the localisers, what the recording has said so far, the steps."""

    def __init__(self, rec: Recording, initial: Prior | None, heading: HeadingPrior | None) -> None:
        self.rec, self.initial, self.heading = rec, initial, heading
        self.locs: dict[str, Localiser | None] = {}
        self.exact: dict[str, bool] = {}
        self.failures: dict[str, str] = {}
        self.cpu: dict[str, float] = {}
        self.scans: dict[int, Scan] = {}
        self.candidates: dict[str, list[Pose]] = {}  # after the last call, per localiser
        self.truth: tuple[Pose, bool] | None = None
        self.label: str | None = None
        self.steps: list[ReplayStep] = []
        self.reproduced: dict[str, bool] = {}
        self.diverged: dict[str, int] = {}
        self.pending: int | None = None  # the step waiting for its live estimate
        self.first_reset = True

    def build(self, name: str, seed: int, extra: Mapping[str, Any]) -> None:
        """Construct localiser `name` (`_build`); one that cannot be built is a failure, unless the
        caller's own options are refused: that is an error at once."""
        started = time.process_time()
        try:
            self.locs[name], self.exact[name] = _build(self.rec, name, seed, extra)
        except (NxtnavError, ValueError, TypeError) as exc:
            if extra:  # the caller's own choice: said at once, not as a failed row
                given = ", ".join(f"{k}={v!r}" for k, v in extra.items())
                raise NxtnavError(f"replay: {name} refuses {given}: {' '.join(str(exc).split())}") from None
            self.locs[name], self.exact[name] = None, False
            self.failures[name] = f"not built: {' '.join(str(exc).split())}"
        self.cpu[name] = time.process_time() - started
        if self.exact[name]:
            self.reproduced[name] = True

    def feed(self, line: int, e: dict[str, Any]) -> bool:
        """Take one event of the recording; True when it was a localiser call (a step)."""
        kind = e["type"]
        if kind in ROBOT_EVENTS and e.get("true_pose") is not None:
            self.truth = truth_of(e)
        if kind == "scan":
            self.scans[int(e["id"])] = scan_from_fields(e)
            self.label = e.get("label")
        elif kind == "estimate" and self.pending is not None:
            self._compare_live(line, e)
        elif kind in CALLS:
            arg = self._argument(line, e)  # once: a reset's prior depends on the resets before
            ests = {name: self._call(name, kind, arg, line) for name in self.locs}
            truth = self.truth
            self.steps.append(ReplayStep(len(self.steps), line, kind, None if truth is None else truth[0], ests, None,
                                         truth_heading=truth is None or truth[1], label=self.label,
                                         candidates={n: self.candidates.get(n, []) for n in self.locs}))
            self.pending = len(self.steps) - 1
            return True
        return False

    def _compare_live(self, line: int, e: dict[str, Any]) -> None:
        """The live estimate `e` after the pending step: kept, and compared with the live localiser's."""
        assert self.pending is not None
        k = self.pending
        self.steps[k] = dataclasses.replace(self.steps[k], live=_live_estimate(e))
        for n in self.reproduced:
            got = self.steps[k].estimates.get(n)
            if self.reproduced[n] and (got is None or _estimate(got) != _strip(e)):
                self.reproduced[n] = False
                self.diverged[n] = line
        self.pending = None

    def _argument(self, line: int, e: dict[str, Any]) -> Any:
        """What the call `e` passes the localisers: a prior, a motion or a scan."""
        kind = e["type"]
        if kind == "predict":
            return Motion(float(e["turn_rad"]), float(e["distance_cm"]))
        if kind == "update":
            if "scan" not in e:
                return scan_from_fields(e)
            raw = self.scans[int(e["scan"])]
            ix = np.asarray(e["index"], dtype=np.int64)
            return Scan(raw.angles[ix], raw.ranges[ix], raw.valid[ix])
        pr = e["prior"]
        arg: Any = None
        if pr is not None and "heading_deg" in pr:
            arg = heading_prior_of(pr, f"{self.rec.path}:{line}")
        elif pr is not None:
            arg = Prior(Pose(*[float(v) for v in pr["mean"]]), np.vstack([decode_floats(r) for r in pr["cov"]]))
        if self.first_reset and self.initial is not None:
            arg = self.initial
        elif arg is None and self.heading is not None:
            arg = self.heading
        self.first_reset = False
        return arg

    def _call(self, name: str, kind: str, arg: Any, line: int) -> PoseEstimate | None:
        """Call `kind` of localiser `name` with `arg`, timed; its estimate after, None once it has failed."""
        loc = self.locs[name]
        if loc is None:
            return None
        started = time.process_time()
        estimate: PoseEstimate | None = None
        self.candidates[name] = []
        try:
            getattr(loc, kind)(arg)
            estimate = loc.estimate()
            self.candidates[name] = candidate_poses(loc)
        except (NxtnavError, ValueError, np.linalg.LinAlgError) as exc:
            self.failures[name] = f"line {line}: {' '.join(str(exc).split())}"
            self.locs[name] = None
        self.cpu[name] += time.process_time() - started
        return estimate

    def report(self, localisers: list[str]) -> ReplayReport:
        compared = sum(1 for s in self.steps if s.live is not None)
        live = self.rec.localiser.name if self.rec.localiser is not None else None
        out_reproduced: dict[str, bool | None] = {
            n: self.reproduced[n] if n in self.reproduced and compared else None for n in self.locs if n == live}
        return ReplayReport(self.rec, localisers, self.steps, out_reproduced, self.diverged, self.failures, compared,
                            self.cpu)


def _strip(e: dict[str, Any]) -> dict[str, Any]:
    return {k: e[k] for k in ("pose", "cov", "converged", "iterations")}


def _live_estimate(e: dict[str, Any]) -> PoseEstimate:
    a = e["pose"]
    return PoseEstimate(Pose(float(a[0]), float(a[1]), float(a[2])), np.vstack([decode_floats(r) for r in e["cov"]]),
                        bool(e["converged"]), int(e["iterations"]))
