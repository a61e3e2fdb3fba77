"""Robot time: the time model, its split in the mission report, and the model against the brick's clock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from toolkit.mission import MissionConfig, run_mission, run_sim_mission, sweep_angles
from toolkit.robots.model_clock import ModelClock
from toolkit.robots.sim import RobotTiming, SimRobot
from toolkit.world import Pose, load_map


def test_sweep_time_counts_readings_and_turret_travel() -> None:
    t = RobotTiming(reading_s=0.02, turret_rate_deg_s=200.0)
    full = sweep_angles(1.0)
    sweep, back = t.sweep(full)
    assert sweep == pytest.approx(360 * 0.02 + 359 / 200.0)
    assert back == pytest.approx(359 / 200.0)
    windows = sweep_angles(1.0, 15.0)
    assert windows.size == 124
    w_sweep, w_back = t.sweep(windows)
    # from the front to -15, up to 285 degrees, back to the front
    assert w_sweep == pytest.approx(124 * 0.02 + (15 + 300) / 200.0)
    assert w_back == pytest.approx(285 / 200.0)
    assert t.scan(windows) < 0.55 * t.scan(full)


def test_sweep_angles_windows_are_the_papers_windows() -> None:
    a = np.degrees(sweep_angles(2.0, 15.0))
    assert np.all(np.diff(a) > 0)  # one pass of the turret
    off = np.abs((a + 45.0) % 90.0 - 45.0)  # distance to the nearest axis
    assert off.max() <= 15.0 + 1e-9
    assert {round(x) for x in a} >= {-14, 0, 14, 76, 90, 104, 166, 180, 194, 256, 270, 284}


def test_sim_robot_splits_its_time() -> None:
    m = load_map("map1")
    robot = SimRobot(m, Pose(50.0, 80.0, 0.0), rng=0)
    robot.ultrascan(sweep_angles(1.0, 15.0))
    robot.turn(math.pi / 2)
    robot.move(10.0)
    parts = robot.sweep_s + robot.turret_return_s + robot.drive_s + robot.turn_s
    assert robot.readings == 124
    assert parts == pytest.approx(robot.robot_time_s)
    assert robot.turn_s == pytest.approx(1.0)


def test_mission_report_has_the_time_split() -> None:
    report = run_sim_mission("map1", seed=2)
    assert report.success
    split = report.times.split
    assert split is not None
    parts = split.sweep_s + split.turret_return_s + split.drive_s + split.turn_s
    assert parts == pytest.approx(report.times.robot_time_s)
    assert split.other_s == pytest.approx(0.0, abs=1e-9)
    assert split.readings > 0 and split.sweep_s > split.turret_return_s > 0
    assert split.drive_s == pytest.approx(report.path_length_cm / RobotTiming().drive_speed_cm_s)
    d = report.to_dict(trace=False)
    assert d["robot_time_split"]["readings"] == split.readings
    assert "sweeping" in report.summary()


def test_model_clock_equals_the_simulators_model() -> None:
    m = load_map("map2")
    robot = SimRobot(m, Pose(30.0, 20.0, 0.5), rng=4)
    clock = ModelClock(robot)
    report = run_mission(clock, m, m.target, rng=4, config=MissionConfig(), truth=robot)
    assert report.success
    assert clock.model_time_s == pytest.approx(robot.robot_time_s)
    assert report.collisions == robot.collisions
    assert report.counts.watchdog_stops == robot.watchdog_stops  # the robot's counters are read through the clock
    assert report.path_length_cm == pytest.approx(robot.odometry_cm)


def test_scan_less_defaults_cost_less_robot_time_than_the_papers_habit() -> None:
    habit = MissionConfig().with_options(**{"global_localisation.align": True,
                                            "global_localisation.scan_step_deg": 1.0, "sweeps.track_align": True,
                                            "fix.rule": "always", "fix.relocalise_every_cm": 40.0})
    lean = run_sim_mission("map2", seed=3)
    old = run_sim_mission("map2", seed=3, config=habit)
    assert lean.success and old.success
    assert lean.times.robot_time_s < 0.5 * old.times.robot_time_s
    assert lean.times.split is not None and old.times.split is not None
    assert lean.times.split.readings < 0.5 * old.times.split.readings
    assert lean.final_error_cm is not None and lean.final_error_cm < 1.0


@pytest.mark.parametrize("bad", [{"sweeps.track_window_deg": 200.0}, {"global_localisation.scan_step_deg": 0.0},
                                 {"fix.rule": "sometimes"}, {"fix.spread_sigmas": -1.0},
                                 {"global_localisation.align_sweeps": -1}, {"rule": "habit"}])
def test_bad_sweep_options_are_refused(bad: dict[str, object]) -> None:
    name = next(iter(bad)).rpartition(".")[2]
    with pytest.raises(ValueError, match=name):
        MissionConfig().with_options(**bad)


@pytest.mark.slow
def test_brick_clock_agrees_with_the_time_model() -> None:
    from toolkit.mission import localiser_options
    from toolkit.robots.nxt import connect_robot
    from toolkit.robots.virtual_brick import BrickServer
    from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld
    from toolkit.world import RobotModel

    m = load_map("map1")
    assert m.start is not None and m.target is not None
    world = BrickWorld(m, Pose.from_deg(float(m.start[0]), float(m.start[1]), 60.0),
                       BrickConfig(latency_s=0.003), sonar="nxt", rng=3)  # the sensor the localiser is told
    with BrickServer(world, port=0) as server:
        robot = ModelClock(connect_robot("socket", host="127.0.0.1", port=server.port))
        try:
            opts = localiser_options("paper-pf", RobotModel.build("nxt"))  # the brick's readings: simulated
            cfg = MissionConfig.for_sonar("nxt", localiser_options=opts)
            report = run_mission(robot, m, m.target, rng=3, config=cfg)
        finally:
            robot.close()
    assert report.success, report.status
    assert report.times.robot_time_s == pytest.approx(world.time_s, rel=0.05)  # the brick's clock
    assert report.times.robot_time_s == pytest.approx(robot.model_time_s, rel=0.10)
    split = report.times.split
    assert split is not None and split.readings > 0
    assert split.sweep_s > 0.5 * report.times.robot_time_s

