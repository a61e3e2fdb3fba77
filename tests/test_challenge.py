"""The course's challenge on real sweeps: the sweeps-backed sonar, `nxtnav run --sonar sweeps:DIR`,
`nxtnav bench challenge`, and their bad input (on the shipped MIT sweeps, or copies of them)."""

from __future__ import annotations

import csv
import faulthandler
import itertools
import json
import math
import os
import shutil
import signal
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, run_cli
from numpy.typing import NDArray

from localisation.base import PoseEstimate, make_localiser
from localisation.models import exact_ranges
from localisation.scan import drop_stuck
from planners import PLANNERS, PlanningProblem, PlanResult, ShortestPathPlanner
from planners.base import make_planner
from toolkit.bench.challenge import COLUMNS, challenge_mission, challenge_tasks, crashed_mission
from toolkit.bench.routes import aligned_headings
from toolkit.mission.challenge import (
    ChallengeConfig,
    ChallengeFix,
    ChallengeRecovery,
    WaypointSweeps,
    course_from,
    plausible_update,
)
from toolkit.mission.sweep_fit import fit_pose, heading_belief, joined, misfits, rank_places
from toolkit.real_sonar.sweep_sonar import (
    SweepRefused,
    SweepSetRobot,
    SweepSetSonar,
    course_waypoints,
    load_challenge_set,
    rotated,
)
from toolkit.real_sonar.sweeps import SweepSet, aligned_heading_deg, load_sweep_set, thin_ray_misfits
from toolkit.robots.sim import SimRobot
from toolkit.world import MotionNoise, Pose, RigidMove, Scan, angle_diff, load_map


@pytest.fixture(scope="module")
def real_set() -> SweepSet:
    return load_challenge_set(REAL_NXT, load_map("co333-arena"))


def test_a_sweep_turns_by_whole_bins_round_its_ring(real_set: SweepSet) -> None:
    sw = real_set.sweeps[0]  # 360 readings a degree apart, clockwise
    as_read = replace(sw, held=None).scan().ranges  # the sensor's readings, held runs as read
    own = rotated(sw, math.radians(sw.heading_deg)).ranges
    assert np.array_equal(own, as_read)
    # a robot turned 3 degrees to the left sees each reading's wall 3 degrees further clockwise: the same
    # readings in the order taken, at turret angles 3 degrees (3 bins) less
    turned = rotated(sw, math.radians(sw.heading_deg + 3.0))
    assert np.array_equal(turned.ranges, as_read)
    ring = np.degrees(turned.angles - rotated(sw, math.radians(sw.heading_deg)).angles)
    assert np.allclose(ring, -3.0)


def test_a_turned_sweep_keeps_its_runs_whole(real_set: SweepSet) -> None:
    """However far the robot stands turned, a stuck run of a sweep stays one run: the same readings are
    dropped as stuck (turning the readings round the ring split a run at the ring's seam)."""
    readings = np.loadtxt(Path(__file__).parent / "data" / "real-nxt-stuck" / "loc_00.dat")  # 88 cm held 160 deg
    sw = replace(real_set.sweeps[0], readings=readings, x_cm=84.0, y_cm=30.0, heading_deg=0.0, held=None)
    dropped = [drop_stuck(rotated(sw, math.radians(turn)), real_set.map, position=(84.0, 30.0))[1]
               for turn in (0.0, 7.0, 90.0, -150.0)]
    assert dropped == [160] * 4


def test_a_stops_sweeps_are_scored_each_on_its_own(real_set: SweepSet) -> None:
    m, turn = real_set.map, math.radians(90.0)
    sw, elsewhere = real_set.sweeps[0], real_set.sweeps[1]
    heading = math.radians(sw.heading_deg)
    first, other = rotated(sw, heading), rotated(elsewhere, heading + turn)  # two sweeps unlike each other
    poses = np.array([[sw.x_cm, sw.y_cm, heading + math.radians(d)] for d in (-20.0, -5.0, 0.0, 7.0, 40.0)])
    each = [thin_ray_misfits(m, first, poses), thin_ray_misfits(m, other, poses + np.array([0.0, 0.0, turn]))]
    stop = misfits(m, joined(first, other, turn), poses)
    assert np.allclose(stop, np.mean(each, axis=0))  # each sweep's median, averaged
    pooled = Scan(np.concatenate([first.angles, other.angles + turn]), np.concatenate([first.ranges, other.ranges]),
                  np.concatenate([first.valid, other.valid]))
    assert not np.allclose(stop, thin_ray_misfits(m, pooled, poses))  # not the median of their echoes pooled
    silent = Scan(other.angles, other.ranges, np.zeros(len(other), dtype=bool))  # no echo: adds nothing
    assert np.allclose(misfits(m, joined(first, silent, turn), poses), each[0])
    again = rotated(sw, heading + turn)  # the same place swept again, turned: the fit finds the heading
    alone = rank_places(m, first, [(sw.x_cm, sw.y_cm)], step_deg=0.5)[0][1]
    both = rank_places(m, joined(first, again, turn), [(sw.x_cm, sw.y_cm)], step_deg=0.5)[0][1]
    assert abs(math.degrees(float(angle_diff(both.theta, alone.theta)))) <= 0.5


def test_the_fit_tries_the_headings_a_sweep_set_is_aligned_on(real_set: SweepSet) -> None:
    """A sweep turned by whole bins fits exactly where its alignment put it, turned by those bins: the fit
    tries the lattice the alignment tried (`ALIGN_STEP_DEG` from 0), wherever the prediction it is centred on."""
    m = real_set.map
    for sw in real_set.sweeps:
        aligned = aligned_heading_deg(sw, m)
        robot = aligned + 37.3  # the sonar turns the ring by 37 whole bins of 1 degree
        scan = rotated(replace(sw, heading_deg=aligned), math.radians(robot))
        for predicted in (None, robot + 7.3, robot - 11.9):
            centre = None if predicted is None else math.radians(predicted)
            fitted = fit_pose(m, scan, [(sw.x_cm, sw.y_cm)], heading=centre, span_deg=30.0)
            assert math.degrees(float(angle_diff(fitted.theta, math.radians(aligned + 37.0)))) == pytest.approx(0.0)


def test_the_sonar_answers_near_a_waypoint_and_refuses_elsewhere(real_set: SweepSet) -> None:
    sonar = SweepSetSonar(real_set, "andrei-alpha/robotics")
    scan, sweep = sonar.sweep_at(Pose(186.0, 33.0, 0.0), rng=0)  # 6.7 cm from (180, 30)
    assert (sweep.x_cm, sweep.y_cm) == (180.0, 30.0) and len(scan) == 360
    with pytest.raises(SweepRefused, match=r"\(180, 30\), is 12\.0 cm away \(more than 10 cm\)"):
        sonar.sweep_at(Pose(168.0, 30.0, 0.0), rng=0)
    wider = SweepSetSonar(real_set, "andrei-alpha/robotics", radius_cm=20.0)
    assert len(wider.sweep_at(Pose(168.0, 30.0, 0.0), rng=0)[0]) == 360
    with pytest.raises(SweepRefused, match=r"\(180, 30\), is 22\.0 cm away \(more than 20 cm\)"):
        wider.sweep_at(Pose(158.0, 30.0, 0.0), rng=0)


def test_a_sweep_answers_for_where_the_robot_stands(real_set: SweepSet) -> None:
    """5 cm nearer the wall ahead (x = 210) the robot reads it 5 cm nearer; 5 cm farther from the wall
    below (y = 0), 5 cm farther; no-echo readings stay no echo. Without the correction, the sweep as taken."""
    sw = real_set.at(180.0, 30.0)[0]
    heading = math.radians(sw.heading_deg)
    at_waypoint = rotated(sw, heading)
    for moved, looking, change in ((Pose(185.0, 30.0, heading), 0.0, -5.0), (Pose(180.0, 35.0, heading), -90.0, 5.0)):
        plain, _ = SweepSetSonar(real_set, sw.repo).sweep_at(moved, rng=0)  # by default, as taken
        assert np.array_equal(plain.ranges, at_waypoint.ranges)
        scan, _ = SweepSetSonar(real_set, sw.repo, offset_correction=True).sweep_at(moved, rng=0)
        off = np.degrees(scan.angles + heading) - looking
        cone = (np.abs((off + 180.0) % 360.0 - 180.0) <= 5.0) & at_waypoint.valid
        assert cone.any()
        assert np.allclose(scan.ranges[cone] - at_waypoint.ranges[cone], change, atol=1.0)
        assert np.array_equal(scan.valid, at_waypoint.valid)


def test_an_update_the_drive_cannot_explain_is_not_trusted() -> None:
    cfg = ChallengeConfig()
    predicted = PoseEstimate(Pose(100.0, 50.0, 0.0), np.diag([4.0, 4.0, 0.001]), False)
    assert plausible_update(predicted, Pose(106.0, 52.0, 0.05), cfg)  # 6 cm: within 3 sd (sd 3.6 cm)
    assert not plausible_update(predicted, Pose(100.0, 70.0, 0.0), cfg)  # 20 cm: a jump
    assert not plausible_update(predicted, Pose(101.0, 50.0, math.radians(40.0)), cfg)  # turned 40 degrees


def test_the_route_starts_at_the_start_and_goes_round_the_course() -> None:
    assert course_from([(1, 1), (2, 2), (3, 3)], 2) == [(3, 3), (1, 1), (2, 2)]


def test_run_with_real_sweeps_visits_every_waypoint_of_the_route(
        tmp_path: Path, twin_heading_warnings: Callable[[], list[str]]) -> None:
    report = tmp_path / "run.json"
    code = run_cli(["run", "--map", "co333-arena", "--sonar", f"sweeps:{REAL_NXT}", "--seed", "3",
                    "--json", str(report)])
    said = twin_heading_warnings()
    assert len(said) == 1 and said[0].startswith("andrei-alpha/robotics/loc_03.dat: heading_deg -90.5")
    doc = json.loads(report.read_text())
    assert code == (0 if doc["reached"] else 1)
    waypoints = [[180.0, 30.0], [126.0, 168.0], [30.0, 54.0]]
    assert doc["route"][0] in waypoints and sorted(doc["route"]) == sorted(waypoints)
    assert doc["visits"][0]["error_cm"] == 0.0  # put down on its start waypoint
    assert doc["worst_error_cm"] == max(v["error_cm"] for v in doc["visits"])
    assert doc["reached"] == (len(doc["visits"]) == 3 and doc["worst_error_cm"] <= 10.0)


@pytest.mark.slow
def test_bench_challenge_writes_a_row_per_mission(tmp_path: Path,
                                                  twin_heading_warnings: Callable[[], list[str]]) -> None:
    """... and warns that the set's heading at (126, 168) is a quarter turn from where the model finds it."""
    out = tmp_path / "out"
    assert run_cli(["bench", "challenge", str(REAL_NXT), "--localisers", "paper-pf", "--seeds", "0",
                    "--out", str(out)]) == 0
    said = twin_heading_warnings()
    assert len(said) == 1 and said[0].startswith("andrei-alpha/robotics/loc_03.dat: heading_deg -90.5")
    with (out / "challenge.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == COLUMNS
    assert {(float(r["start_x_cm"]), float(r["start_y_cm"])) for r in rows} == {(180, 30), (126, 168), (30, 54)}
    for r in rows:
        assert int(r["waypoints"]) == 3 and int(r["collisions"]) >= 0
        if r["reached"] == "True":
            assert float(r["worst_error_cm"]) <= 10.0 and r["status"] == "done"
        elif r["status"] == "done":  # every sweep answered, yet a waypoint was ended more than 10 cm from
            assert float(r["worst_error_cm"]) > 10.0
    doc = json.loads((out / "summary.json").read_text())
    reached = sum(r["reached"] == "True" for r in rows) / 3
    assert doc["summary"]["paper-pf"]["all"]["reached"] == pytest.approx(reached)
    assert "| paper-pf | all | 3 |" in (out / "summary.md").read_text()


def _copy(tmp_path: Path) -> Path:
    dst = tmp_path / "set"
    shutil.copytree(REAL_NXT, dst)
    return dst


def _keep_rows(folder: Path, keep: int) -> None:
    lines = (folder / "sweeps.csv").read_text().splitlines()
    (folder / "sweeps.csv").write_text("\n".join(lines[:1 + keep]) + "\n")


def _drop_heading(folder: Path) -> None:
    text = (folder / "sweeps.csv").read_text().replace(",0.0,-90.5,", ",0.0,,")
    (folder / "sweeps.csv").write_text(text)


@pytest.mark.parametrize(("command", "spoil", "message"), [
    ("run", None, "no such folder"),
    ("run", "map1", "differs from the map 'map1'"),
    ("run", _drop_heading, "sweep andrei-alpha/robotics/loc_03.dat has no heading_deg"),
    ("run", lambda f: _keep_rows(f, 1), "no source has sweeps at two or more waypoints"),
    ("bench", lambda f: _keep_rows(f, 1), "no source has sweeps at two or more waypoints"),
    ("bench", "map1", "differs from the map 'map1'"),
])
def test_bad_sweep_sets_are_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str,
                                                spoil: object, message: str) -> None:
    folder, map_name = _copy(tmp_path), "co333-arena"
    if spoil is None:
        folder = tmp_path / "missing"
    elif isinstance(spoil, str):
        map_name = spoil
    else:
        spoil(folder)  # type: ignore[operator]
    out = tmp_path / "out"
    argv = (["run", "--map", map_name, "--sonar", f"sweeps:{folder}", "--json", str(out / "r.json")]
            if command == "run" else ["bench", "challenge", str(folder), "--map", map_name, "--out", str(out)])
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nxtnav: error: ") and message in err and "\n" not in err
    assert not out.exists()


def test_a_set_without_headings_runs_with_the_headings_that_align_it(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """``--headings aligned``: a sweep without heading_deg (refused by default, above) takes the heading that
    aligns it with the map at its waypoint, within a degree of the one the set gave it; the summary says so.
    An unknown choice is one line and exit 2."""
    folder = _copy(tmp_path)
    _drop_heading(folder)
    out = tmp_path / "out"
    argv = ["bench", "challenge", str(folder), "--map", "co333-arena", "--localisers", "paper-pf", "--seeds", "0"]
    assert run_cli([*argv, "--headings", "north", "--out", str(out)]) == 2
    assert "--headings: must be column, aligned or model, got 'north'" in capsys.readouterr().err
    assert not out.exists()
    assert run_cli([*argv, "--headings", "aligned", "--out", str(out)]) == 0, capsys.readouterr().err
    doc = json.loads((out / "summary.json").read_text())
    assert doc["headings"] == "aligned" and "--headings aligned" in doc["command"]
    assert doc["truth_headings_deg"]["andrei-alpha/robotics/loc_03.dat"] == pytest.approx(-90.5, abs=1.0)
    with (out / "challenge.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 3


def test_run_takes_the_aligned_headings_of_a_set_without_them(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    """`nxtnav run --sonar sweeps:DIR --headings aligned` runs a set without heading_deg (refused without it,
    the error naming the option), the report says which headings it took; `--headings` with a simulated
    sonar is one line and exit 2."""
    folder = _copy(tmp_path)
    _drop_heading(folder)
    report = tmp_path / "r.json"
    argv = ["run", "--map", "co333-arena", "--sonar", f"sweeps:{folder}", "--seed", "0", "--json", str(report)]
    assert run_cli(argv) == 2
    assert "--headings aligned finds it" in capsys.readouterr().err
    assert run_cli([*argv, "--headings", "aligned"]) in (0, 1)
    doc = json.loads(report.read_text())
    assert doc["headings"] == "aligned" and doc["visits"]
    assert run_cli(["run", "--map", "map1", "--headings", "aligned", "--json", str(tmp_path / "s.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith("--headings aligned: only with --sonar sweeps:DIR (a real sweep's heading)")
    assert not (tmp_path / "s.json").exists()


def test_a_crashed_mission_of_a_set_without_headings_is_still_a_row(tmp_path: Path) -> None:
    """A mission whose worker died is recorded from the set as its task loads it: with the headings the task
    carries (``--headings aligned``), not the set's missing column."""
    folder = _copy(tmp_path)
    _drop_heading(folder)
    m = load_map("co333-arena")
    headings = aligned_headings(load_sweep_set(folder, m))
    tasks = challenge_tasks(load_challenge_set(folder, m, headings), "co333-arena", ["paper-pf"], [0],
                            headings=headings)
    row = crashed_mission(tasks[0], "killed by signal 11 (SIGSEGV)")
    assert (row.reached, row.status) == (False, "crashed: killed by signal 11 (SIGSEGV)")
    assert (row.start_x_cm, row.start_y_cm) in {(180.0, 30.0), (126.0, 168.0), (30.0, 54.0)}


def test_run_options_a_challenge_does_not_take_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plot = tmp_path / "mission.png"
    assert run_cli(["run", "--map", "co333-arena", "--sonar", f"sweeps:{REAL_NXT}", "--start", "30,54",
                    "--plot", str(plot)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("nxtnav: error: --start, --plot: not with --sonar sweeps:") and "\n" not in err
    assert not plot.exists()


@pytest.mark.parametrize("oracle", ["pose", "heading"])
def test_an_oracle_gives_the_belief_the_truth_after_each_sweep(real_set: SweepSet, oracle: str) -> None:
    """The ceiling the policy is measured against: with the truth's pose after every sweep, the belief
    stands where the robot does (the believed and the true distance from each waypoint agree); with the
    heading alone, only where odometry puts it."""
    config = ChallengeConfig.model_validate({"fix": {"oracle": oracle}})
    report = challenge_mission(real_set, "andrei-alpha/robotics", 0, 1, "paper-pf", config=config)
    swept = [v for v in report.visits[1:] if v.sweeps]
    assert swept
    same = [math.isclose(v.error_cm, v.estimate_error_cm, abs_tol=0.5) for v in swept]
    assert all(same) if oracle == "pose" else not all(same)


@pytest.fixture
def taken(monkeypatch: pytest.MonkeyPatch) -> list[Pose]:
    """The true poses at which the sweep-set sonar answered, in order (it still answers as it would)."""
    poses: list[Pose] = []
    sweep_at = SweepSetSonar.sweep_at

    def recorded(self: SweepSetSonar, pose: Pose, rng: object = None) -> object:
        poses.append(pose)
        return sweep_at(self, pose, rng)  # type: ignore[arg-type]

    monkeypatch.setattr(SweepSetSonar, "sweep_at", recorded)
    return poses


def test_a_facing_sweep_turns_toward_the_next_leg_and_sweeps_again(real_set: SweepSet, taken: list[Pose]) -> None:
    """With the facing sweep every stop but the last sweeps twice, the second time where it stood for the
    first, turned toward the next waypoint; without it, once. The mission still reaches every waypoint
    (motion noise of 0.1 cm a move, so that a leg's drift cannot miss)."""
    sweeps = {}
    for facing in (False, True):
        taken.clear()
        report = challenge_mission(real_set, "andrei-alpha/robotics", 1, 0, "paper-pf",
                                   noise=MotionNoise(model="absolute"), config=ChallengeConfig(facing_sweep=facing))
        assert report.reached and len(report.visits) == 3 and report.sweeps_taken == len(taken)
        sweeps[facing] = list(taken)
    assert len(sweeps[False]) == 3 and len(sweeps[True]) == 5
    for stop, goal in zip(range(2), report.route[1:], strict=True):
        first, second = sweeps[True][2 * stop], sweeps[True][2 * stop + 1]
        assert math.hypot(first.x - second.x, first.y - second.y) < 0.5
        bearing = math.atan2(goal[1] - second.y, goal[0] - second.x)
        assert abs(math.degrees(float(angle_diff(second.theta, bearing)))) < 15.0
        assert abs(math.degrees(float(angle_diff(first.theta, bearing)))) > 15.0


class _Crashes(ShortestPathPlanner):
    """A planner that kills its own process (a crash in compiled code, as OMPL's AORRTC does now and then)."""

    def plan(self, problem: PlanningProblem) -> PlanResult:
        faulthandler.disable()
        os.kill(os.getpid(), signal.SIGSEGV)
        return super().plan(problem)


def test_bench_challenge_records_crashed_missions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A mission whose worker process dies is a row, not reached, its status the signal, and the summary
    counts it as a miss; the benchmark itself ran (exit 0, as when its missions fail)."""
    out = tmp_path / "challenge"
    with PLANNERS.added({"crashes": _Crashes}):  # the forked workers inherit it
        code = run_cli(["bench", "challenge", str(REAL_NXT), "--map", "co333-arena", "--seeds", "0", "--localisers",
                        "paper-pf", "--planner", "crashes", "--workers", "2", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    with (out / "challenge.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 and all(r["status"] == "crashed: killed by signal 11 (SIGSEGV)" and r["reached"] == "False"
                                  and r["robot_time_s"] == "nan" for r in rows)
    assert "| paper-pf | all | 3 | 0% | – | – | 0 | 0 | – | – |" in (out / "summary.md").read_text()


def test_simulated_readings_run_the_same_mission_on_the_models_sweeps(real_set: SweepSet,
                                                                       taken: list[Pose]) -> None:
    """``challenge.sonar.readings=simulated``: no real sweep is read, the robot sweeps with the model at
    its true pose, and the report scores each leg's starting heading against the truth as for real ones."""
    reports = {readings: challenge_mission(real_set, "andrei-alpha/robotics", 0, 0, "paper-pf",
                                           noise=MotionNoise(model="absolute"),
                                           config=ChallengeConfig.model_validate({"sonar": {"readings": readings}}))
               for readings in ("simulated", "real")}
    assert len(taken) == reports["real"].sweeps_taken == 5  # the real mission's sweeps only
    assert reports["simulated"].sweeps_taken == 5
    for report in reports.values():
        assert len(report.leg_heading_errors_deg) == len(report.route) - 1
        assert all(0.0 <= e <= 180.0 for e in report.leg_heading_errors_deg)
    assert reports["real"].leg_heading_error_deg < 1.0  # two sweeps of real readings pin the heading


def _policy(real_set: SweepSet, true_pose: Pose, believed: Pose, config: ChallengeConfig) -> WaypointSweeps:
    """The challenge's policy for andrei-alpha's sweeps, the robot truly at `true_pose`, believing `believed`."""
    m = real_set.map
    robot = SweepSetRobot(m, true_pose, SweepSetSonar(real_set, "andrei-alpha/robotics"),
                          noise=MotionNoise(model="absolute"), rng=0)
    policy = WaypointSweeps(robot, m, make_localiser("paper-pf", m, rng=0), make_planner("min-turn"),
                            np.random.default_rng(0), config)
    policy._settle(believed)
    return policy


def test_the_first_legs_sweep_picks_the_start_it_fits(real_set: SweepSet) -> None:
    """The sweep taken where the believed start put the robot is fitted where each start would have put it:
    the start whose place the sweep fits wins, in either order of belief."""
    sweep = real_set.at(126.0, 168.0)[0]
    truth = Pose(126.0, 168.0, math.radians(sweep.heading_deg))
    elsewhere = Pose(30.0, 54.0, math.radians(sweep.heading_deg))  # a place whose walls differ
    for believed, starts, right in ((elsewhere, [Pose(0, 0, 0), Pose(96.0, 114.0, 0.0)], 1),
                                    (truth, [Pose(0, 0, 0), Pose(-96.0, -114.0, 0.0)], 0)):
        policy = _policy(real_set, truth, believed, ChallengeConfig())
        predicted = policy.estimate
        assert predicted is not None
        policy.last_fix = (policy.sweep(), predicted, (believed.x, believed.y))
        assert policy.better_start(starts) == right


def test_the_first_leg_is_planned_free_at_the_start_the_mission_may_fall_back_to(real_set: SweepSet) -> None:
    """After the start's fit the next best start stays unresolved (``start_retries``; none with 0), and the first
    leg is planned free where the believed start puts the robot and where that one would, when such a path
    exists: here the other start is the same place turned by 45 degrees, where the plain path meets a wall."""
    truth = Pose(126.0, 168.0, math.radians(real_set.at(126.0, 168.0)[0].heading_deg))
    course = course_waypoints(real_set, "andrei-alpha/robotics")
    policy = _policy(real_set, truth, truth, ChallengeConfig())
    ranked = policy.localise_start(course)
    assert [(m.source, m.target) for m in policy.unresolved] == [(ranked[0], ranked[1])]
    no_retry = _policy(real_set, truth, truth, ChallengeConfig(start_retries=0))
    no_retry.localise_start(course)
    assert not no_retry.unresolved
    policy = _policy(real_set, truth, Pose(126.0, 168.0, -math.pi / 2), ChallengeConfig())
    plain = policy._plan((30.0, 54.0))
    assert plain is not None
    turned = RigidMove(Pose(126.0, 168.0, -math.pi / 2), Pose(126.0, 168.0, -math.pi / 4))
    policy.unresolved = [turned]
    both = policy._plan((30.0, 54.0))
    assert both is not None
    checker = policy.checkers[0]
    assert checker.path_free(plain) and not checker.path_free(turned.points(plain))
    assert checker.path_free(both) and checker.path_free(turned.points(both))


def test_after_a_change_of_start_a_leg_is_driven_only_where_every_open_start_is_free(real_set: SweepSet) -> None:
    """Once the mission has given up its start for another, a leg is driven only on a path free at every start
    still open; with none, and with no free path at all, nothing is driven: no straight line into a wall."""
    here = Pose(126.0, 168.0, 0.0)
    policy = _policy(real_set, here, here, ChallengeConfig())
    away = RigidMove(here, Pose(30.0, 54.0, math.pi))  # the other start: (30, 54)'s copy of the goal is outside
    policy.unresolved = [away]
    assert policy._plan((180.0, 30.0)) is not None  # before a change of start: the plain path, as before
    policy.switched = True
    assert policy._plan((180.0, 30.0)) is None
    assert policy.drive_to((180.0, 30.0)) is False and policy.robot.true_pose == here
    policy.unresolved, policy.switched = [], False
    assert policy.drive_to((180.0, 30.0)) is True and policy.robot.true_pose != here
    assert policy._plan((84.0, 150.0)) is None  # inside the stub wall's margin: no free path at all


def test_a_start_the_drive_would_have_taken_out_of_the_arena_is_given_up(real_set: SweepSet) -> None:
    """Where each other start would have put the robot after its first leg must lie in the arena (within
    ``recovery.start_slack_cm`` of the free space): (30, 54) facing +x would put a robot that drove 108 cm toward -y
    from (126, 168) 54 cm below the arena; facing -x, 6 cm beside it, which drift explains."""
    believed = Pose(126.0, 168.0, 0.0)
    policy = _policy(real_set, believed, Pose(126.0, 60.0, 0.0), ChallengeConfig())
    inside, outside = Pose(30.0, 54.0, math.pi), Pose(30.0, 54.0, 0.0)
    assert policy.possible_starts(believed, [outside, inside]) == [inside]
    strict = ChallengeConfig(recovery=ChallengeRecovery(start_slack_cm=1.0))
    assert not _policy(real_set, believed, Pose(126.0, 60.0, 0.0), strict).possible_starts(believed, [outside, inside])


def test_a_belief_drift_put_too_near_a_wall_plans_from_the_nearest_free_point(real_set: SweepSet) -> None:
    """A belief within the robot's radius of a wall (2 cm too near the wall y = 0) plans from the nearest
    free point, the short move out the path's first leg; one farther in than ``recovery.escape_cm`` plans nothing."""
    truth = Pose(60.0, 12.0, 0.0)
    policy = _policy(real_set, truth, Pose(60.0, 6.0, 0.0), ChallengeConfig())
    bare = policy.checkers[1]
    assert policy.estimate is not None and not bare.point_free(policy.estimate.pose.xy)
    path = policy._plan((30.0, 54.0))
    assert path is not None and path[0].tolist() == policy.estimate.pose.xy.tolist()
    assert 0.0 < math.dist(path[0], path[1]) <= ChallengeConfig().recovery.escape_cm and bare.path_free(path[1:])
    assert _policy(real_set, truth, Pose(60.0, -10.0, 0.0), ChallengeConfig())._plan((30.0, 54.0)) is None


def test_a_change_of_start_a_sweep_decided_is_not_held_to_the_start_given_up(real_set: SweepSet) -> None:
    """A change of start on a sweep that answered and fits the new start better leaves legs free to be planned
    at the new start alone when no path is free at both; one on a refusal alone does not (`switched`)."""
    here = Pose(126.0, 168.0, 0.0)
    for answered, planned in ((True, True), (False, False)):
        policy = _policy(real_set, here, here, ChallengeConfig())
        policy.restart_from(here, here, [Pose(30.0, 54.0, math.pi)], answered=answered)
        assert policy.switched is not answered and len(policy.unresolved) == 1
        assert (policy._plan((180.0, 30.0)) is not None) is planned


@pytest.mark.parametrize(("false_stops", "moved_cm", "stops"), [(1, 30.0, 1), (None, 0.0, 2)])
def test_a_watchdog_stop_at_once_is_looked_at_again_before_the_leg_ends(
        real_set: SweepSet, monkeypatch: pytest.MonkeyPatch, false_stops: int | None, moved_cm: float, stops: int,
) -> None:
    """A move the watchdog stops before it starts (two short readings: the real sensor gives them now and
    then) is tried once more; a leg ends only when the sonar stops it at once twice in a row (an obstacle)."""
    truth = Pose(60.0, 42.0, 0.0)  # 140 cm of free floor ahead
    policy = _policy(real_set, truth, truth, ChallengeConfig())
    robot = policy.robot  # a stop takes two short readings; None: they never end
    readings = itertools.repeat(5.0) if false_stops is None else iter([5.0] * 2 * false_stops)
    original = robot.read_forward
    monkeypatch.setattr(robot, "read_forward", lambda: next(readings, None) or original())
    policy._act(0.0, 30.0)
    assert robot.true_pose.x - truth.x == pytest.approx(moved_cm, abs=0.5) and robot.watchdog_stops == stops


HERE = (180.0, 30.0)  # a waypoint 30 cm from the wall x = 210


def _exact_sweep(angles_deg: NDArray[np.float64]) -> Scan:
    """The arena's exact ranges from `HERE` facing +x, at `angles_deg`."""
    m, angles = load_map("co333-arena"), np.radians(angles_deg)
    return Scan(angles, exact_ranges(m, np.array([[*HERE, 0.0]]), angles)[0], np.ones(angles.size, dtype=bool))


def test_a_flat_fit_leaves_the_heading_to_the_prior_and_a_sharp_one_decides() -> None:
    """A sweep that sees one wall head-on (readings within 4 degrees of its normal) fits every heading
    within a few degrees as well: the prior decides, and the belief stays as wide as the prior. A full
    sweep of the arena pins the heading whatever the prior, and the belief narrows."""
    m, here = load_map("co333-arena"), HERE
    head_on, full = _exact_sweep(np.arange(-4.0, 4.5, 1.0)), _exact_sweep(np.arange(0.0, 360.0, 5.0))
    sd = math.radians(2.0)
    for prior_deg in (-3.0, 3.0):
        around = math.radians(prior_deg)
        heading, spread = heading_belief(m, head_on, here, around, 30.0, 0.25, sd)
        assert math.degrees(heading) == pytest.approx(prior_deg, abs=1.0)  # not halfway to the flat fit's 0
        assert spread == pytest.approx(sd, rel=0.2)
        heading, spread = heading_belief(m, full, here, around, 30.0, 0.25, sd)
        assert math.degrees(heading) == pytest.approx(0.0, abs=0.25)
        assert spread < sd / 2
    _, spread = heading_belief(m, head_on, here, math.radians(3.0), 30.0, 0.25)  # no prior: as wide as the flat
    assert math.degrees(spread) > 2.0
    behind = Scan(full.angles - math.pi, full.ranges, full.valid)  # the same sweep by a robot facing -x
    heading, _ = heading_belief(m, behind, here, math.radians(178.0), 30.0, 0.25, sd)  # round the circle
    assert abs(math.degrees(heading)) == pytest.approx(180.0, abs=0.25)


def test_a_waypoints_flat_sweep_does_not_turn_the_predicted_heading(real_set: SweepSet) -> None:
    """The mission's fix (``fused``, the default) keeps a prediction a flat sweep cannot contradict; the
    fit alone (``sweep``) takes the flat's least misfit, wherever on the flat it fell."""
    predicted = PoseEstimate(Pose(*HERE, math.radians(3.0)), np.diag([9.0, 9.0, math.radians(2.0) ** 2]), True, 1)
    head_on = _exact_sweep(np.arange(-4.0, 4.5, 1.0))
    fused = _policy(real_set, Pose(*HERE, 0.0), predicted.pose, ChallengeConfig())
    heading, spread = fused.fixed_heading(head_on, predicted, HERE)
    assert math.degrees(heading) == pytest.approx(3.0, abs=1.0)
    assert math.degrees(spread) == pytest.approx(2.0, rel=0.2)
    alone = _policy(real_set, Pose(*HERE, 0.0), predicted.pose, ChallengeConfig(fix=ChallengeFix(heading_from="sweep")))
    assert abs(math.degrees(alone.fixed_heading(head_on, predicted, HERE)[0]) - 3.0) > 2.0


def test_under_botsims_noise_a_leg_is_driven_in_the_moves_that_end_it_surest() -> None:
    """BotSim draws a move's error in proportion to it and turns the heading a little at every move:
    shorter moves average the first and add up the second. The moves `MotionNoise.move_cm` picks for a 150 cm
    leg end it closer to where it was aimed, in the simulator itself, than the 10 cm moves it used to
    make; under absolute noise (an error per move whatever its length) it keeps the longest."""
    m, botsim = load_map("co333-arena"), MotionNoise("botsim", 0.1, 0.005)
    best = botsim.move_cm(150.0, 10.0)
    assert 3.0 < best < 6.0
    assert MotionNoise("absolute", 0.1, 0.005).move_cm(150.0, 10.0) == 10.0

    def rms_miss(move_cm: float) -> float:
        misses = []
        for seed in range(400):
            robot = SimRobot(m, Pose(20.0, 42.0, 0.0), noise=botsim, watchdog_cm=0.0, watchdog_step_cm=150.0,
                             rng=seed)
            for _ in range(round(150.0 / move_cm)):
                robot.move(move_cm)
            misses.append(math.hypot(robot.true_pose.x - 170.0, robot.true_pose.y - 42.0))
        return float(np.sqrt(np.mean(np.square(misses))))

    assert rms_miss(150.0 / round(150.0 / best)) < 0.92 * rms_miss(10.0)
