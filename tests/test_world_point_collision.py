"""The point robot's checker: the compiled grid walk against shapely's exact predicates."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from toolkit.world import CollisionChecker, PointCollisionChecker, import_map, load_map, make_checker, map_from_dict
from toolkit.world.grid_kernel import grid_segments_free

_MAPS = ("arena2", "depot")


@pytest.fixture(scope="module", params=_MAPS)
def checkers(request: pytest.FixtureRequest) -> tuple[PointCollisionChecker, PointCollisionChecker]:
    m = load_map(request.param)
    return PointCollisionChecker(m), PointCollisionChecker(m, use_grid=False)


def _segments(m, kind: str, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    g = m.grid
    lo = np.asarray(g.origin)
    size = np.array([g.width, g.height])
    if kind == "corners":  # lattice points: segments through corners, along edges, grazing walls
        a = rng.integers(0, size + 1, (n, 2)).astype(float)
        b = a + rng.integers(-8, 9, (n, 2))
    elif kind == "axis":  # along grid lines and through cell centres
        a = rng.integers(0, size + 1, (n, 2)).astype(float) + rng.choice([0.0, 0.5], (n, 2))
        b = a.copy()
        axis = rng.integers(0, 2, n)
        b[np.arange(n), axis] += rng.integers(-20, 21, n)
    else:
        a = rng.uniform(0, size, (n, 2))
        b = a + rng.normal(0, 15, (n, 2))
    return lo + a * g.cell_cm, lo + b * g.cell_cm


@pytest.mark.parametrize("kind", ["corners", "axis", "random"])
def test_grid_walk_agrees_with_shapely(checkers: tuple[PointCollisionChecker, PointCollisionChecker],
                                       kind: str) -> None:
    grid, exact = checkers
    a, b = _segments(grid.map, kind, 10_000, np.random.default_rng(1))
    fast, truth = grid.segments_free(a, b), exact.segments_free(a, b)
    assert 0.05 < truth.mean() < 0.95, "both outcomes are exercised"
    assert int((fast != truth).sum()) == 0
    assert np.array_equal(grid.point_free(a), exact.point_free(a))


def test_walls_may_be_touched_but_not_crossed() -> None:
    m = import_map_rows([".....", ".@@@.", "....."])
    cc = PointCollisionChecker(m)
    # the obstacle is [1, 4] x [1, 2]: along its top edge, touching its corner, and through it
    assert cc.segment_free([1, 2], [4, 2])
    assert cc.segment_free([0, 1], [2, 3])  # touches the corner (1, 2) only
    assert not cc.segment_free([0, 3], [4, 1])  # enters the obstacle after (2, 2)
    assert not cc.segment_free([0.5, 0.5], [4.5, 2.5])
    assert cc.segment_free([0, 0], [5, 0]) and not cc.segment_free([0, -0.1], [5, -0.1])


def import_map_rows(rows: list[str]):
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "t.map"
        p.write_text(f"type octile\nheight {len(rows)}\nwidth {len(rows[0])}\nmap\n" + "\n".join(rows) + "\n")
        return import_map(p)


def test_a_segment_along_an_edge_between_two_blocked_cells_is_blocked() -> None:
    m = import_map_rows(["...", ".@.", ".@.", "..."])
    cc = PointCollisionChecker(m)
    assert not cc.segment_free([1.5, 1], [1.5, 3])  # through the blocked column's middle
    assert cc.segment_free([1, 0.5], [1, 3.5])  # along its left side
    f = cc.cells
    assert not grid_segments_free(f, np.zeros((5, 4), dtype=bool), np.array([[1.5, 1.0]]), np.array([[1.5, 3.0]]))[0]


def test_make_checker_picks_the_point_checker_for_radius_zero() -> None:
    m = load_map("map1")
    assert isinstance(make_checker(m, 0.0), PointCollisionChecker)
    assert type(make_checker(m, 8.0)) is CollisionChecker
    cc = make_checker(m, 0.0)
    assert cc.robot_radius == 0.0
    assert cc.point_free([0, 0]) and not cc.point_free([-1, 0])
    assert cc.clearance([20, 20]) == pytest.approx(20.0)


def test_thin_walls_cut_a_grid_map() -> None:
    """A thin wall on a grid map: the cell walk still decides the cells, the walls' segments the rest."""
    base = import_map_rows(["........", "..@@....", "........", "........"])
    m = map_from_dict({**base.to_dict(), "walls": [[[5.5, 0], [5.5, 3]], [[0.5, 3.5], [2, 3.5], [2, 3]]]})
    grid, exact = PointCollisionChecker(m), PointCollisionChecker(m, use_grid=False)
    assert grid.use_grid and not exact.use_grid
    rng = np.random.default_rng(4)
    a = np.vstack([rng.uniform([0, 0], [8, 4], (3000, 2)), rng.integers(0, 9, (1000, 2)) * [1, 0.5]])
    b = a + rng.normal(0.0, 2.0, a.shape)
    lines = shapely.linestrings(np.stack([a, b], axis=1))
    on_thin = shapely.intersects(lines, m.thin_lines)
    truth = shapely.covers(m.polygon, lines) & ~on_thin
    assert 0.2 < truth.mean() < 0.8 and int(np.sum(on_thin & shapely.covers(m.polygon, lines))) > 300
    assert np.array_equal(grid.segments_free(a, b), truth) and np.array_equal(exact.segments_free(a, b), truth)
    want = shapely.intersects_xy(m.polygon, *a.T) & ~shapely.intersects_xy(m.thin_lines, *a.T)
    assert np.array_equal(grid.point_free(a), want) and np.array_equal(exact.point_free(a), want)
    assert not grid.point_free([5.5, 1.5]) and not grid.segment_free([4.5, 1.5], [6.5, 1.5])
