"""Missions against a virtual brick that fails them: a dropped link (back, or never back), a stuck
sensor (for a while, or for good). The brick's truth log, not the mission's estimate, decides."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import pytest
from conftest import run_cli

from toolkit.recordings.replay import read_recording, replay
from toolkit.robots.brick_faults import FaultSchedule
from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld
from toolkit.world import Pose, load_map

FAST = BrickConfig(time_factor=1000.0, max_step_s=0.01)


def _brick(faults: list[str], heading_deg: float = 30.0, seed: int = 0) -> tuple[BrickWorld, io.StringIO]:
    m = load_map("map1")
    assert m.start is not None
    log = io.StringIO()
    world = BrickWorld(m, Pose.from_deg(float(m.start[0]), float(m.start[1]), heading_deg), FAST, sonar="nxt",
                       rng=seed, log=log, faults=FaultSchedule(faults, rng=seed))
    return world, log


def _run(server: BrickServer, tmp_path: Path, *extra: str, seed: int = 0) -> int:
    return run_cli(["run", "--robot", "nxt", "--nxt-backend", "socket", "--server-host", "127.0.0.1",
                    "--server-port", str(server.port), "--seed", str(seed), "--json", str(tmp_path / "run.json"),
                    "--record", str(tmp_path / "run.jsonl"), *extra])


@pytest.mark.slow
def test_a_mission_resumes_after_a_dropped_link_and_reaches_the_target(tmp_path: Path) -> None:
    world, log = _brick(["drop-link:20:1"])
    with BrickServer(world, port=0) as server:
        code = _run(server, tmp_path)
        assert server.clients == 2  # the mission's connection and the one after the drop
    doc = json.loads((tmp_path / "run.json").read_text())
    assert code == 0, doc["status"]
    m = load_map("map1")
    assert m.target is not None
    records = [json.loads(line) for line in log.getvalue().splitlines()]
    final = records[-1]
    assert math.hypot(final["pose"][0] - m.target[0], final["pose"][1] - m.target[1]) < 2.0, final
    assert world.collisions == 0
    assert world.faults.fired[0] is not None and world.faults.fired[0].time_s == pytest.approx(20.0, abs=0.011)
    lost = [f for f in doc["faults"] if f["kind"] == "link-lost"]
    assert len(lost) == 1 and lost[0]["recovered"] and lost[0]["resumption"] is not None
    assert [s["action"] for s in doc["trace"]].count("link-restored") == 1
    rec = read_recording(tmp_path / "run.jsonl")
    kinds = [e["type"] for _, e in rec.events]
    assert rec.truncated is None and kinds.count("fault") == 1 and kinds.count("recovery") == 1
    assert kinds.index("fault") < kinds.index("recovery")
    out = replay(rec, [doc["localiser"]])
    assert out.reproduced == {doc["localiser"]: True}  # bit for bit through the loss and the recovery


def test_a_link_that_does_not_come_back_ends_the_mission_with_one_line(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    world, _ = _brick(["drop-link:5:1000"])
    with BrickServer(world, port=0) as server:
        code = _run(server, tmp_path, "--reconnect-timeout", "1")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and err[0].startswith("nxtnav: error: mission failed: link to the robot lost"), err
    assert "not back within 1 s" in err[0]
    doc = json.loads((tmp_path / "run.json").read_text())
    assert doc["outcome"] == "link-lost" and not doc["success"]
    assert [f["recovered"] for f in doc["faults"]] == [False]
    rec = read_recording(tmp_path / "run.jsonl")
    assert rec.truncated is None and rec.events[-1][1] == {"type": "end", "status": doc["status"], "success": False}
    assert not world.driven_ports()  # the brick braked what the vanished client had set going


def test_a_sensor_that_stays_stuck_ends_the_mission_with_a_clear_line(tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    world, _ = _brick(["sonar-stuck:3:100000"])
    with BrickServer(world, port=0) as server:
        code = _run(server, tmp_path)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and "the sonar stayed faulty for 3 sweeps in a row (stuck: the sonar repeated" in err[0]
    doc = json.loads((tmp_path / "run.json").read_text())
    assert [f["kind"] for f in doc["faults"]] == ["sonar"] * 3
    assert [s["action"] for s in doc["trace"]].count("sonar-fault") == 3
    rec = read_recording(tmp_path / "run.jsonl")
    assert [e["kind"] for _, e in rec.events if e["type"] == "fault"] == ["sonar"] * 3


@pytest.mark.slow
def test_a_sweep_spoiled_by_a_stuck_sensor_is_taken_again_and_the_mission_goes_on(tmp_path: Path) -> None:
    world, log = _brick(["sonar-stuck:2:6"], heading_deg=-135.0, seed=1)
    with BrickServer(world, port=0) as server:
        code = _run(server, tmp_path, seed=1)
    doc = json.loads((tmp_path / "run.json").read_text())
    assert code == 0, doc["status"]
    assert [f["kind"] for f in doc["faults"]] == ["sonar"]
    assert doc["faults"][0]["detail"].startswith("stuck: the sonar repeated")
    assert world.faults.to_dict()[0]["acted"] > 30  # readings it spoiled
    final = json.loads(log.getvalue().splitlines()[-1])
    assert math.hypot(final["pose"][0] - 80.0, final["pose"][1] - 80.0) < 2.0 and final["collisions"] == 0
