"""Thin walls (zero thickness) in maps: the file field, free space, ray casting, and the CO333 arena.

The collision checkers' answers near thin walls are compared with shapely in `test_world_collision`.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
import shapely

from toolkit.world import (
    IdealSonar,
    MapError,
    list_maps,
    load_map,
    make_checker,
    map_from_dict,
    ray_cast,
    ray_wall_distances,
)

SQUARE = [[0, 0], [100, 0], [100, 100], [0, 100]]
ROOM = {
    "name": "room",
    "boundary": SQUARE,
    "obstacles": [[[60, 60], [80, 60], [80, 80], [60, 80]]],
    "walls": [
        [[30, 20], [30, 70]],  # one segment, free-standing
        [[0, 50], [15, 50], [15, 90]],  # a polyline from the boundary
        [[60, 60], [60, 40]],  # from an obstacle's corner
        [[50, 100], [50, 80]],  # hanging from the top wall
    ],
}


def test_walls_are_polylines_appended_to_the_walls() -> None:
    m = map_from_dict(ROOM)
    assert len(m.thin_walls) == 4 and [len(w) for w in m.thin_walls] == [2, 3, 2, 2]
    assert m.thin_segments.shape == (5, 4)
    assert m.walls.shape == (4 + 4 + 5, 4)
    np.testing.assert_array_equal(m.walls[-5:], m.thin_segments)
    np.testing.assert_array_equal(m.thin_segments[1:3], [[0, 50, 15, 50], [15, 50, 15, 90]])
    assert m.area == pytest.approx(100 * 100 - 20 * 20)  # zero thickness: no area
    again = map_from_dict(m.to_dict())
    np.testing.assert_array_equal(again.walls, m.walls)
    assert [w.tolist() for w in again.thin_walls] == [w.tolist() for w in m.thin_walls]


def test_a_map_without_walls_is_unchanged() -> None:
    m = load_map("pillars")
    assert m.thin_walls == () and m.thin_segments.shape == (0, 4) and "walls" not in m.to_dict()
    assert m.free_space(0.0) is m.polygon


def test_regions_may_have_walls() -> None:
    m = map_from_dict({"regions": [{"boundary": SQUARE}, {"boundary": [[100, 0], [200, 0], [200, 100]]}],
                       "walls": [[[150, 10], [190, 10]]]})
    assert m.walls.shape == (8, 4) and not m.contains([170, 10]) and m.contains([170, 11])


@pytest.mark.parametrize(
    ("walls", "message"),
    [
        ("[[[10, 10], [10, 10]]]", r"wall 0 vertex 1: zero-length segment, the same point \[10.0, 10.0\] as vertex 0"),
        ("[[[10, 10], [20, 10], [20, 10]]]", r"wall 0 vertex 2: zero-length segment"),
        ("[[[10, 10], [20, 20]], [[50, 50], [150, 50]]]", r"wall 1 vertex 1: \[150.0, 50.0\] is outside the free"),
        ("[[[10, 10], [20, 20]], [[50, 50], [70, 70]]]", r"wall 1 vertex 1: \[70.0, 70.0\] is outside the free space"),
        ("[[[50, 65], [90, 65]]]", r"wall 0: segment vertex 0 -> 1 leaves the free space of the map at \(70, 65\)"),
        ("[[[10, 10], [.nan, 20]]]", r"wall 0 vertex 1\[0\]: coordinate must be finite"),
        ("[[[10, 10], [.inf, 20]]]", r"wall 0 vertex 1\[0\]: coordinate must be finite"),
        ("[[[10, 10], ['a', 20]]]", r"wall 0 vertex 1\[0\]: expected a number, got str"),
        ("[[[10, 10]]]", "wall 0: a wall needs at least 2 points, got 1"),
        ("[[[10, 10], [20, 20, 30]]]", r"wall 0 vertex 1: expected a point \[x, y\]"),
        ("[[10, 10], [20, 20]]", r"wall 0 vertex 0: expected a point \[x, y\], got 10"),
        ("[5]", "wall 0: expected a list of"),
        ("5", "field 'walls' must be a list of polylines"),
    ],
)
def test_bad_walls_are_named(tmp_path: Path, walls: str, message: str) -> None:
    p = tmp_path / "m.yaml"
    p.write_text(f"boundary: {SQUARE}\nobstacles: [[[60, 60], [80, 60], [80, 80], [60, 80]]]\nwalls: {walls}\n")
    with pytest.raises(MapError, match=message) as exc:
        load_map(p)
    assert str(exc.value).startswith(f"{p}: ") and "\n" not in str(exc.value)


def test_a_preset_on_a_wall_is_refused() -> None:
    with pytest.raises(MapError, match=r"map: start \[30.0, 40.0\] lies on wall 0"):
        map_from_dict({**ROOM, "start": [30, 40]})


def test_walls_may_touch_and_run_along_the_boundary() -> None:
    m = map_from_dict({"boundary": SQUARE, "obstacles": [[[60, 60], [80, 60], [80, 80], [60, 80]]],
                       "walls": [[[0, 0], [0, 30]], [[60, 60], [80, 60]], [[100, 100], [80, 80]]]})
    assert len(m.thin_segments) == 3


def test_points_on_a_thin_wall_are_not_free() -> None:
    m = map_from_dict(ROOM)
    on = np.array([[30, 20], [30, 45], [30, 70], [15, 70], [7.5, 50], [60, 50], [50, 90]])
    beside = on + np.array([0.5, 0.5])
    assert not m.contains(on).any() and m.contains(beside).all()
    assert m.on_thin_wall(on).all() and not m.on_thin_wall(beside).any()
    assert not m.is_free(on).any()
    assert m.contains(on[1]) is False and m.contains(beside[1]) is True
    space = m.free_space(0.0)
    assert not shapely.contains_xy(space, *on.T).any() and shapely.contains_xy(space, *beside.T).all()
    assert space.area == pytest.approx(m.area, abs=1e-3)


@pytest.mark.parametrize("radius", [2.0, 8.0])
def test_free_space_keeps_the_radius_from_thin_walls(radius: float) -> None:
    m = map_from_dict(ROOM)
    c = m.free_space(radius)
    pts = m.sample_free(4000, rng=3)
    inside = shapely.contains_xy(c, *pts.T)
    d = shapely.distance(shapely.points(pts), m.wall_lines)
    assert (d[inside] >= radius - 0.02).all()  # arcs drawn as chords: within the chord's sagitta
    assert inside[d > radius + 0.05].all()
    near = shapely.distance(shapely.points(pts), m.thin_lines) < radius
    assert near.sum() > 200 and not inside[near & (d < radius - 0.02)].any()


def test_sample_free_keeps_clear_of_thin_walls() -> None:
    m = map_from_dict(ROOM)
    for clearance in (0.0, 5.0):
        pts = m.sample_free(3000, clearance=clearance, rng=1)
        assert m.contains(pts).all()
        assert (shapely.distance(shapely.points(pts), m.thin_lines) >= max(clearance, 1e-12)).all()


def test_rays_stop_at_thin_walls_from_either_side_and_end_on() -> None:
    m = map_from_dict(ROOM)
    walls = m.walls
    origins = np.array([[10, 40], [45, 40], [30, 10], [30, 80], [50, 60]])
    angles = np.array([0.0, math.pi, math.pi / 2, -math.pi / 2, math.pi / 2])
    want = [20.0, 15.0, 10.0, 10.0, 20.0]
    np.testing.assert_allclose(ray_cast(walls, origins, angles[:, None])[:, 0], want)
    brute = ray_wall_distances(walls, origins[:, 0].astype(float), origins[:, 1].astype(float), np.cos(angles),
                               np.sin(angles)).min(axis=1)
    np.testing.assert_allclose(brute, want)
    # a simulated sonar sees the wall end-on too
    assert IdealSonar(noise_sd=0.0).measure(walls, [30, 10], [math.pi / 2])[0] == pytest.approx(10.0)


# -- the CO333 arena of the real NXT sweeps ---------------------------------------------------------

def test_co333_arena_resolves_by_name() -> None:
    assert list_maps()["co333-arena"].parts[-2:] == ("real-nxt", "arena.yaml")
    m = load_map("co333-arena")
    assert m.name == "co333-arena" and "CO333" in m.description
    np.testing.assert_array_equal(m.boundary, [[0, 0], [0, 168], [84, 168], [84, 210], [168, 210], [168, 84],
                                               [210, 84], [210, 0]])
    np.testing.assert_array_equal(m.thin_segments, [[84, 126, 84, 168]])
    np.testing.assert_array_equal(m.start, [84, 30])
    assert m.area == pytest.approx(84 * 168 + 84 * 210 + 42 * 84)


def test_co333_arena_stub_stops_rays() -> None:
    m = load_map("co333-arena")
    assert ray_cast(m.walls, [60, 147], [0.0])[0] == pytest.approx(24.0)
    assert ray_cast(m.walls, [110, 147], [math.pi])[0] == pytest.approx(26.0)
    assert ray_cast(m.walls, m.start, [math.pi / 2])[0] == pytest.approx(96.0)  # from the start, end-on


@pytest.mark.parametrize("backend", ["index", "fcl"])
def test_co333_arena_stub_blocks_a_robot(backend: str) -> None:
    cc = make_checker(load_map("co333-arena"), 8.0, backend=backend)
    assert cc.point_free([60, 147]) and cc.point_free([110, 147])
    assert not cc.segment_free([60, 147], [110, 147])  # through the stub
    assert not cc.point_free([84, 147]) and not cc.point_free([84, 120])  # on it; 6 cm below its end
    assert cc.path_free([[60, 147], [84, 110], [110, 147]])  # round its end, 16 cm below it


def test_sweep_set_maps_are_listed_by_their_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    sweeps = tmp_path / "sweeps"
    sweeps.mkdir()
    (sweeps / "arena.yaml").write_text(f"name: my-arena\nboundary: {SQUARE}\n")
    (sweeps / "room.yaml").write_text(f"boundary: {SQUARE}\n")
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "arena.yaml").write_text("boundary: [[0, 0]\n")
    monkeypatch.setenv("NXTNAV_MAPS", os.pathsep.join([str(sweeps), str(broken)]))
    names = list_maps()
    assert names["my-arena"] == sweeps / "arena.yaml" and names["room"] == sweeps / "room.yaml"
    assert names["arena"] == broken / "arena.yaml"  # unreadable: by its file name, and loading says why
    assert {"map1", "co333-arena", "arena2", "depot"} <= set(names)
    assert load_map("my-arena").name == "my-arena"
    with pytest.raises(MapError, match="not valid YAML"):
        load_map("arena")
