"""The mission stays readable: short functions, small config groups, every state handled.

The limits are read from the source with `ast`: no function or method in `toolkit/mission/` longer
than `MAX_FUNCTION_LINES` lines (docstring included), no configuration class (a `MissionConfig` group,
or a class named ``...Config`` there) with more than `MAX_CONFIG_FIELDS` fields.
"""

from __future__ import annotations

import ast
from pathlib import Path

from toolkit.mission import MissionConfig
from toolkit.mission.machine import _HANDLERS
from toolkit.mission.states import State

MISSION = Path(__file__).resolve().parents[1] / "toolkit" / "mission"
MAX_FUNCTION_LINES = 60
MAX_CONFIG_FIELDS = 12


def long_functions(folder: Path, limit: int) -> list[str]:
    """``file:function (lines)`` for every function of `folder`'s modules longer than `limit` lines."""
    out = []
    for path in sorted(folder.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                assert node.end_lineno is not None
                lines = node.end_lineno - node.lineno + 1
                if lines > limit:
                    out.append(f"{path.name}:{node.name} ({lines})")
    return out


def config_fields(folder: Path) -> dict[str, int]:
    """The annotated fields of every class named ``...Config`` in `folder`'s modules."""
    out = {}
    for path in sorted(folder.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and node.name.endswith("Config"):
                out[node.name] = sum(isinstance(b, ast.AnnAssign) for b in node.body)
    return out


def test_no_function_of_the_mission_is_longer_than_the_limit() -> None:
    assert long_functions(MISSION, MAX_FUNCTION_LINES) == []


def test_the_size_checks_see_what_they_measure(tmp_path: Path) -> None:
    body = "\n".join(f"    x{i} = {i}" for i in range(MAX_FUNCTION_LINES))
    (tmp_path / "m.py").write_text(f"def long():\n{body}\n\n\nclass BigConfig:\n"
                                   + "\n".join(f"    f{i}: int = {i}" for i in range(13)) + "\n")
    assert long_functions(tmp_path, MAX_FUNCTION_LINES) == [f"m.py:long ({MAX_FUNCTION_LINES + 1})"]
    assert config_fields(tmp_path) == {"BigConfig": 13}


def test_no_config_class_of_the_mission_has_more_than_twelve_fields() -> None:
    found = config_fields(MISSION)
    assert {"MissionConfig", "PlanningConfig", "DriveConfig", "FixConfig", "SweepConfig", "FinalConfig",
            "LimitsConfig"} <= set(found)
    assert {name: n for name, n in found.items() if n > MAX_CONFIG_FIELDS} == {}
    # the groups as the running config holds them agree with the source
    cfg = MissionConfig()
    for name in type(cfg).model_fields:
        group = getattr(cfg, name)
        if type(group).__name__ in found:
            assert len(type(group).model_fields) == found[type(group).__name__]


def test_every_state_but_the_ends_has_one_handler() -> None:
    assert set(_HANDLERS) == set(State) - {State.DONE, State.FAILED}
