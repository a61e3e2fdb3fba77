"""The whole map1 mission through `nxtnav run --robot nxt --nxt-backend socket` against the virtual brick.

The brick's own truth log (not the mission's estimate) decides: the robot must end within 2 cm of the
target with no collision.
"""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np
import pytest

from toolkit.cli import main
from toolkit.recordings.replay import read_recording, replay
from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld
from toolkit.world import Pose, load_map

pytestmark = pytest.mark.slow


@pytest.mark.parametrize(("heading_deg", "seed"), [(30.0, 0), (-135.0, 1)])
def test_map1_mission_on_the_virtual_brick(tmp_path: Path, heading_deg: float, seed: int) -> None:
    m = load_map("map1")
    assert m.start is not None and m.target is not None
    log = io.StringIO()
    # the brick answers with the NXT sensor's model, the sensor the NXT client's localiser is told of
    world = BrickWorld(m, Pose.from_deg(float(m.start[0]), float(m.start[1]), heading_deg),
                       BrickConfig(time_factor=1000.0, max_step_s=0.01), sonar="nxt", rng=seed, log=log)
    report = tmp_path / "mission.json"
    recording = tmp_path / "mission.jsonl"
    with BrickServer(world, port=0) as server:
        try:
            main(["run", "--robot", "nxt", "--nxt-backend", "socket", "--server-host", "127.0.0.1",
                  "--server-port", str(server.port), "--seed", str(seed), "--json", str(report),
                  "--record", str(recording)])
        except SystemExit as exc:
            assert exc.code in (0, None), report.read_text() if report.exists() else exc
    records = [json.loads(line) for line in log.getvalue().splitlines()]
    assert len(records) > 5
    final = records[-1]
    error = math.hypot(final["pose"][0] - m.target[0], final["pose"][1] - m.target[1])
    assert error < 2.0, final
    assert all(r["collisions"] == 0 for r in records)
    assert np.all(np.diff([r["t"] for r in records]) > 0)
    doc = json.loads(report.read_text())
    assert doc["success"] is True and doc["robot"] == "nxt"
    assert doc["robot_time_s"] == pytest.approx(world.time_s, rel=0.05)  # measured on the brick's clock
    # the recording of the CLI run: the brick's tacho counts per command, replayed bit for bit
    rec = read_recording(recording)
    assert rec.truncated is None and rec.header["robot"]["kind"] == "nxt"
    moves = [e for _, e in rec.events if e["type"] == "move" and abs(e["driven_cm"]) > 1.0]
    assert moves and all(e["odometry"]["tacho_after"]["left"] != e["odometry"]["tacho_before"]["left"] for e in moves)
    out = replay(rec, [doc["localiser"]])
    assert out.reproduced == {doc["localiser"]: True} and not out.has_truth
