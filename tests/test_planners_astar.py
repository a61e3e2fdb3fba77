"""Grid A* on a map's own cells against the Moving AI rules, computed independently here.

Ground truth: the octile graph of the cells (8 neighbours, cost 1 straight and sqrt(2) diagonal, a
diagonal only when both cells beside it are free), built in this file from the occupancy grid and
solved by scipy's Dijkstra; nothing of the planner's lattice or search is reused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from planners import PlanningProblem, make_planner
from planners.astar_search import MOVES, Workspace, search
from toolkit.world import Map, OccupancyGrid, grid_to_map, make_checker
from toolkit.world.generated import random_occupancy


def _cells_map(free: np.ndarray, cell_cm: float = 1.0) -> Map:
    return grid_to_map(OccupancyGrid(np.asarray(free, dtype=bool), cell_cm=cell_cm), "cells")


def _centre(i: int, j: int, cell_cm: float = 1.0) -> np.ndarray:
    return np.array([(i + 0.5) * cell_cm, (j + 0.5) * cell_cm])


def _octile_distances(free: np.ndarray, source: tuple[int, int]) -> np.ndarray:
    """Shortest octile lengths (cells) from `source` (column, row) to every cell, Moving AI rules."""
    h, w = free.shape
    idx = np.arange(h * w).reshape(h, w)
    rows, cols, costs = [], [], []
    for dj, di in ((0, 1), (1, 0), (1, 1), (1, -1)):  # each undirected move once
        j0, j1 = max(0, -dj), min(h, h - dj)
        i0, i1 = max(0, -di), min(w, w - di)
        a = free[j0:j1, i0:i1] & free[j0 + dj:j1 + dj, i0 + di:i1 + di]
        if di and dj:  # no corner cutting: both cells beside the diagonal are free
            a &= free[j0 + dj:j1 + dj, i0:i1] & free[j0:j1, i0 + di:i1 + di]
        rows.append(idx[j0:j1, i0:i1][a])
        cols.append(idx[j0 + dj:j1 + dj, i0 + di:i1 + di][a])
        costs.append(np.full(int(a.sum()), math.sqrt(2.0) if di and dj else 1.0))
    r, c, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(costs)
    graph = coo_matrix((v, (r, c)), shape=(h * w, h * w)).tocsr()
    return dijkstra(graph, directed=False, indices=idx[source[1], source[0]]).reshape(h, w)


def test_adjacent_cells_across_a_blocked_corner_are_two_moves_apart() -> None:
    """Start and goal diagonal neighbours with one cell beside them blocked: 2, never sqrt(2).

    The pattern of Moving AI's maze512-1-0 query 0 (start (477, 130), goal (476, 131), optimum 2).
    """
    free = np.ones((3, 3), dtype=bool)  # free[row, column]
    free[1, 2] = False  # cell (column 2, row 1), beside the diagonal (1, 1) -> (2, 2)
    m = _cells_map(free)
    checker = make_checker(m, 0.0)
    start, goal = _centre(1, 1), _centre(2, 2)
    assert checker.segment_free(start, goal), "the segment itself only touches the blocked cell's corner"
    res = make_planner("astar", resolution=None).plan(PlanningProblem(m, checker, start, goal, 5.0, 0))
    assert res.success
    assert res.length == pytest.approx(2.0, abs=1e-12)
    assert _octile_distances(free, (1, 1))[2, 2] == pytest.approx(2.0)
    np.testing.assert_allclose(res.path, [start, _centre(1, 2), goal])


@pytest.mark.parametrize("seed", range(4))
def test_lengths_equal_an_independent_octile_dijkstra(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = random_occupancy(40, 30, density=0.3, rng=seed)
    m = grid_to_map(grid, "random")
    checker = make_checker(m, 0.0)
    planner = make_planner("astar", resolution=None)
    free = grid.free
    cells = np.argwhere(free)  # (row, column)
    checked = 0
    for _ in range(12):
        (sj, si), (gj, gi) = cells[rng.choice(len(cells), 2, replace=False)]
        truth = _octile_distances(free, (int(si), int(sj)))[gj, gi]
        res = planner.plan(PlanningProblem(m, checker, _centre(si, sj), _centre(gi, gj), 5.0, 0))
        if not math.isfinite(truth):
            assert not res.success
            continue
        checked += 1
        assert res.success, res.message
        assert res.length == pytest.approx(truth, rel=1e-12)
        steps = np.abs(np.diff(res.path, axis=0))
        assert np.all(steps.max(axis=1) == 1.0), "every move goes to one of the 8 neighbours"
    assert checked >= 6  # a guard against a vacuous test: most pairs are connected at this density


def test_arena2_queries_match_the_published_optima() -> None:
    """Every tenth query of arena2's 910 (the full set runs in `nxtnav bench scen --check`)."""
    from pathlib import Path

    from toolkit.bench.scen import read_scen
    from toolkit.world import import_map

    external = Path(__file__).resolve().parents[1] / "maps" / "external"
    m = import_map(external / "arena2.map")
    checker = make_checker(m, 0.0)
    planner = make_planner("astar", resolution=None)
    for q in read_scen(external / "arena2.map.scen", m, "octile")[::10]:
        start, goal = q.world(m, "octile")
        res = planner.plan(PlanningProblem(m, checker, start, goal, 10.0, 0))
        assert res.success and res.length == pytest.approx(q.optimal, rel=1e-6, abs=1e-6), q


def test_a_query_gives_the_same_path_whatever_ran_before() -> None:
    grid = random_occupancy(60, 60, density=0.25, rng=11)
    m = grid_to_map(grid, "random")
    checker = make_checker(m, 0.0)
    planner = make_planner("astar", resolution=None)
    cells = np.argwhere(grid.free)
    a, b, c = (_centre(int(col), int(row)) for row, col in cells[[0, len(cells) // 2, -1]])
    first = planner.plan(PlanningProblem(m, checker, a, c, 5.0, 0))
    planner.plan(PlanningProblem(m, checker, b, a, 5.0, 0))
    again = planner.plan(PlanningProblem(m, checker, a, c, 5.0, 0))
    fresh = make_planner("astar", resolution=None).plan(PlanningProblem(m, checker, a, c, 5.0, 0))
    assert first.success
    np.testing.assert_array_equal(first.path, again.path)
    np.testing.assert_array_equal(first.path, fresh.path)


def _open_lattice(nx: int, ny: int, wall_at: int) -> np.ndarray:
    """Move bytes of an nx x ny lattice with every move, except that no move crosses column `wall_at`."""
    moves = np.zeros((nx, ny), dtype=np.uint8)
    for d, (di, dj) in enumerate(MOVES):
        ok = np.zeros((nx, ny), dtype=bool)
        ok[max(0, -di):nx - max(0, di), max(0, -dj):ny - max(0, dj)] = True
        i = np.arange(nx)[:, None]
        ok &= ~(((i <= wall_at) & (i + di > wall_at)) | ((i > wall_at) & (i + di <= wall_at)))
        moves |= ok.astype(np.uint8) << np.uint8(d)
    return moves.ravel()


def test_search_stops_at_its_deadline_and_exhausts_a_closed_lattice() -> None:
    nx = ny = 300
    moves = _open_lattice(nx, ny, wall_at=nx - 2)  # the goal's column is cut off from the rest
    xs, ys = np.arange(nx, dtype=float), np.arange(ny, dtype=float)
    ws = Workspace(nx * ny)
    src = np.array([0], dtype=np.int64)
    goal = np.array([(nx - 1) * ny + ny - 1], dtype=np.int64)
    zero = np.zeros(1)
    late = search(moves, xs, ys, 1.0, ws, (nx - 1.0, ny - 1.0), src, zero, goal, zero, math.inf, octile=True,
                  deadline=0.0)  # already past: one chunk of expansions, then it gives up
    assert late.timed_out and late.nodes is None and 0 < late.expanded < (nx - 1) * ny
    full = search(moves, xs, ys, 1.0, ws, (nx - 1.0, ny - 1.0), src, zero, goal, zero, math.inf, octile=True)
    assert not full.timed_out and full.nodes is None and full.expanded == (nx - 1) * ny  # every reachable node
    open_moves = _open_lattice(nx, ny, wall_at=nx)  # nothing cut: the diagonal, 299 moves
    found = search(open_moves, xs, ys, 1.0, ws, (nx - 1.0, ny - 1.0), src, zero, goal, zero, math.inf, octile=True)
    assert found.nodes is not None and len(found.nodes) == nx and found.nodes[-1] == goal[0]

