"""The FCL collision checker against shapely ground truth: zero disagreements allowed."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from toolkit.world import CollisionChecker, Map, MapError, load_map, map_from_dict

RADIUS = 8.0
N = 10_000


def truth_points(m: Map, pts: np.ndarray, r: float) -> np.ndarray:
    """A disc of radius r at each point is free: inside the free area and no wall closer than r."""
    inside = shapely.contains_xy(m.polygon, pts[:, 0], pts[:, 1])
    return inside & (shapely.distance(shapely.points(pts), m.wall_lines) >= r)


def truth_segments(m: Map, a: np.ndarray, b: np.ndarray, r: float) -> np.ndarray:
    """The disc swept from a to b (the segment buffered by r) touches no wall and starts inside."""
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    inside = shapely.contains_xy(m.polygon, a[:, 0], a[:, 1])
    return inside & (shapely.distance(lines, m.wall_lines) >= r)


def random_obstacle_map(seed: int) -> Map:
    """A square room with random non-overlapping convex and concave obstacles."""
    rng = np.random.default_rng(seed)
    placed: list[shapely.Polygon] = []
    while len(placed) < 5:
        c = rng.uniform(15, 105, 2)
        k = int(rng.integers(3, 8))
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        rad = rng.uniform(3, 12, k)
        poly = shapely.Polygon(c + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]))
        if poly.is_valid and poly.area > 5 and all(poly.distance(p) > 1 for p in placed):
            if shapely.box(1, 1, 119, 119).contains(poly):
                placed.append(poly)
    data = {
        "name": f"random{seed}",
        "boundary": [[0, 0], [120, 0], [120, 120], [0, 120]],
        "obstacles": [np.asarray(p.exterior.coords)[:-1].tolist() for p in placed],
    }
    return map_from_dict(data)


MAPS = ["map1", "map2", "map3", "pillars", "random:1", "random:2"]


def get_map(name: str) -> Map:
    return random_obstacle_map(int(name.split(":")[1])) if name.startswith("random:") else load_map(name)


@pytest.mark.parametrize("name", MAPS)
def test_points_agree_with_shapely(name: str) -> None:
    m = get_map(name)
    cc = CollisionChecker(m, RADIUS)
    rng = np.random.default_rng(42)
    xmin, ymin, xmax, ymax = m.bounds
    pts = rng.uniform([xmin - 5, ymin - 5], [xmax + 5, ymax + 5], (N, 2))
    got = cc.point_free(pts)
    want = truth_points(m, pts, RADIUS)
    assert 0.15 < want.mean() < 0.95  # both outcomes well represented
    assert np.array_equal(got, want), f"{np.sum(got != want)} disagreements"
    assert cc.point_checks == N


@pytest.mark.parametrize("name", MAPS)
def test_segments_agree_with_shapely(name: str) -> None:
    m = get_map(name)
    cc = CollisionChecker(m, RADIUS)
    rng = np.random.default_rng(7)
    a = m.sample_free(N, clearance=RADIUS, rng=rng)  # starts mostly free, so the sweep decides
    b = a + rng.normal(0.0, 25.0, (N, 2))
    got = cc.segments_free(a, b)
    want = truth_segments(m, a, b, RADIUS)
    assert 0.1 < want.mean() < 0.9
    assert np.array_equal(got, want), f"{np.sum(got != want)} disagreements"
    assert cc.segment_checks == N


def test_segments_from_anywhere_agree() -> None:
    m = load_map("map3")
    cc = CollisionChecker(m, 5.0)
    rng = np.random.default_rng(3)
    xmin, ymin, xmax, ymax = m.bounds
    a = rng.uniform([xmin, ymin], [xmax, ymax], (N, 2))
    b = rng.uniform([xmin, ymin], [xmax, ymax], (N, 2))
    assert np.array_equal(cc.segments_free(a, b), truth_segments(m, a, b, 5.0))


def test_thin_wall_cannot_be_tunnelled() -> None:
    """A long segment across a thin obstacle collides although both ends are free (no tunnelling)."""
    m = map_from_dict({"boundary": [[0, 0], [200, 0], [200, 100], [0, 100]],
                       "obstacles": [[[99.9, 10], [100.1, 10], [100.1, 90], [99.9, 90]]]})
    cc = CollisionChecker(m, 3.0)
    assert cc.point_free([20, 50]) and cc.point_free([180, 50])
    assert not cc.segment_free([20, 50], [180, 50])
    # 5 cm from the top wall and from the obstacle's end: free for radius 3, blocked for radius 6
    assert cc.segment_free([20, 95], [180, 95])
    assert cc.segment_free([20, 5], [180, 5])
    assert not CollisionChecker(m, 6.0).segment_free([20, 95], [180, 95])


def test_clearance_matches_distance() -> None:
    m = load_map("map2")
    cc = CollisionChecker(m, RADIUS)
    pts = m.sample_free(500, rng=1)
    want = shapely.distance(shapely.points(pts), m.wall_lines) - RADIUS
    got = cc.clearance(pts)
    np.testing.assert_allclose(got, want, atol=1e-6)
    assert cc.clearance([-10.0, -10.0]) == -np.inf


def test_first_contact_stops_at_the_wall() -> None:
    m = load_map("map1")
    cc = CollisionChecker(m, RADIUS)
    frac = cc.first_contact([20, 20], [20, -80])  # straight down into the wall y = 0
    stop = np.array([20, 20]) + frac * np.array([0, -100])
    assert stop[1] == pytest.approx(RADIUS, abs=2e-3)
    assert cc.point_free(stop)


def test_path_free_and_counters() -> None:
    m = load_map("map1")
    cc = CollisionChecker(m, RADIUS)
    assert cc.path_free([[20, 20], [20, 80], [80, 80]])
    assert not cc.path_free([[20, 20], [80, 80]])  # cuts the notch corner
    assert cc.checks == cc.point_checks + cc.segment_checks > 0
    cc.reset_counters()
    assert cc.checks == 0


@pytest.mark.parametrize("radius", [0.0, -1.0, float("nan")])
def test_bad_radius(radius: float) -> None:
    with pytest.raises(MapError, match="robot_radius"):
        CollisionChecker(load_map("map1"), radius)
