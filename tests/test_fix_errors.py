"""tools/fix_errors.py: a mission's fixes against the simulator's truth and its robot time by kind of step."""

from __future__ import annotations

import math

import pytest
from conftest import load_tool

from toolkit.mission import run_sim_mission

fix_errors = load_tool("fix_errors")


def test_the_fixes_are_read_against_the_truth_and_the_time_adds_up() -> None:
    report = run_sim_mission("map1", seed=3)
    errors = fix_errors.fix_errors(report)
    kinds = {kind for kind, _, _ in errors}
    assert "localise: global attempt 1" in kinds and "relocalise: at target" in kinds
    converged = [s for s in report.trace if s.action.value in ("localise", "relocalise") and "converged" in s.note]
    assert len(errors) == len(converged)
    last = converged[-1]
    assert last.estimate is not None and last.true_pose is not None
    kind, heading, position = errors[-1]
    assert kind == "relocalise: at target"
    assert position == pytest.approx(last.estimate.distance_to(last.true_pose))
    assert heading == pytest.approx(abs(math.degrees(math.remainder(last.estimate.theta - last.true_pose.theta,
                                                                     2 * math.pi))))
    assert all(0.0 <= h <= 180.0 and p >= 0.0 for _, h, p in errors)
    spent = fix_errors.time_by_kind(report)
    assert sum(t for t, _ in spent.values()) == pytest.approx(report.times.robot_time_s)
    assert spent["move"][1] == sum(s.action.value == "move" for s in report.trace)
