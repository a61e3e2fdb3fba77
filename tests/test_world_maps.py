"""Map files: the bundled maps, precise errors for bad files, and a fuzzer over malformed input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from toolkit.world import Map, MapError, list_maps, load_map, map_from_dict

PAPER = {
    "map1": ((20, 20), (80, 80), 8),
    "map2": ((30, 20), (100, 20), 10),
    "map3": ((50, 70), (230, 70), 25),
}


@pytest.mark.parametrize("name", list(PAPER))
def test_bundled_maps(name: str) -> None:
    m = load_map(name)
    start, target, n_walls = PAPER[name]
    assert m.name == name
    assert m.walls.shape == (n_walls, 4)
    np.testing.assert_array_equal(m.start, start)
    np.testing.assert_array_equal(m.target, target)
    assert m.polygon.is_valid and m.area > 0


def test_names_resolve_from_any_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert {"map1", "map2", "map3"} <= set(list_maps())
    assert load_map("map2").name == "map2"


def test_search_path_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "room.yaml").write_text("boundary: [[0, 0], [10, 0], [10, 10], [0, 10]]\n")
    monkeypatch.setenv("NXTNAV_MAPS", str(tmp_path))
    m = load_map("room")
    assert m.name == "room" and m.area == pytest.approx(100.0)


def write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "m.yaml"
    p.write_text(text)
    return p


SQUARE = "[[0, 0], [100, 0], [100, 100], [0, 100]]"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("boundary: [[0, 0], [1, 0]]", "at least 3 vertices"),
        ("boundary: [[0, 0], [1, 1], [2, 2]]", "zero area"),
        ("boundary: [[0, 0], [10, 10], [10, 0], [0, 10]]", r"self-intersecting, edge 0 \(0->1\) meets edge 2 \(2->3\) "
                                                             r"at \(5, 5\)"),
        ("boundary: [[0, 0], [.nan, 0], [0, 1]]", "vertex 1.*finite"),
        ("boundary: [[0, 0], [.inf, 0], [0, 1]]", "finite"),
        ("boundary: [[0, 0], ['a', 0], [0, 1]]", r"vertex 1\[0\]: expected a number, got str"),
        ("boundary: [[0, 0], [true, 0], [0, 1]]", "expected a number, got bool"),
        ("boundary: [[0, 0, 0], [1, 0], [0, 1]]", r"vertex 0: expected a point \[x, y\]"),
        ("boundary: 5", "expected a list of"),
        ("name: m", "missing field 'boundary'"),
        ("- 1\n- 2", "expected a mapping"),
        ("boundary: [[0, 0], [1, 0], [0, 1]]\ncolour: red", "unknown field"),
        ("boundary: [[0, 0], [1, 0], [0, 1]]\nname: 3", "'name' must be a non-empty string"),
        ("boundary: [[0, 0], [1, 0], [1, 0], [0, 1]]", "vertices 1 and 2 are the same point"),
        (f"boundary: {SQUARE}\nobstacles: [[[90, 90], [110, 90], [110, 110]]]", "obstacle 0 is not strictly inside"),
        (f"boundary: {SQUARE}\nobstacles: [[[0, 10], [20, 10], [20, 20]]]", "obstacle 0 is not strictly inside"),
        (f"boundary: {SQUARE}\nobstacles: [[[10, 10], [30, 10], [30, 30]], [[20, 12], [40, 12], [40, 40]]]",
         "obstacles 0 and 1 overlap"),
        (f"boundary: {SQUARE}\nobstacles: 3", "'obstacles' must be a list"),
        (f"boundary: {SQUARE}\nstart: [150, 50]", r"start \[150.0, 50.0\] is outside the free space"),
        (f"boundary: {SQUARE}\nobstacles: [[[10, 10], [30, 10], [30, 30]]]\ntarget: [25, 15]", "target .* outside"),
        (f"boundary: {SQUARE}\nstart: [1, 2, 3]", r"start: expected a point"),
        ("boundary: [[0, 0], [1, 0]\n", "not valid YAML at line"),
        ("regions: 3", "'regions' must be a non-empty list"),
        ("regions: [{holes: []}]", "region 0: missing field 'boundary'"),
        (f"regions: [{{boundary: {SQUARE}, holes: [[[150, 150], [160, 150], [160, 160]]]}}]",
         "region 0: invalid polygon: Hole lies outside shell"),
        (f"regions: [{{boundary: {SQUARE}, holes: [[[10, 10], [.nan, 10], [20, 20]]]}}]", r"hole 0 vertex 1.*finite"),
        (f"regions: [{{boundary: {SQUARE}}}, {{boundary: [[50, 50], [150, 50], [150, 150]]}}]",
         "regions 0 and 1 overlap or share an edge"),
        (f"regions: [{{boundary: {SQUARE}}}]\nboundary: {SQUARE}", "either 'regions' or 'boundary'"),
        (f"regions: [{{boundary: {SQUARE}, colour: red}}]", "region 0: unknown field"),
        (f"boundary: {SQUARE}\ngrid: {{cell_cm: 0, origin: [0, 0], width: 2, height: 2}}", "cell_cm must be positive"),
    ],
)
def test_precise_errors(tmp_path: Path, text: str, message: str) -> None:
    p = write(tmp_path, text)
    with pytest.raises(MapError, match=message) as exc:
        load_map(p)
    assert str(p) in str(exc.value)
    assert "\n" not in str(exc.value)


def test_missing_file_and_unknown_name(tmp_path: Path) -> None:
    with pytest.raises(MapError, match="not found"):
        load_map(tmp_path / "nope.yaml")
    with pytest.raises(MapError, match=r"unknown map 'nomap'; known: .*map1"):
        load_map("nomap")


def test_closed_ring_is_accepted(tmp_path: Path) -> None:
    m = load_map(write(tmp_path, "boundary: [[0, 0], [10, 0], [10, 10], [0, 0]]"))
    assert len(m.boundary) == 3


def test_sample_free_respects_clearance() -> None:
    m = load_map("map3")
    pts = m.sample_free(2000, clearance=8.0, rng=0)
    assert pts.shape == (2000, 2)
    assert m.contains(pts).all()
    assert (shapely.distance(shapely.points(pts), m.wall_lines) >= 8.0).all()
    np.testing.assert_array_equal(pts, m.sample_free(2000, clearance=8.0, rng=0))


def test_free_space_shrinks_by_radius() -> None:
    m = load_map("map1")
    c = m.free_space(8.0)
    pts = m.sample_free(3000, rng=2)
    inside = shapely.contains_xy(c, pts[:, 0], pts[:, 1])
    d = shapely.distance(shapely.points(pts), m.wall_lines)
    assert (d[inside] >= 8.0 - 1e-6).all()
    assert (inside[d > 8.05]).all()


# -- fuzzing: every malformed file gives MapError or a valid map ------------------------------------

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=32),
    st.integers(-1000, 1000),
    st.booleans(),
    st.text(max_size=3),
    st.none(),
)
points = st.one_of(st.lists(numbers, min_size=0, max_size=4), numbers)
rings = st.one_of(st.lists(points, max_size=7), numbers)
maps = st.dictionaries(
    st.sampled_from(["name", "description", "boundary", "obstacles", "walls", "start", "target", "extra"]),
    st.one_of(rings, st.lists(rings, max_size=3), points, st.text(max_size=5)),
)
plausible = st.builds(
    lambda b, o, w, s, t: {"boundary": b, "obstacles": o, "walls": w, "start": s, "target": t},
    st.lists(st.tuples(st.integers(-5, 105), st.integers(-5, 105)).map(list), min_size=0, max_size=8),
    st.lists(st.lists(st.tuples(st.integers(0, 100), st.integers(0, 100)).map(list), max_size=5), max_size=3),
    st.lists(st.lists(st.tuples(st.integers(0, 100), st.integers(0, 100)).map(list), max_size=4), max_size=3),
    st.one_of(st.none(), st.tuples(st.integers(-10, 110), st.integers(-10, 110)).map(list)),
    st.one_of(st.none(), st.tuples(st.floats(-10, 110), st.floats(-10, 110)).map(list)),
)


def check_valid(m: Map) -> None:
    assert shapely.Polygon(m.boundary).is_valid
    assert m.polygon.is_valid and m.area > 0
    assert all(math.isfinite(v) for v in m.walls.ravel())
    for p in (m.start, m.target):
        if p is not None:
            assert m.contains(p)
    assert all(len(w) >= 2 for w in m.thin_walls) and (not m.thin_walls or m.polygon.covers(m.thin_lines))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.one_of(maps, plausible))
def test_fuzz_structures(tmp_path: Path, data: dict) -> None:
    p = tmp_path / "fuzz.yaml"
    p.write_text(yaml.safe_dump(data))
    try:
        m = load_map(p)
    except MapError as exc:
        assert str(exc)
    else:
        check_valid(m)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(max_size=200))
def test_fuzz_raw_text(tmp_path: Path, text: str) -> None:
    p = tmp_path / "fuzz.yaml"
    p.write_text(text, encoding="utf-8")
    try:
        m = load_map(p)
    except MapError:
        pass
    else:
        check_valid(m)


def test_map_from_dict_round_trip() -> None:
    m = load_map("pillars")
    again = map_from_dict(m.to_dict())
    np.testing.assert_array_equal(again.walls, m.walls)
