"""The global-localisation strategy that missions and the localiser benchmark share.

The first test drives the same simulated robot (same start, same seeds) once through a mission and
once through the benchmark's global localisation, logging every command the robot receives: the
global localisation must be the same sequence of sweeps, turns and moves, ending on the same estimate.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from localisation import GlobalLocalisation, Motion, PoseEstimate, Prior, make_localiser
from localisation.base import Localiser
from localisation.exploration import EXPLORE_OVERSHOOT, explore_from_modes, scan_explore_move
from toolkit.bench.localisers import BenchConfig, call_localise
from toolkit.mission import Action, MissionConfig, run_mission
from toolkit.robots.sim import SimRobot
from toolkit.world import CollisionChecker, ConfigError, MoveOutcome, Pose, Scan, load_map

# map3's middle room: its first sweep fits the twin rooms too, and the strategy explores twice
TWIN_POSE = Pose(139.5, 56.5, -2.52)


class LoggedRobot(SimRobot):
    """The simulator, logging every command it receives (turret angles rounded to 1e-9 rad)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.log: list[tuple[Any, ...]] = []

    def ultrascan(self, angles: Any = None) -> Scan:
        key = None if angles is None else tuple(np.round(np.asarray(angles, dtype=float), 9))
        self.log.append(("sweep", key))
        return super().ultrascan(angles)

    def turn(self, angle_rad: float) -> None:
        self.log.append(("turn", angle_rad))
        super().turn(angle_rad)

    def move(self, distance_cm: float) -> MoveOutcome:
        self.log.append(("move", distance_cm))
        return super().move(distance_cm)

    def turnback(self) -> MoveOutcome:
        self.log.append(("turnback",))
        return super().turnback()


def test_a_mission_and_the_benchmark_localise_globally_alike() -> None:
    m = load_map("map3")
    seed = 5
    bench_robot = LoggedRobot(m, TWIN_POSE, rng=3)
    strategy_rng = np.random.default_rng(seed).spawn(2)[0]  # what run_mission hands its strategy
    result = call_localise(bench_robot, make_localiser("paper-pf", m, rng=0), None, strategy_rng,
                           strategy=BenchConfig().strategy)
    assert result.converged and result.moves >= 1  # the twins needed exploring
    assert result.estimate.pose.distance_to(bench_robot.true_pose) < 2.0

    mission_robot = LoggedRobot(m, TWIN_POSE, rng=3)
    target = (TWIN_POSE.x - 10.0, TWIN_POSE.y + 10.0)
    report = run_mission(mission_robot, m, target, localiser=make_localiser("paper-pf", m, rng=0), rng=seed,
                         truth=mission_robot)
    assert report.success, report.status
    n = len(bench_robot.log)
    assert mission_robot.log[:n] == bench_robot.log  # the same sweeps, turns and moves, in the same order
    assert len(mission_robot.log) > n  # and then the mission drove on
    fixes = [s for s in report.trace if s.note.startswith("global attempt") and "converged" in s.note]
    assert fixes and fixes[0].estimate == result.estimate.pose  # the same fix, bit for bit
    explored = [s for s in report.trace if s.action == Action.EXPLORE_MOVE]
    assert len(explored) == result.moves
    assert [s.action for s in report.trace].index(Action.PLAN) > report.trace.index(fixes[0])


@pytest.mark.parametrize("sonar", ["ideal", "nxt"])
def test_the_benchmark_runs_the_missions_strategy(sonar: str) -> None:
    mission = MissionConfig.for_sonar(sonar).global_localisation
    assert BenchConfig(sonar=sonar).strategy == mission == GlobalLocalisation()
    # a mission setting reaches the strategy; the benchmark's options reach its own
    assert MissionConfig().with_options(exploration="scan", max_explore_moves=2).global_localisation == \
        GlobalLocalisation(exploration="scan", max_explore_moves=2)
    assert BenchConfig(sonar=sonar, exploration="scan", scan_processing="raw").strategy == GlobalLocalisation(
        exploration="scan", process=False)


class _CountingPf:
    """Wraps a localiser and counts its resets."""

    def __init__(self, inner: Localiser) -> None:
        self.inner = inner
        self.resets = 0
        self.map = inner.map
        self.name = inner.name

    def reset(self, prior: Prior | None = None) -> None:
        self.resets += 1
        self.inner.reset(prior)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


def test_a_fix_is_confirmed_by_a_second_look_and_recovery_never_resets() -> None:
    # (the benchmark's kidnapped robot runs the strategy without confirmation, attempts or the first reset)
    m = load_map("map1")
    robot = SimRobot(m, Pose(30.0, 30.0, 0.4), rng=1)
    loc = _CountingPf(make_localiser("paper-pf", m, rng=1))
    res = GlobalLocalisation().run(robot, loc, rng=1)  # type: ignore[arg-type]
    assert res.converged and res.moves == 0
    assert loc.resets == 2 and res.scans == 2 and res.iterations == 2  # first look, then the confirming one
    assert res.estimate.pose.distance_to(robot.true_pose) < 2.0
    robot.teleport(Pose(80.0, 85.0, 2.0))
    loc.resets = 0
    recover = replace(GlobalLocalisation(), attempts=1, confirm=False)
    res = recover.run(robot, loc, rng=1, reset=False)  # type: ignore[arg-type]
    assert loc.resets == 0 and res.iterations >= 1  # whatever the localiser made of it, nothing started afresh


@pytest.mark.parametrize("rule", ["modes", "scan"])
def test_both_exploration_rules_tell_the_twin_rooms_apart(rule: str) -> None:
    m = load_map("map3")
    robot = SimRobot(m, TWIN_POSE, rng=3)
    res = GlobalLocalisation(exploration=rule).run(robot, make_localiser("paper-pf", m, rng=0), rng=3)
    assert not res.trace[0].estimate.converged and res.trace[0].explore is not None
    assert res.converged and res.moves >= 1
    assert res.estimate.pose.distance_to(robot.true_pose) < 2.0
    assert robot.collisions == 0


def test_a_move_from_the_modes_is_free_from_every_mode() -> None:
    m = load_map("map3")
    checker = CollisionChecker(m, 9.0)
    twins = [Pose(56.3, 26.9, 1.178), Pose(146.3, 26.9, 1.178), Pose(236.3, 26.9, 1.178)]
    turn, dist = explore_from_modes(twins, m.walls, checker, 30.0, math.radians(12.0))
    assert dist > 0
    for p in twins:
        for dev in (-12.0, 0.0, 12.0):
            h = p.theta + turn + math.radians(dev)
            end = p.xy + (1.0 + EXPLORE_OVERSHOOT) * dist * np.array([math.cos(h), math.sin(h)])
            assert checker.segment_free(p.xy, end)  # with room for the move to overshoot
    # walled in on every side: no move at all
    assert explore_from_modes([Pose(56.3, 26.9, 0.0)], m.walls, CollisionChecker(m, 25.0), 30.0, 0.2) == (0.0, 0.0)


def test_an_exploration_move_leaves_room_to_overshoot() -> None:
    # map1's start, heading 78 degrees (a paper trial's first fix): the roomiest 30 cm move ends where a
    # move 20 % longer (the paper's motion noise at two standard deviations) would meet a wall
    m = load_map("map1")
    checker = CollisionChecker(m, 9.0)
    pose = Pose(19.6, 19.8, math.radians(77.8))
    exact = explore_from_modes([pose], m.walls, checker, 30.0, math.radians(12.0), overshoot=0.0)
    safe = explore_from_modes([pose], m.walls, checker, 30.0, math.radians(12.0))

    def free(move: tuple[float, float], stretch: float) -> bool:
        turn, dist = move
        return all(checker.segment_free(pose.xy, pose.xy + stretch * dist * np.array(
            [math.cos(pose.theta + turn + d), math.sin(pose.theta + turn + d)])) for d in np.radians([-12, 0, 12]))

    assert exact[1] > 0 and not free(exact, 1.0 + EXPLORE_OVERSHOOT)  # the situation
    assert safe[1] > 0 and free(safe, 1.0 + EXPLORE_OVERSHOOT)


def test_the_scan_rule_keeps_its_distance_from_the_wall_ahead() -> None:
    # a corridor 200 cm long ahead and nothing else: the run is 200 - radius, the move 0.7 of it less the safety
    angles = np.radians(np.arange(0.0, 360.0, 1.0))
    ranges = np.full(angles.size, np.inf)
    ranges[0] = 200.0
    scan = Scan.from_readings(angles, ranges)
    turn, dist = scan_explore_move(scan, 8.0, rng=0, max_move_cm=500.0)
    assert turn == 0.0
    assert dist == pytest.approx(0.7 * (200.0 - 8.0 - 5.0))


def test_bad_strategy_settings_are_config_errors() -> None:
    with pytest.raises(ConfigError, match="exploration"):
        GlobalLocalisation(exploration="wander")
    with pytest.raises(ConfigError, match="attempts"):
        GlobalLocalisation(attempts=0)
    with pytest.raises(ConfigError, match="exploration"):
        MissionConfig().with_options(**{"global_localisation.exploration": "wander"})


def test_the_robot_driver_predicts_what_the_robot_did() -> None:
    from localisation.global_localisation import RobotDriver

    m = load_map("map1")
    robot = SimRobot(m, Pose(30.0, 30.0, 0.0), rng=0)

    class Log(Localiser):
        def __init__(self) -> None:
            super().__init__(m)
            self.motions: list[Motion] = []

        def reset(self, prior: Prior | None = None) -> None: ...

        def predict(self, motion: Motion) -> None:
            self.motions.append(motion)

        def update(self, scan: Scan) -> None: ...

        def estimate(self) -> PoseEstimate:
            return PoseEstimate(Pose(0, 0, 0), np.eye(3), False, 0)

    Log.name = "log"
    loc = Log()
    driver = RobotDriver(robot, loc)
    driver.turn(0.5, "explore-turn")
    assert not driver.move(10.0, "explore-move")
    assert loc.motions[0] == Motion(turn_rad=0.5)
    assert loc.motions[1].distance_cm == pytest.approx(robot.odometry_cm)


def test_an_unknown_exploration_rule_is_one_line_and_exit_2(tmp_path: Any, capsys: pytest.CaptureFixture[str]) -> None:
    from conftest import run_cli

    out = tmp_path / "bl"
    argv = ["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf", "--trials", "1",
            "--exploration", "wander", "--out", str(out)]
    assert run_cli(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "--exploration" in lines[0] and "modes, scan" in lines[0]
    assert not out.exists()
