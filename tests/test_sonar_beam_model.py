"""The nxt sonar's beam mixture: a proper distribution, sampled as it is scored, fitted back from its own
readings; stuck runs; the localisers' tabulated costs and the lattice gather."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import real_nxt_arena

from localisation.beam_model import BeamLikelihood, lattice_costs, scan_readings
from localisation.models import exact_ranges, range_lattice, range_table
from localisation.scan import stuck_mask
from toolkit.real_sonar.fit import _EchoRows, _sweep_log_pmf, fit_sonar, score_sonar
from toolkit.real_sonar.sweeps import Sweep, SweepSet, sweep_angles
from toolkit.world import NO_ECHO, NxtSonar, Scan, default_scan_angles, load_map

HEAVY = NxtSonar(noise_sd=2.5, noise_per_m=2.0, bias_cm=-1.0, dropout_prob=0.01, far_dropout_prob=0.4, reach_cm=80.0,
                 reach_width_cm=10.0, phantom_prob=0.3, short_prob=0.1, outlier_prob=0.05)
ALL_READINGS = np.append(np.arange(255.0), NO_ECHO)


@pytest.mark.parametrize("d", [0.0, 3.0, 5.9, 6.0, 30.0, 79.5, 150.0, 254.0, 254.9, 255.0, 400.0, math.inf])
@pytest.mark.parametrize("model", [NxtSonar(), NxtSonar.hardware_facts(), HEAVY])
def test_log_pmf_is_a_distribution_over_readings(model: NxtSonar, d: float) -> None:
    p = np.exp(model.log_pmf(np.full(ALL_READINGS.size, d), ALL_READINGS))
    assert p.sum() == pytest.approx(1.0, abs=1e-9)
    assert np.all(p >= 0)


@pytest.mark.parametrize("d", [4.0, 42.0, 95.0, math.inf])
def test_sample_draws_from_log_pmf(d: float) -> None:
    n = 200_000
    r = HEAVY.sample(np.full(n, d), rng=7)
    assert np.all((r == np.rint(r)) & (r >= 0) & (r <= NO_ECHO))
    freq = np.bincount(np.where(r == NO_ECHO, 255, r).astype(int), minlength=256) / n
    p = np.exp(HEAVY.log_pmf(np.full(ALL_READINGS.size, d), ALL_READINGS))
    assert np.max(np.abs(freq - p)) < 0.006  # binomial sd at p = 0.5 and n = 2e5 is 0.0011


def test_loss_rises_with_range_around_reach() -> None:
    lost = HEAVY.loss_probability(np.array([10.0, 80.0, 200.0]))
    assert lost[0] == pytest.approx(0.01, abs=1e-3)
    assert lost[1] == pytest.approx(0.205, abs=1e-3)
    assert lost[2] == pytest.approx(0.4, abs=1e-3)


def test_parameters_validated() -> None:
    with pytest.raises(ValueError, match="noise_sd"):
        NxtSonar(noise_sd=-1.0)
    with pytest.raises(ValueError, match="phantom_prob"):
        NxtSonar(phantom_prob=1.5)
    with pytest.raises(ValueError, match="short_prob \\+ outlier_prob"):
        NxtSonar(short_prob=0.6, outlier_prob=0.6)
    with pytest.raises(ValueError, match="beam_rays"):
        NxtSonar(beam_rays=2.5)  # type: ignore[arg-type]


def _simulated_set(model: NxtSonar, headings_deg: list[float], seed: int = 0) -> SweepSet:
    m = real_nxt_arena()
    points = [(84, 30), (180, 30), (126, 54), (30, 54), (138, 168), (126, 100)]
    rng = np.random.default_rng(seed)
    sweeps = []
    for i, ((x, y), h) in enumerate(zip(points, headings_deg, strict=True)):
        step, direction = (1.0, "cw") if i % 2 else (5.0, "ccw")
        ang = sweep_angles(int(360 / step), step, direction)
        r = model.measure(m.walls, np.array([x, y], float), math.radians(h) + ang, rng)
        sweeps.append(Sweep("sim", f"s{i}", float(x), float(y), ang, np.asarray(r, dtype=float), step_deg=step,
                            direction=direction))
    return SweepSet(Path("simulated"), m, tuple(sweeps))


def test_the_fit_tabulates_the_same_log_pmf_it_would_compute() -> None:
    # the rows of a sweep's echo distances repeat a few values (positions x headings), readings repeat too
    rng = np.random.default_rng(5)
    distances = np.append(rng.uniform(0.0, 300.0, 40), np.inf).astype(np.float32)
    echoes = rng.choice(distances, size=(300, 72))
    readings = np.where(rng.random(72) < 0.2, NO_ECHO, rng.integers(0, 120, 72)).astype(float)
    model = NxtSonar()
    assert np.array_equal(_sweep_log_pmf(model, _EchoRows.of(echoes), readings),
                          model.log_pmf(echoes, readings[None, :]))


@pytest.mark.slow
def test_fit_recovers_a_known_model() -> None:
    truth = NxtSonar(noise_sd=2.0, noise_per_m=1.0, bias_cm=-1.0, beam_width_deg=20.0, beam_rays=9,
                     critical_incidence_deg=50.0, dropout_prob=0.02, far_dropout_prob=0.5, reach_cm=90.0,
                     reach_width_cm=8.0, phantom_prob=0.2, short_prob=0.1, outlier_prob=0.05)
    headings = [0.0, 15.0, -20.0, 90.0, 170.0, -100.0]
    sets = [_simulated_set(truth, headings, seed) for seed in range(4)]
    fit = fit_sonar(sets, widths=(20.0, 30.0), criticals=(40.0, 50.0))
    got = fit.model
    assert (got.beam_width_deg, got.critical_incidence_deg) == (20.0, 50.0)
    assert got.noise_sd == pytest.approx(2.0, rel=0.2)
    assert got.bias_cm == pytest.approx(-1.0, abs=0.3)
    assert got.outlier_prob == pytest.approx(0.05, abs=0.02)
    assert got.short_prob == pytest.approx(0.1, abs=0.03)
    assert got.far_dropout_prob == pytest.approx(0.5, abs=0.08)
    assert got.reach_cm == pytest.approx(90.0, abs=8.0)
    assert got.phantom_prob == pytest.approx(0.2, abs=0.1)
    # every sweep's heading found again: within 3 degrees, since the fit also lets each sweep sit up to
    # 3 cm off its waypoint (a nuisance a heading error can partly trade against where walls are square)
    errors = [abs((v - headings[int(k.split("/s")[1])] + 180) % 360 - 180) for k, v in fit.headings_deg.items()]
    assert max(errors) <= 3.0 and np.median(errors) <= 1.0
    # the fitted model explains the readings better than the hardware facts do, and its no-echo share is right
    fitted, facts = score_sonar(got, sets, margins=False), score_sonar(NxtSonar.hardware_facts(), sets, margins=False)
    assert fitted.mean_log_likelihood > facts.mean_log_likelihood
    assert abs(fitted.no_echo_model - fitted.no_echo_real) < 0.02


def _map1_sweep(n: int) -> np.ndarray:
    """`n` readings of the `nxt` lobe's noise-free echo at (80, 80) of map1, heading -130 degrees, each
    moved by -1, 0 or +1 cm in turn (varying readings: no run of one value), 255 where nothing echoes."""
    angles = math.radians(-130.0) + default_scan_angles(n)
    echo = np.asarray(NxtSonar().echo_distance(load_map("map1").walls, np.array([80.0, 80.0]), angles))
    return np.where(np.isfinite(echo), np.rint(echo) + np.arange(n) % 3 - 1, NO_ECHO)


def test_stuck_runs_found_and_no_echo_runs_kept() -> None:
    m = load_map("map1")
    ang = default_scan_angles(360)
    r = _map1_sweep(360)
    r[100:160] = 33.0  # a 60-degree stuck run, facing a wall 26 cm away
    r[200:230] = 50.0  # a 30-degree run: too short to judge
    stuck = stuck_mask(Scan.from_readings(ang, r), m)
    assert stuck[100:160].all() and stuck.sum() == 60
    r[250:350] = NO_ECHO  # a long silent arc: never stuck
    assert not stuck_mask(Scan.from_readings(ang, r), m)[250:350].any()
    coarse = Scan.from_readings(default_scan_angles(72), np.r_[np.full(10, 60.0), _map1_sweep(72)[10:]])
    assert stuck_mask(coarse, m).sum() == 10  # ten 5-degree readings: 50 degrees, facing a wall 21 cm away


def test_beam_costs_use_no_echo_as_evidence() -> None:
    lik = BeamLikelihood(NxtSonar())
    silent = np.array([NO_ECHO])
    near, nothing = lik.sq_residuals(np.array([[40.0]]), silent), lik.sq_residuals(np.array([[np.inf]]), silent)
    assert nothing[0] < near[0]  # hearing nothing is likelier where nothing is in reach
    # one wrong reading costs a bounded amount: twenty right readings outweigh it
    e = np.full((2, 21), 50.0)
    e[1] += 8.0  # a pose 8 cm off
    meas = np.r_[np.full(20, 50.0), 130.0]
    cost = lik.sq_residuals(e, meas)
    assert cost[0] < cost[1]


def test_lattice_gather_equals_table_lookups() -> None:
    m = load_map("map1")
    model = NxtSonar()
    table = range_table(m, 1.0, 360, None, model.beam_width_deg, model.critical_incidence_deg,
                        max_range_cm=model.max_range_cm)
    lattice = range_lattice(table, 2, 7.0)
    lik = BeamLikelihood(model).with_step(math.radians(5.0))
    rel = default_scan_angles(72)
    meas = np.asarray(model.measure(m.walls, np.array([30.0, 70.0]), 0.4 + rel, rng=3), dtype=float)
    costs = lattice_costs(lattice, rel, meas, lik, max_beams=0)
    rng = np.random.default_rng(0)
    cells = rng.integers(0, len(lattice), 50)
    heads = rng.integers(0, 360, 50)
    poses = np.column_stack([lattice.xy[cells], np.radians(heads)])
    direct = lik.sq_residuals(table.lookup(poses, rel)[0], meas)
    np.testing.assert_allclose(costs[cells, heads], direct, rtol=1e-4)
    # and the pose nearest the truth is among the best of the lattice
    best = np.unravel_index(np.argmin(costs), costs.shape)
    assert np.hypot(*(lattice.xy[best[0]] - [30.0, 70.0])) <= 4.0


def test_scan_readings_keep_no_echo_and_drop_stuck() -> None:
    lik = BeamLikelihood(NxtSonar())
    r = _map1_sweep(360)
    silent = int(np.sum(r[50:] == NO_ECHO))
    r[0:50] = NO_ECHO
    r[100:170] = 33.0
    _, meas, weighted = scan_readings(Scan.from_readings(default_scan_angles(), r), lik, load_map("map1"))
    assert meas.size == 290 and np.sum(meas == NO_ECHO) == 50 + silent
    assert weighted.weight == pytest.approx(NxtSonar().reading_weight(math.radians(1.0)))


def test_exact_ranges_match_table_on_the_arena() -> None:
    """The localisers' expected echoes (table) agree with the sonar's own lobe casting."""
    m = real_nxt_arena()
    model = NxtSonar()
    rel = default_scan_angles(36)
    pose = np.array([[120.0, 60.0, 0.3]])
    sensor = np.asarray(model.echo_distance(m.walls, pose[0, :2], pose[0, 2] + rel), dtype=float)
    cast = exact_ranges(m, pose, rel, beam_width_deg=model.beam_width_deg, beam_rays=model.beam_rays,
                        critical_incidence_deg=model.critical_incidence_deg)[0]
    np.testing.assert_allclose(cast, sensor, rtol=1e-9)


def test_default_is_the_shipped_fitted_profile() -> None:
    from conftest import REAL_NXT

    from toolkit.real_sonar.fit import load_sonar_profile

    assert load_sonar_profile(REAL_NXT / "sonar-profiles" / "nxt-fitted.yaml") == NxtSonar()
    assert NxtSonar() != NxtSonar.hardware_facts()
