"""`nxtnav bench world`: ray casting, collision checks, c-space and range-model figures for one map.

Every figure is the median of `repeats` timings in this process. The optional peer, raycast2d
(Bresenham walks over an occupancy image, GPL-3.0, used as a library only), casts the same rays from
the same positions snapped to pixel centres on the map rasterised at `pixel_cm`; its ranges are
compared with ours from those same positions.
"""

from __future__ import annotations

import importlib
import math
import time
from typing import Any

import numpy as np
import shapely

from localisation.models import range_table
from toolkit.world import Map, RngLike, RobotModel, as_rng, default_scan_angles, make_checker, ray_cast

__all__ = ["bench_world_figures", "peer_raycast2d"]


def _median_time(fn: Any, repeats: int) -> tuple[float, float]:
    """Median wall-clock and CPU (this process) seconds of `repeats` calls of `fn`."""
    wall, cpu = [], []
    for _ in range(max(1, repeats)):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return float(np.median(wall)), float(np.median(cpu))


def peer_raycast2d(m: Map, origins: np.ndarray, angles: np.ndarray, repeats: int,
                   max_pixels: int = 4096) -> dict[str, Any] | None:
    """raycast2d on the rasterised map: rays/s and the mean |range difference| to ours (None if absent)."""
    try:
        raycaster = importlib.import_module("raycast2D.raycaster")
    except ImportError:
        return None
    xmin, ymin, xmax, ymax = m.bounds
    pixel = max(1.0, max(xmax - xmin, ymax - ymin) / max_pixels)
    w, h = math.ceil((xmax - xmin) / pixel) + 2, math.ceil((ymax - ymin) / pixel) + 2
    gx, gy = np.meshgrid(xmin + (np.arange(w) - 0.5) * pixel, ymin + (np.arange(h) - 0.5) * pixel)
    img = shapely.contains_xy(m.polygon, gx, gy).astype(np.uint8)  # row = y, column = x; 1 = free
    for x1, y1, x2, y2 in m.thin_segments:  # a thin wall blocks every pixel it passes (sampled at 1/8 pixel)
        t = np.linspace(0.0, 1.0, math.ceil(8.0 * math.hypot(x2 - x1, y2 - y1) / pixel) + 2)
        img[np.floor((y1 + t * (y2 - y1) - ymin) / pixel + 1.0).astype(np.int64),
            np.floor((x1 + t * (x2 - x1) - xmin) / pixel + 1.0).astype(np.int64)] = 0
    px = np.clip(np.floor((origins[:, 0] - xmin) / pixel + 1.0).astype(np.int64), 1, w - 2)
    py = np.clip(np.floor((origins[:, 1] - ymin) / pixel + 1.0).astype(np.int64), 1, h - 2)
    ok = img[py, px] == 1
    px, py = px[ok], py[ok]
    if len(px) == 0:
        return None
    dx, dy = np.cos(angles), np.sin(angles)
    # ray ends on the image border along each direction (so the direction is not bent by clipping)
    with np.errstate(divide="ignore"):
        tx = np.where(dx > 0, (w - 1 - px[:, None]) / dx, np.where(dx < 0, -px[:, None] / dx, np.inf))
        ty = np.where(dy > 0, (h - 1 - py[:, None]) / dy, np.where(dy < 0, -py[:, None] / dy, np.inf))
    t = np.minimum(tx, ty)
    ex = np.clip(np.rint(px[:, None] + t * dx), 0, w - 1).astype(np.uint32)
    ey = np.clip(np.rint(py[:, None] + t * dy), 0, h - 1).astype(np.uint32)
    hits = np.zeros((len(px), angles.size, 3), dtype=np.uint32)

    def run() -> None:
        for k in range(len(px)):
            rays = np.column_stack([ex[k], ey[k], np.zeros(angles.size, np.uint32)])
            raycaster.raycast(img, rays, int(px[k]), int(py[k]))
            hits[k] = rays

    elapsed, cpu = _median_time(run, repeats)
    peer_r = np.hypot(hits[..., 0].astype(float) - px[:, None], hits[..., 1].astype(float) - py[:, None]) * pixel
    centres = np.column_stack([xmin + (px - 0.5) * pixel, ymin + (py - 0.5) * pixel])
    ours = ray_cast(m.walls, centres, angles)
    both = (hits[..., 2] == 1) & np.isfinite(ours)
    return {
        "name": "raycast2d",
        "pixel_cm": pixel,
        "rays": int(len(px) * angles.size),
        "rays_per_s": len(px) * angles.size / elapsed,
        "rays_per_cpu_s": len(px) * angles.size / cpu,
        "mean_abs_range_diff_cm": float(np.mean(np.abs(peer_r[both] - ours[both]))) if both.any() else math.nan,
    }


STEP_RADII = 2.5
"""Standard deviation of a benchmark segment's x and y steps, in robot radii (20 cm for 8 cm)."""
LONG_STEP_RADII = 10.0
"""The same for the long segments (80 cm for 8 cm): motions across rooms rather than within reach."""


def _range_model_figures(m: Map, sonar: str, range_memory_mb: float | None) -> dict[str, Any]:
    """The particle filters' range table for `sonar` on `m`: its build time (wall and CPU s), size
    (bytes), cell size (cm) and value type."""
    t0, c0 = time.perf_counter(), time.process_time()
    facets = RobotModel.build(sonar).facets()  # the table's own lobe and range limit, as the localisers' are
    lobe = facets.get("lobe", {})
    table = range_table(m, memory_mb=range_memory_mb, lattice_step=2,
                        beam_width_deg=lobe.get("beam_width_deg", 0.0),
                        critical_incidence_deg=lobe.get("critical_incidence_deg"),
                        max_range_cm=facets.get("max_range", {}).get("max_range_cm"))
    return {"range_model_sonar": sonar, "range_model_build_s": time.perf_counter() - t0,
            "range_model_build_cpu_s": time.process_time() - c0, "range_model_bytes": table.nbytes,
            "range_model_resolution_cm": table.resolution_cm, "range_model_dtype": table.dtype}


def bench_world_figures(m: Map, *, radius: float = 8.0, poses: int = 1000, repeats: int = 5,
                        segments: int = 20000, range_model: bool = True, range_memory_mb: float | None = None,
                        sonar: str = "ideal", peer: bool = True, collision: str = "index",
                        rng: RngLike = 0) -> dict[str, Any]:
    """The figures of `nxtnav bench world` as a JSON-ready dict (rates per second, times in s, bytes).

    Rates come twice: per wall-clock second and per CPU second of this process (``*_per_cpu_s``),
    which is steadier on a shared machine. Checks: points uniform over the map's bounds; segments
    from those points with normal x and y steps of `STEP_RADII` robot radii (and, for the
    ``long_segment`` figures, `LONG_STEP_RADII`): the same distribution relative to the robot on
    every map. The range model is the particle filters' table for `sonar` (``nxt``: its lobe,
    specular loss and 255 cm range limit). `collision` picks the checker (`toolkit.world.make_checker`):
    ``index`` (its wall index and clearance raster count in the c-space build and memory) or ``fcl``
    (its BVH; no index figures).
    """
    gen = as_rng(rng)
    t0, c0 = time.perf_counter(), time.process_time()
    cc = make_checker(m, radius, collision)
    m.free_space(radius)
    indexed = cc.backend == "index"
    raster_bytes = cc.clearance_raster.nbytes if indexed else None  # built here: it counts in the c-space build
    cspace_s, cspace_c = time.perf_counter() - t0, time.process_time() - c0
    origins = m.sample_free(poses, rng=gen)
    angles = default_scan_angles()
    ray_cast(m.walls, origins[:2], angles)  # compile and index outside the timing
    ray_s, ray_c = _median_time(lambda: ray_cast(m.walls, origins, angles), repeats)
    xmin, ymin, xmax, ymax = m.bounds
    a = gen.uniform([xmin, ymin], [xmax, ymax], (segments, 2))
    b = a + gen.normal(0.0, STEP_RADII * radius, (segments, 2))
    far = a + gen.normal(0.0, LONG_STEP_RADII * radius, (segments, 2))
    cc.segments_free(a[:10], b[:10])
    seg_s, seg_c = _median_time(lambda: cc.segments_free(a, b), repeats)
    long_s, long_c = _median_time(lambda: cc.segments_free(a, far), repeats)
    pt_s, pt_c = _median_time(lambda: cc.point_free(a), repeats)
    fig: dict[str, Any] = {
        "map": m.name,
        "edges": len(m.walls),
        "radius_cm": radius,
        "collision": cc.backend,
        "repeats": repeats,
        "rays": int(poses * angles.size),
        "rays_per_s": poses * angles.size / ray_s,
        "segment_checks_per_s": segments / seg_s,
        "point_checks_per_s": segments / pt_s,
        "rays_per_cpu_s": poses * angles.size / ray_c,
        "segment_checks_per_cpu_s": segments / seg_c,
        "point_checks_per_cpu_s": segments / pt_c,
        "segment_step_sd_cm": STEP_RADII * radius,
        "mean_segment_cm": float(np.mean(np.hypot(*(b - a).T))),
        "long_segment_checks_per_s": segments / long_s,
        "long_segment_checks_per_cpu_s": segments / long_c,
        "mean_long_segment_cm": float(np.mean(np.hypot(*(far - a).T))),
        "free_fraction_points": float(np.mean(cc.point_free(a))),
        "free_fraction_segments": float(np.mean(cc.segments_free(a, b))),
        "free_fraction_long_segments": float(np.mean(cc.segments_free(a, far))),
        "cspace_build_s": cspace_s,
        "cspace_build_cpu_s": cspace_c,
        "index_bytes": cc.index.nbytes if indexed else None,
        "clearance_raster_bytes": raster_bytes,
        "range_model_build_s": None,
        "range_model_bytes": None,
    }
    if range_model:
        fig.update(_range_model_figures(m, sonar, range_memory_mb))
    if peer:
        sub = origins[: min(poses, 300)]
        res = peer_raycast2d(m, sub, angles, repeats)
        if res is not None:
            res["ratio"] = fig["rays_per_s"] / res["rays_per_s"]
            res["ratio_cpu"] = fig["rays_per_cpu_s"] / res["rays_per_cpu_s"]
        fig["peer"] = res
    return fig
