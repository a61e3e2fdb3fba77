"""The robot's cost of a path: robot time by the timing model's speed and turn rate, predicted error."""

from __future__ import annotations

import math

import pytest

from toolkit.world import ConfigError, MotionNoise, RobotModel, RobotTiming, objective_cost, path_cost, robot_time_s
from toolkit.world.robot_cost import monte_carlo_error_cm, predicted_error_cm

ZIGZAG = [[0.0, 0.0], [60.0, 0.0], [60.0, 45.0], [100.0, 75.0]]


def test_robot_time_of_a_path_by_hand() -> None:
    """60 + 45 + 50 cm at 12 cm/s; turns of 90 and 90 - 36.87 degrees at 60 deg/s; 0.5 s per turn."""
    timing = RobotTiming(drive_speed_cm_s=12.0, turn_rate_deg_s=60.0, stop_turn_s=0.5)
    by_hand = 155.0 / 12.0 + (90.0 + (90.0 - math.degrees(math.atan2(30, 40)))) / 60.0 + 2 * 0.5
    assert robot_time_s(ZIGZAG, timing) == pytest.approx(by_hand, rel=1e-12)
    assert objective_cost("robot-time", ZIGZAG, timing) == pytest.approx(by_hand, rel=1e-12)
    assert objective_cost("turns", ZIGZAG) == 2
    assert objective_cost("length", ZIGZAG) == pytest.approx(155.0)
    model = RobotModel(timing=timing)
    assert path_cost(ZIGZAG, model.timing, model.motion).robot_time_s == pytest.approx(by_hand)


@pytest.mark.parametrize("model", ["botsim", "absolute"])
def test_closed_form_error_agrees_with_seeded_drives(model: str) -> None:
    noise = MotionNoise(model, 0.1, 0.03)  # type: ignore[arg-type]
    closed = predicted_error_cm(ZIGZAG, noise)
    drawn = monte_carlo_error_cm(ZIGZAG, noise, runs=20000, seed=3)
    assert closed == pytest.approx(drawn, rel=0.05)
    assert predicted_error_cm(ZIGZAG, MotionNoise(model, 0.0, 0.0)) == 0.0  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [0.0, -1.0, math.inf, math.nan])
def test_zero_or_infinite_speed_is_refused(bad: float) -> None:
    with pytest.raises(ConfigError, match="drive_speed_cm_s"):
        RobotTiming(drive_speed_cm_s=bad)
    with pytest.raises(ConfigError, match="turn_rate_deg_s"):
        RobotTiming(turn_rate_deg_s=bad)


def test_unknown_objective_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"unknown objective 'time'.*robot-time"):
        objective_cost("time", ZIGZAG)
