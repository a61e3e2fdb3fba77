"""Fitting and scoring the `nxt` sonar model on real sweeps taken at known positions.

The model is `toolkit.world.NxtSonar`: a lobe with specular loss gives each reading's echo distance
``d`` (from the map, the waypoint and the heading); a beam mixture gives P(reading | d). A fit
maximises the summed log-probability of every reading of every sweep:

* the lobe (`beam_width_deg`, `critical_incidence_deg`) on a grid, since each value needs new ray casts;
* for each lobe, the mixture's continuous parameters by L-BFGS-B (scipy), alternating with the
  heading of each sweep (not measured on the real robot: the best of every 0.5 degrees);
* the lobe with the highest likelihood wins; then `correlation_deg` is the integrated
  autocorrelation time of the readings' log-probabilities along the finest sweeps (how many
  neighbouring readings carry one reading's worth of evidence).

Each sweep's position may sit up to 3 cm from its waypoint (`POSITION_OFFSETS_CM`: the robots drove there
by odometry); headings and these offsets are nuisance parameters of the fit, and scoring aligns a
sweep the same way for every model it compares.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from localisation.base import HeadingPrior
from localisation.scan import drop_stuck

from ..world import NO_ECHO, ConfigError, Map, NxtSonar, angle_diff, circular_mean, wrap_angle
from ..world.arrays import FloatArray, finite_median
from .margins import sweep_margins
from .profile_file import SonarProfileError, load_sonar_profile, save_sonar_profile
from .sweeps import Sweep, SweepSet

__all__ = [
    "BASELINES",
    "FIT_PARAMETERS",
    "TWIN_HEADING_DEG",
    "AlignedSweep",
    "FitResult",
    "HeldOutScore",
    "LeaveOneOut",
    "RepoFold",
    "SonarProfileError",
    "SweepScore",
    "align_sweeps",
    "fit_sonar",
    "heading_disagreements",
    "load_sonar_profile",
    "profiles_by_source",
    "repo_folds",
    "save_sonar_profile",
    "score_fold",
    "score_sonar",
    "source_profile_name",
    "sweep_folds",
    "turret_offset_deg",
]

log = logging.getLogger(__name__)


FIT_PARAMETERS = ("noise_sd", "noise_per_m", "bias_cm", "dropout_prob", "far_dropout_prob", "reach_cm",
                  "reach_width_cm", "phantom_prob", "short_prob", "outlier_prob")
"""The mixture's continuous parameters fitted for each lobe."""
_BOUNDS = {"noise_sd": (0.3, 20.0), "noise_per_m": (0.0, 20.0), "bias_cm": (-10.0, 10.0),
           "dropout_prob": (1e-4, 0.9), "far_dropout_prob": (1e-4, 0.999), "reach_cm": (20.0, 255.0),
           "reach_width_cm": (1.0, 100.0), "phantom_prob": (1e-4, 0.999), "short_prob": (1e-4, 0.9),
           "outlier_prob": (1e-4, 0.9)}
HEADING_STEP_DEG = 0.5
POSITION_OFFSETS_CM = tuple((dx, dy) for dx in (-3.0, 0.0, 3.0) for dy in (-3.0, 0.0, 3.0))
"""Positions tried around each waypoint: the robots drove to them by odometry, a few cm off; without this
nuisance a fit widens the lobe to forgive the position error."""
LOG_FLOOR = -700.0
"""Least log-probability a reading counts for in a score (a reading the model calls impossible, such as
a wrong reading under a model without outliers, would otherwise make the mean -inf)."""
BASELINES: dict[str, Callable[[], NxtSonar]] = {"default": NxtSonar, "hardware": NxtSonar.hardware_facts}
"""Models a score is compared with (`nxtnav sonar score --baseline`): the toolkit's `nxt` default, and
the model from the published hardware facts alone."""

DEFAULT_WIDTHS = (10.0, 20.0, 30.0, 40.0, 60.0)
DEFAULT_CRITICALS = (20.0, 30.0, 40.0, 50.0, 60.0)
"""The lobe grid of the shipped default model's fit (docs/real-sonar.md)."""


@dataclass(frozen=True)
class _Sweep:
    """One sweep prepared for fitting: its usable readings (stuck runs left out; no echo as 255)."""

    sweep: Sweep
    angles: FloatArray
    readings: FloatArray


def _prepare(sweeps: Sequence[Sweep], m: Map) -> list[_Sweep]:
    out = []
    for s in sweeps:
        scan, _ = drop_stuck(s.scan(), m, position=(s.x_cm, s.y_cm))  # judged at the documented waypoint
        readings = np.where(scan.valid, scan.ranges, NO_ECHO)
        out.append(_Sweep(s, scan.angles, readings))
    return out


def _directions() -> FloatArray:
    return np.radians(np.arange(0.0, 360.0, HEADING_STEP_DEG))


@dataclass(frozen=True)
class _EchoRows:
    """Echo distances (K * H, n) of a sweep's readings for every candidate pose, stored as the distinct
    distances (`values`, float32) and each entry's index among them (`at`): row ``r`` is
    ``values[at[r]]``. The fit scores every row many times; a table over the distinct values is
    several times smaller than the rows, and the indices are found once, not at every score."""

    values: np.ndarray
    at: np.ndarray

    @classmethod
    def of(cls, echoes: FloatArray) -> _EchoRows:
        values, at = np.unique(echoes, return_inverse=True)
        return cls(values, at.reshape(echoes.shape))

    def __getitem__(self, row: int) -> np.ndarray:
        return np.asarray(self.values[self.at[row]])


def _echo_by_pose(model: NxtSonar, m: Map, sw: _Sweep) -> _EchoRows:
    """Echo distances of the sweep's readings for every position of `POSITION_OFFSETS_CM` around the
    waypoint (K) and every candidate heading (H, HEADING_STEP_DEG apart); row ``k * H + h``."""
    dirs = _directions()
    k = dirs.size
    rel = np.rint(np.degrees(sw.angles) / HEADING_STEP_DEG).astype(np.int64)
    idx = (np.arange(k)[:, None] + rel[None, :]) % k
    ranges = [np.asarray(model.echo_distance(m.walls, np.array([sw.sweep.x_cm + dx, sw.sweep.y_cm + dy]), dirs),
                         dtype=np.float32) for dx, dy in POSITION_OFFSETS_CM]
    values, where = np.unique(np.concatenate(ranges), return_inverse=True)
    return _EchoRows(values, np.concatenate([where[i * k + idx] for i in range(len(ranges))]))


def _pose(sw: _Sweep, index: int) -> tuple[float, float, float]:
    """The position (cm) and heading (rad, wrapped) of row `index` of `_echo_by_pose`."""
    n_dir = _directions().size
    dx, dy = POSITION_OFFSETS_CM[index // n_dir]
    return sw.sweep.x_cm + dx, sw.sweep.y_cm + dy, float(wrap_angle(_directions()[index % n_dir]))


def _sweep_log_pmf(model: NxtSonar, echoes: _EchoRows, readings: FloatArray) -> FloatArray:
    """``model.log_pmf(echoes, readings[None, :])``, (rows, n), from a table over the distinct echo
    distances x the distinct readings: the same numbers, computed once for each distinct pair."""
    r, r_at = np.unique(readings, return_inverse=True)
    table = model.log_pmf(echoes.values.astype(float)[:, None], r[None, :])
    return np.asarray(table[echoes.at, r_at.reshape(1, -1)])


def _best_poses(model: NxtSonar, echoes: list[_EchoRows], sweeps: list[_Sweep]) -> list[int]:
    """The row of `_echo_by_pose` (position and heading) where each sweep is most likely."""
    return [int(np.argmax(_sweep_log_pmf(model, e, sw.readings).sum(axis=1)))
            for e, sw in zip(echoes, sweeps, strict=True)]


def _with(params: dict[str, Any], names: Sequence[str], x: FloatArray) -> NxtSonar:
    """The model of `params` (``asdict`` of one, made once by the caller) with `names` set to `x`."""
    return NxtSonar(**{**params, **{k: float(v) for k, v in zip(names, x, strict=True)}})


def _fit_mixture(model: NxtSonar, d: FloatArray, r: FloatArray) -> NxtSonar:
    """The mixture parameters that maximise sum log P(r | d), starting from `model`'s.

    Each evaluation computes log P(r | d) once for each distinct (d, r) pair and spreads it over the
    readings, so every reading's term, and the sum over them, are the numbers computed per reading."""
    from scipy.optimize import minimize  # here, not with the module: scoring and profiles need no optimiser

    names = FIT_PARAMETERS
    lo = np.array([_BOUNDS[k][0] for k in names])
    hi = np.array([_BOUNDS[k][1] for k in names])
    x0 = np.clip(np.array([getattr(model, k) for k in names], dtype=float), lo, hi)
    params = asdict(model)
    d_r, at = np.unique(np.stack(np.broadcast_arrays(np.asarray(d, dtype=float), np.asarray(r, dtype=float))),
                        axis=1, return_inverse=True)
    at = at.reshape(-1)

    def nll(x: FloatArray) -> float:
        if x[names.index("short_prob")] + x[names.index("outlier_prob")] >= 0.99:
            return 1e12
        lp = _with(params, names, x).log_pmf(d_r[0], d_r[1])[at]
        return float(-np.sum(np.maximum(lp, LOG_FLOOR)))

    res = minimize(nll, x0, method="L-BFGS-B", bounds=list(zip(lo, hi, strict=True)),
                   options={"maxiter": 200, "eps": 1e-5})
    return _with(params, names, np.asarray(res.x, dtype=float))


def _gather(echoes: list[_EchoRows], headings: list[int], sweeps: list[_Sweep]) -> tuple[FloatArray, FloatArray]:
    d = np.concatenate([e[h] for e, h in zip(echoes, headings, strict=True)])
    r = np.concatenate([sw.readings for sw in sweeps])
    return d, r


def _expected_log_pmf(model: NxtSonar, d: FloatArray) -> FloatArray:
    """E[log P(R | d)] over the model's own readings R, for each echo distance in `d`."""
    levels = np.arange(model._levels() + 1, dtype=float)
    levels[-1] = NO_ECHO
    lp = np.maximum(model.log_pmf(d[:, None], levels[None, :]), LOG_FLOOR)
    return np.asarray(np.sum(np.exp(lp) * lp, axis=1))


def _correlation_deg(model: NxtSonar, d_per: list[FloatArray], sweeps: list[_Sweep]) -> float:
    """Integrated autocorrelation time (degrees) of the readings' surprise along the sweeps with the
    finest step: log P(r | d) minus its expectation given d (so that a long arc of far walls, poorly
    explained by design, is not mistaken for correlated errors). The sum over lags stops at the first
    negative autocorrelation."""
    finest = min(sw.sweep.step_deg for sw in sweeps)
    taus = []
    for d, sw in zip(d_per, sweeps, strict=True):
        if sw.sweep.step_deg != finest:
            continue
        x = np.maximum(model.log_pmf(d, sw.readings), -30.0) - _expected_log_pmf(model, d)
        x = x - x.mean()
        var = float(np.mean(x * x))
        if var <= 0:
            continue
        tau = 1.0
        for lag in range(1, x.size // 4):
            rho = float(np.mean(x[:-lag] * x[lag:])) / var
            if rho <= 0:
                break
            tau += 2.0 * rho
        taus.append(tau)
    return float(np.median(taus) * finest) if taus else 0.0


@dataclass(frozen=True)
class FitResult:
    """A fitted model, the heading of each sweep, and how well it explains the readings."""

    model: NxtSonar
    headings_deg: dict[str, float]
    mean_log_likelihood: float
    readings: int
    sweeps: int
    lobes: list[dict[str, float]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.model.to_dict(), "headings_deg": self.headings_deg,
                "mean_log_likelihood": self.mean_log_likelihood, "readings": self.readings, "sweeps": self.sweeps,
                "lobes": self.lobes}


def fit_sonar(sets: Sequence[SweepSet], *, widths: Sequence[float] = DEFAULT_WIDTHS,
              criticals: Sequence[float] = DEFAULT_CRITICALS, start: NxtSonar | None = None, rounds: int = 3,
              progress: Callable[[int, int], None] | None = None) -> FitResult:
    """Fit the `nxt` sonar model by maximum likelihood to the sweeps of `sets` (module docstring).

    Parameters
    ----------
    sets : sequence of SweepSet
        Sweeps at known positions, each set with its map.
    widths, criticals : sequences of float
        The lobe widths and specular incidence limits tried (degrees).
    start : NxtSonar, optional
        Starting mixture parameters (default: a heavy-tailed guess).
    rounds : int
        Alternations of headings and mixture per lobe.
    progress : callable, optional
        Called with (lobes done, lobes in all).
    """
    items = [(s.map, sw) for s in sets for sw in _prepare(list(s), s.map)]
    if not items:
        raise ConfigError("no sweeps to fit")
    base = start or NxtSonar(noise_sd=2.0, noise_per_m=1.0, dropout_prob=0.02, far_dropout_prob=0.5, reach_cm=100.0,
                             reach_width_cm=20.0, phantom_prob=0.5, short_prob=0.1, outlier_prob=0.05)
    best: tuple[float, NxtSonar, list[int], list[_EchoRows]] | None = None
    lobes: list[dict[str, float]] = []
    grid = [(w, c) for w in widths for c in criticals]
    sweeps = [sw for _, sw in items]
    for i, (w, c) in enumerate(grid):
        model = NxtSonar(**{**asdict(base), "beam_width_deg": float(w), "critical_incidence_deg": float(c),
                            "beam_rays": max(round(w / 2.5) | 1, 1)})
        echoes = [_echo_by_pose(model, m, sw) for m, sw in items]
        headings = _best_poses(model, echoes, sweeps)
        for _ in range(rounds):
            d, r = _gather(echoes, headings, sweeps)
            model = _fit_mixture(model, d, r)
            new = _best_poses(model, echoes, sweeps)
            if new == headings:
                break
            headings = new
        d, r = _gather(echoes, headings, sweeps)
        ll = float(np.mean(model.log_pmf(d, r)))
        lobes.append({"beam_width_deg": float(w), "critical_incidence_deg": float(c), "mean_log_likelihood": ll})
        log.info("lobe %g deg, specular %g deg: %.4f nats per reading", w, c, ll)
        if best is None or ll > best[0]:
            best = (ll, model, headings, echoes)
        if progress is not None:
            progress(i + 1, len(grid))
    assert best is not None
    ll, model, headings, echoes = best
    d_per = [e[h] for e, h in zip(echoes, headings, strict=True)]
    model = NxtSonar(**{**asdict(model), "correlation_deg": round(_correlation_deg(model, d_per, sweeps), 2)})
    heading_deg = {sw.sweep.label: math.degrees(_pose(sw, h)[2]) for sw, h in zip(sweeps, headings, strict=True)}
    return FitResult(model, heading_deg, ll, int(sum(sw.readings.size for sw in sweeps)), len(sweeps), lobes)


def turret_offset_deg(sweeps: Sequence[Sweep], fitted_deg: Mapping[str, float]) -> float:
    """The recording robot's turret zero (degrees, `NxtSonar.turret_offset_deg`): the circular mean of each
    sweep's fitted heading (`fitted_deg`, by label) less its ``heading_deg``, over the sweeps that have one,
    twins (further than `TWIN_HEADING_DEG`) left out. 0 for sweeps of several sources (each robot has its
    own) or without a ``heading_deg``."""
    if len({s.repo for s in sweeps}) != 1:
        return 0.0
    gaps = [float(angle_diff(math.radians(fitted_deg[s.label]), math.radians(s.heading_deg)))
            for s in sweeps if not math.isnan(s.heading_deg) and s.label in fitted_deg]
    gaps = [g for g in gaps if abs(g) <= math.radians(TWIN_HEADING_DEG)]
    return round(math.degrees(float(circular_mean(gaps))), 2) if gaps else 0.0


@dataclass(frozen=True)
class SweepScore:
    """How well a model explains real sweeps at their known positions (headings aligned by the model)."""

    mean_log_likelihood: float
    no_echo_real: float
    no_echo_model: float
    median_abs_diff_cm: float
    readings: int
    sweeps: int
    waypoint_most_likely: float = math.nan
    """Share of sweeps the model explains best at their waypoint (`toolkit.real_sonar.margins`): an upper
    bound on the share of sweeps any localiser using the model places within 20 cm from that sweep alone."""
    per_sweep: list[dict[str, Any]] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def score_sonar(model: NxtSonar, sets: Sequence[SweepSet], margins: bool = True,
                heading_prior: HeadingPrior | None = None, on_sweep: Callable[[], None] | None = None) -> SweepScore:
    """Mean log-probability per reading, no-echo share real against model, and the median |real - model|
    of the readings where both answer (the model's noise-free reading ``d + bias``), each sweep where
    the model finds it most likely (`align_sweeps`); and, with `margins` (a search of the whole map's
    lattice per sweep, the costly part), per sweep the margin (nats) by which the model prefers the
    waypoint to any place further than 20 cm (`toolkit.real_sonar.margins`, weighed by `heading_prior` when
    given); NaN without. With `margins`, `on_sweep` is called as each sweep's margin is done (a progress
    display)."""
    aligned = [a for s in sets for a in align_sweeps(model, s)]
    if not aligned:
        raise ConfigError("no sweeps to score")
    margin = ([m for s in sets for m in sweep_margins(model, s, heading_prior=heading_prior, on_sweep=on_sweep)]
              if margins else [math.nan] * len(aligned))
    per: list[dict[str, Any]] = []
    lps, silents, diffs, reals = [], [], [], []
    for a in aligned:
        lp = np.maximum(model.log_pmf(a.echo, a.readings), LOG_FLOOR)
        p_silent = np.exp(model.log_pmf(a.echo, np.full(a.echo.shape, NO_ECHO)))
        real_silent = a.readings >= model.max_range_cm
        diff = np.where(~real_silent & np.isfinite(a.echo), np.abs(a.readings - (a.echo + model.bias_cm)), np.nan)
        per.append({"sweep": a.sweep.label, "offset_cm": [a.x_cm - a.sweep.x_cm, a.y_cm - a.sweep.y_cm],
                    "heading_deg": math.degrees(a.heading_rad),
                    "set_heading_deg": None if math.isnan(a.sweep.heading_deg) else a.sweep.heading_deg,
                    "readings": int(a.readings.size),
                    "mean_log_likelihood": float(np.mean(lp)), "no_echo_real": float(np.mean(real_silent)),
                    "no_echo_model": float(np.mean(p_silent)), "median_abs_diff_cm": finite_median(diff),
                    "margin_nats": margin[len(per)]})
        lps.append(lp)
        silents.append(p_silent)
        diffs.append(diff)
        reals.append(real_silent)
    return SweepScore(float(np.mean(np.concatenate(lps))), float(np.mean(np.concatenate(reals))),
                      float(np.mean(np.concatenate(silents))), finite_median(np.concatenate(diffs)),
                      int(sum(x.size for x in lps)), len(aligned),
                      float(np.mean(np.asarray(margin) > 0.0)) if margins else math.nan, per)



# -- leave one repository out ----------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RepoFold:
    """One fold of a leave-one-repository-out test: the sweeps of `repo` held out, the others to fit on."""

    repo: str
    train: list[SweepSet]
    held_out: list[SweepSet]


def repo_folds(sets: Sequence[SweepSet]) -> list[RepoFold]:
    """One fold per source (``repo`` column) of the sweeps, in order of first appearance; each set keeps
    its map. Raises `ConfigError` when the sweeps come from fewer than two sources."""
    repos = list(dict.fromkeys(sw.repo for s in sets for sw in s))
    if len(repos) < 2:
        raise ConfigError("leaving one repository out needs sweeps from two or more repositories; these all "
                          f"come from {', '.join(repos) or 'none'}")

    def pick(repo: str, held: bool) -> list[SweepSet]:
        out = [SweepSet(s.folder, s.map, tuple(sw for sw in s if (sw.repo == repo) == held)) for s in sets]
        return [s for s in out if len(s)]

    return [RepoFold(repo, pick(repo, False), pick(repo, True)) for repo in repos]


def sweep_folds(sets: Sequence[SweepSet]) -> list[RepoFold]:
    """One fold per sweep of every source with two or more sweeps: that sweep held out, its source's other
    sweeps to fit on (the test of a per-source profile, `sonar fit --per-source`: a robot's model scored on
    a sweep it was not fitted on). Each fold is named by the held-out sweep's label. Raises `ConfigError`
    when no source has two sweeps."""
    folds = []
    for repo in dict.fromkeys(sw.repo for s in sets for sw in s):
        mine = [(s, sw) for s in sets for sw in s if sw.repo == repo]
        if len(mine) < 2:
            continue
        for held_set, held in mine:
            train = [SweepSet(s.folder, s.map, tuple(sw for sw in s if sw.repo == repo and sw is not held))
                     for s in sets]
            folds.append(RepoFold(held.label, [t for t in train if len(t)],
                                  [SweepSet(held_set.folder, held_set.map, (held,))]))
    if not folds:
        raise ConfigError("leaving one sweep out of its source needs a source with two or more sweeps; every "
                          "source here has one")
    return folds


@dataclass(frozen=True)
class HeldOutScore:
    """The sweeps of one fold (a source, or one sweep: `repo` names what was held out) scored by the model fitted
    without them and by a baseline model."""

    repo: str
    fitted: SweepScore
    baseline: SweepScore
    model: NxtSonar

    @property
    def readings(self) -> int:
        return self.fitted.readings

    def to_dict(self) -> dict[str, Any]:
        return {"repo": self.repo, "readings": self.readings, "sweeps": self.fitted.sweeps,
                "fitted": self.fitted.to_dict(), "baseline": self.baseline.to_dict(), "model": self.model.to_dict()}


def score_fold(fold: RepoFold, *, widths: Sequence[float] = DEFAULT_WIDTHS,
               criticals: Sequence[float] = DEFAULT_CRITICALS, baseline: NxtSonar | None = None,
               progress: Callable[[int, int], None] | None = None) -> HeldOutScore:
    """Fit on the fold's training sweeps (`fit_sonar` with `widths` and `criticals`), then score its held-out
    sweeps with that model and with `baseline` (default `NxtSonar.hardware_facts()`)."""
    fit = fit_sonar(fold.train, widths=widths, criticals=criticals, progress=progress)
    base = baseline if baseline is not None else NxtSonar.hardware_facts()
    return HeldOutScore(fold.repo, score_sonar(fit.model, fold.held_out), score_sonar(base, fold.held_out), fit.model)


TWIN_HEADING_DEG = 45.0
"""A sweep whose ``heading_deg`` lies further than this (degrees) from the heading a sonar model finds
it most likely at is nearer another quarter turn than its own: in a box or a square arena, the twin."""


def heading_disagreements(headings: Iterable[tuple[str, float | None, float]], model: str,
                          limit_deg: float = TWIN_HEADING_DEG) -> list[str]:
    """One line for each (sweep label, the set's ``heading_deg`` or None, the heading `model` finds the sweep
    most likely at) of `headings` whose two headings differ by more than `limit_deg` (degrees): a truth
    heading that is likely a twin."""
    out = []
    for label, given, found in headings:
        if given is None or math.isnan(given):
            continue
        gap = abs(math.degrees(float(angle_diff(math.radians(found), math.radians(given)))))
        if gap > limit_deg:
            out.append(f"{label}: heading_deg {given:g} is {gap:.0f} degrees from the heading the {model} model "
                       f"finds the sweep most likely at ({found:.1f}); a route or challenge that takes heading_deg "
                       "as the truth drives from a heading the sweep does not show")
    return out


SCORE_FIELDS = ("mean_log_likelihood", "no_echo_real", "no_echo_model", "median_abs_diff_cm")


@dataclass(frozen=True)
class LeaveOneOut:
    """Every fold of a leave-one-repository-out test, and their means weighted by the held-out readings.

    `fitted` and `baseline` hold the weighted means of `SCORE_FIELDS` (the median difference's mean is a
    mean of per-source medians); `beats_baseline` says whether the fitted models explain the held-out
    readings better (a higher mean log-likelihood per reading), `no_echo_gap` how far their no-echo share
    lies from the real one.
    """

    folds: list[HeldOutScore]
    fitted: dict[str, float]
    baseline: dict[str, float]

    @classmethod
    def of(cls, folds: Sequence[HeldOutScore]) -> LeaveOneOut:
        w = np.array([f.readings for f in folds], dtype=float)

        def mean(which: str) -> dict[str, float]:
            out = {}
            for k in SCORE_FIELDS:
                v = np.array([getattr(getattr(f, which), k) for f in folds], dtype=float)
                ok = ~np.isnan(v)
                out[k] = float(np.average(v[ok], weights=w[ok])) if ok.any() and w[ok].sum() > 0 else math.nan
            return out

        return cls(list(folds), mean("fitted"), mean("baseline"))

    @property
    def readings(self) -> int:
        return sum(f.readings for f in self.folds)

    @property
    def beats_baseline(self) -> bool:
        return self.fitted["mean_log_likelihood"] > self.baseline["mean_log_likelihood"]

    @property
    def no_echo_gap(self) -> float:
        return abs(self.fitted["no_echo_model"] - self.fitted["no_echo_real"])

    @property
    def fold_no_echo_gaps(self) -> list[float]:
        """Each fold's own gap between the no-echo share its fitted model expects and the real one."""
        return [abs(f.fitted.no_echo_model - f.fitted.no_echo_real) for f in self.folds]

    def to_dict(self) -> dict[str, Any]:
        return {"folds": [f.to_dict() for f in self.folds], "readings": self.readings,
                "weighted_mean": {"fitted": self.fitted, "baseline": self.baseline},
                "beats_baseline": self.beats_baseline, "no_echo_gap": self.no_echo_gap}


@dataclass(frozen=True, eq=False)
class AlignedSweep:
    """A sweep at the pose where a model finds it most likely, with the model's echo distance per reading."""

    sweep: Sweep
    x_cm: float
    y_cm: float
    heading_rad: float
    angles: FloatArray
    readings: FloatArray
    echo: FloatArray
    walls: FloatArray


def align_sweeps(model: NxtSonar, sweeps: SweepSet) -> list[AlignedSweep]:
    """Every sweep of `sweeps` (stuck runs dropped) where `model` finds it most likely: a heading and a
    position within `POSITION_OFFSETS_CM` of its waypoint."""
    prepared = _prepare(list(sweeps), sweeps.map)
    echoes = [_echo_by_pose(model, sweeps.map, sw) for sw in prepared]
    out = []
    for sw, e, i in zip(prepared, echoes, _best_poses(model, echoes, prepared), strict=True):
        x, y, heading = _pose(sw, i)
        out.append(AlignedSweep(sw.sweep, x, y, heading, sw.angles, sw.readings, np.asarray(e[i], dtype=float),
                                sweeps.map.walls))
    return out


# -- profile files (the file itself: `toolkit.real_sonar.profile_file`) ----------------------------------
def source_profile_name(repo: str) -> str:
    """The file name of source `repo`'s profile in a folder of per-source profiles: the ``/`` of
    ``owner/name`` as ``+`` (as a sweep set's ``raw/`` folders name sources), then ``.yaml``."""
    return repo.replace("/", "+") + ".yaml"


def profiles_by_source(path: str | Path, repos: Sequence[str]) -> dict[str, NxtSonar]:
    """Each source's model from `path`: a profile file (one model for every source) or a folder of
    per-source profiles (`source_profile_name`, as ``nxtnav sonar fit --per-source`` writes them), which
    must hold one for every source of `repos`. Raises `SonarProfileError` naming the file missing."""
    p = Path(path)
    if not p.is_dir():
        model = load_sonar_profile(p)
        return {repo: model for repo in repos}
    missing = [repo for repo in repos if not (p / source_profile_name(repo)).is_file()]
    if missing:
        raise SonarProfileError(f"{p}: no profile {source_profile_name(missing[0])} for source {missing[0]} "
                                f"(a folder of per-source profiles needs one for each of {len(repos)} sources)")
    return {repo: load_sonar_profile(p / source_profile_name(repo)) for repo in repos}
