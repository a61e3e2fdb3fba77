"""`amcl`: KLD-sampling, augmented-MCL recovery, the likelihood field and the beam model."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from localisation import LOCALISERS, Motion, Prior, localise, make_localiser
from localisation.amcl import Amcl, DistanceField, kld_bound
from localisation.amcl_models import MEASUREMENT_MODELS, BeamModel, LikelihoodFieldModel, MeasurementModel
from localisation.models import exact_ranges
from localisation.scan import process_scan
from toolkit.robots.sim import SimRobot
from toolkit.world import ConfigError, NxtSonar, Pose, angle_diff, load_map


def _expected(a: Amcl, poses: np.ndarray, rel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The beam model's expected ranges of amcl `a` (N, B) and the poses inside its table."""
    assert isinstance(a.measurement, BeamModel)
    return a.measurement.expected_ranges(poses, rel)


def _scan(m, pose: Pose, seed: int = 0):  # type: ignore[no-untyped-def]
    return process_scan(SimRobot(m, pose, rng=seed).ultrascan(), reference="min").scan


def test_registered_with_nav2_defaults() -> None:
    assert LOCALISERS.get("amcl") is Amcl
    a = make_localiser("amcl", load_map("map1"), rng=0)
    assert isinstance(a, Amcl)
    assert (a.min_particles, a.max_particles, a.pf_err, a.pf_z) == (150, 2000, 0.05, 0.99)
    assert (a.alpha_slow, a.alpha_fast) == (0.001, 0.1)
    assert a.model == "field"
    assert make_localiser("amcl", load_map("map1"), rng=0, beam_width_deg=20.0).model == "beam"


@pytest.mark.parametrize("bad", [{"model": "sonar"}, {"min_particles": 0}, {"min_particles": 3000},
                                 {"pf_err": 0.0}, {"recovery_alpha_fast": 2.0}, {"recovery_sampler": "x"},
                                 {"refine_steps": -1}, {"refine_particles": 0}, {"ambiguity_injection": 2.0},
                                 {"lobe_rays": 1}, {"lobe_rays": -3}])
def test_bad_options_are_refused(bad: dict[str, object]) -> None:
    with pytest.raises(ValueError):
        Amcl(load_map("map1"), rng=0, **bad)  # type: ignore[arg-type]


def test_kld_bound_is_fox_formula() -> None:
    k = np.array([1, 2, 5, 50, 400])
    z, eps = 0.99, 0.05
    km1 = np.maximum(k - 1, 1)
    expected = np.ceil(km1 / (2 * eps) * (1 - 2 / (9 * km1) + np.sqrt(2 / (9 * km1)) * z) ** 3)
    expected[0] = 0
    assert np.array_equal(kld_bound(k, eps, z), expected.astype(int))
    assert np.all(np.diff(kld_bound(np.arange(1, 500), eps, z)) >= 0)


def test_distance_field_matches_exact_distances(botsim_map) -> None:  # type: ignore[no-untyped-def]
    field = DistanceField(botsim_map, resolution_cm=0.5, max_dist_cm=1e6)
    rng = np.random.default_rng(1)
    xmin, ymin, xmax, ymax = botsim_map.bounds
    pts = rng.uniform([xmin - 5, ymin - 5], [xmax + 5, ymax + 5], size=(3000, 2))
    exact = shapely.distance(shapely.points(pts), shapely.multilinestrings(botsim_map.walls.reshape(-1, 2, 2)))
    inside = (pts[:, 0] >= xmin) & (pts[:, 0] <= xmax) & (pts[:, 1] >= ymin) & (pts[:, 1] <= ymax)
    got = field(pts)
    err = np.abs(got - exact)[inside]
    # bilinear interpolation of a 1-Lipschitz function: at most the cell diagonal, usually far less
    assert inside.sum() > 2000 and err.max() <= 0.5 * math.sqrt(2) + 1e-9
    assert np.median(err) < 0.05
    # outside the grid: the nearest node's distance plus the way to it, an upper bound
    assert np.all(got[~inside] >= exact[~inside] - 0.5 * math.sqrt(2))


def test_kld_count_follows_the_spread() -> None:
    m = load_map("map1")
    truth = Pose(30.0, 30.0, 0.4)
    scan = _scan(m, truth)
    tight = Amcl(m, rng=1, min_particles=20)
    tight.reset(Prior(truth, np.diag([0.01, 0.01, 1e-5])))
    tight.update(scan)
    flat = Amcl(m, rng=1, min_particles=20, sigma_hit=1000.0)  # an uninformative scan keeps the cloud wide
    flat.reset(Prior(truth, np.diag([400.0, 400.0, 1.0])))
    flat.update(scan)
    assert tight.particle_counts[-1] < 100
    assert flat.particle_counts[-1] > 1000


def test_same_seed_same_estimates() -> None:
    m = load_map("map2")
    scan = _scan(m, Pose(40.0, 20.0, 1.0))
    out = []
    for _ in range(2):
        a = make_localiser("amcl", m, rng=7)
        a.reset()
        a.update(scan)
        a.predict(Motion(0.3, 2.0))
        out.append(a.estimate().pose.as_array())
    assert np.array_equal(out[0], out[1])


@pytest.mark.parametrize("model", ["field", "beam"])
def test_global_localisation_with_the_procedure(model: str) -> None:
    m = load_map("map1")
    truth = Pose(25.0, 80.0, -2.0)
    robot = SimRobot(m, truth, rng=3)
    res = localise(robot, make_localiser("amcl", m, rng=3, model=model), rng=3)
    assert res.converged
    assert res.estimate.pose.distance_to(robot.true_pose) < 2.0


def _kidnap(seed: int = 5, **options: object) -> tuple[Amcl, Pose]:
    """Track at A for four scans, then feed scans taken at B, 50 cm away; returns the localiser and B."""
    m = load_map("map1")
    a_pose, b_pose = Pose(25.0, 25.0, 0.5), Pose(80.0, 80.0, -2.5)
    loc = Amcl(m, rng=seed, **options)  # type: ignore[arg-type]
    loc.reset(Prior(a_pose, np.diag([1.0, 1.0, 1e-3])))
    for k in range(4):
        loc.predict(Motion(0.0, 0.0))
        loc.update(_scan(m, a_pose, k))
    for k in range(12):
        loc.update(_scan(m, b_pose, 100 + k))
    return loc, b_pose


def test_augmented_mcl_recovers_from_a_kidnapping() -> None:
    loc, b = _kidnap()
    assert loc.injected > 0
    assert loc.estimate().pose.distance_to(b) < 2.0


def test_without_recovery_the_kidnapped_filter_stays_lost() -> None:
    loc, b = _kidnap(recovery_alpha_slow=0.0)
    assert loc.injected == 0
    assert loc.estimate().pose.distance_to(b) > 20.0


def test_beam_interpolation_follows_exact_ranges() -> None:
    m = load_map("map1")
    poses = np.column_stack([m.sample_free(300, clearance=10.0, rng=1), np.random.default_rng(2).uniform(-3, 3, 300)])
    rel = np.radians(np.arange(0.0, 360.0, 7.0))
    exact = exact_ranges(m, poses, rel)
    errors = []
    for interpolate in (True, False):
        expected, inside = _expected(Amcl(m, rng=0, model="beam", beam_interpolation=interpolate), poses, rel)
        assert inside.all()
        errors.append(np.median(np.abs(expected - exact)[np.isfinite(exact)]))
    # the nearest 1 cm cell and 1-degree direction are off by ~0.3 cm; trilinear interpolation far less
    assert errors[0] < 0.05 < errors[1]


def test_lobe_readings_follow_the_nxt_sonar() -> None:
    m = load_map("map1")
    rng = np.random.default_rng(3)
    poses = np.column_stack([m.sample_free(150, clearance=10.0, rng=rng), rng.uniform(-math.pi, math.pi, 150)])
    rel = np.radians(np.arange(0.0, 360.0, 3.0))
    lobe = NxtSonar.hardware_facts(beam_rays=161)  # a near-continuous 20-degree lobe, specular loss beyond 40
    sensor = lobe.echo_distance(m.walls, poses[:, :2], poses[:, 2:3] + rel[None, :])
    off = {}
    for edges in (True, False):
        a = Amcl(m, rng=0, beam_width_deg=20.0, critical_incidence_deg=40.0, lobe_rays=21 if edges else 0)
        expected, inside = _expected(a, poses, rel)
        assert inside.all()
        with np.errstate(invalid="ignore"):
            agree = (np.abs(expected - sensor) <= 1.0) | (np.isinf(expected) & np.isinf(sensor))
        off[edges] = float(np.mean(~agree))
    # the table's lobe interpolated between directions misses ~1 % of the readings by more than 1 cm
    assert off[True] < 0.006 and off[True] < off[False] / 2


def test_a_wall_entering_the_lobe_edge_steps_the_reading() -> None:
    # map1, a pose 12 cm from a wall whose end enters the lobes of beams 346-349 degrees at their edge
    m = load_map("map1")
    pose = np.array([[32.96, 46.21, -0.02475]])
    rel = np.radians([345.0, 346.0, 347.0, 348.0, 349.0, 350.0])
    sensor = NxtSonar.hardware_facts(beam_rays=161).echo_distance(m.walls, pose[:, :2], pose[:, 2:3] + rel[None, :])[0]
    kw = {"beam_width_deg": 20.0, "critical_incidence_deg": 40.0}
    edges = _expected(Amcl(m, rng=0, **kw), pose, rel)[0][0]  # type: ignore[arg-type]
    smeared = _expected(Amcl(m, rng=0, lobe_rays=0, **kw), pose, rel)[0][0]  # type: ignore[arg-type]
    assert np.all(sensor[1:] < 12.5)
    assert np.allclose(edges, sensor, atol=0.1)
    assert np.max(np.abs(smeared - sensor)) > 2.0


def test_a_new_fix_is_refined_on_its_scan() -> None:
    errors = {}
    for steps in (0, 12):
        errs = []
        for seed in range(3):
            loc, b = _kidnap(refine_steps=steps, seed=seed)
            est = loc.estimate()
            errs.append(est.pose.distance_to(b) + abs(math.degrees(float(angle_diff(est.pose.theta, b.theta)))) / 3)
        errors[steps] = max(errs)
    # unrefined, the fresh particles that took over collapse onto the one nearest the truth, and stay
    assert errors[12] < 0.5 < errors[0]


def test_scans_update_only_after_update_min_d_or_a() -> None:
    """nav2's update thresholds: a scan taken before the robot drove `update_min_d` or turned `update_min_a`
    since the last update leaves the belief where the motion put it; one taken after updates it."""
    m = load_map("map2")
    truth = Pose(40.0, 20.0, 1.0)
    prior = Prior(Pose(42.0, 19.0, 1.05), np.diag([9.0, 9.0, math.radians(5.0) ** 2]))
    a = make_localiser("amcl", m, rng=3, update_min_d=5.0, update_min_a=0.3)
    a.reset(prior)
    a.update(_scan(m, truth))
    first = a.estimate().pose.as_array()
    a.predict(Motion(0.1, 2.0))  # 2 cm and 0.1 rad: under both thresholds
    moved = a.estimate().pose.as_array()
    a.update(_scan(m, Pose(*_after(truth, 0.1, 2.0)), seed=1))
    assert np.array_equal(a.estimate().pose.as_array(), moved)
    assert not np.array_equal(moved, first)
    a.predict(Motion(0.0, 4.0))  # 6 cm since the last update: over update_min_d
    before = a.estimate().pose.as_array()
    a.update(_scan(m, Pose(*_after(truth, 0.1, 6.0)), seed=2))
    assert not np.array_equal(a.estimate().pose.as_array(), before)
    b = make_localiser("amcl", m, rng=3)  # the defaults (0, 0): every scan updates
    b.reset(prior)
    b.update(_scan(m, truth))
    b.predict(Motion(0.1, 2.0))
    kept = b.estimate().pose.as_array()
    b.update(_scan(m, Pose(*_after(truth, 0.1, 2.0)), seed=1))
    assert not np.array_equal(b.estimate().pose.as_array(), kept)


def _after(pose: Pose, turn: float, distance: float) -> tuple[float, float, float]:
    """Where a noise-free turn and drive take `pose`."""
    th = pose.theta + turn
    return pose.x + distance * math.cos(th), pose.y + distance * math.sin(th), th


# -- measurement models, registered by name and chosen once ------------------------------------------------
def test_the_model_is_chosen_once_by_name_and_an_unknown_one_lists_the_known() -> None:
    m = load_map("map1")
    assert type(Amcl(m, rng=0).measurement) is LikelihoodFieldModel
    nxt = Amcl(m, rng=0, sonar_model=NxtSonar())
    assert nxt.model == "nxt-beam" and nxt.model == Amcl(m, rng=0, model="beam", sonar_model=NxtSonar()).model
    with pytest.raises(ConfigError, match=r"amcl model must be one of auto, beam, field, nxt-beam, got 'sonar'$"):
        Amcl(m, rng=0, model="sonar")
    with pytest.raises(ConfigError, match="the likelihood field cannot use a sonar_model"):
        Amcl(m, rng=0, model="field", sonar_model=NxtSonar())
    with pytest.raises(ConfigError, match="the NXT beam model needs a sonar_model"):
        Amcl(m, rng=0, model="nxt-beam")


class _Flat(MeasurementModel):
    """A model of one's own: every free pose explains every scan alike (the belief follows the odometry)."""

    title = "flat model"

    def log_likelihood(self, poses: np.ndarray, rel: np.ndarray, meas: np.ndarray) -> np.ndarray:
        return np.where(self.free(poses[:, :2], 0.0), 0.0, -np.inf)


_Flat.name = "flat"  # set after the body: registered only inside `added`


def test_a_registered_model_of_ones_own_weighs_the_scans() -> None:
    m = load_map("map1")
    start = Pose(20.0, 20.0, 0.0)
    prior = Prior(start, np.diag([9.0, 9.0, 0.01]))
    with MEASUREMENT_MODELS.added({"flat": _Flat}):
        flat = Amcl(m, rng=0, model="flat", recovery_alpha_slow=0.0, refine_steps=0, ambiguity_nats=0.0)
        flat.reset(prior)
        flat.update(_scan(m, start))
        assert flat.model == "flat" and flat.iterations == 1
        spread = float(np.sqrt(np.trace(np.cov(flat.particles[:, :2].T))))
        assert spread > 2.0  # the scan did not narrow the cloud, as the field model would
        field = Amcl(m, rng=0, recovery_alpha_slow=0.0, refine_steps=0, ambiguity_nats=0.0)
        field.reset(prior)
        field.update(_scan(m, start))
        assert float(np.sqrt(np.trace(np.cov(field.particles[:, :2].T)))) < spread
    with pytest.raises(ConfigError, match="must be one of auto, beam, field, nxt-beam, got 'flat'"):
        Amcl(m, rng=0, model="flat")  # gone with its block


def test_an_ambiguous_first_fix_draws_fresh_particles_from_the_sweep() -> None:
    """A real sweep at (180, 30) fits the arena turned by 90 degrees better: amcl's first fix (not
    converged) lists both places among its candidates, and its resampling draws fresh particles from
    the sweep, as for an ambiguous converged fix, so that the next sweep can still weigh the true place
    (before, the heaviest candidate kept every particle; along real routes the true place was lost)."""
    from conftest import REAL_NXT

    from localisation.ambiguity import candidate_poses, truth_among
    from localisation.robot_options import localiser_options
    from toolkit.real_sonar.sweeps import load_sweep_set
    from toolkit.world import RobotModel

    sweeps = load_sweep_set(REAL_NXT)
    sweep = sweeps.at(180.0, 30.0)[0]
    loc = make_localiser("amcl", sweeps.map, rng=0,
                         **localiser_options("amcl", RobotModel(NxtSonar(), readings="real")))
    loc.reset(None)
    loc.update(sweep.scan())
    assert not loc.estimate().converged and truth_among(candidate_poses(loc), 180.0, 30.0)
    assert loc.estimate().pose.distance_to(Pose(180.0, 30.0, 0.0)) > 100.0  # the twin is the estimate
    assert loc.injected > 0


def test_a_first_fix_drawn_from_the_sweep_gives_each_place_its_posterior_mass() -> None:
    """The sweep at (126, 168) leaves three places; the exact posterior on the lattice (`grid`) gives
    them about 0.57 / 0.32 / 0.11. amcl draws its first particles from the sweep's tempered lattice
    likelihood, so each must be weighed by the likelihood over the probability of its draw: weighed by
    the likelihood alone, the places' masses were those of the likelihood squared (0.82 / 0.16 / 0.03),
    and along real routes the heaviest place outweighed the true one the second sweep pointed to."""
    from conftest import REAL_NXT

    from localisation.clusters import cluster
    from localisation.robot_options import localiser_options
    from toolkit.real_sonar.sweeps import load_sweep_set
    from toolkit.world import RobotModel

    sweeps = load_sweep_set(REAL_NXT)
    scan = sweeps.at(126.0, 168.0)[0].scan()
    robot = RobotModel(NxtSonar(), readings="real")

    def places(name: str) -> list[tuple[float, float, float]]:
        """The three heaviest places (20 cm, 30 degrees) of the belief after the sweep: (mass, x, y)."""
        loc = make_localiser(name, sweeps.map, rng=0, **localiser_options(name, robot))
        loc.reset(None)
        loc.update(scan)
        cloud = loc.cloud()
        assert cloud is not None
        p, w = cloud
        with np.errstate(divide="ignore"):
            labels, log_mass = cluster(p, np.log(w), 20.0, math.radians(30.0), 6)
        out = []
        for k in np.argsort(-log_mass)[:3]:
            at = labels == k
            x, y = np.average(p[at, :2], axis=0, weights=w[at])
            out.append((float(np.exp(log_mass[k])), float(x), float(y)))
        return out

    exact, drawn = places("grid"), places("amcl")
    assert exact[0][0] < 0.75 and exact[2][0] > 0.05  # three places that matter
    for mass, x, y in exact:
        match = [m for m, px, py in drawn if math.hypot(px - x, py - y) < 10.0]
        assert match and abs(match[0] - mass) < 0.1, (exact, drawn)
