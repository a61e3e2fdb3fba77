"""The clearance raster only removes work: every answer it gives is shapely's, on dense and open maps."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from toolkit.world import CollisionChecker, Map, load_map
from toolkit.world.clearance_raster import BLOCKED, FREE, UNKNOWN
from toolkit.world.generated import random_grid_map

GRID = random_grid_map(40, cell_cm=10.0, density=0.5, rng=3)
N = 10_000


def truth_points(m: Map, pts: np.ndarray, r: float) -> np.ndarray:
    inside = shapely.contains_xy(m.polygon, pts[:, 0], pts[:, 1])
    return inside & (shapely.distance(shapely.points(pts), m.wall_lines) >= r)


def truth_segments(m: Map, a: np.ndarray, b: np.ndarray, r: float) -> np.ndarray:
    inside = shapely.contains_xy(m.polygon, a[:, 0], a[:, 1])
    return inside & (shapely.distance(shapely.linestrings(np.stack([a, b], axis=1)), m.wall_lines) >= r)


def near_band(m: Map, r: float, rng: np.random.Generator, n: int) -> np.ndarray:
    """Points at a distance close to r from the walls (where the raster must leave the answer open)."""
    lines = np.asarray(m.walls)[rng.integers(0, len(m.walls), n)]
    t = rng.uniform(0, 1, (n, 1))
    foot = lines[:, :2] + t * (lines[:, 2:] - lines[:, :2])
    ang = rng.uniform(-np.pi, np.pi, n)
    d = r + rng.normal(0.0, 0.3, n)
    return foot + d[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])


@pytest.mark.parametrize(("m", "radius"), [(GRID, 4.0), (GRID, 8.0), (load_map("map1"), 8.0),
                                           (load_map("pillars"), 3.0)], ids=["grid-r4", "grid-r8", "map1", "pillars"])
def test_raster_answers_are_exact(m: Map, radius: float) -> None:
    cc = CollisionChecker(m, radius)
    raster = cc.clearance_raster
    rng = np.random.default_rng(11)
    xmin, ymin, xmax, ymax = m.bounds
    pts = np.concatenate([rng.uniform([xmin - 5, ymin - 5], [xmax + 5, ymax + 5], (N, 2)),
                          near_band(m, radius, rng, N)])
    state = raster.points(pts)
    assert (state != UNKNOWN).mean() > 0.5  # the raster decides most random points
    want = truth_points(m, pts, radius)
    assert np.array_equal(want[state == FREE], np.ones(int((state == FREE).sum()), bool))
    assert not want[state == BLOCKED].any()
    np.testing.assert_array_equal(cc.point_free(pts), want)
    for sd in (3.0, 25.0, 200.0):  # short, typical and map-crossing motions
        b = pts + rng.normal(0.0, sd, pts.shape)
        seg = raster.segments(pts, b)
        want_seg = truth_segments(m, pts, b, radius)
        assert want_seg[seg == FREE].all() and not want_seg[seg == BLOCKED].any()
        np.testing.assert_array_equal(cc.segments_free(pts, b), want_seg)


def test_segments_along_cell_lines_and_through_corners() -> None:
    """Axis-parallel segments on the raster's cell lines and diagonals through its cell corners."""
    radius = 4.0
    cc = CollisionChecker(GRID, radius)
    r = cc.clearance_raster
    x0, y0 = r.origin
    k = np.arange(0, min(r.shape) - 1, 3, dtype=float)
    a = np.column_stack([x0 + k * r.cell, y0 + k[::-1] * r.cell])
    steps = np.array([[37.0, 0.0], [0.0, -29.0], [23.0, 23.0], [-17.0, 17.0]]) * r.cell
    for b in (a + step for step in steps):
        np.testing.assert_array_equal(cc.segments_free(a, b), truth_segments(GRID, a, b, radius))


def test_a_checker_asked_little_builds_no_raster() -> None:
    cc = CollisionChecker(load_map("maps/external/depot.yaml"), 8.0)
    cc.point_free(np.array([[500.0, 500.0], [1000.0, 700.0]]))
    cc.segments_free(np.array([[500.0, 500.0]]), np.array([[520.0, 500.0]]))
    assert cc._clearance is None
    assert cc.clearance_raster.nbytes > 0
