"""The simulated robot: BotSim's noise semantics, the watchdog, true collisions, robot time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from toolkit.robots import MotionNoise, RobotTiming, SimRobot
from toolkit.world import CollisionChecker, NxtSonar, Pose, Robot, RobotError, RobotGeometry, load_map

QUIET = MotionNoise("botsim", 0.0, 0.0)


def test_implements_protocol() -> None:
    assert isinstance(SimRobot(load_map("map1"), Pose(20, 20)), Robot)


def test_noise_free_motion_is_exact() -> None:
    r = SimRobot(load_map("map1"), Pose(20, 20, 0.0), noise=QUIET, rng=0)
    r.turn(math.pi / 2)
    out = r.move(30.0)
    assert out.distance_cm == pytest.approx(30.0) and not out.watchdog
    assert r.true_pose.x == pytest.approx(20.0) and r.true_pose.y == pytest.approx(50.0)
    assert r.true_pose.theta == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("model", ["botsim", "absolute"])
def test_noise_statistics(model: str) -> None:
    """Final positions after a 40 cm move spread as the noise model says."""
    m = load_map("map1")
    noise = MotionNoise(model, motion=0.1 if model == "botsim" else 2.0, turn=0.0)
    xs = []
    for seed in range(400):
        r = SimRobot(m, Pose(10, 80, 0.0), noise=noise, rng=seed, watchdog_cm=0.0)
        r.move(40.0)
        xs.append(r.true_pose.x - 10.0)
    xs = np.array(xs)
    assert np.mean(xs) == pytest.approx(40.0, abs=0.6)
    assert np.std(xs) == pytest.approx(4.0 if model == "botsim" else 2.0, rel=0.15)


def test_turn_noise_proportional_vs_absolute() -> None:
    m = load_map("map1")
    for model, want in (("botsim", 0.1 * math.pi), ("absolute", 0.1)):
        th = []
        for seed in range(400):
            r = SimRobot(m, Pose(50, 80, 0.0), noise=MotionNoise(model, 0.0, 0.1), rng=seed)
            r.turn(math.pi / 2 if model == "botsim" else 1.0)
            th.append(r.true_pose.theta)
        scale = math.pi / 2 if model == "botsim" else 1.0
        assert np.std(th) == pytest.approx(0.1 * scale if model == "botsim" else want, rel=0.15)


def test_watchdog_stops_before_the_wall_and_turnback() -> None:
    m = load_map("map1")
    r = SimRobot(m, Pose(50, 80, 0.0), noise=QUIET, sensor_noise=0.0, rng=0)
    out = r.move(200.0)
    assert out.watchdog and out.distance_cm < 200
    assert 106 - r.true_pose.x >= r.watchdog_cm - 1.0  # stopped about watchdog_cm from the wall
    assert r.watchdog_stops == 1 and r.collisions == 0
    x = r.true_pose.x
    back = r.turnback()
    assert back.distance_cm == pytest.approx(-r.backoff_cm)
    assert r.true_pose.x == pytest.approx(x - r.backoff_cm)


def test_true_collision_is_counted_and_never_passes_a_wall() -> None:
    """Sliding along a wall at a shallow angle the forward sonar sees nothing; the disc stops at contact."""
    m = load_map("map1")
    geo = RobotGeometry(radius_cm=8.0)
    r = SimRobot(m, Pose(10, 12, math.radians(-10)), geometry=geo, noise=QUIET, sensor_noise=0.0, rng=0)
    r.move(50.0)
    assert r.collisions == 1
    cc = CollisionChecker(m, 8.0)
    assert cc.point_free(r.true_pose.xy)
    assert r.true_pose.y == pytest.approx(8.0, abs=0.01)


def test_robot_time_model() -> None:
    # the default sweep visits 0..359 degrees: 359 degrees of turret travel out and 359 back
    t = RobotTiming(drive_speed_cm_s=10.0, turn_rate_deg_s=90.0, reading_s=0.02, turret_rate_deg_s=359.0)
    r = SimRobot(load_map("map1"), Pose(20, 20), noise=QUIET, timing=t, rng=0)
    r.turn(math.pi / 2)
    r.move(20.0)
    r.ultrascan()
    assert r.robot_time_s == pytest.approx(1.0 + 2.0 + 360 * 0.02 + 1.0 + 1.0)
    assert r.turret_return_s == pytest.approx(1.0)


def test_scan_is_relative_to_heading() -> None:
    m = load_map("map1")
    r = SimRobot(m, Pose.from_deg(20, 20, 90), noise=QUIET, sensor_noise=0.0, rng=0)
    s = r.ultrascan(np.radians([0.0, 90.0, 180.0, 270.0]))
    np.testing.assert_allclose(s.ranges, [85.0, 20.0, 20.0, 40.0])  # ahead=up, left, behind=down, right
    assert s.valid.all()


def test_seeded_and_errors() -> None:
    m = load_map("map2")

    def run(seed: int) -> tuple:
        r = SimRobot(m, Pose(30, 20, 0.3), rng=seed)
        r.turn(0.5)
        r.move(20)
        return (r.true_pose, r.ultrascan().ranges.sum())

    assert run(4) == run(4)
    assert run(4) != run(5)
    with pytest.raises(RobotError, match="in collision"):
        SimRobot(m, Pose(2, 2))
    r = SimRobot(m, Pose(30, 20))
    with pytest.raises(RobotError, match="finite"):
        r.move(float("nan"))
    r.close()
    with pytest.raises(RobotError, match="closed"):
        r.turn(1.0)


def test_ideal_sonar_has_no_range_limit_and_the_nxt_stops_at_255() -> None:
    """In a 7 m room the ideal model (BotSim's ultraScan) reads every wall, 350 cm away or more; the NXT none."""
    from toolkit.world.generated import random_grid_map

    room = random_grid_map(140, cell_cm=5.0, density=0.0)
    ideal = SimRobot(room, Pose(350.0, 350.0, 0.0), sonar="ideal", rng=0).ultrascan()
    assert ideal.valid.all()
    assert ideal.ranges.min() > 345.0
    facts = SimRobot(room, Pose(350.0, 350.0, 0.0), sonar=NxtSonar.hardware_facts(), rng=0).ultrascan()
    assert not facts.valid.any()  # no echo beyond 255 cm
    nxt = SimRobot(room, Pose(350.0, 350.0, 0.0), sonar="nxt", rng=0).ultrascan()
    heard = nxt.ranges[nxt.valid]  # the fitted sensor's phantom readings where nothing echoes: random
    assert abs(heard.size / len(nxt) - NxtSonar().phantom_prob) < 0.1 and np.ptp(heard) > 100
