"""Recording a run (`nxtnav run --record`) and replaying it offline (`nxtnav replay`).

The live localiser replayed with its recorded stream must give the live estimates bit for bit, on
the simulator and through the virtual brick; broken recordings give one line naming the line at
fault (exit 2); a recording cut short replays up to the break.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from toolkit.cli import main
from toolkit.mission import MissionConfig, localiser_options, run_mission, run_sim_mission
from toolkit.recordings.recorder import Recorder, scan_fields, scan_from_fields
from toolkit.recordings.replay import RecordingError, read_recording, replay
from toolkit.world import NxtnavError, Pose, RobotModel, Scan, load_map

DATA = Path(__file__).parent / "data"
EXAMPLE = DATA / "recording_map1_nxt.jsonl"


def _record_sim(path: Path, localiser: str, seed: int = 3, sonar: str = "ideal") -> None:
    m = load_map("map1")
    rec = Recorder(path, map=m, robot={"kind": "sim"}, sonar={"model": sonar, "sensor_noise": 1.0}, seed=seed,
                   extra={"noise": {"model": "botsim", "motion": 0.1, "turn": 0.005}})
    report = run_sim_mission(m, seed=seed, localiser=localiser, sonar=sonar, recorder=rec)
    rec.close(report.status, report.success)
    assert report.success


@pytest.mark.parametrize("localiser", ["amcl", "paper-pf"])
def test_sim_recording_replays_bit_for_bit(tmp_path: Path, localiser: str) -> None:
    path = tmp_path / "run.jsonl"
    _record_sim(path, localiser)
    rec = read_recording(path)
    assert rec.truncated is None and rec.localiser is not None and rec.localiser.name == localiser
    kinds = {e["type"] for _, e in rec.events}
    assert {"turn", "move", "scan", "reset", "predict", "update", "estimate", "end"} <= kinds
    report = replay(rec, [localiser, "pf-systematic"])
    assert report.reproduced == {localiser: True}
    live = [s.live for s in report.steps]
    assert all(e is not None for e in live)
    assert all(np.array_equal(s.live.cov, s.estimates[localiser].cov) for s in report.steps if s.live is not None)
    summary = report.summary()
    assert report.has_truth and summary[localiser]["final_error_cm"] < 2.0
    assert math.isfinite(summary["pf-systematic"]["rmse_cm"])


def test_another_seed_is_not_the_live_run(tmp_path: Path) -> None:
    """Guard against a vacuous comparison: the live localiser with a different stream differs."""
    path = tmp_path / "run.jsonl"
    _record_sim(path, "amcl")
    rec = read_recording(path)
    assert rec.localiser is not None
    tampered = type(rec)(rec.path, rec.header, rec.map, type(rec.localiser)(rec.localiser.name, rec.localiser.options,
                                                                            None), rec.events)
    report = replay(tampered, ["amcl"], seed=12345)
    assert report.reproduced == {"amcl": None}
    differs = [s for s in report.steps if s.live is not None and s.estimates["amcl"] is not None
               and s.estimates["amcl"].pose.as_array().tolist() != s.live.pose.as_array().tolist()]
    assert differs


def test_scan_fields_round_trip_exactly() -> None:
    rng = np.random.default_rng(0)
    for angles in (np.arange(360) * (2 * np.pi / 360), np.sort(rng.uniform(-3, 3, 50))):
        ranges = rng.uniform(5, 200, angles.size)
        ranges[3] = np.inf
        valid = rng.random(angles.size) > 0.1
        back = scan_from_fields(json.loads(json.dumps(scan_fields(Scan(angles, ranges, valid)))))
        assert np.array_equal(back.angles, angles) and np.array_equal(back.ranges, ranges)
        assert np.array_equal(back.valid, valid)


def test_example_recording_replays_bit_for_bit_and_is_small() -> None:
    assert EXAMPLE.stat().st_size < 200_000
    rec = read_recording(EXAMPLE)
    assert rec.header["version"] == 1 and rec.header["sonar"]["model"] == "nxt"
    report = replay(rec, ["amcl", "paper-pf"])
    assert report.reproduced == {"amcl": True}
    assert report.summary()["paper-pf"]["updates"] >= 2


def test_options_replace_what_a_localiser_is_given() -> None:
    """`replay(options=...)` changes what each localiser is given: its estimates differ from the plain
    replay's, and the live localiser given options is a new run, not compared with the live estimates
    (that the options go on top of the recording's is checked in test_import_sweeps)."""
    rec = read_recording(EXAMPLE)
    opts = {"pf-systematic": {"n_particles": 150}, "amcl": {"max_particles": 400}}
    report = replay(rec, ["amcl", "pf-systematic"], seed=4, options=opts)
    plain = replay(rec, ["amcl", "pf-systematic"], seed=4)
    assert report.reproduced == {"amcl": None} and plain.reproduced == {"amcl": True}
    got = [s.estimates["pf-systematic"] for s in report.steps]
    want = [s.estimates["pf-systematic"] for s in plain.steps]
    assert all(g is not None and w is not None for g, w in zip(got, want, strict=True))
    assert any(g.pose != w.pose for g, w in zip(got, want, strict=True))  # type: ignore[union-attr]
    assert any(s.estimates["amcl"] != p.estimates["amcl"] for s, p in zip(report.steps, plain.steps, strict=True))
    with pytest.raises(NxtnavError, match="options for ekf, which is not among amcl"):
        replay(rec, ["amcl"], options={"ekf": {"gate_cm": 5.0}})
    with pytest.raises(NxtnavError, match="amcl refuses min_particles=500, max_particles=100: need"):
        replay(rec, ["amcl"], options={"amcl": {"min_particles": 500, "max_particles": 100}})


def test_cli_set_gives_replay_its_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    js = tmp_path / "r.json"
    code, _, _ = _run_replay(EXAMPLE, capsys, "--localisers", "pf-systematic", "--seed", "4",
                             "--set", "pf-systematic.n_particles=150", "--json", str(js))
    assert code == 0
    got = json.loads(js.read_text())
    want = replay(read_recording(EXAMPLE), ["pf-systematic"], seed=4, options={"pf-systematic": {"n_particles": 150}})
    assert [s["estimates"]["pf-systematic"]["pose"] for s in got["steps"]] == [
        s.estimates["pf-systematic"].pose.to_list_deg() for s in want.steps]  # type: ignore[union-attr]
    code, out, _ = _run_replay(EXAMPLE, capsys, "--localisers", "amcl", "--set", "amcl.max_particles=400")
    assert code == 0 and "amcl: given --set options, a new run; not compared with the live estimates" in out
    code, _, err = _run_replay(EXAMPLE, capsys, "--localisers", "amcl", "--set", "amcl.min_particles=500",
                               "--set", "amcl.max_particles=100")
    assert code == 2 and "amcl refuses min_particles=500, max_particles=100" in err and err.count("\n") == 1, err
    for bad, why in (("pf-systematic.bogus=1", "pf-systematic has no option bogus"),
                     ("amcl.max_particles=10", "options for amcl, which is not among pf-systematic"),
                     ("pf-systematic.n_particles=-3", "pf-systematic.n_particles: -3 is out of its range")):
        code, _, err = _run_replay(EXAMPLE, capsys, "--localisers", "pf-systematic", "--set", bad)
        assert code == 2 and why in err and len(err.strip().splitlines()) == 1, err


def test_cli_records_and_replays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path, js, png = tmp_path / "r.jsonl", tmp_path / "r.json", tmp_path / "r.png"
    main(["run", "--map", "map1", "--seed", "3", "--localiser", "amcl", "--record", str(path)])
    main(["replay", str(path), "--localisers", "amcl,paper-pf", "--json", str(js), "-o", str(png)])
    out = capsys.readouterr().out
    assert re.search(r"amcl: replayed estimates equal the [0-9]+ live ones bit for bit", out)
    doc = json.loads(js.read_text())
    assert doc["reproduced"] == {"amcl": True} and doc["truth"] is True
    assert doc["steps"] and set(doc["steps"][-1]["estimates"]) == {"amcl", "paper-pf"}
    assert png.stat().st_size > 10_000


def _run_replay(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> tuple[int, str, str]:
    try:
        main(["replay", str(path), *extra])
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda lines: lines.__setitem__(5, lines[5][:-3] + "]]"), r"line 6: not valid JSON"),
    (lambda lines: lines.__setitem__(0, lines[0].replace('"version":1', '"version":7')), r"line 1: format version 7"),
    (lambda lines: lines.__setitem__(2, '{"type":"predict","turn_rad":"left","distance_cm":0}'),
     r"line 3: field 'turn_rad' must be a number"),
    (lambda lines: lines.__setitem__(3, '{"type":"jump"}'), r"line 4: unknown event type 'jump'"),
    (lambda lines: lines.insert(1, '{"type":"update","scan":99,"index":[0]}'), r"line 2: update refers to scan 99"),
])
def test_malformed_recordings_name_the_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], mutate: object,
                                            message: str) -> None:
    lines = EXAMPLE.read_text().splitlines()
    mutate(lines)  # type: ignore[operator]
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    code, _, err = _run_replay(bad, capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and err.startswith("nxtnav: error: ")
    assert str(bad) in err
    assert re.search(message, err), err


def test_truncated_recording_replays_up_to_the_break(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = EXAMPLE.read_text()
    lines = text.splitlines(keepends=True)
    keep = len(lines) // 2
    cut = tmp_path / "cut.jsonl"
    cut.write_text("".join(lines[:keep]) + lines[keep][: len(lines[keep]) // 2])
    rec = read_recording(cut)
    assert rec.truncated is not None and f"line {keep + 1}" in rec.truncated
    full = read_recording(EXAMPLE)
    calls = sum(1 for i, e in full.events if e["type"] in ("reset", "predict", "update") and i <= keep)
    report = replay(rec, ["amcl"])
    assert len(report.steps) == calls and report.reproduced == {"amcl": True}
    code, out, err = _run_replay(cut, capsys, "--localisers", "amcl")
    assert code == 0 and f"line {keep + 1}: cut short" in err and "bit for bit" in out


def test_unknown_localiser_and_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run_replay(EXAMPLE, capsys, "--localisers", "amcl,nope")
    assert code == 2 and "nope" in err and "paper-pf" in err
    code, _, err = _run_replay(tmp_path / "none.jsonl", capsys)
    assert code == 2 and "cannot read the recording" in err
    short = tmp_path / "short.jsonl"  # header, localiser and reset, cut before the live estimate
    short.write_text("".join(EXAMPLE.read_text().splitlines(keepends=True)[:3]))
    code, out, err = _run_replay(short, capsys, "--localisers", "amcl,ekf")
    assert code == 0 and "holds no live estimate" in out and "ekf: failed at line 3" in err
    with pytest.raises(RecordingError, match="empty file"):
        (tmp_path / "e.jsonl").write_text("")
        read_recording(tmp_path / "e.jsonl")


@pytest.mark.slow
def test_virtual_brick_recording_replays_bit_for_bit(tmp_path: Path) -> None:
    from toolkit.robots.nxt import connect_robot
    from toolkit.robots.virtual_brick import BrickServer
    from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld

    m = load_map("map1")
    world = BrickWorld(m, Pose.from_deg(20.0, 20.0, 30.0), BrickConfig(time_factor=1000.0, max_step_s=0.01), rng=2)
    path = tmp_path / "brick.jsonl"
    with BrickServer(world, port=0) as server:
        robot = connect_robot("socket", host="127.0.0.1", port=server.port)
        rec = Recorder(path, map=m, robot={"kind": "nxt", "link": robot.link}, sonar={"model": "nxt"}, seed=2,
                       truth=lambda: world.pose)
        try:
            opts = localiser_options("amcl", RobotModel.build("nxt"))  # the brick draws every reading independently
            report = run_mission(robot, m, (30.0, 80.0), localiser="amcl", rng=2,
                                 config=MissionConfig.for_sonar("nxt", localiser_options=opts), recorder=rec,
                                 truth=world)
        finally:
            robot.close()
            rec.close(report.status, report.success)
    assert report.poses.start == Pose.from_deg(20.0, 20.0, 30.0)  # the world is the report's truth source
    assert report.poses.final_pose is not None and report.collisions is not None
    recording = read_recording(path)
    moves = [e for _, e in recording.events if e["type"] == "move"]
    assert moves and all(e["odometry"]["tacho_after"]["left"] != e["odometry"]["tacho_before"]["left"]
                         for e in moves if abs(e["driven_cm"]) > 1.0)
    out = replay(recording, ["amcl"])
    assert out.reproduced == {"amcl": True}
    # the truth comes from the brick's world: the last replayed estimate's error is the distance from
    # the mission's final estimate to where the brick's world has the robot at the end
    assert out.has_truth and report.poses.final_estimate is not None
    assert out.summary()["amcl"]["final_error_cm"] == pytest.approx(report.poses.final_estimate.distance_to(world.pose),
                                                                    abs=1e-9)


def test_recording_leaves_the_mission_unchanged() -> None:
    """The recorder passes the localiser's modes through: a recorded mission is the unrecorded one.

    With the nxt sonar, amcl on map1 (seed 6) meets an ambiguous belief, where the mission asks the
    localiser for its modes; a recorder that hid them drove another mission.
    """
    m = load_map("map1")
    plain = run_sim_mission(m, seed=6, localiser="amcl", sonar="nxt")
    rec = Recorder(None, map=m, robot={"kind": "sim"}, sonar={"model": "nxt"}, seed=6)
    recorded = run_sim_mission(m, seed=6, localiser="amcl", sonar="nxt", recorder=rec)
    assert recorded.status == plain.status and recorded.poses.final_pose == plain.poses.final_pose
    assert [s.true_pose for s in recorded.trace] == [s.true_pose for s in plain.trace]


def test_version_3_plans_and_clouds(tmp_path: Path) -> None:
    """Each planned path is a ``plan`` line; each estimate carries at most N particles summing to weight 1."""
    m = load_map("map1")
    lines: list[dict[str, object]] = []
    path = tmp_path / "v3.jsonl"
    rec = Recorder(path, map=m, robot={"kind": "sim"}, sonar={"model": "ideal", "sensor_noise": 1.0}, seed=3,
                   particles=25, listeners=[lines.append])
    report = run_sim_mission(m, seed=3, localiser="paper-pf", recorder=rec)
    rec.close(report.status, report.success)
    events = [e for _, e in read_recording(path).events]
    plans = [e["path"] for e in events if e["type"] == "plan"]
    assert len(plans) == len(report.plans) and all(np.array_equal(np.array(p), q) for p, q in zip(plans, report.plans,
                                                                                                 strict=True))
    clouds = [e["particles"] for e in events if e["type"] == "estimate"]
    assert clouds and all(len(c["poses"]) == 25 < c["n"] for c in clouds)
    assert all(math.isclose(sum(c["weights"]), 1.0) for c in clouds)
    assert [e["type"] for e in lines] == ["header", *[e["type"] for e in events]]  # the listener saw every line


def test_version_3_fields_in_an_older_file_are_refused(tmp_path: Path) -> None:
    lines = EXAMPLE.read_text().splitlines()
    lines.insert(3, '{"type":"plan","path":[[20,20],[80,80]]}')
    bad = tmp_path / "old.jsonl"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=r"line 4: a 'plan' event needs format version 3 \(the header says 1\)"):
        read_recording(bad)
