"""Row-sweep visibility on grids against the exact grid walk, and `shortest` on grids against polygons."""

from __future__ import annotations

import numpy as np
import pytest

from planners import PlanningProblem, make_planner
from toolkit.world import OccupancyGrid, PointCollisionChecker, grid_to_map
from toolkit.world.grid_kernel import grid_pinches, grid_segments_free
from toolkit.world.grid_visibility import grid_reflex_corners, grid_visibility_edges, grid_visible_points


def _random_grid(rng: np.random.Generator, lo: int, hi: int) -> np.ndarray:
    h, w = rng.integers(lo, hi, 2)
    free = rng.random((h, w)) > rng.choice([0.03, 0.1, 0.25, 0.45])
    if rng.random() < 0.3:  # a pattern rich in pinches (blocked cells meeting diagonally)
        free[::2, ::2] &= rng.random(free[::2, ::2].shape) > 0.5
    return free


def _walk_visible(free: np.ndarray, target: np.ndarray, x: int, y: int) -> set[tuple[int, int]]:
    ys, xs = np.nonzero(target)
    keep = ~((xs == x) & (ys == y))
    xs, ys = xs[keep], ys[keep]
    a = np.repeat([[x, y]], len(xs), axis=0).astype(float)
    ok = grid_segments_free(free, grid_pinches(free), a, np.column_stack([xs, ys]).astype(float))
    return set(zip(xs[ok].tolist(), ys[ok].tolist(), strict=True))


def test_sweep_sees_exactly_what_the_grid_walk_sees() -> None:
    rng = np.random.default_rng(11)
    for _ in range(150):
        free = _random_grid(rng, 3, 30)
        h, w = free.shape
        target = rng.random((h + 1, w + 1)) < 0.7
        for _ in range(3):
            x, y = int(rng.integers(0, w + 1)), int(rng.integers(0, h + 1))
            got = set(map(tuple, grid_visible_points(free, target, x, y).tolist()))
            assert got == _walk_visible(free, target, x, y), (free.astype(int).tolist(), x, y)


def test_sweep_edges_are_the_tangent_pairs_the_grid_walk_finds_free() -> None:
    rng = np.random.default_rng(12)
    for _ in range(40):
        free = _random_grid(rng, 3, 16)
        xy, edges = grid_visibility_edges(free)
        _, quad = grid_reflex_corners(free)
        i, j = np.triu_indices(len(xy), k=1)
        d = xy[i] - xy[j]
        cross = d[:, 0] * d[:, 1]
        tangent = (cross * quad[i, 0] * quad[i, 1] <= 0) & (cross * quad[j, 0] * quad[j, 1] <= 0)
        i, j = i[tangent], j[tangent]
        free_pairs = grid_segments_free(free, grid_pinches(free), xy[i].astype(float), xy[j].astype(float))
        expected = set(zip(i[free_pairs].tolist(), j[free_pairs].tolist(), strict=True))
        assert set(map(tuple, edges.tolist())) == expected


def test_reflex_corners_have_exactly_one_blocked_cell_around() -> None:
    free = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], dtype=bool)  # one hole in the middle
    xy, quad = grid_reflex_corners(free)
    assert sorted(map(tuple, xy.tolist())) == [(1, 1), (1, 2), (2, 1), (2, 2)]
    blocked = {tuple(p): tuple(q) for p, q in zip(xy.tolist(), quad.tolist(), strict=True)}
    assert blocked[(1, 1)] == (1, 1) and blocked[(2, 2)] == (-1, -1)


@pytest.mark.parametrize("seed", [0, 1])
def test_shortest_on_a_grid_equals_the_polygon_graph(seed: int) -> None:
    """The lazy row-sweep graph and the all-pairs polygon graph give the same lengths, query by query."""
    rng = np.random.default_rng(seed)
    free = rng.random((26, 34)) > 0.25
    m = grid_to_map(OccupancyGrid(free, cell_cm=2.0), "random")
    grid_checker = PointCollisionChecker(m)
    poly_checker = PointCollisionChecker(m, use_grid=False)
    assert grid_checker.use_grid and not poly_checker.use_grid
    lazy, full = make_planner("shortest"), make_planner("shortest")
    cells = np.argwhere(free)
    agree = scanned = 0
    for _ in range(30):
        a, b = cells[rng.choice(len(cells), 2, replace=False)]
        s, g = 2.0 * (a[::-1] + rng.integers(0, 2, 2)), 2.0 * (b[::-1] + rng.integers(0, 2, 2))  # cell corners
        r1 = lazy.plan(PlanningProblem(m, grid_checker, s, g))
        r2 = full.plan(PlanningProblem(m, poly_checker, s, g))
        assert r1.success == r2.success, (s, g, r1.status, r2.status)
        if r1.success:
            assert r1.length == pytest.approx(r2.length, rel=1e-9, abs=1e-9)
            assert poly_checker.segments_free(r1.path[:-1], r1.path[1:]).all()
            agree += 1
            scanned = max(scanned, r1.info.get("graph_scanned_nodes", 0))
    assert agree >= 10  # enough reachable pairs to mean something
    assert 0 < scanned < len(grid_reflex_corners(free)[0])  # the sweeps ran, lazily


def test_a_simplified_outline_is_not_taken_for_its_grid() -> None:
    free = np.ones((16, 16), dtype=bool)
    for k in range(3, 13):  # a staircase, whose outline simplification cuts
        free[k, k:k + 2] = False
    exact = grid_to_map(OccupancyGrid(free, cell_cm=1.0), "g")
    simplified = grid_to_map(OccupancyGrid(free, cell_cm=1.0), "g", simplify_cm=1.5)
    assert PointCollisionChecker(exact).use_grid
    assert simplified.polygon.area < exact.polygon.area
    assert not PointCollisionChecker(simplified).use_grid
