"""The indexed, compiled queries equal brute force and shapely on a map with hundreds of obstacles."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from toolkit.world import CollisionChecker, IdealSonar, NxtSonar, load_map, ray_cast, ray_wall_distances
from toolkit.world.edge_index import EdgeIndex, edge_index
from toolkit.world.generated import random_grid_map

GRID = random_grid_map(40, cell_cm=10.0, density=0.5, rng=3)


def brute_force(walls: np.ndarray, origins: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every ray against every wall: the definition the index must reproduce."""
    ox, oy = np.repeat(origins[:, 0], angles.shape[1]), np.repeat(origins[:, 1], angles.shape[1])
    t = ray_wall_distances(walls, ox, oy, np.cos(angles.ravel()), np.sin(angles.ravel()))
    idx = np.argmin(t, axis=1)
    best = t[np.arange(len(t)), idx]
    return best.reshape(angles.shape), np.where(np.isfinite(best), idx, -1).reshape(angles.shape)


def test_grid_map_is_large_and_valid() -> None:
    assert len(GRID.walls) > 500
    assert GRID.polygon.is_valid
    assert len(edge_index(GRID.walls).items) >= len(GRID.walls)


@pytest.mark.parametrize("where", ["inside", "anywhere", "corners"])
def test_ray_cast_equals_brute_force(where: str) -> None:
    rng = np.random.default_rng(0)
    xmin, ymin, xmax, ymax = GRID.bounds
    if where == "inside":
        origins = GRID.sample_free(200, rng=rng)
        angles = rng.uniform(-np.pi, np.pi, (200, 30))
    elif where == "anywhere":  # origins outside the map and rays that miss it too
        origins = rng.uniform([xmin - 50, ymin - 50], [xmax + 50, ymax + 50], (200, 2))
        angles = rng.uniform(-np.pi, np.pi, (200, 30))
    else:  # block corners along the axes and diagonals: rays through vertices and along walls
        origins = rng.integers(0, 41, (200, 2)) * 10.0
        angles = np.tile(np.arange(8) * np.pi / 4, (200, 1))
    want, want_wall = brute_force(GRID.walls, origins, angles)
    got, got_wall = ray_cast(GRID.walls, origins, angles, return_wall=True)
    assert np.isfinite(want).mean() > 0.5
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got_wall, want_wall)


def test_k_crossings_are_the_nearest_within_slack() -> None:
    rng = np.random.default_rng(1)
    origins = GRID.sample_free(100, rng=rng)
    angles = rng.uniform(-np.pi, np.pi, 100)
    t, w = edge_index(GRID.walls).cast(origins[:, 0], origins[:, 1], angles, k=3, slack=25.0)
    full = ray_wall_distances(GRID.walls, origins[:, 0], origins[:, 1], np.cos(angles), np.sin(angles))
    for r in range(100):
        near = np.sort(full[r][full[r] <= full[r].min() + 25.0])[:3]
        np.testing.assert_array_equal(t[r][np.isfinite(t[r])], near)
        assert np.all(full[r, w[r][w[r] >= 0]] == t[r][w[r] >= 0])
    assert (np.isfinite(t).sum(axis=1) > 1).mean() > 0.2  # second crossings do occur


def test_disc_checks_and_clearance_agree_with_shapely() -> None:
    radius = 4.0
    cc = CollisionChecker(GRID, radius)
    rng = np.random.default_rng(2)
    xmin, ymin, xmax, ymax = GRID.bounds
    pts = rng.uniform([xmin - 5, ymin - 5], [xmax + 5, ymax + 5], (5000, 2))
    inside = shapely.contains_xy(GRID.polygon, pts[:, 0], pts[:, 1])
    dist = shapely.distance(shapely.points(pts), GRID.wall_lines)
    want = inside & (dist >= radius)
    assert 0.1 < want.mean() < 0.9
    np.testing.assert_array_equal(cc.point_free(pts), want)
    np.testing.assert_allclose(cc.clearance(pts[inside]), dist[inside] - radius, atol=1e-9)
    b = pts + rng.normal(0.0, 30.0, pts.shape)
    seg = inside & (shapely.distance(shapely.linestrings(np.stack([pts, b], axis=1)), GRID.wall_lines) >= radius)
    assert 0.05 < seg.mean() < 0.9
    np.testing.assert_array_equal(cc.segments_free(pts, b), seg)


def test_sonars_use_the_exact_first_hit() -> None:
    rng = np.random.default_rng(4)
    origins = GRID.sample_free(50, rng=rng)
    angles = rng.uniform(-np.pi, np.pi, (50, 12))
    exact = ray_cast(GRID.walls, origins, angles)
    np.testing.assert_array_equal(IdealSonar(noise_sd=0.0).measure(GRID.walls, origins, angles), exact)
    noisy = IdealSonar(noise_sd=1.0).measure(GRID.walls, origins, angles, rng=5)
    assert abs(float(np.mean(noisy - exact))) < 0.3 and 0.5 < float(np.std(noisy - exact)) < 1.5
    thin = NxtSonar(beam_rays=1, critical_incidence_deg=90.0)
    np.testing.assert_array_equal(thin.echo_distance(GRID.walls, origins, angles), exact)


def test_index_is_built_once_per_walls_array_and_again_after_a_change() -> None:
    m = load_map("map2")
    assert edge_index(m.walls) is edge_index(m.walls)
    walls = m.walls.copy()
    first = edge_index(walls)
    walls[0, 0] += 1.0
    assert edge_index(walls) is not first
    np.testing.assert_array_equal(edge_index(walls).walls, walls)


def test_empty_and_tiny_inputs() -> None:
    empty = EdgeIndex.build(np.zeros((0, 4)))
    t, w = empty.cast(np.zeros(2), np.zeros(2), np.array([0.0, 1.0]))
    assert np.isinf(t).all() and (w == -1).all()
    assert ray_cast([[10, -5, 10, 5]], [0, 0], [0.0, np.pi]).tolist() == [10.0, np.inf]


def test_max_range_drops_far_hits_only() -> None:
    rng = np.random.default_rng(6)
    origins = GRID.sample_free(100, rng=rng)
    angles = rng.uniform(-np.pi, np.pi, (100, 20))
    full = ray_cast(GRID.walls, origins, angles)
    capped = ray_cast(GRID.walls, origins, angles, max_range=40.0)
    near = full <= 40.0
    assert 0.2 < near.mean() < 0.9
    np.testing.assert_array_equal(capped[near], full[near])
    assert np.isinf(capped[~near]).all()


def test_checker_and_index_pickle() -> None:
    """Process pools ship checkers to workers: the index (with its per-thread scratch) must pickle."""
    import pickle

    cc = CollisionChecker(GRID, 4.0)
    a = GRID.sample_free(50, rng=9)
    b = a + 20.0
    want = cc.segments_free(a, b)
    clone = pickle.loads(pickle.dumps(cc))
    np.testing.assert_array_equal(clone.segments_free(a, b), want)
