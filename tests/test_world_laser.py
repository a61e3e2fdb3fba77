"""The `laser` sensor model: a thin ray, Gaussian noise, no echo outside the message's limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from toolkit.world import SONAR_MODELS, ConfigError, LaserScanner, load_map, make_sonar, ray_cast


def test_registered_beside_the_sonars() -> None:
    assert {"ideal", "nxt", "laser"} <= set(SONAR_MODELS.names())
    assert isinstance(make_sonar("laser", noise_sd=0.5), LaserScanner)


def test_readings_are_the_ray_cast_plus_noise() -> None:
    world = load_map("map1")
    angles = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    laser = LaserScanner(noise_sd=1.0, max_range_cm=1000.0)
    exact = ray_cast(world.walls, [20.0, 20.0], angles)
    got = laser.measure(world.walls, [20.0, 20.0], angles, rng=1)
    err = got - exact
    assert np.all(np.isfinite(got)) and abs(err.mean()) < 0.2 and err.std() == pytest.approx(1.0, rel=0.15)


def test_no_echo_outside_the_limits() -> None:
    world = load_map("map1")
    laser = LaserScanner(noise_sd=0.0, min_range_cm=30.0, max_range_cm=60.0)
    angles = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    exact = ray_cast(world.walls, [20.0, 20.0], angles)
    got = laser.measure(world.walls, [20.0, 20.0], angles, rng=1)
    inside = (exact >= 30.0) & (exact <= 60.0)
    assert np.array_equal(np.isfinite(got), inside) and np.allclose(got[inside], exact[inside])
    scan = laser.to_scan(angles, [np.nan, 10.0, 45.0, 70.0, np.inf] + [45.0] * 355)
    assert scan.valid[:5].tolist() == [False, False, True, False, False]


def test_log_pdf_is_a_distribution() -> None:
    """For a wall at 40 cm: the echo density integrates, with the no-echo probability, to one."""
    laser = LaserScanner(noise_sd=2.0, min_range_cm=10.0, max_range_cm=45.0, miss_prob=0.1, rand_prob=0.05)
    for d in (40.0, 44.0, math.inf):
        dens, _ = integrate.quad(lambda r, d=d: math.exp(float(laser.log_pdf(d, r))), 10.0, 45.0, points=[40, 44],
                                 limit=200)
        none = math.exp(float(laser.log_pdf(d, math.inf)))
        assert dens + none == pytest.approx(1.0, abs=1e-6)


def test_sample_follows_log_pdf() -> None:
    laser = LaserScanner(noise_sd=2.0, min_range_cm=10.0, max_range_cm=45.0, miss_prob=0.1, rand_prob=0.05)
    r = laser.sample(np.full(200_000, 44.0), rng=3)
    assert np.mean(~np.isfinite(r)) == pytest.approx(math.exp(float(laser.log_pdf(44.0, math.inf))), abs=0.005)


def test_bad_parameters() -> None:
    with pytest.raises(ConfigError, match="max_range_cm"):
        LaserScanner(min_range_cm=10.0, max_range_cm=5.0)
    with pytest.raises(ConfigError, match="miss_prob"):
        LaserScanner(miss_prob=1.5)
