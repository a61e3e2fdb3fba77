"""What `toolkit.recordings.replay.replay` reports: each localiser call's estimates (`ReplayStep`) and the whole
run's (`ReplayReport`): errors against the truth or agreement without one, evo's trajectory scores
(with the reason when one is missing), CPU time, and whether the live localiser was reproduced.

Every estimate with a true pose also gets its `Verdict`, judged as ``nxtnav bench sweeps`` judges a
run (`localisation.ambiguity`): converged or not, ambiguous (the candidate poses of the belief's
modes) or not, the truth among the candidates (within `CANDIDATE_RADIUS_CM`) or not. An estimate
further than that from the truth is explained in one line (`ReplayReport.explanations`): ambiguous,
not converged, or confidently wrong.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from localisation.ambiguity import CANDIDATE_RADIUS_CM, confidently_wrong, describe_candidates, truth_among
from localisation.base import PoseEstimate

from ..world import Pose, angle_diff
from ..world.arrays import finite_median
from .trajectory_scores import TrajectoryScores, score_trajectory

if TYPE_CHECKING:
    from .reading import Recording

__all__ = ["CANDIDATE_RADIUS_CM", "ReplayReport", "ReplayStep", "Verdict"]

WITHIN_CM = 10.0
"""The summary counts the estimates this close (cm) to the truth."""


@dataclass(frozen=True)
class Verdict:
    """Why an estimate is where it is, against a true position.

    Attributes
    ----------
    error_cm : float
        Distance (cm) from the estimate to the true position.
    converged : bool
        The localiser's own converged flag.
    spread_cm : float
        The estimate's position spread (cm).
    candidates : list of Pose
        The candidate poses of an ambiguous belief (cm, cm, rad), heaviest first; empty when not ambiguous.
    truth_in_candidates : bool
        Whether a candidate lies within `CANDIDATE_RADIUS_CM` of the true position.
    """

    error_cm: float
    converged: bool
    spread_cm: float
    candidates: list[Pose]
    truth_in_candidates: bool

    @property
    def ambiguous(self) -> bool:
        return len(self.candidates) > 1

    @property
    def large(self) -> bool:
        """More than `CANDIDATE_RADIUS_CM` from the truth: an error that needs its reason."""
        return self.error_cm > CANDIDATE_RADIUS_CM

    @property
    def confidently_wrong(self) -> bool:
        return confidently_wrong(self.converged, self.ambiguous, self.error_cm)

    def reason(self) -> str:
        """The one-phrase why: ambiguous (and whether the truth is among the candidates), not converged
        (with the spread), or confidently wrong."""
        if self.ambiguous:
            among = "among" if self.truth_in_candidates else "not among"
            return f"{describe_candidates(self.candidates)}, the truth {among} them"
        if not self.converged:
            return f"not converged (spread {self.spread_cm:.1f} cm)"
        return f"confidently wrong (converged, not ambiguous, spread {self.spread_cm:.1f} cm)"

    def to_dict(self) -> dict[str, Any]:
        return {"ambiguous": self.ambiguous, "candidates": [p.to_list_deg() for p in self.candidates],
                "candidates_text": describe_candidates(self.candidates) or None,
                "truth_in_candidates": self.truth_in_candidates, "confidently_wrong": self.confidently_wrong,
                "reason": self.reason() if self.large else None}


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
    candidates : dict
        Per localiser, the candidate poses of its belief after the call when ambiguous (else empty).
    """

    index: int
    line: int
    call: str
    truth: Pose | None
    estimates: dict[str, PoseEstimate | None]
    live: PoseEstimate | None
    truth_heading: bool = True
    label: str | None = None
    candidates: dict[str, list[Pose]] = field(default_factory=dict)

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

    def verdict(self, name: str) -> Verdict | None:
        """`name`'s estimate judged against the true position (`Verdict`); None without either."""
        e = self.estimates.get(name)
        if e is None or self.truth is None:
            return None
        cands = self.candidates.get(name, [])
        return Verdict(self.error_cm(name), bool(e.converged), e.std_xy_cm, cands,
                       truth_among(cands, self.truth.x, self.truth.y))

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
            if e is None:
                out["estimates"][name] = None
                continue
            verdict = self.verdict(name)
            cands = self.candidates.get(name, [])
            out["estimates"][name] = {
                "pose": e.pose.to_list_deg(), "spread_cm": e.std_xy_cm,
                "spread_deg": math.degrees(e.std_heading_rad), "converged": e.converged,
                "error_cm": _nan_none(self.error_cm(name)),
                "heading_error_deg": _nan_none(self.heading_error_deg(name)),
                "agreement_cm": _nan_none(self.agreement_cm(name, reference)),
                "ambiguous": len(cands) > 1, "candidates": [p.to_list_deg() for p in cands],
                "candidates_text": describe_candidates(cands) or None,
                "truth_in_candidates": None, "confidently_wrong": None, "reason": None,
                **({} if verdict is None else verdict.to_dict())}
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
            row: dict[str, float] = {"updates": float(len(ups)), "median_spread_cm": finite_median(spread),
                                     "final_spread_cm": float(spread[-1]) if spread.size else math.nan}
            if self.has_truth:
                err = np.array([s.error_cm(name) for s in ups])
                fin = err[np.isfinite(err)]
                row.update({"rmse_cm": float(np.sqrt(np.mean(fin**2))) if fin.size else math.nan,
                            "median_error_cm": finite_median(err),
                            "final_error_cm": float(err[-1]) if err.size else math.nan,
                            "final_heading_error_deg": ups[-1].heading_error_deg(name) if ups else math.nan})
                row.update(self.verdict_counts(name))
                scores = self.trajectory_scores(name)
                row.update({"ape_rmse_cm": scores.ape_rmse_cm, "ape_heading_rmse_deg": scores.ape_heading_rmse_deg,
                            "rpe_per_m_cm": scores.rpe_per_m_cm, "scored_updates": float(scores.poses)})
            else:
                agr = np.array([s.agreement_cm(name, ref) for s in ups])
                row.update({"median_agreement_cm": finite_median(agr),
                            "max_agreement_cm": float(np.nanmax(agr)) if np.isfinite(agr).any() else math.nan})
            row["cpu_s"] = self.cpu_s.get(name, math.nan)
            out[name] = row
        return out

    def verdict_counts(self, name: str) -> dict[str, float]:
        """Over `name`'s estimates after the updates that have a true pose: how many (``judged_updates``),
        within `WITHIN_CM` of the truth, ambiguous with the truth among the candidates, confidently wrong."""
        verdicts = [v for s in self.steps if s.call == "update" and (v := s.verdict(name)) is not None]
        return {"judged_updates": float(len(verdicts)),
                "within_10cm": float(sum(v.error_cm <= WITHIN_CM for v in verdicts)),
                "ambiguous_truth_among": float(sum(v.ambiguous and v.truth_in_candidates for v in verdicts)),
                "confidently_wrong": float(sum(v.confidently_wrong for v in verdicts))}

    def explanations(self) -> list[str]:
        """One line per estimate after an update further than `CANDIDATE_RADIUS_CM` from the truth, saying
        why (`Verdict.reason`), then one line per localiser counting the verdicts; empty without truth."""
        if not self.has_truth:
            return []
        lines = []
        for s in self.steps:
            for name in self.localisers:
                v = s.verdict(name) if s.call == "update" else None
                if v is not None and v.large:
                    where = f"step {s.index} (line {s.line}{', ' + s.label if s.label else ''})"
                    lines.append(f"{where}: {name} {v.error_cm:.1f} cm off: {v.reason()}")
        for name in self.localisers:
            c = self.verdict_counts(name)
            lines.append(f"{name}: {c['judged_updates']:.0f} updates with a true pose, {c['within_10cm']:.0f} within "
                         f"{WITHIN_CM:g} cm, {c['ambiguous_truth_among']:.0f} ambiguous with the truth among the "
                         f"candidates, {c['confidently_wrong']:.0f} confidently wrong")
        return lines

    def trajectory_scores(self, name: str) -> TrajectoryScores:
        """evo's APE (after rigid alignment) and RPE per metre of `name`'s estimates after the updates,
        against the true poses (`toolkit.recordings.trajectory_scores`); NaN without true headings."""
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

