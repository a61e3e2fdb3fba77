"""`nxtnav bench faults`: the faults drawn for each mission, and one small campaign end to end."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli

from toolkit.bench.faults import FAULT_KINDS, draw_faults, fault_tasks
from toolkit.recordings.replay import read_recording


def test_every_mission_gets_one_or_two_faults_inside_its_run() -> None:
    rng = np.random.default_rng(0)
    seen: set[str] = set()
    for _ in range(300):
        faults = draw_faults(rng, FAULT_KINDS, 120.0)
        assert 1 <= len(faults) <= 2
        for f in faults:
            seen.add(f.kind)
            if f.kind == "sonar-garbage":
                assert f.at_s == 0.0 and 0.02 <= f.arg <= 0.3
            else:
                assert 0.1 * 120.0 <= f.at_s <= 0.85 * 120.0
    assert seen == set(FAULT_KINDS)
    only = {f.kind for _ in range(50) for f in draw_faults(rng, ("stall",), 60.0)}
    assert only == {"stall"}


def test_tasks_take_the_maps_in_turn_with_their_own_seeds() -> None:
    tasks = fault_tasks(5, 3, ("drop-link",), ("map1", "map2"))
    assert [t.map for t in tasks] == ["map1", "map2", "map1", "map2", "map1"]
    assert len({t.seed for t in tasks}) == 5 and tasks == fault_tasks(5, 3, ("drop-link",), ("map1", "map2"))
    assert tasks[0].start[:2] == (20.0, 20.0)


@pytest.mark.slow
def test_a_small_campaign_reports_what_the_bricks_and_the_recordings_say(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "faults.json"
    # seed 2 draws one link down for 1.1 wall-clock seconds (seed 4 drew 6.1 s of waiting)
    code = run_cli(["bench", "faults", "--missions", "1", "--seed", "2", "--faults", "drop-link", "--maps", "map1",
                    "--json", str(out), "--recordings", str(tmp_path / "rec")])
    assert code == 0
    doc = json.loads(out.read_text())
    (mission,) = doc["missions"]
    s = doc["summary"]
    assert s["missions"] == 1 and s["success"] == int(mission["success"]) and s["collisions"] == mission["collisions"]
    assert [f["kind"] for f in mission["faults"]] and all(f["kind"] == "drop-link" for f in mission["faults"])
    assert all(f["fired_at_s"] is not None and f["acted"] == 1 for f in mission["faults"])  # inside the run
    assert s["links_lost"] == len([n for n in mission["noticed"] if n["kind"] == "link-lost"]) >= 1
    assert mission["success"] and mission["left_running"] == 0 and s["motors_left_running"] == 0
    assert mission["readable"] and mission["reproduced"] is True and not mission["truncated"]
    assert mission["extra_robot_s"] == pytest.approx(mission["robot_time_s"] - mission["baseline_robot_time_s"])
    kept = sorted(p.name for p in (tmp_path / "rec").iterdir())
    assert kept == ["mission-0000-baseline.jsonl", "mission-0000.jsonl"]
    rec = read_recording(tmp_path / "rec" / "mission-0000.jsonl")
    assert [e["kind"] for _, e in rec.events if e["type"] == "fault"] == ["link-lost"] * s["links_lost"]
    assert rec.header["faults"] == [{k: f[k] for k in ("kind", "at_s", "arg")} for f in mission["faults"]]
    assert "1 reached the target" in capsys.readouterr().out
