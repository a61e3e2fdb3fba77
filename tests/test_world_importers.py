"""Importing grid maps (ROS map_server, Moving AI): exact free space, regions, pinches, bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import shapely
from conftest import run_cli
from PIL import Image
from scipy import ndimage

from toolkit.world import (
    MapError,
    OccupancyGrid,
    PointCollisionChecker,
    grid_to_map,
    import_map,
    load_map,
    map_from_dict,
)
from toolkit.world.generated import random_occupancy
from toolkit.world.importers import read_movingai_map, read_ros_map, write_movingai_map

EXTERNAL = Path(__file__).resolve().parents[1] / "maps" / "external"
REAL_MAPS = {
    "arena2": EXTERNAL / "arena2.map",
    "AcrosstheCape": EXTERNAL / "AcrosstheCape.map",
    "turtlebot3_world": EXTERNAL / "turtlebot3_world.yaml",
    "depot": EXTERNAL / "depot.yaml",
}


def _reader(path: Path) -> OccupancyGrid:
    return read_movingai_map(path) if path.suffix == ".map" else read_ros_map(path)


@pytest.fixture(scope="module", params=list(REAL_MAPS))
def real(request: pytest.FixtureRequest) -> tuple[OccupancyGrid, object]:
    path = REAL_MAPS[request.param]
    return _reader(path), import_map(path)


def _cell_of(grid: OccupancyGrid, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ij = np.floor((pts - np.asarray(grid.origin)) / grid.cell_cm).astype(int)
    return ij[:, 0], ij[:, 1]


def test_free_space_equals_the_free_cells(real: tuple[OccupancyGrid, object]) -> None:
    """10,000 random points (and every cell centre): inside the polygons exactly when their cell is free."""
    grid, m = real
    h, w = grid.free.shape
    x0, y0 = grid.origin
    c = grid.cell_cm
    rng = np.random.default_rng(0)
    pts = rng.uniform([x0, y0], [x0 + w * c, y0 + h * c], (10_000, 2))
    i, j = _cell_of(grid, pts)
    truth = grid.free[j, i]
    inside = shapely.contains_xy(m.polygon, pts[:, 0], pts[:, 1])
    assert truth.any() and (~truth).any()
    assert int((inside != truth).sum()) == 0
    centres = m.grid.centres().reshape(-1, 2)
    assert np.array_equal(shapely.contains_xy(m.polygon, centres[:, 0], centres[:, 1]), grid.free.ravel())
    assert m.area == pytest.approx(grid.free.sum() * c * c)


def test_regions_are_the_4_connected_groups_of_free_cells(real: tuple[OccupancyGrid, object]) -> None:
    grid, m = real
    labels, n = ndimage.label(grid.free)  # 4-connectivity
    assert len(m.regions) == n
    sizes = sorted(np.bincount(labels.ravel())[1:] * grid.cell_cm**2)
    assert sorted(r.polygon.area for r in m.regions) == pytest.approx(sizes)


def test_every_double_corner_closes_the_passage(real: tuple[OccupancyGrid, object]) -> None:
    grid, m = real
    f = np.zeros((grid.free.shape[0] + 2, grid.free.shape[1] + 2), dtype=bool)
    f[1:-1, 1:-1] = grid.free
    sw, se, nw, ne = f[:-1, :-1], f[:-1, 1:], f[1:, :-1], f[1:, 1:]
    rising = sw & ne & ~se & ~nw
    falling = se & nw & ~sw & ~ne
    jj, ii = np.nonzero(rising | falling)
    assert len(ii), "every shipped map has a double corner (else this test would check nothing)"
    corners = np.column_stack([grid.origin[0] + ii * grid.cell_cm, grid.origin[1] + jj * grid.cell_cm])
    assert {tuple(p) for p in corners} == {tuple(p) for p in m.pinch_points}
    # the corner is on the boundary, not inside, and the diagonal through it is blocked
    assert not shapely.contains_xy(m.polygon, corners[:, 0], corners[:, 1]).any()
    d = 0.25 * grid.cell_cm
    step = np.where(rising[jj, ii][:, None], [d, d], [d, -d])  # along the free diagonal
    cc = PointCollisionChecker(m)
    a, b = corners - step, corners + step
    assert cc.point_free(a).all() and cc.point_free(b).all()
    assert not cc.segments_free(a, b).any()
    assert not PointCollisionChecker(m, use_grid=False).segments_free(a, b).any()


def test_names_resolve_to_external_maps() -> None:
    m = load_map("arena2")
    assert m.grid is not None and (m.grid.width, m.grid.height) == (281, 209)
    assert len(m.walls) == 1076
    assert load_map("turtlebot3_world").grid.cell_cm == pytest.approx(5.0)


def test_map_yaml_round_trip_keeps_regions(tmp_path: Path) -> None:
    m = import_map(REAL_MAPS["depot"])
    again = map_from_dict(m.to_dict())
    assert len(again.regions) == len(m.regions)
    assert again.polygon.equals(m.polygon)
    assert again.grid == m.grid


# -- ROS map_server semantics on small images ---------------------------------------------------

def _ros(tmp_path: Path, pixels: np.ndarray, image: str = "m.pgm", **fields: object) -> Path:
    Image.fromarray(pixels.astype(np.uint8)).save(tmp_path / image)
    doc = {"image": image, "resolution": 0.05, "origin": [-1.0, 2.0, 0.0], "negate": 0,
           "occupied_thresh": 0.65, "free_thresh": 0.196, **fields}
    p = tmp_path / "m.yaml"
    p.write_text("\n".join(f"{k}: {v}" for k, v in doc.items()) + "\n")
    return p


PIXELS = np.array([[254, 0, 205],
                   [254, 254, 0]])  # free, occupied, unknown / free, free, occupied; row 0 on top


def test_ros_trinary_unknown_origin_and_resolution(tmp_path: Path) -> None:
    g = read_ros_map(_ros(tmp_path, PIXELS))
    assert g.cell_cm == pytest.approx(5.0) and g.origin == pytest.approx((-100.0, 200.0))
    np.testing.assert_array_equal(g.free, [[True, True, False], [True, False, False]])  # bottom row first
    g2 = read_ros_map(_ros(tmp_path, PIXELS), unknown="free")
    assert g2.free[1, 2]
    m = import_map(tmp_path / "m.yaml")
    assert m.contains([-100 + 2.5, 200 + 7.5]) and not m.contains([-100 + 7.5, 200 + 7.5])


def test_ros_negate_and_raw_modes(tmp_path: Path) -> None:
    g = read_ros_map(_ros(tmp_path, 255 - PIXELS, negate=1))
    np.testing.assert_array_equal(g.free, [[True, True, False], [True, False, False]])
    raw = np.array([[0, 100, 255], [0, 0, 50]])
    g = read_ros_map(_ros(tmp_path, raw, mode="raw"))
    np.testing.assert_array_equal(g.free, [[True, True, False], [True, False, False]])


@pytest.mark.parametrize("fmt", ["P2", "P5", "PNG"])
def test_ros_image_formats(tmp_path: Path, fmt: str) -> None:
    if fmt == "P2":  # ASCII PGM, written by hand
        (tmp_path / "m.pgm").write_text("P2\n3 2\n255\n254 0 205\n254 254 0\n")
        p = tmp_path / "m.yaml"
        p.write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                     "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    else:
        p = _ros(tmp_path, PIXELS, image="m.png" if fmt == "PNG" else "m.pgm")
    np.testing.assert_array_equal(read_ros_map(p).free, [[True, True, False], [True, False, False]])


# -- Moving AI --------------------------------------------------------------------------------

def _movingai(tmp_path: Path, rows: list[str], header: str | None = None) -> Path:
    p = tmp_path / "t.map"
    head = header if header is not None else f"type octile\nheight {len(rows)}\nwidth {len(rows[0])}\nmap\n"
    p.write_text(head + "\n".join(rows) + "\n")
    return p


def test_movingai_terrain_and_cell_size(tmp_path: Path) -> None:
    p = _movingai(tmp_path, [".G@", "STW", "O.."])
    g = read_movingai_map(p, cell_cm=2.0)
    np.testing.assert_array_equal(g.free, [[False, True, True], [True, False, False], [True, True, False]])
    m = import_map(p, cell_cm=2.0)
    assert m.area == pytest.approx(5 * 4.0)


def test_two_cells_meeting_at_a_corner_are_two_regions(tmp_path: Path) -> None:
    m = import_map(_movingai(tmp_path, [".@", "@."]))
    assert len(m.regions) == 2 and len(m.pinch_points) == 1
    assert m.region_of([0.5, 1.5]) != m.region_of([1.5, 0.5])
    from planners import make_planner
    from planners.base import PlanningProblem, PlanStatus

    for name in ("astar", "shortest", "min-turn"):
        opts = {"resolution": None} if name == "astar" else {}
        res = make_planner(name, **opts).plan(PlanningProblem.create(m, 0.0, [0.5, 1.5], [1.5, 0.5], 1.0, 0))
        assert not res.success and res.status is PlanStatus.UNREACHABLE, (name, res.message)


def test_simplify_only_grows_obstacles(tmp_path: Path) -> None:
    exact = import_map(REAL_MAPS["depot"])
    simple = import_map(REAL_MAPS["depot"], simplify_cm=10.0)
    assert len(simple.walls) < len(exact.walls)
    assert shapely.difference(simple.polygon, exact.polygon).area < 1e-6


@pytest.mark.parametrize(
    ("rows", "header", "message"),
    [
        ([".@.", ".."], None, r"line 6 \(map row 1\): 2 characters, the header says width 3"),
        ([".x."], None, "unknown terrain 'x'"),
        ([".."], "type octile\nheight 3\nwidth 2\nmap\n", "height 3 but only 1 rows"),
        ([".."], "type tile\nheight 1\nwidth 2\nmap\n", "type' must be octile"),
        ([".."], "type octile\nheight 1\nwidth 2\n", "line 4: expected a header line 'key value' or 'map'"),
        (["@@"], None, "no free cell"),
    ],
)
def test_movingai_errors(tmp_path: Path, rows: list[str], header: str | None, message: str) -> None:
    p = _movingai(tmp_path, rows, header)
    with pytest.raises(MapError, match=message) as exc:
        import_map(p)
    assert str(p) in str(exc.value) and "\n" not in str(exc.value)


def test_ros_errors(tmp_path: Path) -> None:
    p = _ros(tmp_path, PIXELS)
    (tmp_path / "m.pgm").unlink()
    with pytest.raises(MapError, match=r"image .*m.pgm' not found"):
        import_map(p)
    # a PGM whose pixel data is shorter than its header says
    (tmp_path / "m.pgm").write_bytes(b"P5\n30 20\n255\n" + bytes(100))
    with pytest.raises(MapError, match=r"m.pgm: cannot read map image") as exc:
        import_map(p)
    assert "\n" not in str(exc.value)
    p.write_text("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\noccupied_thresh: 0.65\nfree_thresh: 0.2\n")
    with pytest.raises(MapError, match="resolution must be positive"):
        import_map(p)


def test_grid_to_map_rejects_an_empty_grid() -> None:
    with pytest.raises(MapError, match="no free cell"):
        grid_to_map(OccupancyGrid(np.zeros((3, 3), dtype=bool)), "empty")


def test_a_written_movingai_map_reads_back_cell_for_cell(tmp_path: Path) -> None:
    grid = random_occupancy(13, 7, density=0.3, rng=5)
    write_movingai_map(grid, tmp_path / "r.map")
    back = read_movingai_map(tmp_path / "r.map")
    assert back.free.shape == (7, 13) and np.array_equal(back.free, grid.free)
    assert not (tmp_path / "r.map.part").exists()


def test_maps_random_writes_a_seeded_map_and_never_overwrites_unasked(tmp_path: Path) -> None:
    out = tmp_path / "r.map"
    assert run_cli(["maps", "random", "24", "-o", str(out), "--density", "0.25", "--seed", "4"]) == 0
    first = out.read_text()
    assert run_cli(["maps", "random", "24", "-o", str(out), "--seed", "5"]) == 2
    assert out.read_text() == first  # refused, untouched
    assert run_cli(["maps", "random", "24", "-o", str(out), "--density", "0.25", "--seed", "4", "--force"]) == 0
    assert out.read_text() == first  # same seed, same map
    blocked = (~read_movingai_map(out).free).mean()
    assert 0.1 < blocked < 0.4
    assert run_cli(["maps", "random", "24", "-o", str(tmp_path / "x.map"), "--density", "1.5"]) == 2
