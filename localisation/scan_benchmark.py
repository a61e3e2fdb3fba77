"""Measuring what the paper's scan processing buys: processed vs raw scans on random poses.

`compare_scan_processing` draws random poses in a map, simulates a sonar (``nxt`` by default, the
LEGO sensor with its wide lobe, specular loss and no-echo readings) with `toolkit.world`'s sonar
models, and for each pose compares

* the raw scan: every usable reading of a 360-degree sweep taken where the robot stands;
* the processed scan: the robot turns toward the minimum reading, sweeps again, and keeps the
  readings within +-15 degrees of 0/90/180/270 (`localisation.scan`).

Two levels are reported: the readings themselves (error against the exact distance along the
sensor axis) and global localisation from that one scan with a localiser (success = within 2 cm
and 3 degrees). Only `toolkit.world` is used (no robot implementation), so the comparison is cheap
and exactly reproducible from its seed.

>>> from toolkit.world import load_map
>>> cmp = compare_scan_processing(load_map("map1"), n_poses=2, rng=0, localise=False)
>>> cmp.raw.n_poses
2
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from toolkit.world import (
    Map,
    Pose,
    RngLike,
    Scan,
    SonarModel,
    angle_diff,
    as_rng,
    default_scan_angles,
    make_sonar,
    ray_cast,
)
from toolkit.world.arrays import FloatArray

from .base import make_localiser
from .scan import ScanProcessing, min_reading, process_scan, raw_scan

__all__ = [
    "ReadingStats",
    "ScanProcessingComparison",
    "SingleScanBenchmark",
    "VariantStats",
    "compare_scan_processing",
    "single_scan_benchmark",
]


@dataclass(frozen=True)
class ReadingStats:
    """Errors of the readings a localiser is given, against the exact distance along the sensor axis.

    Attributes
    ----------
    readings_per_scan : float
        Mean number of readings kept per scan.
    median_abs_error_cm, rmse_cm : float
        Of (reading - exact axis distance) over all kept readings.
    gross_fraction : float
        Fraction of kept readings more than `gross_cm` off.
    gross_cm : float
    """

    readings_per_scan: float
    median_abs_error_cm: float
    rmse_cm: float
    gross_fraction: float
    gross_cm: float

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


@dataclass(frozen=True)
class VariantStats:
    """Results of one variant (raw or processed) over all poses."""

    n_poses: int
    readings: ReadingStats
    success_rate: float | None = None
    median_error_cm: float | None = None
    median_heading_error_deg: float | None = None
    median_time_s: float | None = None

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["readings"] = self.readings.to_dict()
        return d


@dataclass(frozen=True)
class ScanProcessingComparison:
    """Raw vs processed scans on the same poses (see `compare_scan_processing`)."""

    map: str
    sonar: dict[str, Any]
    localiser: str | None
    localiser_options: dict[str, Any]
    seed: int | None
    raw: VariantStats
    processed: VariantStats
    errors_cm: dict[str, list[float]] = field(default_factory=dict, repr=False)

    @property
    def reading_error_reduction(self) -> float:
        """Relative reduction of the median absolute reading error (0.5 = halved)."""
        r, p = self.raw.readings.median_abs_error_cm, self.processed.readings.median_abs_error_cm
        return float(1.0 - p / r) if r > 0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "map": self.map,
            "sonar": self.sonar,
            "localiser": self.localiser,
            "localiser_options": self.localiser_options,
            "seed": self.seed,
            "raw": self.raw.to_dict(),
            "processed": self.processed.to_dict(),
            "reading_error_reduction": self.reading_error_reduction,
        }

    def summary(self) -> str:
        """A small Markdown table of the comparison."""
        gross = f"{self.raw.readings.gross_cm:g}"
        rows = [
            f"| scans | readings/scan | median abs error (cm) | RMSE (cm) | gross (>{gross} cm) | success "
            "| median error (cm) | median heading error (deg) | median time (ms) |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for label, v in (("raw", self.raw), ("processed", self.processed)):
            r = v.readings
            succ = "-" if v.success_rate is None else f"{100 * v.success_rate:.1f} %"
            err = "-" if v.median_error_cm is None else f"{v.median_error_cm:.2f}"
            head = "-" if v.median_heading_error_deg is None else f"{v.median_heading_error_deg:.2f}"
            tms = "-" if v.median_time_s is None else f"{1000 * v.median_time_s:.1f}"
            rows.append(f"| {label} | {r.readings_per_scan:.1f} | {r.median_abs_error_cm:.2f} | {r.rmse_cm:.2f} | "
                        f"{100 * r.gross_fraction:.1f} % | {succ} | {err} | {head} | {tms} |")
        return "\n".join(rows)


def _reading_stats(errors: list[FloatArray], n_poses: int, gross_cm: float) -> ReadingStats:
    e = np.concatenate(errors) if errors else np.zeros(0)
    if e.size == 0:
        return ReadingStats(0.0, math.nan, math.nan, math.nan, gross_cm)
    return ReadingStats(
        readings_per_scan=float(e.size / max(n_poses, 1)),
        median_abs_error_cm=float(np.median(np.abs(e))),
        rmse_cm=float(np.sqrt(np.mean(e * e))),
        gross_fraction=float(np.mean(np.abs(e) > gross_cm)),
        gross_cm=gross_cm,
    )


def _sweep(map: Map, sonar: SonarModel, pose: Pose, angles: FloatArray, gen: np.random.Generator) -> Scan:
    ranges = np.asarray(sonar.measure(map.walls, pose.xy, pose.theta + angles, gen), dtype=float)
    return sonar.to_scan(angles, ranges)


def compare_scan_processing(
    map: Map,
    *,
    n_poses: int = 100,
    sonar: str | SonarModel = "nxt",
    sonar_options: dict[str, Any] | None = None,
    localiser: str = "paper-pf",
    localiser_options: dict[str, Any] | None = None,
    processing: ScanProcessing | None = None,
    clearance_cm: float = 8.0,
    gross_cm: float = 5.0,
    localise: bool = True,
    rng: RngLike = None,
) -> ScanProcessingComparison:
    """Compare raw and processed scans on `n_poses` random poses (see the module docstring).

    Parameters
    ----------
    map : Map
    n_poses : int
        Random true poses (uniform over the free space with `clearance_cm`, uniform headings).
    sonar : str or SonarModel
        Sonar model (``nxt`` by default) and its `sonar_options`.
    localiser : str
        Registry name of the localiser used for the localisation comparison (a global one).
    localiser_options : dict, optional
        Its options; for the ``nxt`` sonar by default ``sensor_sigma_cm`` 2 cm and the sonar's lobe
        width and critical incidence as ``beam_width_deg`` and ``critical_incidence_deg``.
    processing : ScanProcessing, optional
        The paper's processing by default.
    gross_cm : float
        Threshold of a gross reading error.
    localise : bool
        Also localise from each scan (slower); False compares the readings only.
    rng : None, int or Generator
        Seed of the poses and the sonar noise.

    Returns
    -------
    ScanProcessingComparison
    """
    gen = as_rng(rng)
    seed = rng if isinstance(rng, int) else None
    model = make_sonar(sonar, **(sonar_options or {})) if isinstance(sonar, str) else sonar
    opts = dict(localiser_options or {})
    if model.name == "nxt":
        opts.setdefault("sensor_sigma_cm", 2.0)
        opts.setdefault("beam_width_deg", float(getattr(model, "beam_width_deg", 20.0)))
        opts.setdefault("critical_incidence_deg", float(getattr(model, "critical_incidence_deg", 40.0)))
    settings = processing or ScanProcessing()
    loc = make_localiser(localiser, map, rng=gen, **opts) if localise else None
    angles = default_scan_angles()
    xy = map.sample_free(n_poses, clearance_cm, gen)
    headings = gen.uniform(-math.pi, math.pi, n_poses)
    read_err: dict[str, list[FloatArray]] = {"raw": [], "processed": []}
    loc_err: dict[str, list[tuple[float, float, float]]] = {"raw": [], "processed": []}
    for (x, y), th in zip(xy, headings, strict=True):
        pose = Pose(x, y, th)
        first = _sweep(map, model, pose, angles, gen)
        a_min, _ = min_reading(first, settings.min_range_cm)
        turned = Pose(x, y, th + a_min)
        second = _sweep(map, model, turned, angles, gen)
        variants = {
            "raw": (pose, raw_scan(first, settings.min_range_cm, settings.range_limit_cm)),
            "processed": (turned, process_scan(second, settings).scan),
        }
        for label, (truth, scan) in variants.items():
            heard = scan.subset(scan.valid)  # the reading errors of echoes (no-echo readings have none)
            if len(heard):
                exact = np.asarray(ray_cast(map.walls, truth.xy, truth.theta + heard.angles), dtype=float)
                read_err[label].append(heard.ranges - exact)
            if loc is not None:
                t0 = time.perf_counter()
                loc.reset()
                if len(scan):
                    loc.update(scan)
                est = loc.estimate().pose
                dt = time.perf_counter() - t0
                dh = abs(math.degrees(angle_diff(est.theta, truth.theta)))
                loc_err[label].append((est.distance_to(truth), dh, dt))
    stats = {}
    for label in ("raw", "processed"):
        rs = _reading_stats(read_err[label], n_poses, gross_cm)
        if loc is not None:
            le = np.array(loc_err[label])
            succ = float(np.mean((le[:, 0] <= 2.0) & (le[:, 1] <= 3.0)))
            stats[label] = VariantStats(n_poses, rs, succ, float(np.median(le[:, 0])), float(np.median(le[:, 1])),
                                        float(np.median(le[:, 2])))
        else:
            stats[label] = VariantStats(n_poses, rs)
    errors = {k: [float(v[0]) for v in loc_err[k]] for k in loc_err}
    return ScanProcessingComparison(
        map=map.name,
        sonar=model.to_dict(),
        localiser=localiser if localise else None,
        localiser_options=opts,
        seed=seed,
        raw=stats["raw"],
        processed=stats["processed"],
        errors_cm=errors,
    )


@dataclass(frozen=True)
class SingleScanBenchmark:
    """Global localisation from one processed scan per random pose (see `single_scan_benchmark`).

    Attributes
    ----------
    map, localiser, sonar : str, str, dict
    n_poses : int
    success_rate : float
        Fraction within `success_cm` and `success_deg`.
    median_time_s, p90_time_s : float
        Wall-clock time of ``reset()`` + ``update(scan)`` (the range table is built beforehand).
    median_error_cm, median_heading_error_deg : float
    converged_rate : float
        Fraction the localiser reported as converged (ambiguous twins are not).
    errors_cm, heading_errors_deg, times_s : tuple of float
        Per pose, in pose order.
    converged : tuple of bool
        Per pose, whether the localiser reported convergence.
    truths : tuple of (x, y, heading_deg)
        The true (turned) poses.
    """

    map: str
    localiser: str
    sonar: dict[str, Any]
    n_poses: int
    seed: int | None
    success_cm: float
    success_deg: float
    success_rate: float
    converged_rate: float
    median_time_s: float
    p90_time_s: float
    median_error_cm: float
    median_heading_error_deg: float
    errors_cm: tuple[float, ...] = field(repr=False, default=())
    heading_errors_deg: tuple[float, ...] = field(repr=False, default=())
    times_s: tuple[float, ...] = field(repr=False, default=())
    converged: tuple[bool, ...] = field(repr=False, default=())
    truths: tuple[tuple[float, float, float], ...] = field(repr=False, default=())

    @property
    def success_or_flagged_rate(self) -> float:
        """Fraction that succeeded or that the localiser flagged as not converged (ambiguous)."""
        ok = [(e <= self.success_cm and h <= self.success_deg) or not c
              for e, h, c in zip(self.errors_cm, self.heading_errors_deg, self.converged, strict=True)]
        return float(np.mean(ok)) if ok else math.nan

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def single_scan_benchmark(
    map: Map,
    *,
    n_poses: int = 100,
    localiser: str = "paper-pf",
    localiser_options: dict[str, Any] | None = None,
    sonar: str | SonarModel = "ideal",
    sonar_options: dict[str, Any] | None = None,
    processing: ScanProcessing | None = None,
    clearance_cm: float = 8.0,
    success_cm: float = 2.0,
    success_deg: float = 3.0,
    rng: RngLike = None,
) -> SingleScanBenchmark:
    """Time and score global localisation from one processed 360-degree scan on random poses.

    For each pose: sweep, turn toward the minimum reading (exactly), sweep again, process (the
    paper's windows), then time ``reset()`` and one ``update(scan)`` of the localiser. The
    localiser (and its range table) is built once before the first pose.
    """
    gen = as_rng(rng)
    seed = rng if isinstance(rng, int) else None
    model = make_sonar(sonar, **(sonar_options or {})) if isinstance(sonar, str) else sonar
    settings = processing or ScanProcessing()
    loc = make_localiser(localiser, map, rng=gen, **(localiser_options or {}))
    angles = default_scan_angles()
    xy = map.sample_free(n_poses, clearance_cm, gen)
    headings = gen.uniform(-math.pi, math.pi, n_poses)
    errs, herrs, times, conv = [], [], [], []
    truths: list[tuple[float, float, float]] = []
    for (x, y), th in zip(xy, headings, strict=True):
        first = _sweep(map, model, Pose(x, y, th), angles, gen)
        a_min, _ = min_reading(first, settings.min_range_cm)
        truth = Pose(x, y, th + a_min)
        scan = process_scan(_sweep(map, model, truth, angles, gen), settings).scan
        t0 = time.perf_counter()
        loc.reset()
        loc.update(scan)
        est = loc.estimate()
        times.append(time.perf_counter() - t0)
        errs.append(est.pose.distance_to(truth))
        herrs.append(abs(math.degrees(angle_diff(est.pose.theta, truth.theta))))
        conv.append(bool(est.converged))
        truths.append((truth.x, truth.y, truth.heading_deg))
    e, h, t = np.array(errs), np.array(herrs), np.array(times)
    return SingleScanBenchmark(
        map=map.name,
        localiser=localiser,
        sonar=model.to_dict(),
        n_poses=n_poses,
        seed=seed,
        success_cm=success_cm,
        success_deg=success_deg,
        success_rate=float(np.mean((e <= success_cm) & (h <= success_deg))),
        converged_rate=float(np.mean(conv)),
        median_time_s=float(np.median(t)),
        p90_time_s=float(np.percentile(t, 90)),
        median_error_cm=float(np.median(e)),
        median_heading_error_deg=float(np.median(h)),
        errors_cm=tuple(float(v) for v in e),
        heading_errors_deg=tuple(float(v) for v in h),
        times_s=tuple(float(v) for v in t),
        converged=tuple(conv),
        truths=tuple(truths),
    )
