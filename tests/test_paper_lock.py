"""tools/paper_lock.py: a behaviour lock that skips wall-clock fields and nothing else."""

from __future__ import annotations

import json
from pathlib import Path

from conftest import load_tool

paper_lock = load_tool("paper_lock")

_RUN = [{"sonar": "nxt", "rows": [{"map": "map1", "success_rate": 1.0, "completion_s": 0.3, "cpu_median_s": 0.2,
                                   "robot_time_s": 38.2, "robot_time_split": {"sweep_s": 22.8}}]}]


def _changed(**row: float) -> list[dict]:
    doc = json.loads(json.dumps(_RUN))
    doc[0]["rows"][0].update(row)
    return doc


def test_wall_clock_fields_are_ignored() -> None:
    assert paper_lock.differences(_RUN, _changed(completion_s=9.9, cpu_median_s=4.0)) == []


def test_a_deterministic_field_that_moves_is_named() -> None:
    diff = paper_lock.differences(_RUN, _changed(robot_time_s=38.3))
    assert diff == [("[0]/rows[0]/robot_time_s", 38.2, 38.3)]


def test_a_field_missing_on_one_side_counts(tmp_path: Path) -> None:
    doc = _changed()
    del doc[0]["rows"][0]["robot_time_split"]
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(_RUN))
    b.write_text(json.dumps(doc))
    assert paper_lock.main([str(a), str(b)]) == 1
    assert paper_lock.main([str(a), str(a)]) == 0
    assert paper_lock.main([str(a), str(tmp_path / "none.json")]) == 2
