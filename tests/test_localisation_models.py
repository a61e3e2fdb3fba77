"""Motion and measurement models: simulator semantics, range table, FFT lattice, log-space likelihood."""

from __future__ import annotations

import math

import numpy as np
import pytest

from localisation.base import Motion
from localisation.models import MotionModel, RangeLikelihood, exact_ranges, range_lattice, range_table
from localisation.resampling import log_normalise
from toolkit.robots.sim import MotionNoise, SimRobot
from toolkit.world import Pose, angle_diff, load_map, ray_cast


@pytest.mark.parametrize("model,motion,turn", [("botsim", 0.1, 0.005), ("absolute", 0.5, 0.02)])
def test_motion_model_matches_simulator(model: str, motion: float, turn: float) -> None:
    """Sampled end poses have the simulator's spread (independent ground truth: SimRobot)."""
    m = load_map("map1")
    start = Pose(25.0, 85.0, 0.3)  # the drive ends 14 cm from the nearest wall: no collision truncates it
    act = Motion(turn_rad=-0.8, distance_cm=25.0)
    sim_end = []
    robot = SimRobot(m, start, noise=MotionNoise(model, motion, turn), rng=1)  # type: ignore[arg-type]
    for _ in range(400):
        robot.teleport(start)
        robot.turn(act.turn_rad)
        robot.move(act.distance_cm)
        sim_end.append(robot.true_pose.as_array())
    sim = np.array(sim_end)
    assert robot.collisions == 0 and robot.watchdog_stops == 0  # the motion model knows no walls
    mm = MotionModel(model, motion, turn)
    ours = mm.sample(np.tile(start.as_array(), (4000, 1)), act, rng=2)
    for k in range(2):
        assert abs(ours[:, k].mean() - sim[:, k].mean()) < 0.5
        assert ours[:, k].std() == pytest.approx(sim[:, k].std(), rel=0.2)
    dth_o = angle_diff(ours[:, 2], start.theta + act.turn_rad)
    dth_s = angle_diff(sim[:, 2], start.theta + act.turn_rad)
    assert np.std(dth_o) == pytest.approx(np.std(dth_s), rel=0.2)
    # the linearised covariance agrees with the samples
    cov = mm.covariance(start.as_array(), act)
    assert math.sqrt(cov[0, 0] + cov[1, 1]) == pytest.approx(math.sqrt(ours[:, 0].var() + ours[:, 1].var()), rel=0.15)


def test_motion_model_rejects_unknown_noise_model() -> None:
    with pytest.raises(ValueError, match="noise model"):
        MotionModel("gaussian")


@pytest.mark.parametrize("name", ["map1", "map3"])
def test_range_table_agrees_with_ray_casting(name: str) -> None:
    m = load_map(name)
    table = range_table(m)
    rng = np.random.default_rng(0)
    xy = m.sample_free(200, 8.0, rng)
    poses = np.column_stack([xy, rng.uniform(-math.pi, math.pi, 200)])
    rel = np.radians(np.arange(0, 360, 7.0))
    got, inside = table.lookup(poses, rel)
    exact = exact_ranges(m, poses, rel)
    assert inside.all()
    err = np.abs(got - exact)
    assert np.median(err) < 0.6  # nearest cell (1 cm) and nearest degree
    assert np.mean(err < 3.0) > 0.97  # large errors only at range discontinuities (corners)


def test_exact_lobe_ranges_are_the_nxt_sonars_echoes() -> None:
    """With a lobe, `exact_ranges` is the noise-free reading of `NxtSonar` (same rays, same specular
    loss; rays shared by neighbouring beams are cast once, so equal to a nanometre rather than
    bit for bit), and a range limit only removes echoes beyond it."""
    from toolkit.world import NxtSonar

    m = load_map("map2")
    rng = np.random.default_rng(4)
    xy = m.sample_free(150, 8.0, rng)
    poses = np.column_stack([xy, rng.uniform(-math.pi, math.pi, 150)])
    rel = np.radians(np.r_[np.arange(0, 360, 11.0), np.arange(80.0, 111.0)])  # a window of shared rays
    sonar = NxtSonar(beam_width_deg=20.0, beam_rays=9, critical_incidence_deg=40.0)
    want = sonar.echo_distance(m.walls, poses[:, :2], poses[:, 2:3] + rel[None, :])
    got = exact_ranges(m, poses, rel, beam_width_deg=20.0, beam_rays=9, critical_incidence_deg=40.0)

    def same(a: np.ndarray, b: np.ndarray) -> bool:
        fin = np.isfinite(b)
        return bool(np.array_equal(np.isfinite(a), fin) and np.allclose(a[fin], b[fin], rtol=0.0, atol=1e-7))

    assert same(got, want)
    assert np.isinf(got).any() and np.isfinite(got).any()  # specular loss happens, echoes too
    near = exact_ranges(m, poses, rel, beam_width_deg=20.0, beam_rays=9, critical_incidence_deg=40.0,
                        max_range_cm=40.0)
    assert same(near, np.where(want <= 40.0, want, np.inf))
    # without specular loss every ray echoes: the lobe reads no farther than its middle ray
    wide = exact_ranges(m, poses, rel, beam_width_deg=20.0, beam_rays=9)
    assert np.isfinite(wide).all() and np.all(wide <= exact_ranges(m, poses, rel) + 1e-9)


def test_lattice_ssd_equals_direct_sum() -> None:
    m = load_map("map2")
    table = range_table(m)
    lat = range_lattice(table, step=3, clearance_cm=5.0)
    rng = np.random.default_rng(1)
    rel = np.radians(rng.choice(360, size=50, replace=False).astype(float))
    meas = rng.uniform(5, 80, size=50)
    ssd = lat.ssd(rel, meas)
    for _ in range(20):
        c, h = int(rng.integers(len(lat))), int(rng.integers(360))
        pose = np.array([[*lat.xy[c], math.radians(h)]])
        e, _ = table.lookup(pose, rel)
        assert ssd[c, h] == pytest.approx(float(np.sum((e[0] - meas) ** 2)), rel=1e-6, abs=1e-3)


def test_log_space_weights_survive_360_beams() -> None:
    lik = RangeLikelihood(sigma_cm=1.0, cap=5.0)
    meas = np.full(360, 50.0)
    expected = np.vstack([np.full(360, 53.0), np.full(360, 53.2), np.full(360, 80.0)])
    ll = lik.log_likelihood(expected, meas)
    assert np.all(np.isfinite(ll))
    assert np.all(np.exp(ll) == 0.0)  # the likelihoods themselves underflow...
    w = log_normalise(ll)  # ...but the normalised weights are exact
    assert w.sum() == pytest.approx(1.0)
    assert w[0] == pytest.approx(1.0) and w[1] > 0.0
    assert w[1] == pytest.approx(math.exp(ll[1] - ll[0]), rel=1e-9)
    # the cap bounds one beam's cost
    assert ll[2] == pytest.approx(-0.5 * 360 * 25.0)


def test_lobe_table_with_specular_loss_matches_nxt_sonar() -> None:
    """The expected ranges for a wide sonar agree with toolkit.world's NxtSonar (noise-free echoes)."""
    from toolkit.world import NxtSonar

    m = load_map("map2")
    sonar = NxtSonar()
    table = range_table(m, beam_width_deg=sonar.beam_width_deg, critical_incidence_deg=sonar.critical_incidence_deg)
    thin = range_table(m)
    rng = np.random.default_rng(4)
    xy = m.sample_free(40, 8.0, rng)
    rel = np.radians(np.arange(0.0, 360.0, 3.0))
    poses = np.column_stack([xy, rng.uniform(-math.pi, math.pi, 40)])
    echo = np.asarray(sonar.echo_distance(m.walls, xy, poses[:, 2:3] + rel[None, :]))
    got, _ = table.lookup(poses, rel)
    flat, _ = thin.lookup(poses, rel)
    both = np.isfinite(echo) & np.isfinite(got)
    assert np.mean(np.isfinite(echo) == np.isfinite(got)) > 0.95
    err = np.abs(got[both] - echo[both])
    assert np.median(err) < 0.6 and np.mean(err < 3.0) > 0.95
    # the thin-ray table is a much worse model of this sonar
    thin_err = np.abs(flat[both] - echo[both])
    assert np.mean(thin_err < 3.0) < np.mean(err < 3.0) - 0.05


def test_range_table_fits_its_memory_budget() -> None:
    """A budget too small for 1 cm float32 cells gives uint16 ranges, then coarser cells; never more memory."""
    from localisation.models import plan_range_table

    m = load_map("map1")
    full = range_table(m, memory_mb=64)
    assert full.dtype == "float32" and full.resolution_cm == 1.0
    budget = full.nbytes * 0.6 / 2**20  # uint16 at 1 cm fits, float32 does not
    half = range_table(m, memory_mb=budget)
    assert half.dtype == "uint16" and half.resolution_cm == 1.0 and half.nbytes <= budget * 2**20
    rows = np.arange(0, len(full.centres), 97)
    a, b = full.decode(rows), half.decode(rows)
    assert np.array_equal(np.isinf(a), np.isinf(b))
    assert np.max(np.abs(a[np.isfinite(a)] - b[np.isfinite(b)])) <= half.quantum_cm / 2 + 1e-4
    coarse = range_table(m, memory_mb=budget / 3)
    assert coarse.resolution_cm > 1.0 and coarse.nbytes <= budget / 3 * 2**20
    plan = plan_range_table(m, 360, int(budget / 3 * 2**20))
    assert plan.resolution_cm == coarse.resolution_cm and plan.dtype == coarse.dtype


@pytest.mark.parametrize("memory_mb", [0.0, -5.0, 0.01])
def test_range_table_budget_errors_name_the_option(memory_mb: float) -> None:
    from toolkit.world import ConfigError

    with pytest.raises(ConfigError, match="--range-memory-mb") as err:
        range_table(load_map("map1"), memory_mb=memory_mb)
    assert "\n" not in str(err.value)


def test_range_table_budget_from_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    from localisation.models import range_memory_budget
    from toolkit.world import ConfigError

    monkeypatch.setenv("NXTNAV_RANGE_MEMORY_MB", "2")
    assert range_memory_budget() == 2 * 2**20
    assert range_memory_budget(3) == 3 * 2**20
    monkeypatch.setenv("NXTNAV_RANGE_MEMORY_MB", "lots")
    with pytest.raises(ConfigError, match="NXTNAV_RANGE_MEMORY_MB"):
        range_memory_budget()


def test_coarse_table_interpolates_between_cells() -> None:
    """A 2 cm table (a map under a budget) reads between cell centres: nearer the exact ranges than its cells."""
    m = load_map("map1")
    table = range_table(m, resolution_cm=2.0)
    assert table.resolution_cm == 2.0
    rng = np.random.default_rng(8)
    xy = m.sample_free(300, clearance=10.0, rng=rng)
    poses = np.column_stack([xy, rng.uniform(-np.pi, np.pi, 300)])
    rel = np.radians(np.arange(0, 360, 30, dtype=float))
    k = np.rint((poses[:, 2:3] + rel[None, :]) / (2 * np.pi / table.n_angles)) * (2 * np.pi / table.n_angles)
    exact = ray_cast(m.walls, xy, k).astype(np.float32)  # along the table's directions
    got, inside = table.lookup(poses, rel)
    nearest = np.take_along_axis(table.decode(table.cells(xy)),
                                 np.mod(np.rint(k / (2 * np.pi / table.n_angles)), table.n_angles).astype(int), 1)
    assert inside.all()
    ok = np.isfinite(exact)
    assert np.median(np.abs(got - exact)[ok]) < 0.5 * np.median(np.abs(nearest - exact)[ok])
