"""The robot-time objective compiled against the installed OMPL wheel: an opt-in speed-up (README.md).

`planners.ompl_objective.robot_time_objective` builds this one when `load` gives its class (after
``make compiled``) and the Python `planners.ompl_objective.RobotTimeObjective` otherwise; both give the
same costs. `load` gives the compiled class, or the reason it cannot: not built, or built for another
wheel. Both couplings are checked before the import, since neither fails cleanly after it: an extension
whose nanobind registry key differs from the wheel's aborts the interpreter, and one compiled against
another OMPL's headers calls the wrong virtual functions (OMPL 2.0.2 adds one to
`OptimizationObjective`).
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import importlib.util
import json
import math
import sys
import sysconfig
from pathlib import Path
from typing import Any

from .abi_key import file_digest, registry_key

__all__ = ["BUILD_RECORD", "compiled_objective", "library_name", "load"]

HERE = Path(__file__).resolve().parent
BUILD_RECORD = "build_info.json"
"""What build.sh writes next to the library: the wheel it was built for (``ompl`` version, nanobind's
``registry_key``, ``libompl_sha256``)."""
_MODULE = "_robot_time"


def library_name() -> str:
    """The extension's file name for this Python (``_robot_time.cpython-311-x86_64-linux-gnu.so``)."""
    return _MODULE + str(sysconfig.get_config_var("EXT_SUFFIX") or ".so")


def _wheel() -> tuple[str, str, Path]:
    """The installed ompl wheel's version, nanobind registry key and ``libompl.so``."""
    import ompl.base  # noqa: F401 (the wheel's types and libompl.so first)

    wheel_dir = Path(importlib.import_module("ompl").__file__ or "").parent
    key = next((registry_key(p) for p in sorted(wheel_dir.glob("_ompl*.so"))), "")
    return importlib.metadata.version("ompl"), key, wheel_dir / "libompl.so"


def _refusal(folder: Path) -> str:
    """Why the build in `folder` cannot be loaded into this interpreter ("" when it can be imported)."""
    record_path, library = folder / BUILD_RECORD, folder / library_name()
    if not record_path.is_file():
        return f"not built (no {BUILD_RECORD} in {folder}: make compiled)"
    if not library.is_file():
        return f"not built for this Python (no {library.name} in {folder}): rebuild (make compiled)"
    try:
        record = json.loads(record_path.read_text(encoding="utf-8"))
        built_version, built_key, built_digest = record["ompl"], record["registry_key"], record["libompl_sha256"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return f"unreadable {record_path} ({type(exc).__name__}: {exc}): rebuild (make compiled)"
    version, key, libompl = _wheel()
    if (version, key) != (built_version, built_key):
        return (f"built for ompl {built_version} ({built_key}), installed ompl {version} ({key}): "
                "rebuild (make compiled)")
    if file_digest(libompl) != built_digest:
        return f"built for another libompl.so of ompl {version}: rebuild (make compiled)"
    return ""


@functools.cache
def load(folder: Path = HERE) -> tuple[Any, str]:
    """The compiled ``RobotTimeObjectiveC`` class built in `folder` and "", or None and why it cannot be used.

    Parameters
    ----------
    folder : Path
        Where build.sh put the library and its record (this package's folder; another one for tests).
    """
    why = _refusal(Path(folder))
    if why:
        return None, why
    spec = importlib.util.spec_from_file_location(f"{__name__}.{_MODULE}", Path(folder) / library_name())
    if spec is None or spec.loader is None:
        return None, f"cannot import {Path(folder) / library_name()}: rebuild (make compiled)"
    try:  # an extension module is made (dlopen, PyInit) by module_from_spec
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except ImportError as exc:
        return None, f"cannot import {Path(folder) / library_name()} ({exc}): rebuild (make compiled)"
    version = importlib.metadata.version("ompl")
    if module.ompl_version != version:
        return None, f"compiled with ompl {module.ompl_version}'s headers, installed {version}: rebuild (make compiled)"
    sys.modules[spec.name] = module
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
