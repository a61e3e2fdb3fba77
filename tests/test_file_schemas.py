"""Typed files: the recording's lines and the sweep set's rows are models shared by the writer and the
reader; their JSON Schemas in docs/reference/schemas/ are generated from them and kept equal."""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import load_tool

from toolkit.recordings.format import RecordingError
from toolkit.recordings.recorder import Recorder
from toolkit.world import load_map

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "tests" / "data" / "recording_map1_nxt.jsonl"  # a version-1 recording
FAULT = {"type": "fault", "kind": "link-lost", "t": 12.5, "detail": "move 10.0 cm failed: lost the connection"}
RECOVERY = {"type": "recovery", "kind": "link-lost", "robot_time_s": 12.5, "detail": "back", "recovered": True,
            "outage_s": 1.2, "recovery_robot_s": 9.0, "true_pose": [20.0, 30.0, None],
            "resumption": {"action": "move", "requested": 10.0, "done": 4.2, "tacho_before": {"left": 0, "right": 0},
                           "tacho_after": {"left": 86, "right": 86, "turret": 0}}}


def _tool() -> ModuleType:
    return load_tool("schemas")


def _validator(jsonschema: ModuleType, schema: dict[str, Any]) -> Callable[[Any], None]:
    """``jsonschema.validate(instance, schema)`` for many instances: the schema is checked once (validate
    checks it again at every call), then each instance as validate judges it, its best-matching error raised."""
    cls = jsonschema.validators.validator_for(schema)
    cls.check_schema(schema)
    validator = cls(schema)

    def validate(instance: Any) -> None:
        error = jsonschema.exceptions.best_match(validator.iter_errors(instance))
        if error is not None:
            raise error

    return validate


def test_committed_schemas_equal_the_models(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    tool = _tool()
    assert tool.main(["--check"]) == 0, "python tools/schemas.py"
    page = (REPO / "docs" / "reference" / "schemas.md").read_text(encoding="utf-8")
    assert all(f"(schemas/{name})" in page for name in tool.file_schemas()), "docs/reference/schemas.md links them"
    # the check sees a stale file, writing mends it, and another kind's schema in the folder is left alone
    (tmp_path / "sweep-set.json").write_text("{}\n")
    (tmp_path / "localiser-x.json").write_text("{}\n")
    assert tool.main([str(tmp_path), "--check"]) == 1 and "sweep-set.json" in capsys.readouterr().err
    assert tool.main([str(tmp_path)]) == 0 and tool.main([str(tmp_path), "--check"]) == 0
    assert (tmp_path / "localiser-x.json").read_text() == "{}\n"


def test_every_recorded_line_meets_the_published_schemas() -> None:
    jsonschema = pytest.importorskip("jsonschema")
    folder = REPO / "docs" / "reference" / "schemas"
    header, event = (json.loads((folder / f"recording-{n}.json").read_text()) for n in ("header", "event"))
    lines = [json.loads(line) for line in EXAMPLE.read_text().splitlines()]
    jsonschema.validate(lines[0], header)
    kinds = set()
    validate_event = _validator(jsonschema, event)
    for line in [*lines[1:], FAULT, RECOVERY]:
        validate_event(line)
        kinds.add(line["type"])
    assert {"localiser", "scan", "update", "estimate", "move", "fault", "recovery", "end"} <= kinds
    with pytest.raises(jsonschema.ValidationError):  # the schema refuses what the reader refuses
        jsonschema.validate({"type": "predict", "turn_rad": "left", "distance_cm": 0}, event)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"type": "jump"}, event)


def test_the_writer_refuses_a_line_the_reader_would_refuse() -> None:
    out = io.StringIO()
    rec = Recorder(out, map=load_map("map1"), robot={"kind": "sim"}, sonar={"model": "ideal"}, seed=1)
    rec.event("predict", turn_rad=0.5, distance_cm=10.0)
    written = out.getvalue()
    with pytest.raises(RecordingError, match=r"recording line 3: field 'turn_rad' must be a number, got \"left\""):
        rec.event("predict", turn_rad="left", distance_cm=10.0)
    with pytest.raises(RecordingError, match="update refers to scan 4, which no earlier line holds"):
        rec.event("update", scan=4, index=[0])
    with pytest.raises(RecordingError, match="unknown event type 'jump'"):
        rec.event("jump")
    assert out.getvalue() == written and rec.lines == 2  # nothing of the refused lines was written


def test_shipped_maps_meet_the_published_map_schema() -> None:
    """Every shipped map file (both forms: boundary with obstacles and walls, and regions with a grid as an
    import writes them) meets map.json, and the schema refuses an unknown field as the reader does."""
    jsonschema = pytest.importorskip("jsonschema")
    from toolkit.world import MapError, list_maps, map_from_dict
    from toolkit.world.yaml_text import load_yaml

    schema = json.loads((REPO / "docs" / "reference" / "schemas" / "map.json").read_text())
    files = [p for p in list_maps().values() if p.suffix in (".yaml", ".yml")]
    docs = [d for d in (load_yaml(p.read_text(encoding="utf-8")) for p in files) if "image" not in d]
    assert len(docs) >= 4 and any("walls" in d for d in docs)
    recorded = json.loads(EXAMPLE.read_text().splitlines()[0])["map"]  # a recording's map, in its file form
    grid = {"name": "g", "regions": [{"boundary": [[0, 0], [50, 0], [50, 40], [0, 40]],
                                      "holes": [[[10, 10], [20, 10], [20, 20], [10, 20]]]}],
            "grid": {"cell_cm": 1.0, "origin": [0, 0], "width": 50, "height": 40}, "start": [5, 5]}
    validate_map = _validator(jsonschema, schema)
    for doc in [*docs, recorded, grid]:
        validate_map(doc)
        map_from_dict(doc)
    bad = {**docs[0], "colour": "red"}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema)
    with pytest.raises(MapError, match=r"map: unknown field\(s\) colour; allowed: name"):
        map_from_dict(bad)
