"""tools/truth_consistency.py: dead reckoning from a recording's motions against its true poses."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import load_tool

from toolkit.recordings.recorder import Recorder
from toolkit.world import Pose, Scan, load_map

truth_consistency = load_tool("truth_consistency")

STEP_CM, STEPS = 5.0, 120
"""A winding path driven in steps of 5 cm, each after a turn of up to 0.2 rad (`_turn`)."""


def _turn(k: int) -> float:
    """Turns that change from step to step: on a circle a late truth would be the same path, step for step."""
    return 0.2 * math.sin(k / 3.0)


def _circle_recording(path: Path, lag_steps: int) -> None:
    """Each step a turn and a drive, then a scan whose true pose is the exact pose `lag_steps` steps earlier
    (a truth stamped late)."""
    rec = Recorder(path, map=load_map("map1"), robot={"kind": "ros", "imported": "test"},
                   sonar={"model": "ideal", "sensor_noise": 1.0}, seed=None)
    scan = Scan(np.array([0.0, 1.0]), np.array([30.0, 40.0]), np.array([True, True]))
    poses = [Pose(0.0, 0.0, 0.0)]
    for k in range(STEPS):
        rec.event("predict", turn_rad=_turn(k), distance_cm=STEP_CM)
        p = poses[-1]
        h = p.theta + _turn(k)
        poses.append(Pose(p.x + STEP_CM * math.cos(h), p.y + STEP_CM * math.sin(h), h))
        rec.stamped_scan(scan, 0.1 * k, 0.1 * k + 0.05, poses[max(len(poses) - 1 - lag_steps, 0)])
    rec.close("done", True)


def test_a_truth_that_is_the_dead_reckoning_has_no_error(tmp_path: Path) -> None:
    path = tmp_path / "exact.jsonl"
    _circle_recording(path, lag_steps=0)
    odo, truth = truth_consistency.odometry_and_truth(str(path))
    assert len(truth) == STEPS and np.allclose(odo[:, :2], truth[:, :2])
    translation, rotation = truth_consistency.relative_pose_error(truth, odo, 0.1)
    assert translation == pytest.approx(0.0, abs=1e-6) and rotation == pytest.approx(0.0, abs=1e-6)


def test_a_truth_stamped_one_step_late_shows_over_short_stretches(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                                                   ) -> None:
    """Lagging one step, the truth's motion over 10 cm is the odometry's of one step before: where the turns
    change, the two differ by millimetres (the exact truth gives 0, above)."""
    path = tmp_path / "late.jsonl"
    _circle_recording(path, lag_steps=1)
    assert truth_consistency.main([str(path), "--deltas", "0.1"]) == 0
    row = capsys.readouterr().out.strip().splitlines()[-1]
    translation = float(row.split("|")[3].split(",")[0])
    assert 0.2 < translation < 2.0


def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text("not json\n")
    assert truth_consistency.main([str(bad)]) == 2
    assert truth_consistency.main([str(bad), "--deltas", "0.1,x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "line 1" in err[0] and "--deltas" in err[1]
