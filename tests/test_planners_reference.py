"""The reference planners against ground truth: analytic shortest paths, brute force, shapely geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from planners import PlanningProblem, PlanStatus, make_planner
from planners.reference import (
    MinLinkPlanner,
    ShortestPathPlanner,
    circumradius,
    cspace_polygon,
    polygon_vertices,
)
from toolkit.world import CollisionChecker, load_map, map_from_dict

R = 8.0

# a 100 x 100 room split by a thin wall from the floor up to y = 60 (0.5 cm gap: closed for the disc)
THIN_WALL = {
    "name": "thin-wall",
    "boundary": [[0, 0], [100, 0], [100, 100], [0, 100]],
    "obstacles": [[[49, 0.5], [51, 0.5], [51, 60], [49, 60]]],
    "start": [20, 20],
    "target": [80, 20],
}


def thin_wall_length(start: np.ndarray, r: float) -> float:
    """Exact shortest length over the thin wall for a disc of radius r (symmetric start/goal).

    Tangent from the start to the circle of radius r about the corner (49, 60), arc to the top of
    that circle, 2 cm along the top of the wall, and the mirror image down to the goal.
    """
    c = np.array([49.0, 60.0])
    d = float(np.hypot(*(start - c)))
    tangent = math.sqrt(d * d - r * r)
    phi = math.atan2(start[1] - c[1], start[0] - c[0]) % (2 * math.pi)  # direction corner -> start
    touch = phi - math.acos(r / d)  # the tangent point on the upper-left side
    arc = touch - math.pi / 2
    assert 0 < arc < math.pi
    return 2 * (tangent + r * arc) + 2.0


def test_shortest_matches_the_analytic_length() -> None:
    m = map_from_dict(THIN_WALL)
    checker = CollisionChecker(m, R)
    res = make_planner("shortest").plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    exact = thin_wall_length(m.start, R)
    tol = res.info["length_tolerance_cm"]
    assert res.success
    assert exact - 1e-9 <= res.length <= exact + tol
    assert tol < 0.1  # the bound is tight: about (R' - r) * (turned angle + 2 pi)
    # a coarser polygon stays feasible and within its own (larger) bound
    coarse = ShortestPathPlanner(n_sides=16).plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    assert exact - 1e-9 <= coarse.length <= exact + coarse.info["length_tolerance_cm"]
    assert coarse.info["length_tolerance_cm"] > tol


def test_shortest_is_a_straight_line_when_visible() -> None:
    m = load_map("map1")
    checker = CollisionChecker(m, R)
    res = make_planner("shortest").plan(PlanningProblem(m, checker, [20, 20], [40, 90], 5.0, 0))
    assert len(res.path) == 2 and res.length == pytest.approx(math.hypot(20, 70))


def _all_simple_path_lengths(nodes: np.ndarray, free: np.ndarray, s: int, g: int) -> float:
    """Brute force: the shortest over every simple path from s to g (depth-first enumeration)."""
    best = math.inf
    dist = np.hypot(*(nodes[:, None, :] - nodes[None, :, :]).transpose(2, 0, 1))

    def dfs(u: int, seen: set[int], length: float) -> None:
        nonlocal best
        if length >= best:
            return
        if u == g:
            best = length
            return
        for v in np.flatnonzero(free[u]):
            if int(v) not in seen:
                dfs(int(v), seen | {int(v)}, length + dist[u, v])

    dfs(s, {s}, 0.0)
    return best


@pytest.mark.parametrize("map_name", ["thin", "pillars-small"])
def test_shortest_matches_brute_force_over_all_simple_paths(map_name: str) -> None:
    """With an octagon for the disc the graph is small enough to enumerate every simple path."""
    if map_name == "thin":
        m = map_from_dict(THIN_WALL)
        start, goal = m.start, m.target
    else:
        m = map_from_dict({"boundary": [[0, 0], [120, 0], [120, 80], [0, 80]],
                           "obstacles": [[[40, 20], [60, 20], [60, 60], [40, 60]], [[80, 0.5], [90, 0.5], [90, 40],
                                                                                      [80, 40]]]})
        start, goal = np.array([15.0, 40.0]), np.array([105.0, 15.0])
    checker = CollisionChecker(m, R)
    planner = ShortestPathPlanner(n_sides=8)
    res = planner.plan(PlanningProblem(m, checker, start, goal, 5.0, 0))
    assert res.success
    # every vertex of the polygonal c-space, every pair checked: no tangent filter, no reflex filter
    v, _, _, _ = polygon_vertices(cspace_polygon(m, R, n_sides=8))
    nodes = np.vstack([v, start, goal])
    n = len(nodes)
    iu, ju = np.triu_indices(n, k=1)
    ok = checker.segments_free(nodes[iu], nodes[ju])
    free = np.zeros((n, n), dtype=bool)
    free[iu[ok], ju[ok]] = True
    free |= free.T
    assert n <= 40
    best = _all_simple_path_lengths(nodes, free, n - 2, n - 1)
    assert res.length == pytest.approx(best, rel=1e-9)


@pytest.mark.parametrize("map_name", ["map1", "map2", "map3", "pillars"])
def test_cspace_polygon_lies_inside_the_true_cspace(map_name: str) -> None:
    m = load_map(map_name)
    cs = cspace_polygon(m, R)
    big = circumradius(R)
    assert 0 < big - R < 0.011
    boundary = shapely.get_coordinates(shapely.segmentize(cs.boundary, 0.5))
    assert np.min(m.wall_distance(boundary)) >= R  # every boundary point clears the walls
    # and it contains the true c-space of the circumscribed radius (points with clearance >= R')
    pts = m.sample_free(2000, clearance=big + 1e-6, rng=0)
    assert np.all(shapely.covers(cs, shapely.points(pts)))
    _, reflex, _, _ = polygon_vertices(cs)
    assert reflex.any() and not reflex.all()


def test_min_link_is_exact_on_the_thin_wall() -> None:
    """One segment cannot pass the wall; two can (over its top), so the minimum is 2 links."""
    m = map_from_dict(THIN_WALL)
    checker = CollisionChecker(m, R)
    assert not checker.segment_free(m.start, m.target)
    assert checker.path_free([m.start, [50, 90], m.target])
    res = make_planner("min-link").plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    assert res.success and res.info["links"] == 2 and len(res.path) == 3
    # the shortest two-link path is no longer than the hand-made one
    assert res.length <= float(np.sum(np.hypot(*np.diff([m.start, [50, 90], m.target], axis=0).T)))


@pytest.mark.parametrize("map_name", ["map1", "map2", "map3"])
def test_min_link_counts_on_botsim_maps(map_name: str) -> None:
    """map1: start and target do not see each other, one bend suffices; maps 2 and 3 need two bends."""
    m = load_map(map_name)
    checker = CollisionChecker(m, R)
    res = MinLinkPlanner().plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    expected = {"map1": 2, "map2": 3, "map3": 3}[map_name]
    assert res.info["links"] == expected == len(res.path) - 1
    assert checker.path_free(res.path)


def test_graph_cache_is_reused_per_map() -> None:
    m = load_map("map2")
    checker = CollisionChecker(m, R)
    p = ShortestPathPlanner()
    first = p.plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    second = p.plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    np.testing.assert_array_equal(first.path, second.path)
    assert second.collision_checks < first.collision_checks


def test_no_path_when_the_cspace_is_split() -> None:
    m = map_from_dict({"boundary": [[0, 0], [200, 0], [200, 100], [0, 100]],
                       "obstacles": [[[98, 0.5], [102, 0.5], [102, 45], [98, 45]],
                                     [[98, 55], [102, 55], [102, 99.5], [98, 99.5]]]})
    checker = CollisionChecker(m, R)
    for name in ("shortest", "min-link"):
        res = make_planner(name).plan(PlanningProblem(m, checker, [40, 50], [160, 50], 5.0, 0))
        # the c-space is in two pieces: reported unreachable at once (before the planner runs)
        assert not res.success and res.status is PlanStatus.UNREACHABLE, res.message


@pytest.mark.parametrize("map_name", ["map2", "map3"])
def test_two_links_are_impossible_on_maps_2_and_3(map_name: str) -> None:
    """No point of a 1 cm grid sees both start and target, so min-link's 3 segments are the minimum."""
    m = load_map(map_name)
    checker = CollisionChecker(m, R)
    xmin, ymin, xmax, ymax = m.bounds
    gx, gy = np.meshgrid(np.arange(xmin, xmax, 1.0), np.arange(ymin, ymax, 1.0), indexing="ij")
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    grid = grid[m.is_free(grid, R)]
    seen = grid[checker.segments_free(np.repeat(m.start[None], len(grid), axis=0), grid)]
    assert len(seen) > 100
    both = checker.segments_free(seen, np.repeat(m.target[None], len(seen), axis=0))
    assert not both.any()


def test_shorten_bends_keeps_links_and_never_lengthens() -> None:
    from planners.reference import shorten_bends

    m = load_map("map2")
    checker = CollisionChecker(m, R)
    res = MinLinkPlanner(refine=False).plan(PlanningProblem(m, checker, m.start, m.target, 5.0, 0))
    short = shorten_bends(checker, res.path)
    assert short.shape == res.path.shape
    np.testing.assert_array_equal(short[[0, -1]], res.path[[0, -1]])
    before = float(np.sum(np.hypot(*np.diff(res.path, axis=0).T)))
    after = float(np.sum(np.hypot(*np.diff(short, axis=0).T)))
    assert after <= before and after < before - 1.0  # the graph's bends sit on a 3 cm lattice
    assert checker.path_free(short)
    segs = shapely.linestrings(np.stack([short[:-1], short[1:]], axis=1))
    assert np.all(shapely.distance(segs, m.wall_lines) >= R - 1e-7)
