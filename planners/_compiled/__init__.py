"""The robot-time objective compiled against the installed OMPL wheel: a feasibility study (README.md).

`load` gives the compiled class, or the reason it cannot: not built (build.sh), or built for another
wheel. Both couplings are checked before the import, since neither fails cleanly after it: an extension
whose nanobind registry key differs from the wheel's aborts the interpreter, and one compiled against
another OMPL's headers calls the wrong virtual functions (OMPL 2.0.2's draft adds one to
`OptimizationObjective`).
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import json
import math
from pathlib import Path
from typing import Any

from .abi_key import file_digest, registry_key

__all__ = ["compiled_objective", "load"]

_HERE = Path(__file__).resolve().parent


@functools.cache
def load() -> tuple[Any, str]:
    """The compiled ``RobotTimeObjectiveC`` class and "", or None and why it cannot be used."""
    record_path = _HERE / "build_info.json"
    if not record_path.is_file() or not list(_HERE.glob("_robot_time*.so")):
        return None, "not built (planners/_compiled/build.sh)"
    record = json.loads(record_path.read_text(encoding="utf-8"))
    import ompl.base  # noqa: F401 (the wheel's types and libompl.so first)

    wheel_dir = Path(importlib.import_module("ompl").__file__ or "").parent
    version = importlib.metadata.version("ompl")
    key = next((registry_key(p) for p in wheel_dir.glob("_ompl*.so")), "")
    if version != record["ompl"] or key != record["registry_key"]:
        return None, (f"built for ompl {record['ompl']} ({record['registry_key']}), "
                      f"installed ompl {version} ({key}): rebuild")
    if file_digest(wheel_dir / "libompl.so") != record["libompl_sha256"]:
        return None, f"built for another libompl.so of ompl {version}: rebuild"
    module = importlib.import_module(f"{__name__}._robot_time")
    if module.ompl_version != version:
        return None, f"compiled with ompl {module.ompl_version}'s headers, installed {version}: rebuild"
    return module.RobotTimeObjectiveC, ""


def compiled_objective(si: Any, timing: Any, start: tuple[float, float], goal: tuple[float, float]) -> Any:
    """The compiled objective with `planners.ompl_objective.RobotTimeObjective`'s arguments (None when
    `load` says it cannot be used).

    Parameters
    ----------
    si : ompl.base.SpaceInformation
        Of an `ompl.base.SE2StateSpace` (cm, rad).
    timing : toolkit.world.RobotTiming
    start, goal : (float, float)
        Positions (cm) whose heading is free.
    """
    cls, _ = load()
    if cls is None:
        return None
    return cls(si, 1.0 / float(timing.drive_speed_cm_s), math.degrees(1.0) / float(timing.turn_rate_deg_s),
               float(timing.stop_turn_s), float(start[0]), float(start[1]), float(goal[0]), float(goal[1]))
