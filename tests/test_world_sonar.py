"""Sonar models: the ideal sonar reproduces BotSim's statistics; the NXT model's effects appear."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from toolkit.world import (
    NO_ECHO,
    SONAR_MODELS,
    IdealSonar,
    NxtSonar,
    Pose,
    RegistryError,
    default_scan_angles,
    load_map,
    make_sonar,
    ray_cast,
    ray_wall_distances,
)


def shapely_ray(m, origin, angle, length=1000.0) -> float:
    """Exact first-hit distance with shapely: the ray as a long segment intersected with the walls."""
    o = shapely.Point(origin)
    ray = shapely.LineString([origin, (origin[0] + length * np.cos(angle), origin[1] + length * np.sin(angle))])
    hit = ray.intersection(m.wall_lines)
    return np.inf if hit.is_empty else o.distance(hit)


@pytest.mark.parametrize("name", ["map1", "map2", "map3", "pillars", "co333-arena"])
def test_ray_cast_matches_shapely(name: str) -> None:
    m = load_map(name)
    rng = np.random.default_rng(5)
    origins = m.sample_free(40, rng=rng)
    angles = rng.uniform(-np.pi, np.pi, (40, 9))
    got = ray_cast(m.walls, origins, angles)
    want = np.array([[shapely_ray(m, o, a) for a in row] for o, row in zip(origins, angles, strict=True)])
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_ray_cast_shapes_and_misses() -> None:
    walls = np.array([[10, -5, 10, 5]], float)
    assert ray_cast(walls, [0, 0], [0.0, np.pi]).tolist() == [10.0, np.inf]
    r, w = ray_cast(walls, [[0, 0], [5, 0]], [0.0], return_wall=True)
    assert r.shape == (2, 1) and r[1, 0] == pytest.approx(5.0) and w.tolist() == [[0], [0]]


def test_ideal_mean_and_spread_match_botsim() -> None:
    """At a fixed pose the mean of many scans equals exact ray casting within 0.1 cm, spread = noise."""
    m = load_map("map1")
    pose = Pose.from_deg(30.0, 75.0, 20.0)
    angles = pose.theta + default_scan_angles()
    exact = ray_cast(m.walls, pose.xy, angles)
    sonar = IdealSonar(noise_sd=1.0)
    origins = np.repeat(pose.xy[None], 2000, axis=0)
    scans = sonar.measure(m.walls, origins, angles, rng=11)
    assert scans.shape == (2000, 360)
    mean = scans.mean(axis=0)
    # Away from corners the mean reading is the exact range. Where a second wall crosses the ray
    # within a few noise widths (corners), BotSim's minimum over noisy crossings reads short, by design.
    second = np.sort(ray_wall_distances(m.walls, *np.repeat(pose.xy[:, None], 360, axis=1),
                                        np.cos(angles), np.sin(angles)), axis=1)[:, 1]
    clean = second - exact > 4.0
    assert clean.mean() > 0.9
    assert np.max(np.abs(mean - exact)[clean]) < 0.1
    assert np.mean(np.abs(mean - exact)) < 0.1
    # radial spread of a crossing point with N(0, s^2) on x and y is s (for distances >> s)
    np.testing.assert_allclose(scans.std(axis=0).mean(), 1.0, atol=0.03)


def test_ideal_no_hit_is_inf_and_noise_free_is_exact() -> None:
    m = load_map("map1")
    exact = ray_cast(m.walls, [20, 20], default_scan_angles())
    np.testing.assert_allclose(IdealSonar(noise_sd=0.0).measure(m.walls, [20, 20], default_scan_angles()), exact)
    outside = IdealSonar().measure(m.walls, [-50, -50], np.array([np.pi]), rng=0)
    assert np.isinf(outside).all()


def test_seeded() -> None:
    m = load_map("map2")
    for name in SONAR_MODELS.names():
        s = make_sonar(name)
        a = s.measure(m.walls, [40, 30], default_scan_angles(), rng=3)
        b = s.measure(m.walls, [40, 30], default_scan_angles(), rng=3)
        np.testing.assert_array_equal(a, b)


def test_nxt_readings_are_whole_cm_or_255() -> None:
    m = load_map("map1")
    r = NxtSonar().measure(m.walls, [20, 85], default_scan_angles(), rng=0)
    assert np.all((r == np.rint(r)) & (r >= 0) & (r <= NO_ECHO))


def test_nxt_specular_loss_at_steep_incidence() -> None:
    """Facing a long wall head-on echoes; at 70 degrees off its normal the near wall is lost."""
    walls = np.array([[50, -1000, 50, 1000]], float)  # one wall, nothing behind it
    sonar = NxtSonar.hardware_facts(noise_sd=0.0, dropout_prob=0.0, far_dropout_prob=0.0, beam_width_deg=10)
    head_on = sonar.measure(walls, [0, 0], np.array([0.0]), rng=0)
    steep = sonar.measure(walls, [0, 0], np.radians([70.0]), rng=0)
    assert head_on[0] == 50
    assert steep[0] == NO_ECHO
    # a farther wall seen square-on through the lobe answers instead of the lost near wall
    walls2 = np.array([[50, -1000, 50, 140], [-1000, 200, 1000, 200]], float)
    r = sonar.measure(walls2, [0, 0], np.radians([70.0]), rng=0)[0]
    assert r != NO_ECHO and r > 50 / np.cos(np.radians(70.0))


def test_nxt_lobe_reads_short_near_corners() -> None:
    """A lobe sees the nearest echoing surface within its width, so it reads shorter than its axis."""
    m = load_map("map1")
    sonar = NxtSonar.hardware_facts(noise_sd=0.0, dropout_prob=0.0, far_dropout_prob=0.0)
    axis = ray_cast(m.walls, [42, 20], np.radians([90.0]))[0]  # passes just left of the notch corner
    lobe = sonar.measure(m.walls, [42, 20], np.radians([90.0]), rng=0)[0]
    assert axis == pytest.approx(85.0)
    assert lobe == pytest.approx(25.0 / np.cos(np.radians(10.0)), abs=1.0)


def test_nxt_dropouts_and_close_range() -> None:
    walls = np.array([[50, -1000, 50, 1000]], float)
    sonar = NxtSonar(dropout_prob=0.2, noise_sd=0.0)
    r = sonar.measure(walls, np.zeros((5000, 2)), np.zeros(1), rng=1)
    assert 0.17 < np.mean(r == NO_ECHO) < 0.23
    close = NxtSonar(dropout_prob=0.0, noise_sd=0.0).measure(walls, np.tile([47.0, 0.0], (5000, 1)), np.zeros(1), rng=2)
    assert 0.4 < np.mean(close == NO_ECHO) < 0.6  # 3 cm is below the 6 cm minimum range
    assert np.all(close[close != NO_ECHO] < 6)


def test_nxt_max_range() -> None:
    walls = np.array([[300, -1000, 300, 1000]], float)
    r = NxtSonar.hardware_facts(dropout_prob=0.0).measure(walls, [0, 0], np.zeros(10), rng=0)
    assert np.all(r == NO_ECHO)
    # the fitted model's phantom readings: where nothing echoes, some random readings all the same
    silent = NxtSonar().measure(walls, np.zeros((4000, 2)), np.zeros(1), rng=0)
    assert np.mean(silent != NO_ECHO) == pytest.approx(NxtSonar().phantom_prob, abs=0.03)


def test_registry_and_validation() -> None:
    assert {"ideal", "nxt"} <= set(SONAR_MODELS.names())
    with pytest.raises(RegistryError, match="unknown sonar model 'radar'; known: ideal, laser, nxt"):
        make_sonar("radar")
    with pytest.raises(ValueError, match="dropout_prob"):
        NxtSonar(dropout_prob=1.5)
    assert make_sonar("nxt", beam_width_deg=30).to_dict()["beam_width_deg"] == 30
