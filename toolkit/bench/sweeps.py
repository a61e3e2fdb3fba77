"""``nxtnav bench sweeps``: global localisation from each real sweep alone, scored against its waypoint.

Each task resets one localiser globally, gives it one sweep (no motion) and compares its estimate's
position with the waypoint (the heading of a real sweep is not known, so positions only). With a
`HeadingPrior` (``--heading-prior``) the reset knows the heading roughly and the position not at all:
another task, for a robot that believes its heading (it drove there by odometry). A run is

* within 10 / 20 cm: its estimate's position error;
* **confidently wrong**: converged, not ambiguous, more than 20 cm off;
* **honest**: within 20 cm, or ambiguous with a candidate within 20 cm of the waypoint.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from localisation.ambiguity import CANDIDATE_RADIUS_CM, candidate_poses, confidently_wrong, truth_among
from localisation.base import HeadingPrior, make_localiser
from localisation.robot_options import localiser_options
from toolkit.bench.common import write_rows_csv
from toolkit.real_sonar.sweeps import SweepSet, load_sweep_set
from toolkit.seeds import derive_seed
from toolkit.world import NxtSonar, RobotModel

__all__ = ["CANDIDATE_RADIUS_CM", "COLUMNS", "SweepRun", "SweepTask", "make_sweep_tasks", "run_sweep",
           "summarise", "write_sweeps_csv", "write_sweeps_summary"]

@dataclass(frozen=True)
class SweepTask:
    """One localiser on one sweep with one seed (picklable: the model travels as its parameters)."""

    folder: str
    map: str | None
    index: int
    localiser: str
    seed: int
    sonar: dict[str, Any]
    options: dict[str, Any]
    heading_prior: HeadingPrior | None = None


@dataclass(frozen=True)
class SweepRun:
    """The outcome of one `SweepTask` (the CSV's columns, in order)."""

    repo: str
    file: str
    x_cm: float
    y_cm: float
    localiser: str
    seed: int
    estimate_x_cm: float
    estimate_y_cm: float
    estimate_heading_deg: float
    error_cm: float
    converged: bool
    ambiguous: bool
    candidates: int
    truth_in_candidates: bool
    time_s: float

    @property
    def confidently_wrong(self) -> bool:
        return confidently_wrong(self.converged, self.ambiguous, self.error_cm)

    @property
    def honest(self) -> bool:
        return self.error_cm <= CANDIDATE_RADIUS_CM or (self.ambiguous and self.truth_in_candidates)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


COLUMNS = tuple(f.name for f in fields(SweepRun))


@lru_cache(maxsize=8)
def _sweep_set(folder: str, map: str | None) -> SweepSet:
    return load_sweep_set(folder, map)


def make_sweep_tasks(sweeps: SweepSet, map: str | None, localisers: Sequence[str], seeds: Sequence[int],
                     sonar: NxtSonar | Mapping[str, NxtSonar], options: dict[str, dict[str, Any]] | None = None,
                     heading_prior: HeadingPrior | None = None) -> list[SweepTask]:
    """Every localiser x seed x sweep of `sweeps` (the slowest loop innermost, so progress is even);
    every reset global, or with `heading_prior` the heading known roughly. `sonar` is the model of every
    sweep, or each source's model by its name (``repo``).

    The tasks name the folder by its absolute path: a worker process may run in another folder."""
    params = {sw.repo: asdict(sonar if isinstance(sonar, NxtSonar) else sonar[sw.repo]) for sw in sweeps}
    opts = options or {}
    folder = str(Path(sweeps.folder).absolute())
    return [SweepTask(folder, map, i, name, int(s), params[sweeps.sweeps[i].repo], dict(opts.get(name, {})),
                      heading_prior)
            for name in localisers for s in seeds for i in range(len(sweeps))]


def run_sweep(task: SweepTask) -> SweepRun:
    """Localise globally from one sweep (`SweepTask`) and score the estimate against the waypoint."""
    sweeps = _sweep_set(task.folder, task.map)
    sw = sweeps.sweeps[task.index]
    sonar = NxtSonar(**task.sonar)
    robot = RobotModel(sonar, readings="real")
    opts = {**localiser_options(task.localiser, robot), **task.options}
    t0 = time.perf_counter()
    loc = make_localiser(task.localiser, sweeps.map, rng=derive_seed(task.seed, "sweeps", sw.label), **opts)
    loc.reset(task.heading_prior)
    loc.update(sw.scan(sonar.turret_offset_deg))
    est = loc.estimate()
    cands = candidate_poses(loc)
    elapsed = time.perf_counter() - t0
    found = truth_among(cands, sw.x_cm, sw.y_cm)
    return SweepRun(sw.repo, sw.file, sw.x_cm, sw.y_cm, task.localiser, task.seed, round(est.pose.x, 3),
                    round(est.pose.y, 3), round(est.pose.heading_deg, 3),
                    round(math.hypot(est.pose.x - sw.x_cm, est.pose.y - sw.y_cm), 3), bool(est.converged),
                    len(cands) > 1, len(cands), found, round(elapsed, 4))


def write_sweeps_csv(runs: Sequence[SweepRun], path: Path) -> Path:
    """`runs` as CSV with `COLUMNS` (written to a temporary file, then moved into place)."""
    return write_rows_csv((r.to_dict() for r in runs), COLUMNS, path)


def summarise(runs: Sequence[SweepRun], localiser: str) -> dict[str, float]:
    """Shares within 10 and 20 cm, median error, confidently wrong, honest, and time of `localiser`'s runs."""
    mine = [r for r in runs if r.localiser == localiser]
    if not mine:
        return {"runs": 0}
    err = np.array([r.error_cm for r in mine])
    return {"runs": len(mine), "within_10cm": float(np.mean(err <= 10.0)), "within_20cm": float(np.mean(err <= 20.0)),
            "median_error_cm": float(np.median(err)),
            "confidently_wrong": float(np.mean([r.confidently_wrong for r in mine])),
            "honest": float(np.mean([r.honest for r in mine])),
            "ambiguous": float(np.mean([r.ambiguous for r in mine])),
            "median_time_s": float(np.median([r.time_s for r in mine]))}


def write_sweeps_summary(runs: Sequence[SweepRun], path: Path, *, localisers: Sequence[str], sweeps: SweepSet,
                         seeds: Sequence[int], sonar: NxtSonar | Mapping[str, NxtSonar], command: str,
                         wall_time_s: float,
                         complete: bool = True, heading_prior: HeadingPrior | None = None) -> Path:
    """A Markdown summary: per localiser, the shares of the module docstring, and the sonar model used."""
    lines = [] if complete else [f"**INCOMPLETE**: {len(runs)} runs finished; the table covers only them.\n"]
    task = ("Global localisation" if heading_prior is None else
            f"Localisation with the heading known to {math.degrees(heading_prior.sd_rad):g} degrees "
            f"(prior {math.degrees(heading_prior.heading_rad):g} degrees) and the position unknown")
    lines += [f"# {task} from one real sweep: {len(sweeps)} sweeps of `{sweeps.folder}`, "
              f"map `{sweeps.map.name}`, seeds {', '.join(map(str, seeds))}", "",
              "| localiser | runs | within 10 cm | within 20 cm | median error (cm) | confidently wrong | honest "
              "| ambiguous | median time (s) |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name in localisers:
        s = summarise(runs, name)
        if not s.get("runs"):
            continue
        lines.append(f"| {name} | {s['runs']} | {s['within_10cm']:.0%} | {s['within_20cm']:.0%} | "
                     f"{s['median_error_cm']:.1f} | {s['confidently_wrong']:.0%} | {s['honest']:.0%} | "
                     f"{s['ambiguous']:.0%} | {s['median_time_s']:.2f} |")
    if sweeps.left_out:
        lines += ["", *(f"Left out (its readings cannot be used): {why}  " for why in sweeps.left_out)]
    lines += ["", "*Confidently wrong*: converged, not ambiguous, more than 20 cm off. *Honest*: within 20 cm, "
              "or ambiguous with a candidate within 20 cm of the waypoint. Positions only: the heading of a "
              "real sweep was not measured.", "",
              *_sonar_lines(sonar),
              f"Command: `{command}`  ", f"Wall time: {wall_time_s:.1f} s", ""]
    path.write_text("\n".join(lines))
    return path


def _sonar_lines(sonar: NxtSonar | Mapping[str, NxtSonar]) -> list[str]:
    """The summary's lines on the robot and sonar models: one model, or each source's."""
    models = {"": sonar} if isinstance(sonar, NxtSonar) else dict(sonar)
    lines: list[str] = []
    for repo, model in models.items():
        whose = f" of {repo}" if repo else ""
        lines += [f"Robot model given to every localiser{whose}: {RobotModel(model, readings='real').describe()}.",
                  "", f"Sonar model (`nxt`){whose}: " + ", ".join(f"{k} {v:g}" for k, v in asdict(model).items()),
                  ""]
    return lines
