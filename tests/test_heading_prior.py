"""A heading prior: the position unknown, the heading roughly known (`localisation.base.HeadingPrior`).

Ground truth: a square room, where one sweep fits four places equally (the room turned by 0, 90, 180
and 270 degrees about its centre), so only the heading can tell the true place from its twins.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, run_cli

from localisation import HeadingPrior, Motion, candidate_poses, make_localiser
from localisation.robot_options import localiser_options
from toolkit.mission import Outcome, run_sim_mission
from toolkit.real_sonar.margins import sweep_margins
from toolkit.real_sonar.sweeps import load_sweep_set
from toolkit.recordings.recorder import Recorder
from toolkit.recordings.replay import read_recording, replay
from toolkit.world import ConfigError, LocalisationError, NxtSonar, Pose, RobotModel, Scan, map_from_dict

SQUARE = map_from_dict({"name": "square", "boundary": [[0, 0], [120, 0], [120, 120], [0, 120]]})
TRUTH = (35.0, 25.0, math.radians(10.0))
SONAR = NxtSonar()
ANGLES = np.radians(np.arange(0.0, 360.0, 5.0))
GLOBAL = ("paper-pf", "amcl")


def _sweep(seed: int, pose: tuple[float, float, float] = TRUTH) -> Scan:
    rng = np.random.default_rng(seed)
    readings = SONAR.measure(SQUARE.walls, np.array([pose[:2]]), (pose[2] + ANGLES)[None, :], rng)[0]
    return SONAR.to_scan(ANGLES, readings)


def _localiser(name: str, seed: int):  # type: ignore[no-untyped-def]
    return make_localiser(name, SQUARE, rng=seed, **localiser_options(name, RobotModel(SONAR)))


def _twins() -> list[tuple[float, float]]:
    """The true position turned about the room's centre by 0, 90, 180 and 270 degrees."""
    x, y = TRUTH[0] - 60.0, TRUTH[1] - 60.0
    return [(60.0 + x * math.cos(a) - y * math.sin(a), 60.0 + x * math.sin(a) + y * math.cos(a))
            for a in np.radians([0.0, 90.0, 180.0, 270.0])]


def test_the_prior_is_a_wrapped_gaussian_and_refuses_bad_values() -> None:
    hp = HeadingPrior(math.radians(170.0), math.radians(10.0))
    assert float(hp.cost(math.radians(-170.0))) == pytest.approx(4.0)  # 20 degrees away across +-180
    draws = hp.sample(20000, np.random.default_rng(0))
    assert np.all(np.abs(draws) <= math.pi)
    off = np.degrees(np.angle(np.exp(1j * (draws - hp.heading_rad))))
    assert abs(off.mean()) < 0.3 and off.std() == pytest.approx(10.0, rel=0.03)
    assert HeadingPrior.parse("-90:15") == HeadingPrior(math.radians(-90.0), math.radians(15.0))
    for bad in ("0", "0:0", "0:-5", "a:5", "0:5:1", "nan:5"):
        with pytest.raises(ConfigError, match="heading prior"):
            HeadingPrior.parse(bad)


@pytest.mark.parametrize("name", GLOBAL)
def test_without_the_heading_a_square_room_is_ambiguous(name: str) -> None:
    twins = _twins()
    for seed in (0, 1, 2):
        loc = _localiser(name, seed)
        loc.reset(None)
        loc.update(_sweep(seed))
        cands = candidate_poses(loc)
        assert not loc.estimate().converged
        found = {i for i, (tx, ty) in enumerate(twins) for c in cands if math.hypot(c.x - tx, c.y - ty) <= 10.0}
        assert len(found) >= 3, f"seed {seed}: candidates {cands} find only twins {sorted(found)}"


@pytest.mark.parametrize("name", GLOBAL)
def test_the_heading_prior_picks_the_true_twin(name: str) -> None:
    for seed in (0, 1, 2):
        loc = _localiser(name, seed)
        loc.reset(HeadingPrior(math.radians(25.0), math.radians(20.0)))  # 15 degrees off the truth
        loc.update(_sweep(seed))
        est = loc.estimate().pose
        assert math.hypot(est.x - TRUTH[0], est.y - TRUTH[1]) <= 5.0, f"seed {seed}: {est}"
        assert abs(math.degrees(est.theta - TRUTH[2])) <= 5.0, f"seed {seed}: {est}"


@pytest.mark.parametrize("name", GLOBAL)
def test_the_heading_prior_turns_with_the_robot_before_the_first_sweep(name: str) -> None:
    turned = (TRUTH[0], TRUTH[1], TRUTH[2] + math.radians(90.0))
    loc = _localiser(name, 0)
    loc.reset(HeadingPrior(TRUTH[2], math.radians(15.0)))
    loc.predict(Motion(turn_rad=math.radians(90.0)))
    loc.update(_sweep(0, turned))
    est = loc.estimate().pose
    assert math.hypot(est.x - TRUTH[0], est.y - TRUTH[1]) <= 5.0 and abs(math.degrees(est.theta - turned[2])) <= 5.0


def test_it_weighs_the_first_fix_only() -> None:
    """After the first fix the motion history carries the heading: a second global reset without the
    prior is as ambiguous as ever."""
    loc = _localiser("paper-pf", 0)
    loc.reset(HeadingPrior(TRUTH[2], math.radians(10.0)))
    loc.update(_sweep(0))
    loc.reset(None)
    loc.update(_sweep(1))
    assert len(candidate_poses(loc)) >= 3


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_pose_trackers_refuse_it(name: str) -> None:
    with pytest.raises(LocalisationError, match="heading prior gives it no position"):
        _localiser(name, 0).reset(HeadingPrior(0.0, 0.3))


def test_a_recorded_heading_prior_replays_bit_for_bit(tmp_path: Path) -> None:
    path = tmp_path / "rec.jsonl"
    rec = Recorder(path, map=SQUARE, robot={"kind": "sim"}, sonar={"model": "nxt", "params": SONAR.to_dict()},
                   seed=3)
    rng = np.random.default_rng(3)
    opts = localiser_options("paper-pf", RobotModel(SONAR))
    loc = rec.wrap_localiser(make_localiser("paper-pf", SQUARE, rng=rng, **opts), options=opts, rng=rng)
    loc.reset(HeadingPrior(TRUTH[2], math.radians(20.0)))
    scan = _sweep(3)
    rec.known_scan(scan, TRUTH[:2], TRUTH[2])
    loc.update(scan)
    rec.close("done", None)
    resets = [e for e in map(json.loads, path.read_text().splitlines()) if e.get("type") == "reset"]
    assert resets[0]["prior"] == {"heading_deg": pytest.approx(10.0), "sd_deg": pytest.approx(20.0)}
    report = replay(read_recording(path), ["paper-pf"])
    assert report.reproduced["paper-pf"] is True and report.compared > 0
    est = report.steps[-1].estimates["paper-pf"]
    assert est is not None and math.hypot(est.pose.x - TRUTH[0], est.pose.y - TRUTH[1]) <= 5.0


def test_a_recording_with_a_bad_heading_prior_is_one_line_and_exit_2(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "rec.jsonl"
    rec = Recorder(path, map=SQUARE, robot={"kind": "sim"}, sonar={"model": "nxt", "params": SONAR.to_dict()},
                   seed=0)
    rec.reset_event(HeadingPrior(0.0, 0.2))
    rec.close("done", None)
    good = path.read_text()
    path.write_text(good.replace('"sd_deg":', '"sd_deg":-').replace(":--", ":-"))
    assert run_cli(["replay", str(path), "--localisers", "paper-pf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{path} line 2" in err[0] and "sd_deg > 0" in err[0] and "-11.4" in err[0]


def test_a_mission_told_its_start_heading_finds_the_true_twin() -> None:
    """In a square room no exploration move tells the four twins apart (the moves are symmetric too):
    the mission ends ambiguous. Told its heading to 10 degrees (1 SD off the truth), the first global
    localisation picks the true twin and the mission reaches the target."""
    room = map_from_dict({"name": "square", "boundary": [[0, 0], [120, 0], [120, 120], [0, 120]],
                          "target": [90, 90]})
    start = Pose(TRUTH[0], TRUTH[1], TRUTH[2])
    blind = run_sim_mission(room, seed=0, start=start)
    assert blind.outcome is Outcome.AMBIGUOUS, blind.status
    for seed in (0, 1):
        told = run_sim_mission(room, seed=seed, start=start, start_heading=HeadingPrior(0.0, math.radians(10.0)))
        assert told.success and told.final_error_cm < 1.0 and told.collisions == 0, told.status


@pytest.mark.slow
def test_bench_sweeps_and_replay_take_a_heading_prior(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert run_cli(["bench", "sweeps", str(REAL_NXT), "--seeds", "0", "--localisers", "amcl",
                    "--heading-prior", "0:20", "--out", str(out)]) == 0
    assert "heading known to 20 degrees" in (out / "summary.md").read_text()
    assert json.loads((out / "config.json").read_text())["heading_prior"] == {"heading_deg": 0.0, "sd_deg": 20.0}
    rec = tmp_path / "sweeps.jsonl"
    assert run_cli(["import", "sweeps", str(REAL_NXT), "-o", str(rec)]) == 0
    got = tmp_path / "replay.json"
    assert run_cli(["replay", str(rec), "--localisers", "amcl", "--initial-heading", "0:20", "--json", str(got)]) == 0
    steps = [s for s in json.loads(got.read_text())["steps"] if s["call"] == "update"]
    assert len(steps) == 3  # every sweep's global reset took the prior (its own fix, the same scores)


def test_on_a_real_sweep_the_prior_turns_the_twin_margin_round() -> None:
    """At (180, 30) the arena turned by 90 degrees explains the real sweep better than the waypoint
    (docs/real-sonar.md); weighed by the heading the robot believed (+x), the waypoint wins."""
    sweeps = load_sweep_set(REAL_NXT)
    i = [(s.x_cm, s.y_cm) for s in sweeps].index((180.0, 30.0))
    # each sweep's margin is its own: without the prior only that sweep's is looked at, so only it is scored
    plain = sweep_margins(SONAR, dataclasses.replace(sweeps, sweeps=sweeps.sweeps[i : i + 1]))
    weighed = sweep_margins(SONAR, sweeps, heading_prior=HeadingPrior(0.0, math.radians(20.0)))
    assert plain[0] < 0.0 < weighed[i]
    assert all(w > 0.0 for w in weighed)


@pytest.mark.parametrize(("command", "value"), [
    (["bench", "sweeps", str(REAL_NXT), "--out"], "north"),
    (["bench", "sweeps", str(REAL_NXT), "--out"], "0:0"),
    (["sonar", "score", str(REAL_NXT), "--json"], "0"),
])
def test_a_bad_heading_prior_is_one_line_and_exit_2(tmp_path: Path, command: list[str], value: str,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert run_cli([*command, str(out), "--heading-prior", value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--heading-prior" in err[0] and value in err[0]
    assert not out.exists()
