"""The compiled robot-time objective's command line (planners/_compiled/README.md).

``python tools/compiled_objective.py key LIBRARY``: the nanobind registry key compiled into an extension
(`planners._compiled.abi_key.registry_key`), and ``record JSON VERSION KEY LIBOMPL``: the build's record
that the loader checks; both run by planners/_compiled/build.sh.

Two checks, once ``make compiled`` has built it. ``python tools/compiled_objective.py equal``: the
compiled objective against the Python one (`planners.ompl_objective.RobotTimeObjective`) on random SE(2)
state pairs, with the cases the cost
singles out (leaving the start, reaching the goal, no displacement, a heading along the segment);
fails when any cost differs by more than 1e-9 s.

``python tools/compiled_objective.py bench [MAP] [RUNS] [PLANNER]``: the OMPL planner (default
``ompl:RRTstar``) on the map's own query under ``length``, ``robot-time`` with the Python objective and
``robot-time`` with the compiled one (the planner option ``objective_impl``), the same seeds and the same
number of iterations (the planners' deterministic budget), and the planning time per collision check (us)
of each.
"""

from __future__ import annotations

import json
import math
import statistics
import sys
from pathlib import Path
from typing import Any

import numpy as np


def _pair(rng: np.random.Generator, i: int, start: tuple[float, float], goal: tuple[float, float]) -> Any:
    """Two positions and headings; every sixth pair of a kind the cost singles out."""
    kind = i % 6
    a = start if kind in (1, 5) else (float(rng.uniform(-200, 200)), float(rng.uniform(-200, 200)))
    z = goal if kind in (2, 5) else a if kind == 3 else (float(rng.uniform(-200, 200)), float(rng.uniform(-200, 200)))
    ya, yz = (float(v) for v in rng.uniform(-math.pi, math.pi, 2))
    if kind == 4:  # headings along the segment: no turn leaving or arriving
        ya = yz = math.atan2(z[1] - a[1], z[0] - a[0])
    return a, ya, z, yz


def equal(pairs: int = 100_000) -> float:
    """The largest difference (s) between the two objectives' costs over `pairs` pairs and two timings."""
    import ompl.base as ob

    from planners._compiled import compiled_objective, load
    from planners.ompl_objective import RobotTimeObjective
    from toolkit.world import RobotTiming

    if load()[0] is None:
        raise SystemExit(f"measure: error: {load()[1]}")
    space = ob.SE2StateSpace()
    box = ob.RealVectorBounds(2)
    box.setLow(-200.0)
    box.setHigh(200.0)
    space.setBounds(box)
    si = ob.SpaceInformation(space)
    rng = np.random.default_rng(1)
    start, goal, worst = (12.5, -40.25), (150.0, 99.75), 0.0
    s1, s2 = space.allocState(), space.allocState()
    for timing in (RobotTiming(), RobotTiming(drive_speed_cm_s=7.3, turn_rate_deg_s=41.0, stop_turn_s=0.35)):
        python, compiled = RobotTimeObjective(si, timing, start, goal), compiled_objective(si, timing, start, goal)
        assert python.isSymmetric() is compiled.isSymmetric() is False
        for i in range(pairs):
            a, ya, z, yz = _pair(rng, i, start, goal)
            s1.setX(a[0]), s1.setY(a[1]), s1.setYaw(ya), s2.setX(z[0]), s2.setY(z[1]), s2.setYaw(yz)
            for name in ("motionCost", "motionCostHeuristic", "stateCost"):
                args = (s1,) if name == "stateCost" else (s1, s2)
                worst = max(worst, abs(getattr(python, name)(*args).value() - getattr(compiled, name)(*args).value()))
    return worst


def bench(map_name: str = "map1", runs: int = 3, planner_name: str = "ompl:RRTstar") -> dict[str, float]:
    """The median planning time per collision check (us) of each variant, one line per run printed."""
    from planners import PlanningProblem, make_planner
    from planners._compiled import load
    from toolkit.world import CollisionChecker, RobotTiming, load_map

    if load()[0] is None:
        raise SystemExit(f"measure: error: {load()[1]}")
    variants = {"length": {"objective": "length"}, "python": {"objective": "robot-time", "objective_impl": "python"},
                "compiled": {"objective": "robot-time", "objective_impl": "compiled"}}
    m = load_map(map_name)
    start, target = m.start, m.target
    if start is None or target is None:
        raise SystemExit(f"measure: error: map {map_name} has no start and target")
    checker = CollisionChecker(m, robot_radius=8.0)
    timing = RobotTiming()
    per_check: dict[str, list[float]] = {variant: [] for variant in variants}
    for seed in (-1, *range(runs)):  # seed -1 warms up (the checker's index, the imports)
        for variant, options in variants.items():
            planner = make_planner(planner_name, **options)
            res = planner.plan(PlanningProblem(m, checker, start, target, time_limit=0.1 if seed < 0 else 1.0,
                                               rng=abs(seed), timing=timing))
            if seed < 0:
                continue
            assert res.info.get("objective_impl", "length") == variant  # length records none
            per_check[variant].append(1e6 * res.time_s / max(res.collision_checks, 1))
            print(f"{map_name} {planner_name} run {seed} {variant:8s} {res.status} cost {res.objective_cost:.4f} "
                  f"time {res.time_s:.2f} s checks {res.collision_checks} "
                  f"iterations {res.info.get('iterations')}: {per_check[variant][-1]:.1f} us/check", flush=True)
    return {variant: statistics.median(values) for variant, values in per_check.items()}


def _main(argv: list[str]) -> int:
    from planners._compiled.abi_key import file_digest, registry_key

    if argv[:1] == ["key"] and len(argv) == 2:
        key = registry_key(Path(argv[1]))
        print(key)
        return 0 if key else 1
    if argv[:1] == ["record"] and len(argv) == 5:
        out, version, key, libompl = argv[1:]
        record = {"ompl": version, "registry_key": key, "libompl_sha256": file_digest(Path(libompl))}
        Path(out).write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        return 0
    if argv[:1] == ["equal"]:
        worst = equal()
        print(f"largest |python - compiled| cost: {worst:.3e} s")
        return 0 if worst <= 1e-9 else 1
    if argv[:1] == ["bench"]:
        rest = argv[1:]
        med = bench(rest[0] if rest else "map1", int(rest[1]) if len(rest) > 1 else 3,
                    rest[2] if len(rest) > 2 else "ompl:RRTstar")
        ratios = ", ".join(f"{k}/length x{med[k] / med['length']:.2f}" for k in ("python", "compiled"))
        print("median us/check: " + ", ".join(f"{k} {v:.1f}" for k, v in med.items()) + "; " + ratios)
        return 0
    print("usage: python tools/compiled_objective.py key LIBRARY | record JSON VERSION KEY LIBOMPL | equal | "
          "bench [MAP] [RUNS] [PLANNER]", file=sys.stderr)
    return 2


if __name__ == "__main__":
    raise SystemExit(_main(sys.argv[1:]))
