"""tools/estimate_smoothing.py: a localiser's estimates smoothed against the odometry, scored by evo."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import load_tool

from toolkit.recordings.recorder import Recorder
from toolkit.world import Pose, Scan, load_map

_TOOLS = Path(__file__).parents[1] / "tools"
sys.path.insert(0, str(_TOOLS))
smoothing = load_tool("estimate_smoothing")

STEP_CM, STEPS = 5.0, 120


def _recording(path: Path) -> list[Pose]:
    """A winding 6 m path in 5 cm steps whose truth is the exact dead reckoning; returns the true poses."""
    rec = Recorder(path, map=load_map("map1"), robot={"kind": "ros", "imported": "test"},
                   sonar={"model": "ideal", "sensor_noise": 1.0}, seed=None)
    scan = Scan(np.array([0.0, 1.0]), np.array([30.0, 40.0]), np.array([True, True]))
    poses = [Pose(0.0, 0.0, 0.0)]
    for k in range(STEPS):
        turn = 0.2 * math.sin(k / 3.0)
        rec.event("predict", turn_rad=turn, distance_cm=STEP_CM)
        p = poses[-1]
        h = p.theta + turn
        poses.append(Pose(p.x + STEP_CM * math.cos(h), p.y + STEP_CM * math.sin(h), h))
        rec.stamped_scan(scan, 0.1 * k, 0.1 * k + 0.05, poses[-1])
    rec.close("done", True)
    return poses[1:]


def _report(path: Path, truth: list[Pose], estimates: np.ndarray) -> None:
    """A replay report (`nxtnav replay --json`'s layout) of one localiser, `jumpy`, one update per truth."""
    steps = [{"index": i, "call": "update", "truth": t.to_list_deg(),
              "estimates": {"jumpy": {"pose": [e[0], e[1], math.degrees(e[2])]}}}
             for i, (t, e) in enumerate(zip(truth, estimates, strict=True))]
    path.write_text(json.dumps({"localisers": ["jumpy"], "steps": steps}))


def test_smoothing_a_jittery_correction_lowers_its_relative_error(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """Estimates that jump around the truth by an independent 1 cm, 0.5 degree at each update: the raw
    column is evo's RPE of those estimates, and a centred mean over the corrections removes most of it."""
    rec = tmp_path / "rec.jsonl"
    truth = _recording(rec)
    rng = np.random.default_rng(3)
    exact = np.array([p.as_array() for p in truth])
    est = np.array([np.asarray(smoothing.se2_compose(np.array([dx, dy, dh]), p))
                    for (dx, dy, dh), p in zip(rng.normal(0, [1.0, 1.0, math.radians(0.5)], (STEPS, 3)), exact,
                                               strict=True)])
    rep = tmp_path / "replay.json"
    _report(rep, truth, est)
    assert smoothing.main([str(rec), str(rep)]) == 0
    cells = [float(v) for v in capsys.readouterr().out.strip().splitlines()[-1].strip("|").split("|")[1:]]
    raw, _half, _fifth, window2, window8, true_heading, scale = cells
    assert raw == pytest.approx(smoothing.relative_pose_error(exact, est)[0], abs=0.01)
    assert raw > 1.0
    assert window8 < 0.5 * raw and window2 < raw
    assert true_heading < raw  # the heading jitter is a part of it
    assert scale == pytest.approx(1.0, abs=0.01)


def test_a_report_of_another_recording_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rec = tmp_path / "rec.jsonl"
    truth = _recording(rec)
    rep = tmp_path / "replay.json"
    _report(rep, truth[:50], np.array([p.as_array() for p in truth[:50]]))
    assert smoothing.main([str(rec), str(rep)]) == 2
    assert smoothing.main([str(rec), str(rep), "--localisers", "amcl"]) == 2
    (tmp_path / "junk.json").write_text("{")
    assert smoothing.main([str(rec), str(tmp_path / "junk.json")]) == 2
    (tmp_path / "stepless.json").write_text(json.dumps({"localisers": ["jumpy"], "steps": [{"call": "update"}]}))
    assert smoothing.main([str(rec), str(tmp_path / "stepless.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4
    assert "50 scored estimates" in err[0] and "no localiser 'amcl'" in err[1] and "not a replay report" in err[2]
    assert "step 0 is not a replay step" in err[3]
