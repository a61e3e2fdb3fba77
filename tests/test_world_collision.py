"""The FCL collision checker against shapely ground truth: zero disagreements allowed."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from toolkit.world import CollisionChecker, Map, MapError, load_map, make_checker, map_from_dict

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


STUBS = {
    "name": "stubs",
    "boundary": [[0, 0], [160, 0], [160, 120], [0, 120]],
    "obstacles": [[[100, 70], [130, 70], [130, 95], [100, 95]]],
    "walls": [
        [[40, 30], [40, 90]],  # free-standing
        [[70, 0], [70, 40]],  # from the boundary
        [[95, 25], [120, 25], [120, 50]],  # a polyline
        [[100, 70], [100, 50]],  # from an obstacle's corner
        [[130, 82], [150, 82]],  # from an obstacle's side
    ],
}
"""A room whose thin walls (zero thickness) stand free, touch the boundary and touch an obstacle."""

MAPS = ["map1", "map2", "map3", "pillars", "random:1", "random:2", "stubs", "co333-arena"]


def get_map(name: str) -> Map:
    if name == "stubs":
        return map_from_dict(STUBS)
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


# -- thin walls: zero thickness, seen by both disc backends and by the point checker ---------------

def near_thin_walls(m: Map, n: int, spread: float, rng: np.random.Generator) -> np.ndarray:
    """`n` points scattered about the thin walls (normal offsets of `spread` cm from points along them)."""
    segs = m.thin_segments[rng.integers(0, len(m.thin_segments), n)]
    t = rng.uniform(-0.1, 1.1, (n, 1))
    return segs[:, :2] + t * (segs[:, 2:] - segs[:, :2]) + rng.normal(0.0, spread, (n, 2))


def decided_by_thin_walls(m: Map, geoms: np.ndarray, r: float) -> int:
    """How many geometries lie within r of a thin wall but not of any other wall (the stubs alone decide)."""
    edges = shapely.multilinestrings(m.walls[:len(m.walls) - len(m.thin_segments)].reshape(-1, 2, 2))
    return int(np.sum((shapely.distance(geoms, m.thin_lines) < r) & (shapely.distance(geoms, edges) >= r)))


@pytest.mark.parametrize("radius", [8.0, 3.0])
@pytest.mark.parametrize("backend", ["index", "fcl"])
def test_thin_walls_agree_with_shapely(backend: str, radius: float) -> None:
    m = map_from_dict(STUBS)
    cc = make_checker(m, radius, backend=backend)
    rng = np.random.default_rng(11)
    n = 2000 if backend == "fcl" else N
    xmin, ymin, xmax, ymax = m.bounds
    pts = np.vstack([near_thin_walls(m, n // 2, radius, rng), rng.uniform([xmin, ymin], [xmax, ymax], (n // 2, 2))])
    want = truth_points(m, pts, radius)
    assert decided_by_thin_walls(m, shapely.points(pts[shapely.contains_xy(m.polygon, *pts.T)]), radius) > n // 5
    assert np.array_equal(cc.point_free(pts), want), "point checks"
    a = m.sample_free(n, clearance=radius, rng=rng)
    b = a + rng.normal(0.0, 30.0, a.shape)
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    assert decided_by_thin_walls(m, lines, radius) > n // 10
    assert np.array_equal(cc.segments_free(a, b), truth_segments(m, a, b, radius)), "segment checks"
    inside = pts[shapely.contains_xy(m.polygon, *pts.T)][:300]
    np.testing.assert_allclose(cc.clearance(inside), shapely.distance(shapely.points(inside), m.wall_lines) - radius,
                               atol=1e-6)


def test_point_robot_never_touches_a_thin_wall() -> None:
    """Radius 0: the closed free area minus the thin walls; walls of the boundary may be touched."""
    m = map_from_dict(STUBS)
    cc = make_checker(m, 0.0)
    rng = np.random.default_rng(5)
    on = near_thin_walls(m, 2000, 0.0, rng)  # on the walls' lines, some beyond their ends
    pts = np.vstack([on, near_thin_walls(m, 2000, 2.0, rng)])
    want = shapely.intersects_xy(m.polygon, *pts.T) & ~shapely.intersects_xy(m.thin_lines, *pts.T)
    assert 500 < int(np.sum(~want & shapely.contains_xy(m.polygon, *pts.T)))  # refused only for a thin wall
    assert np.array_equal(cc.point_free(pts), want)
    assert np.array_equal(m.contains(pts), want & shapely.contains_xy(m.polygon, *pts.T))
    a = pts[want]
    b = a + rng.normal(0.0, 15.0, a.shape)
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    hits = shapely.intersects(lines, m.thin_lines)
    assert hits.sum() > 300 and (~hits).sum() > 300
    assert np.array_equal(cc.segments_free(a, b), shapely.covers(m.polygon, lines) & ~hits)
    assert cc.segment_free([0, 60], [40, 60]) is False  # ends on the free-standing wall
    assert cc.segment_free([0, 0], [60, 0])  # along the boundary
    assert not cc.segment_free([60, 0], [80, 0])  # ... but not past the foot of the wall that stands on it


@pytest.mark.parametrize("radius", [0.0, 0.5, 3.0, 8.0])
@pytest.mark.parametrize("backend", ["index", "fcl"])
def test_crossing_a_thin_wall_is_never_free(backend: str, radius: float) -> None:
    m = map_from_dict(STUBS)
    cc = make_checker(m, radius, backend=backend)
    assert cc.point_free([20, 60]) and cc.point_free([60, 60])
    assert not cc.segment_free([20, 60], [60, 60])  # straight through the free-standing wall
    assert not cc.path_free([[20, 100], [20, 60], [60, 60]])
    assert cc.path_free([[20, 60], [20, 105], [60, 105], [60, 60]])  # round its end
    assert not cc.point_free([40, 60])
