"""The compiled robot-time objective (`planners._compiled`, built by the opt-in ``make compiled``).

When it is built for the installed ompl wheel it must give the Python objective's costs and RRT* the
same paths; when it is not, the tests that need it are skipped with `load`'s reason and the planners
use the Python objective. The loader's refusal of a build made for another wheel, and the planner
option ``objective_impl``, are tested either way.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import ompl.base as ob
import pytest
from conftest import fails_cleanly, run_cli

from planners import PlanningProblem, make_planner
from planners._compiled import BUILD_RECORD, compiled_objective, library_name, load
from planners._compiled.abi_key import file_digest, registry_key
from planners.ompl_objective import RobotTimeObjective, robot_time_objective
from toolkit.world import RobotTiming, load_map, make_checker

COMPILED, WHY_NOT = load()
needs_compiled = pytest.mark.skipif(COMPILED is None, reason=f"the compiled objective is not loaded: {WHY_NOT}")
TIMINGS = (RobotTiming(), RobotTiming(drive_speed_cm_s=7.3, turn_rate_deg_s=41.0, stop_turn_s=0.35))
START, GOAL = (12.5, -40.25), (150.0, 99.75)


def _se2_pairs(count: int, seed: int) -> list[tuple[float, ...]]:
    """`count` SE(2) state pairs ``(x1, y1, yaw1, x2, y2, yaw2)`` (cm, rad), every fifth pair of a kind the
    cost treats apart: leaving START, reaching GOAL, no displacement, headings along the segment."""
    rng = np.random.default_rng(seed)
    pairs: list[tuple[float, ...]] = []
    for i in range(count):
        a, z = rng.uniform(-200, 200, 2), rng.uniform(-200, 200, 2)
        ya, yz = rng.uniform(-math.pi, math.pi, 2)
        kind = i % 5
        if kind == 1:
            a = np.array(START)
        elif kind == 2:
            z = np.array(GOAL)
        elif kind == 3:
            z = a
        elif kind == 4:
            ya = yz = math.atan2(z[1] - a[1], z[0] - a[0])
        pairs.append((float(a[0]), float(a[1]), float(ya), float(z[0]), float(z[1]), float(yz)))
    return pairs


def _se2_space() -> tuple[Any, Any]:
    """OMPL's SE(2) space on a 400 x 400 cm box round the origin, and its space information."""
    space = ob.SE2StateSpace()
    box = ob.RealVectorBounds(2)
    box.setLow(-200.0)
    box.setHigh(200.0)
    space.setBounds(box)
    return space, ob.SpaceInformation(space)


@needs_compiled
def test_compiled_objective_gives_the_python_costs_when_built() -> None:
    """Skipped with `load`'s reason unless ``make compiled`` built it for this wheel."""
    space, si = _se2_space()
    s1, s2 = space.allocState(), space.allocState()
    for timing in TIMINGS:
        python = RobotTimeObjective(si, timing, START, GOAL)
        compiled = compiled_objective(si, timing, START, GOAL)
        assert compiled.isSymmetric() is python.isSymmetric() is False
        for x1, y1, yaw1, x2, y2, yaw2 in _se2_pairs(300, seed=7):
            s1.setX(x1), s1.setY(y1), s1.setYaw(yaw1), s2.setX(x2), s2.setY(y2), s2.setYaw(yaw2)
            for name in ("motionCost", "motionCostHeuristic"):
                want = getattr(python, name)(s1, s2).value()
                assert getattr(compiled, name)(s1, s2).value() == pytest.approx(want, rel=1e-12, abs=1e-12), name
            assert compiled.stateCost(s1).value() == python.stateCost(s1).value() == 0.0


@needs_compiled
@pytest.mark.parametrize("seed", [3, 11])
def test_rrtstar_finds_the_same_path_with_either_objective_when_built(seed: int) -> None:
    """Skipped with `load`'s reason unless ``make compiled`` built it for this wheel."""
    m = load_map("map1")
    assert m.start is not None and m.target is not None
    checker = make_checker(m, 8.0)
    results = {}
    for impl in ("compiled", "python"):
        problem = PlanningProblem(m, checker, m.start, m.target, 0.1, np.random.default_rng(seed), TIMINGS[1])
        results[impl] = make_planner("rrtstar", objective="robot-time", objective_impl=impl).plan(problem)
        assert results[impl].success and results[impl].info["objective_impl"] == impl
    compiled, python = results["compiled"], results["python"]
    assert np.array_equal(compiled.path, python.path)
    assert compiled.objective_cost == pytest.approx(python.objective_cost, rel=1e-12)
    assert compiled.collision_checks == python.collision_checks


def _build_folder(folder: Path, record: object) -> Path:
    """A folder holding a library file that is no library and the build record `record`."""
    folder.mkdir()
    (folder / library_name()).write_bytes(b"not a shared library")
    (folder / BUILD_RECORD).write_text(record if isinstance(record, str) else json.dumps(record), encoding="utf-8")
    return folder


def test_load_refuses_a_build_record_of_another_wheel(tmp_path: Path) -> None:
    """Always runs: the record is checked before the library is imported (a library built for another
    wheel may abort the interpreter or call the wrong virtual functions), so a fake one never loads."""
    import ompl

    version = importlib.metadata.version("ompl")
    key = registry_key(next(Path(ompl.__file__ or "").parent.glob("_ompl*.so")))
    this_wheel = {"ompl": version, "registry_key": key}
    cases = {
        "none": (None, "not built"),
        "version": ({**this_wheel, "ompl": "1.6.0", "libompl_sha256": "0" * 64}, "built for ompl 1.6.0"),
        "key": ({**this_wheel, "registry_key": "v16_system_libstdcpp", "libompl_sha256": "0" * 64},
                "(v16_system_libstdcpp)"),
        "digest": ({**this_wheel, "libompl_sha256": "0" * 64}, "another libompl.so"),
        "broken": ("{", "unreadable"),
    }
    for name, (record, words) in cases.items():
        folder = tmp_path / name if record is None else _build_folder(tmp_path / name, record)
        cls, why = load(folder)
        assert cls is None and words in why and "make compiled" in why, (name, why)
    # a record of this very wheel passes the check; the fake library then fails to import, cleanly
    digest = file_digest(Path(ompl.__file__ or "").parent / "libompl.so")
    cls, why = load(_build_folder(tmp_path / "this-wheel", {**this_wheel, "libompl_sha256": digest}))
    assert cls is None and why.startswith("cannot import"), why


def test_objective_impl_option_picks_the_objective_or_refuses_with_loads_reason(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Always runs: ``objective_impl=compiled`` plans with the compiled objective when it is built and is
    a one-line error naming `load`'s reason when not; ``auto`` takes it when built; ``python`` never."""
    base = ["plan", "--map", "map1", "--planner", "rrtstar", "--objective", "robot-time", "--time-limit", "0.02",
            "--exec-repeats", "0"]
    expected = {"auto": "compiled" if COMPILED else "python", "python": "python", "compiled": "compiled"}
    for impl, used in expected.items():
        out = tmp_path / impl
        argv = [*base, "--set", f"rrtstar.objective_impl={impl}", "-o", str(out / "p.png"), "--json",
                str(out / "p.json")]
        if used == "compiled" and COMPILED is None:
            fails_cleanly(argv, capsys, "objective_impl 'compiled'", WHY_NOT)
            assert not out.exists()
            continue
        assert run_cli(argv) == 0
        assert json.loads((out / "p.json").read_text())["info"]["objective_impl"] == used


def test_robot_time_objective_falls_back_to_python_unless_compiled_is_asked() -> None:
    """Always runs: ``python`` gives the Python class; ``auto`` whatever `load` allows."""
    _, si = _se2_space()
    objective, impl = robot_time_objective(si, TIMINGS[0], START, GOAL, "python")
    assert isinstance(objective, RobotTimeObjective) and impl == "python"
    objective, impl = robot_time_objective(si, TIMINGS[0], START, GOAL, "auto")
    assert impl == ("compiled" if COMPILED else "python")
    assert isinstance(objective, ob.OptimizationObjective)
    assert isinstance(objective, RobotTimeObjective) is (COMPILED is None)
