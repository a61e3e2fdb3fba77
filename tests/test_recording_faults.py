"""Recordings of faulty runs (format version 3: ``fault`` and ``recovery`` lines); older versions still read."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from toolkit.recordings.recorder import FORMAT_VERSION
from toolkit.recordings.replay import RecordingError, read_recording, replay

EXAMPLE = Path(__file__).parent / "data" / "recording_map1_nxt.jsonl"  # a version-1 recording

FAULT = {"type": "fault", "kind": "link-lost", "t": 12.5, "detail": "move 10.0 cm failed: lost the connection"}
RECOVERY = {"type": "recovery", "kind": "link-lost", "robot_time_s": 12.5, "detail": "back", "recovered": True,
            "outage_s": 1.2, "recovery_robot_s": 9.0, "true_pose": None,
            "resumption": {"action": "move", "requested": 10.0, "done": 4.2, "tacho_before": {"left": 0, "right": 0},
                           "tacho_after": {"left": 86, "right": 86, "turret": 0}}}


def _with(tmp_path: Path, version: int, *extra: dict[str, object], at: int = 5) -> Path:
    lines = EXAMPLE.read_text().splitlines()
    head = json.loads(lines[0])
    head["version"] = version
    lines[0] = json.dumps(head)
    lines[at:at] = [json.dumps(e) for e in extra]
    out = tmp_path / "rec.jsonl"
    out.write_text("\n".join(lines) + "\n")
    return out


def test_this_version_writes_version_3_and_reads_every_older_one() -> None:
    assert FORMAT_VERSION == 3
    old = read_recording(EXAMPLE)
    assert old.header["version"] == 1 and old.truncated is None
    live = old.localiser
    assert live is not None and replay(old, [live.name]).reproduced == {live.name: True}


def test_fault_and_recovery_lines_read_back_and_leave_the_replay_bit_for_bit(tmp_path: Path) -> None:
    rec = read_recording(_with(tmp_path, 3, FAULT, RECOVERY))
    kinds = [e["type"] for _, e in rec.events]
    assert kinds.count("fault") == 1 and kinds.count("recovery") == 1
    live = rec.localiser
    assert live is not None and replay(rec, [live.name]).reproduced == {live.name: True}


@pytest.mark.parametrize(("version", "line", "message"), [
    (2, FAULT, r"line 6: a 'fault' line needs format version 3 \(the header says 2\)"),
    (3, {**FAULT, "t": "soon"}, r"line 6: field 't' must be a number"),
    (3, {**RECOVERY, "recovered": "yes"}, r"line 6: field 'recovered' must be true/false"),
    (3, {**RECOVERY, "resumption": {"action": "move", "requested": 10.0}}, r"line 6: resumption: missing field 'done'"),
    (3, {k: v for k, v in RECOVERY.items() if k != "outage_s"}, r"line 6: missing field 'outage_s'"),
])
def test_bad_fault_lines_name_the_line_and_field(tmp_path: Path, version: int, line: dict[str, object],
                                                 message: str) -> None:
    with pytest.raises(RecordingError, match=message):
        read_recording(_with(tmp_path, version, line))


def test_the_example_script_writes_a_version_1_file_that_replays(tmp_path: Path) -> None:
    """`tools/example_recording.py` keeps the example a version-1 file: what this nxtnav records (version 3,
    with planned paths and particles), written back without them, reads as version 1 and replays bit
    for bit; the version-3 copy as it was is refused once its header says 1."""
    from conftest import load_tool, run_cli

    tool = load_tool("example_recording")
    recorded = tmp_path / "run.jsonl"
    assert run_cli(["run", "--map", "map1", "--seed", "3", "--localiser", "amcl", "--record", str(recorded)]) == 0
    lines = [json.loads(text) for text in recorded.read_text().splitlines()]
    assert {"plan"} <= {line["type"] for line in lines} and any("particles" in line for line in lines)
    v1 = tmp_path / "v1.jsonl"
    v1.write_text("".join(json.dumps(line) + "\n" for line in tool.as_version_1(lines)))
    rec = read_recording(v1)
    assert rec.header["version"] == 1 and rec.localiser is not None
    assert replay(rec, [rec.localiser.name]).reproduced == {rec.localiser.name: True}
    mislabelled = tmp_path / "mislabelled.jsonl"
    mislabelled.write_text("".join(json.dumps({**line, "version": 1} if line["type"] == "header" else line) + "\n"
                                   for line in lines))
    with pytest.raises(RecordingError, match="version 3"):
        read_recording(mislabelled)
