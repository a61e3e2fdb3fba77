"""Whole missions with the real stack (min-turn planner, paper-pf localiser) on the simulator.

Every check compares the report with the simulator's own truth (true pose, contact counter,
watchdog counter, odometry, clock).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import localisation
from localisation.base import Prior
from localisation.heading_check import MIN_OFFSET_DEG, check_heading
from localisation.robot_options import localiser_options
from localisation.scan import sweep_angles
from toolkit.mission import Action, MissionConfig, MissionReport, Outcome, run_mission, run_sim_mission
from toolkit.mission.checkers import Checkers
from toolkit.mission.context import MissionContext
from toolkit.robots.sim import MotionNoise, SimRobot
from toolkit.seeds import derive_seeds
from toolkit.world import (
    ConfigError,
    NxtSonar,
    Pose,
    Robot,
    RobotCounters,
    RobotModel,
    TruthSource,
    angle_diff,
    load_map,
)


def _sim_mission(name: str, seed: int, model: str = "botsim", sonar: str = "ideal",
                 start: Pose | None = None) -> tuple[object, SimRobot]:
    m = load_map(name)
    s_start, s_sim, s_stack = derive_seeds(seed, n=3)
    assert m.start is not None and m.target is not None
    pose = start or Pose(*m.start, np.random.default_rng(s_start).uniform(-math.pi, math.pi))
    robot = SimRobot(m, pose, noise=MotionNoise(model), sonar=sonar, rng=s_sim)
    report = run_mission(robot, m, m.target, rng=s_stack, truth=robot)
    return report, robot


def _check_against_truth(report: object, robot: SimRobot) -> None:
    from toolkit.mission import MissionReport

    assert isinstance(report, MissionReport)
    assert report.success, report.status
    assert report.poses.final_pose == robot.true_pose
    assert report.final_error_cm == pytest.approx(robot.true_pose.distance_to(report.poses.target))
    assert report.final_error_cm < 2.5
    assert report.collisions == robot.collisions == 0
    assert report.counts.watchdog_stops == robot.watchdog_stops
    assert report.path_length_cm == pytest.approx(robot.odometry_cm)
    assert report.times.robot_time_s == pytest.approx(robot.robot_time_s)
    assert report.poses.final_estimate is not None
    # the estimate the mission stopped on is close to the truth (the localiser's accuracy)
    assert report.poses.final_estimate.distance_to(robot.true_pose) < 2.0
    # the first plan starts where the first estimate was and ends at the target
    assert report.plans and np.allclose(report.plans[0][-1], report.poses.target)
    assert report.trace[0].action == Action.LOCALISE
    assert report.trace[-1].true_pose == robot.true_pose


@pytest.mark.parametrize("name", ["map1", "map2", "map3"])
@pytest.mark.parametrize("model", ["botsim", "absolute"])
def test_whole_mission_against_the_simulator(name: str, model: str) -> None:
    report, robot = _sim_mission(name, seed=11, model=model)
    _check_against_truth(report, robot)


def test_mission_with_the_nxt_sonar() -> None:
    report, robot = _sim_mission("map1", seed=4, sonar="nxt")
    _check_against_truth(report, robot)


@pytest.mark.parametrize("name", ["map2", "map3"])
def test_mission_from_a_random_start(name: str) -> None:
    m = load_map(name)
    start = m.random_pose(rng=7)
    assert m.wall_distance(start.xy) >= 10.0
    report, robot = _sim_mission(name, seed=7, start=start)
    _check_against_truth(report, robot)


def test_run_sim_mission_is_reproducible() -> None:
    a = run_sim_mission("map1", seed=3)
    b = run_sim_mission("map1", seed=3)
    assert a.seed == b.seed == 3
    assert a.poses.final_pose == b.poses.final_pose
    assert a.path_length_cm == b.path_length_cm
    assert [s.action for s in a.trace] == [s.action for s in b.trace]


def test_target_in_wall_with_the_real_stack() -> None:
    report = run_sim_mission("map2", seed=0, target=(1.0, 1.0))
    assert not report.success
    assert report.outcome in (Outcome.TARGET_OUTSIDE, Outcome.TARGET_IN_WALL), report.status


def test_unreachable_target_with_the_real_stack() -> None:
    from toolkit.world import map_from_dict

    m = map_from_dict({"name": "split", "boundary": [[0, 0], [60, 0], [60, 25], [65, 25], [65, 0], [120, 0],
                                                      [120, 60], [65, 60], [65, 35], [60, 35], [60, 60], [0, 60]]})
    cfg = MissionConfig().with_options(**{"planning.time_s": 0.2})
    report = run_sim_mission(m, seed=1, start=Pose(25, 30, 0.0), target=(95.0, 30.0), config=cfg)
    assert not report.success
    assert report.outcome in (Outcome.UNREACHABLE, Outcome.LOST), report.status
    assert report.collisions == 0


def test_nxt_sonar_localisers_are_told_the_lobe() -> None:
    from toolkit.mission import localiser_options
    from toolkit.world import NXT_SONAR_SIGMA_CM, RobotModel

    nxt = localiser_options("paper-pf", RobotModel.build("nxt"))
    model = NxtSonar()
    assert nxt["ranges.beam_width_deg"] == model.beam_width_deg
    assert nxt["ranges.critical_incidence_deg"] == model.critical_incidence_deg
    assert nxt["sensor.sonar_model"] == model.simulated()  # the whole model, for those that use its beam mixture
    assert nxt["sensor.sensor_sigma_cm"] == NXT_SONAR_SIGMA_CM
    ideal = localiser_options("paper-pf", RobotModel.build("ideal", sensor_noise=1.5))
    assert "ranges.beam_width_deg" not in ideal and ideal["sensor.sensor_sigma_cm"] == 1.5
    assert "ekf" in localisation.LOCALISERS
    assert not any("beam_width_deg" in k for k in localiser_options("ekf", RobotModel.build("nxt")))


def test_nxt_sonar_mission_among_the_slanted_walls_of_map2() -> None:
    # Table I trial 0 of map2 (absolute noise): with a thin-ray model the filter settled 8 degrees off
    # in the wedge bay and the robot stopped 4.2 cm from the target while believing it was there
    report = run_sim_mission("map2", seed=3964924996, sonar="nxt", noise_model="absolute")
    assert report.success, report.status
    assert report.final_error_cm is not None and report.final_error_cm <= 3.0
    assert report.collisions == 0


def test_exploring_from_a_loose_heading_touches_no_wall() -> None:
    # at map2's preset start one sweep of the nxt sonar leaves the belief ambiguous, so the robot
    # explores before it plans; an exploration move planned from loose modes once touched the corner at
    # (30, 40) (the move must clear every mode's pose). Seed 2 is a mission where exploring happens.
    report = run_sim_mission("map2", seed=2, sonar="nxt")
    assert report.success, report.status
    assert report.collisions == 0
    assert report.final_error_cm is not None and report.final_error_cm <= 1.0
    assert any(s.action == Action.EXPLORE_MOVE for s in report.trace)  # it did explore, and safely


def test_without_a_safe_exploration_move_the_robot_turns_and_sweeps_again() -> None:
    # exploration moves shorter than 1 cm are no moves: at map2's start the nxt sonar's first sweep
    # knows the place but not the heading, and the robot settles it the paper's way on the spot
    cfg = MissionConfig.for_sonar("nxt", explore_step_cm=0.5)
    report = run_sim_mission("map2", seed=2, sonar="nxt", config=cfg)  # a start that needs a second sweep
    assert report.success, report.status
    assert report.collisions == 0
    actions = [s.action for s in report.trace]
    first_drive = actions.index(Action.MOVE)
    assert Action.ALIGN_TURN in actions[:first_drive] and Action.EXPLORE_MOVE not in actions
    assert all(s.distance_cm == 0.0 for s in report.trace[:first_drive])  # turned on the spot only
    off = MissionConfig.for_sonar("nxt", explore_step_cm=0.5, align_sweeps=0)
    lost = run_sim_mission("map2", seed=2, sonar="nxt", config=off)
    assert Action.ALIGN_TURN not in [s.action for s in lost.trace]


def test_report_counts_the_cpu_time_of_the_mission() -> None:
    report = run_sim_mission("map1", seed=2)
    assert report.success
    assert 0.0 < report.times.cpu_s < math.inf
    assert report.to_dict(trace=False)["cpu_s"] == report.times.cpu_s
    assert "s CPU" in report.summary()


class _ProtocolOnly:
    """The simulator seen through the `Robot` protocol alone: no truth, no counters, no checker."""

    def __init__(self, robot: SimRobot) -> None:
        self._robot = robot
        self.geometry = robot.geometry

    def move(self, distance_cm: float) -> Any:
        return self._robot.move(distance_cm)

    def turn(self, angle_rad: float) -> None:
        self._robot.turn(angle_rad)

    def ultrascan(self, angles: Any = None) -> Any:
        return self._robot.ultrascan(angles)

    def turnback(self) -> Any:
        return self._robot.turnback()

    def stop(self) -> None:
        self._robot.stop()

    def close(self) -> None:
        self._robot.close()

    @property
    def robot_time_s(self) -> float:
        return self._robot.robot_time_s


def test_a_mission_reads_the_robot_through_its_protocol_and_the_truth_from_its_source() -> None:
    m = load_map("map1")
    assert m.target is not None
    sim = SimRobot(m, Pose(30.0, 20.0, 1.0), rng=2)
    robot = _ProtocolOnly(sim)
    assert isinstance(robot, Robot) and not isinstance(robot, TruthSource | RobotCounters)
    blind = run_mission(robot, m, m.target, rng=2)  # no truth source: nothing true in the report
    assert blind.success and blind.poses.final_pose is None and blind.collisions is None and blind.poses.start is None
    assert blind.path_length_cm == pytest.approx(sim.odometry_cm)  # the mission's own count of the moves
    assert all(s.true_pose is None for s in blind.trace)

    sim = SimRobot(m, Pose(30.0, 20.0, 1.0), rng=2)
    report = run_mission(_ProtocolOnly(sim), m, m.target, rng=2, truth=sim)
    assert report.poses.start == Pose(30.0, 20.0, 1.0) and report.poses.final_pose == sim.true_pose
    assert report.collisions == sim.collisions == 0
    assert report.trace[-1].true_pose == sim.true_pose
    assert [s.action for s in report.trace] == [s.action for s in blind.trace]  # the truth steers nothing


@pytest.mark.parametrize("tracking", ["continue", "prior"])
def test_tracking_from_a_prior_converges_as_tracking_from_the_belief_does(tracking: str) -> None:
    m = load_map("map2")
    assert m.start is not None and m.target is not None
    robot = SimRobot(m, Pose(float(m.start[0]), float(m.start[1]), 0.4), rng=3)
    loc = localisation.make_localiser("paper-pf", m, rng=3)
    priors: list[object] = []
    reset = loc.reset
    loc.reset = lambda prior=None: (priors.append(prior), reset(prior))[1]  # type: ignore[method-assign]
    cfg = MissionConfig().with_options(**{"fix.tracking": tracking})
    report = run_mission(robot, m, m.target, localiser=loc, rng=3, config=cfg, truth=robot)
    _check_against_truth(report, robot)
    fixes = [s.note for s in report.trace if s.action == Action.RELOCALISE]
    assert len(fixes) == report.counts.relocalisations >= 3
    assert all(": converged" in note for note in fixes)  # no fallback was needed
    from_prior = sum(p is not None for p in priors)
    assert from_prior == (report.counts.relocalisations if tracking == "prior" else 0)


class _SlipsOnce(_ProtocolOnly):
    """A robot whose first turn of more than 40 degrees turns only 60 % of the command (wheels that skid)."""

    def __init__(self, robot: SimRobot) -> None:
        super().__init__(robot)
        self.slipped: float | None = None

    def turn(self, angle_rad: float) -> None:
        if self.slipped is None and abs(angle_rad) > math.radians(40.0):
            self.slipped = angle_rad
            angle_rad *= 0.6
        self._robot.turn(angle_rad)


def _nxt_slip_mission(seed: int, check_turn_deg: float | None) -> tuple[MissionReport, _SlipsOnce]:
    """map1 with the simulated NXT sonar (the ``nxt`` tuning, the localiser told the sensor), through a
    robot whose first large turn slips."""
    m = load_map("map1")
    assert m.start is not None and m.target is not None
    model = RobotModel.build("nxt")
    sim = SimRobot(m, Pose(*m.start, 1.0), geometry=model.geometry, noise=model.motion, sonar=model.sonar, rng=seed)
    robot = _SlipsOnce(sim)
    cfg = MissionConfig.for_sonar("nxt", localiser_options=localiser_options("paper-pf", model))
    cfg = cfg.with_options(**{"fix.check_turn_deg": check_turn_deg})
    return run_mission(robot, m, m.target, rng=seed, truth=sim, config=cfg), robot


def test_a_heading_check_after_a_large_turn_sees_a_slipped_turn_before_the_leg() -> None:
    # a mission whose slipped turn meets a wall without the check (with the nxt tuning's allowances of
    # 15 degrees, 2 cm and 4 degrees seed 0 was one; with 10, 1 and 2 seeds 3 and 7 of 0-7 are)
    seed = 3
    checking, robot = _nxt_slip_mission(seed, 20.0)
    blind, blind_robot = _nxt_slip_mission(seed, None)
    assert robot.slipped is not None and blind_robot.slipped is not None
    assert blind.collisions is not None and blind.collisions > 0  # the situation: a slip that meets a wall
    assert checking.success and checking.collisions == 0, checking.status
    off = [s for s in checking.trace if s.action == Action.OFF_COURSE]
    assert len(off) == 1 and "sweep after the turn fits a heading" in (off[0].note or "")
    assert [f.kind for f in checking.faults] == ["motion"]  # said once, as a motion fault
    # the re-localisation from the heading the sweep fits put the belief right, by the simulator's truth
    i = checking.trace.index(off[0])
    assert off[0].estimate is not None and off[0].true_pose is not None
    assert abs(math.degrees(angle_diff(off[0].estimate.theta, off[0].true_pose.theta))) > 15.0
    fix = checking.trace[i + 1]
    assert fix.action == Action.RELOCALISE and fix.estimate is not None and fix.true_pose is not None
    assert abs(math.degrees(angle_diff(fix.estimate.theta, fix.true_pose.theta))) < 3.0


def test_the_heading_check_is_the_nxt_tuning_and_leaves_an_agreeing_belief_alone() -> None:
    with pytest.raises(ConfigError, match="check_turn_deg"):
        MissionConfig().with_options(**{"fix.check_turn_deg": -5.0})
    assert MissionConfig().fix.check_turn_deg is None
    assert MissionConfig.for_sonar("nxt").fix.check_turn_deg == 20.0
    report = run_sim_mission("map1", seed=1)
    assert report.success, report.status
    assert not any(s.action == Action.CHECK_HEADING for s in report.trace)
    report = run_sim_mission("map1", seed=1, sonar="nxt")
    assert report.success and report.collisions == 0, report.status
    checks = [i for i, s in enumerate(report.trace) if s.action == Action.CHECK_HEADING]
    assert checks and not any(s.action == Action.OFF_COURSE for s in report.trace)
    for i in checks:  # the turn before, the same belief after, then the leg
        before, step = report.trace[i - 1], report.trace[i]
        assert before.action == Action.TURN and before.turn_rad is not None
        assert abs(before.turn_rad) >= math.radians(20.0)
        assert step.estimate == before.estimate
        after = report.trace[i + 1]  # the leg: at most a small turn to re-aim from the predicted belief first
        assert after.action == Action.MOVE or (after.action == Action.TURN and after.turn_rad is not None
                                                and abs(after.turn_rad) < math.radians(20.0))


def _context_at(pose: Pose) -> tuple[MissionContext, SimRobot]:
    """A mission's context on map1 with the simulator at `pose` and the belief there too."""
    m = load_map("map1")
    assert m.target is not None
    robot = SimRobot(m, pose, noise=MotionNoise("absolute", 0.0, 0.0), rng=0)
    loc = localisation.make_localiser("paper-pf", m, rng=0)
    ctx = MissionContext(robot, m, m.target, MissionConfig(), lambda: loc, truth=robot)
    ctx.checker = Checkers(m, ctx.radius, ctx.cfg).bare
    loc.reset(Prior(pose, np.diag([0.25, 0.25, math.radians(0.5) ** 2])))
    ctx.estimate = loc.estimate()
    return ctx, robot


@pytest.mark.parametrize(("behind_cm", "backs_cm"), [(30.0, 10.0), (15.0, 5.0), (9.5, 0.0)])
def test_a_back_off_stops_short_of_the_wall_behind(behind_cm: float, backs_cm: float) -> None:
    ctx, robot = _context_at(Pose(50.0, behind_cm, math.pi / 2))  # facing +y, the outer wall y = 0 behind
    assert robot.backoff_distance_cm == 10.0
    ctx.turnback()
    step = ctx.trace[-1]
    assert step.action == Action.TURNBACK
    # the robot (radius 8) keeps 2 cm from the wall, as the map shows it from the belief
    assert step.distance_cm == pytest.approx(-backs_cm, abs=0.3)
    assert robot.true_pose.y == pytest.approx(behind_cm - backs_cm, abs=0.3)
    assert robot.collisions == 0
    if backs_cm == 0.0:
        assert step.note == "no room behind to back off"


def test_an_estimate_touching_a_wall_drives_out_instead_of_re_planning_until_it_gives_up() -> None:
    from planners import make_planner
    from toolkit.mission.driving import Leg
    from toolkit.mission.machine import Mission

    m = load_map("map1")
    assert m.target is not None
    robot = SimRobot(m, Pose(8.8, 50.0, 0.0), noise=MotionNoise("absolute", 0.0, 0.0), rng=0)
    loc = localisation.make_localiser("paper-pf", m, rng=0)
    mission = Mission(robot, m, m.target, make_planner("min-turn"), lambda: loc, np.random.default_rng(0),
                      MissionConfig(), truth=robot)
    belief = Pose(7.6, 50.0, 0.0)  # 1.2 cm off: the disc (8 cm) of the belief is in the wall x = 0
    loc.reset(Prior(belief, np.diag([0.25, 0.25, math.radians(0.5) ** 2])))
    mission.context.estimate = loc.estimate()
    path = mission.planner.plan()
    bare = mission.checkers.bare
    assert not bare.point_free(path[0])  # the situation: planned from an estimate inside the c-space
    assert bare.point_free(path[1]) and float(np.hypot(*(path[1] - path[0]))) <= 8.0  # the escape
    end = mission.driving.leg(path[1], 0, path[2])
    assert end.leg is not Leg.DEVIATED  # driven, not planned again and again
    assert robot.true_pose.x > 8.8 and robot.collisions == 0


def test_the_heading_check_sees_a_slip_the_tracking_windows_miss() -> None:
    """The campaign's collision at a24f1db (`nxtnav bench faults --missions 100 --seed 0`, mission 93):
    on map1 at (31.3, 29.9), a turn that slipped left the belief 14 degrees off. There the three
    tracking windows ahead and to the sides do not tell the heading; the check's front half does, and
    the mission re-localises from it."""
    from planners import make_planner
    from toolkit.mission.config import TRACK_WINDOWS
    from toolkit.mission.machine import Mission
    from toolkit.mission.states import State

    m = load_map("map1")
    assert m.target is not None
    model = RobotModel.build("nxt")
    true = Pose(31.27, 29.90, math.radians(69.69))
    robot = SimRobot(m, true, geometry=model.geometry, noise=MotionNoise("absolute", 0.0, 0.0),
                     sonar=model.sonar, rng=0)
    cfg = MissionConfig.for_sonar("nxt", localiser_options=localiser_options("paper-pf", model))
    loc = localisation.make_localiser("paper-pf", m, rng=0, **cfg.localiser_options)
    mission = Mission(robot, m, m.target, make_planner("min-turn"), lambda: loc, np.random.default_rng(0), cfg,
                      truth=robot)
    belief = Pose(31.33, 30.52, math.radians(83.89))
    loc.reset(Prior(belief, np.diag([0.25, 0.25, math.radians(0.5) ** 2])))
    mission.context.estimate = loc.estimate()
    # the situation: sweeps of the three windows, simulated from the true pose, leave the heading unsure
    windows = sweep_angles(cfg.sweeps.track_scan_step_deg, cfg.sweeps.track_window_deg, TRACK_WINDOWS["sides"])
    for _ in range(5):
        check = check_heading(m, belief, robot.ultrascan(windows), cfg.localiser_options["sensor.sonar_model"])
        assert not check.off and check.unsure
    assert mission._check_heading() is State.REPLAN
    steps = mission.context.trace
    off = [s for s in steps if s.action == Action.OFF_COURSE]
    assert len(off) == 1 and "91 readings" in (off[0].note or "")
    fix = steps[steps.index(off[0]) + 1]
    assert fix.action == Action.RELOCALISE and fix.estimate is not None
    # by the simulator's truth: from 14 degrees off to within what a tracking fix corrects
    assert abs(math.degrees(angle_diff(fix.estimate.theta, true.theta))) < MIN_OFFSET_DEG
