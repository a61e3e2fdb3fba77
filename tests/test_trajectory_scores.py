"""evo's trajectory errors (`toolkit.recordings.trajectory_scores`) against trajectories whose errors are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from toolkit.recordings.trajectory_scores import relative_pose_error, score_trajectory


def _loop(n: int = 200) -> np.ndarray:
    s = np.linspace(0.0, 2 * math.pi, n)
    return np.column_stack([500 + 300 * np.cos(s), 400 + 200 * np.sin(s), s + math.pi / 2])


def _moved(p: np.ndarray, x: float, y: float, a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    out = p.copy()
    out[:, 0] = x + c * p[:, 0] - s * p[:, 1]
    out[:, 1] = y + s * p[:, 0] + c * p[:, 1]
    out[:, 2] = p[:, 2] + a
    return out


def test_a_rigid_offset_costs_nothing() -> None:
    truth = _loop()
    scores = score_trajectory(truth, _moved(truth, 140.0, -35.0, 0.4))
    assert scores.ape_rmse_cm == pytest.approx(0.0, abs=1e-6)
    assert scores.ape_heading_rmse_deg == pytest.approx(0.0, abs=1e-6)
    assert scores.rpe_per_m_cm == pytest.approx(0.0, abs=1e-6)


def test_noise_of_known_size() -> None:
    """Independent noise of 2 cm on x and y and 0.5 degrees on the heading: APE near sqrt(8) cm and 0.5
    degrees; the RPE compares two poses, so near sqrt(2) times the APE."""
    rng = np.random.default_rng(7)
    truth = _loop(4000)
    est = truth + rng.normal(0.0, [2.0, 2.0, math.radians(0.5)], truth.shape)
    scores = score_trajectory(truth, _moved(est, -50.0, 20.0, -1.0))
    assert scores.ape_rmse_cm == pytest.approx(math.sqrt(8.0), rel=0.05)
    assert scores.ape_heading_rmse_deg == pytest.approx(0.5, rel=0.05)
    assert scores.rpe_per_m_cm == pytest.approx(math.sqrt(2.0) * math.sqrt(8.0), rel=0.1)


def test_a_scale_error_is_not_aligned_away() -> None:
    """The alignment is rigid (no scale): a trajectory 2 % too large keeps an error."""
    truth = _loop()
    est = truth.copy()
    est[:, :2] = (truth[:, :2] - truth[:, :2].mean(axis=0)) * 1.02 + truth[:, :2].mean(axis=0)
    scores = score_trajectory(truth, est)
    assert scores.ape_rmse_cm > 3.0 and scores.rpe_per_m_cm > 1.0


def test_short_paths_have_no_rpe() -> None:
    truth = _loop()[:5] * np.array([0.01, 0.01, 1.0])
    assert math.isnan(score_trajectory(truth, truth).rpe_per_m_cm)


def test_a_straight_line_cannot_be_aligned() -> None:
    truth = np.column_stack([np.linspace(0, 500, 50), np.zeros(50), np.zeros(50)])
    assert math.isnan(score_trajectory(truth, truth + 1.0).ape_rmse_cm)


def test_a_constant_heading_offset_shows_over_every_pair() -> None:
    """Headings 0.5 degrees off the truth's everywhere, positions exact: one metre of driving, seen from
    a frame turned by 0.5 degrees, lands 2 sin(0.25 degrees) x 100 cm away, and the rotation between
    two poses is exact. Over 10 cm it is a tenth of that."""
    truth = _loop(4000)
    est = truth.copy()
    est[:, 2] += math.radians(0.5)
    for delta_m in (0.1, 1.0):
        translation, rotation = relative_pose_error(truth, est, delta_m)
        assert translation == pytest.approx(2 * math.sin(math.radians(0.25)) * 100 * delta_m, rel=0.02)
        assert rotation == pytest.approx(0.0, abs=1e-6)
    assert score_trajectory(truth, est).rpe_per_m_cm == pytest.approx(relative_pose_error(truth, est)[0])


def test_missing_scores_say_why() -> None:
    """Every NaN comes with its reason: a path shorter than a metre, poses too sparse to hold a pair a
    metre apart (evo raises for those), fewer than three poses."""
    short = _loop()[:5] * np.array([0.01, 0.01, 1.0])
    scores = score_trajectory(short, short)
    assert math.isnan(scores.rpe_per_m_cm) and "shorter than the 1 m" in (scores.rpe_note or "")
    assert scores.ape_note is None and math.isfinite(scores.ape_rmse_cm)
    sparse = _loop(5)  # five poses round a loop of about 16 m: no two 1 m apart within 10 %
    scores = score_trajectory(sparse, sparse)
    assert math.isnan(scores.rpe_per_m_cm) and "no two of the 5 true poses lie 1 m apart" in (scores.rpe_note or "")
    assert score_trajectory(_loop(), _loop()).rpe_note is None
    two = score_trajectory(_loop()[:2], _loop()[:2])
    assert two.ape_note == two.rpe_note == "2 true poses; the scores need three or more"
    assert two.to_dict()["rpe_per_m_cm"] is None
    still = np.tile([20.0, 20.0, 0.5], (5, 1))  # a robot that never moved: nothing to align
    assert score_trajectory(still, still + 0.3).ape_note == "the true positions are one point: no unique alignment"
