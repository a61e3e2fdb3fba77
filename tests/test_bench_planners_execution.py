"""Execution error: the vectorised open-loop drives against the simulator and against theory."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from toolkit.bench.execution import drive_commands, execution_error, simulate_open_loop, simulate_with_robot
from toolkit.robots.sim import MotionNoise
from toolkit.world import CollisionChecker, PlanningError, load_map, map_from_dict

ROOM = map_from_dict({"name": "room", "boundary": [[0, 0], [400, 0], [400, 400], [0, 400]]})


def zigzag(start: tuple[float, float], goal: tuple[float, float], bends: int, amplitude: float) -> np.ndarray:
    """A path from start to goal with `bends` interior waypoints alternating +-amplitude off the line."""
    a, b = np.array(start, float), np.array(goal, float)
    t = np.linspace(0.0, 1.0, bends + 2)
    pts = a + t[:, None] * (b - a)
    normal = np.array([-(b - a)[1], (b - a)[0]]) / np.hypot(*(b - a))
    offsets = np.zeros(bends + 2)
    offsets[1:-1] = amplitude * np.where(np.arange(bends) % 2 == 0, 1.0, -1.0)
    return pts + offsets[:, None] * normal


def test_drive_commands_merge_collinear_and_drop_zero_length() -> None:
    path = [[0, 0], [10, 0], [10, 0], [20, 0], [20, 10], [20, 10]]
    turns, moves, h0 = drive_commands(path)
    assert h0 == 0.0
    np.testing.assert_allclose(moves, [20.0, 10.0])
    np.testing.assert_allclose(turns, [0.0, math.pi / 2])
    turns, moves, h0 = drive_commands(path, start_heading=math.pi)
    np.testing.assert_allclose(np.abs(turns[0]), math.pi)
    with pytest.raises(PlanningError):
        drive_commands([[1, 1]])


@pytest.mark.parametrize("noise", [MotionNoise(), MotionNoise("absolute", 1.0, 0.05)], ids=["botsim", "absolute"])
def test_matches_simulator_draw_for_draw(noise: MotionNoise) -> None:
    m = load_map("map1")
    path = np.array([[20, 20], [30, 30], [20, 40], [30, 50], [20, 60], [20, 80], [80, 80]], float)
    fast, hit_fast, turns = simulate_open_loop(path, CollisionChecker(m, 8.0), repeats=40, noise=noise, rng=7)
    slow, hit_slow = simulate_with_robot(path, m, repeats=40, noise=noise, rng=7)
    assert turns == 5
    np.testing.assert_array_equal(hit_fast, hit_slow)
    # free drives agree to rounding; drives that touch a wall agree to the contact search tolerance
    np.testing.assert_allclose(fast[~hit_fast], slow[~hit_fast], atol=1e-9)
    np.testing.assert_allclose(fast, slow, atol=2e-2)


def test_wall_contacts_match_the_simulator() -> None:
    # a path hugging the c-space boundary: noise pushes many drives into the wall
    m = load_map("map1")
    path = np.array([[8.5, 20.0], [8.5, 90.0], [90.0, 96.5]])
    noise = MotionNoise("absolute", 0.5, 0.03)
    fast, hit_fast, _ = simulate_open_loop(path, CollisionChecker(m, 8.0), repeats=30, noise=noise, rng=1)
    slow, hit_slow = simulate_with_robot(path, m, repeats=30, noise=noise, rng=1)
    assert 0 < hit_fast.sum() < 30
    np.testing.assert_array_equal(hit_fast, hit_slow)
    np.testing.assert_allclose(fast, slow, atol=2e-2)
    # and the robot disc never ends inside a wall (independent check: shapely distance to the walls)
    assert np.all(m.wall_distance(fast) >= 8.0 - 1e-2)


def test_straight_line_error_matches_theory_under_botsim() -> None:
    # one move of L cm: along-track error ~ N(0, (0.1 L)^2), lateral ~ L * N(0, 0.005^2)
    cc = CollisionChecker(ROOM, 8.0)
    length = 200.0
    res = execution_error([[20, 200], [20 + length, 200]], cc, repeats=4000, rng=3)
    along, lateral = 0.1 * length, 0.005 * length
    # E|N(0, s1^2) x N(0, s2^2)| for a 2-D Gaussian with s2 << s1, by numerical integration
    z = np.random.default_rng(0).standard_normal((200000, 2)) * [along, lateral]
    expected = float(np.hypot(z[:, 0], z[:, 1]).mean())
    assert res.mean_cm == pytest.approx(expected, rel=0.04)
    assert res.collision_fraction == 0.0
    assert res.turns == 0


def test_error_grows_with_turns_under_absolute_noise() -> None:
    # same endpoints, more bends: every extra move and turn adds its own error
    cc = CollisionChecker(ROOM, 8.0)
    noise = MotionNoise("absolute", 1.0, 0.02)
    means = []
    for bends in (0, 2, 6, 14):
        path = zigzag((50, 200), (350, 200), bends, 30.0)
        res = execution_error(path, cc, repeats=2000, noise=noise, rng=11)
        assert res.turns == bends
        means.append(res.mean_cm)
    assert all(b > a * 1.05 for a, b in itertools.pairwise(means)), means


def test_to_dict_and_seeding() -> None:
    cc = CollisionChecker(load_map("map1"), 8.0)
    path = [[20, 20], [20, 80], [80, 80]]
    a = execution_error(path, cc, repeats=50, rng=5)
    b = execution_error(path, cc, repeats=50, rng=5)
    c = execution_error(path, cc, repeats=50, rng=6)
    assert a.to_dict() == b.to_dict()
    assert a.mean_cm != c.mean_cm
    d = a.to_dict()
    assert set(d) >= {"mean_cm", "median_cm", "collision_fraction", "repeats", "noise"}
    assert d["noise"] == {"model": "botsim", "motion": 0.1, "turn": 0.005}
    assert a.final_xy.shape == (50, 2)
    with pytest.raises(ValueError):
        execution_error(path, cc, repeats=0)
