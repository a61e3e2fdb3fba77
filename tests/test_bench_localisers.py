"""The localiser benchmark: CSV layout, success against the simulator's truth, scenarios, CLI errors.

The plumbing is checked with two test-only localisers that read the simulator's true pose (which a
real localiser never sees): ``test-oracle`` reports the truth shifted by a fixed offset, so its
success is known in advance; ``test-dead-reckoning`` starts at the truth and only integrates the
commanded motions, so it cannot notice a kidnapping. They are registered for one test at a time
(`LOCALISERS.added`) so that tests parametrised over the registry never see them.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
from conftest import run_cli

import toolkit.robots.sim as sim
from localisation.base import LOCALISERS, Localiser, Motion, PoseEstimate, Prior
from toolkit.bench import localisers as bench
from toolkit.seeds import derive_seed
from toolkit.world import FACETS, Map, Pose, Scan, angle_diff, load_map, wrap_angle

_ROBOTS: list[sim.SimRobot] = []


_IGNORES_THE_ROBOT = {facet: "a test double reads the simulator, not the robot model" for facet in FACETS}


class _Oracle(Localiser):
    """The simulator's true pose moved `offset_cm` along +x and turned by `offset_deg`."""

    robot_options = _IGNORES_THE_ROBOT
    offset_cm: ClassVar[float] = 1.5
    offset_deg: ClassVar[float] = 2.5

    def __init__(self, map: Map, *, rng: Any = None) -> None:
        super().__init__(map, rng=rng)
        self.robot = _ROBOTS[-1]
        self.iterations = 0

    def reset(self, prior: Prior | None = None) -> None:
        self.iterations = 0

    def predict(self, motion: Motion) -> None:
        pass

    def update(self, scan: Scan) -> None:
        self.iterations += 1

    def estimate(self) -> PoseEstimate:
        t = self.robot.true_pose
        pose = Pose(t.x + self.offset_cm, t.y, t.theta + math.radians(self.offset_deg))
        return PoseEstimate(pose, np.eye(3) * 1e-4, True, self.iterations)


class _FarOracle(_Oracle):
    offset_cm = 2.5
    offset_deg = 0.0


class _TurnedOracle(_Oracle):
    offset_cm = 0.0
    offset_deg = -3.5


class _DeadReckoning(Localiser):
    """Starts at the true pose and integrates the commanded motions; never looks at a scan."""

    robot_options = _IGNORES_THE_ROBOT

    def __init__(self, map: Map, *, rng: Any = None) -> None:
        super().__init__(map, rng=rng)
        self.robot = _ROBOTS[-1]
        self.pose = self.robot.true_pose
        self.iterations = 0

    def reset(self, prior: Prior | None = None) -> None:
        self.pose = self.robot.true_pose
        self.iterations = 0

    def predict(self, motion: Motion) -> None:
        th = wrap_angle(self.pose.theta + motion.turn_rad)
        self.pose = Pose(self.pose.x + motion.distance_cm * math.cos(th),
                         self.pose.y + motion.distance_cm * math.sin(th), th)

    def update(self, scan: Scan) -> None:
        self.iterations += 1

    def estimate(self) -> PoseEstimate:
        return PoseEstimate(self.pose, np.eye(3) * 1e-4, True, self.iterations)


class _PriorRecorder(_DeadReckoning):
    """A pose tracker (needs a prior) that reports its prior's mean and remembers it."""

    needs_prior = True
    priors: ClassVar[list[Prior | None]] = []

    def reset(self, prior: Prior | None = None) -> None:
        type(self).priors.append(prior)
        if prior is None:
            raise AssertionError("a tracker must get a prior")
        self.pose = prior.mean
        self.iterations = 0


class _Broken(_Oracle):
    """Raises on its second update (a numerical failure in the middle of a run)."""

    def update(self, scan: Scan) -> None:
        super().update(scan)
        if self.iterations >= 2:
            raise np.linalg.LinAlgError("matrix is not positive definite")


TEST_LOCALISERS = {
    "test-oracle": _Oracle,
    "test-oracle-far": _FarOracle,
    "test-oracle-turned": _TurnedOracle,
    "test-dead-reckoning": _DeadReckoning,
    "test-tracker": _PriorRecorder,
    "test-broken": _Broken,
}


@pytest.fixture
def oracles(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Register the test localisers and record every SimRobot built, for this test only."""
    for name, cls in TEST_LOCALISERS.items():
        monkeypatch.setattr(cls, "name", name, raising=False)  # not in the class body: that would register it
    original = sim.SimRobot.__init__

    def recording_init(self: sim.SimRobot, *args: Any, **kwargs: Any) -> None:
        original(self, *args, **kwargs)
        _ROBOTS.append(self)

    monkeypatch.setattr(sim.SimRobot, "__init__", recording_init)  # the oracles read the truth of the last robot
    with LOCALISERS.added(TEST_LOCALISERS):
        yield list(TEST_LOCALISERS)
    _ROBOTS.clear()
    _PriorRecorder.priors.clear()


def rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        return list(reader.fieldnames or []), list(reader)


# -- success criterion ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("err", "herr", "ok"),
    [(0.0, 0.0, True), (2.0, 3.0, True), (2.0, -3.0, True), (2.001, 0.0, False), (0.0, 3.001, False),
     (0.0, -3.5, False), (math.nan, 0.0, False)],
)
def test_success_is_2cm_and_3deg(err: float, herr: float, ok: bool) -> None:
    assert bench.is_success(err, herr) is ok


def test_trial_seeds_do_not_depend_on_localiser_or_map_order() -> None:
    cfg = bench.BenchConfig()
    a = bench.make_tasks("global", ["map1", "map2"], ["paper-pf"], 3, 7, cfg)
    b = bench.make_tasks("global", ["map2", "map1"], [], 3, 7, cfg)
    assert not b  # no localiser, no task
    seeds = {(t.map, t.trial): t.seed for t in a}
    for t in range(3):
        assert derive_seed(7, "map1", t) == derive_seed(7, "map1", t)
        assert derive_seed(7, "map1", t) != derive_seed(8, "map1", t)
        if seeds:
            assert seeds[("map1", t)] == derive_seed(7, "map1", t)
    m = load_map("map3")
    poses = [m.random_pose(np.random.default_rng(s), 10.0) for s in range(200)]
    xy = np.array([p.xy for p in poses])
    assert np.all(m.contains(xy)) and np.min(m.wall_distance(xy)) >= 10.0 - 1e-9


# -- the global scenario through the CLI ----------------------------------------------------------


def test_global_runs_csv_success_against_truth(tmp_path: Path, oracles: list[str]) -> None:
    out = tmp_path / "bench"
    locs = "test-oracle,test-oracle-far,test-oracle-turned"
    assert run_cli(["bench", "localisers", "--maps", "map1,map3", "--localisers", locs, "--trials", "3",
                "--seed", "5", "--out", str(out)]) == 0
    cols, data = rows(out / "runs.csv")
    assert tuple(cols) == bench.RUNS_COLUMNS
    assert len(data) == 2 * 3 * 3
    by = {(r["map"], r["localiser"], int(r["trial"])): r for r in data}
    assert len(by) == len(data)
    for (m, loc, t), r in by.items():
        assert int(r["seed"]) == derive_seed(5, m, t)
        err, herr = float(r["error_cm"]), float(r["heading_error_deg"])
        cls = TEST_LOCALISERS[loc]
        # the oracle's offset is measured against the simulator's truth at the end of the procedure
        assert err == pytest.approx(cls.offset_cm, abs=1e-6)
        assert herr == pytest.approx(cls.offset_deg, abs=1e-6)
        assert (r["success"] == "true") is (loc == "test-oracle")
        assert r["converged"] == "true"
        assert int(r["scans"]) >= 1 and int(r["iterations"]) >= 1 and float(r["time_s"]) > 0
    summary = (out / "summary.md").read_text()
    for m in ("map1", "map3"):
        assert f"### {m}" in summary
    assert "| test-oracle | 3 | 100.0 % |" in summary
    assert "| test-oracle-far | 3 | 0.0 % |" in summary
    for png in ("errors.png", "times.png", "success.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG"


def test_same_true_poses_for_every_localiser(tmp_path: Path, oracles: list[str]) -> None:
    cfg = bench.BenchConfig()
    starts: dict[tuple[str, int], list[Pose]] = {}
    for task in bench.make_tasks("global", ["map2"], ["test-oracle", "test-oracle-far"], 2, 3, cfg):
        n = len(_ROBOTS)
        bench.run_trial(task)
        first = _ROBOTS[n]
        starts.setdefault(("map2", task.trial), []).append(first.true_pose)
    assert all(len(v) == 2 for v in starts.values())


def test_non_empty_out_needs_force(tmp_path: Path, oracles: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    args = ["bench", "localisers", "--maps", "map1", "--localisers", "test-oracle", "--trials", "1", "--out", str(out)]
    assert run_cli(args) == 2
    err = capsys.readouterr().err
    assert "not empty" in err and len(err.strip().splitlines()) == 1
    assert not (out / "runs.csv").exists()
    assert run_cli([*args, "--force"]) == 0
    assert (out / "keep.txt").exists() and (out / "runs.csv").exists()


@pytest.mark.parametrize("kind", ["noisy-truth", "pf"])
def test_tracker_prior(kind: str, oracles: list[str]) -> None:
    m = load_map("map1")
    truth = Pose(80.0, 85.0, 0.5)
    cfg = bench.BenchConfig(tracker_prior=kind, prior_sd=(3.0, 5.0))
    out, robot, _ = bench.localise_once(m, truth, "test-tracker", config=cfg, rng=9)
    assert out.prior == kind
    priors = _PriorRecorder.priors
    assert len(priors) == 2  # the first look and the confirming one both start from the prior
    prior = priors[0]
    assert prior is not None and priors[1] is prior
    if kind == "noisy-truth":  # the start pose plus noise of the configured size
        assert prior.mean.distance_to(truth) < 5 * 3.0 * math.sqrt(2)
        assert np.sqrt(np.diag(prior.cov)) == pytest.approx([3.0, 3.0, math.radians(5.0)])
    else:  # paper-pf's estimate; its localisation and the tracker's left the robot where it was
        assert "paper-pf" in LOCALISERS
        assert robot.true_pose.distance_to(truth) < 1e-9
        assert prior.mean.distance_to(truth) < 2.0


def test_summary_says_how_trackers_were_initialised(tmp_path: Path, oracles: list[str]) -> None:
    for kind, needle in (("noisy-truth", "true pose plus Gaussian noise"), ("pf", "first estimate of a `paper-pf`")):
        out = tmp_path / kind
        assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "test-oracle,test-tracker",
                    "--trials", "1", "--tracker-prior", kind, "--out", str(out)]) == 0
        text = (out / "summary.md").read_text()
        assert "pose trackers (test-tracker)" in text and needle in text


# -- tracking and kidnapped scenarios ----------------------------------------------------------------


def test_tracking_scenario_rmse_against_truth(tmp_path: Path, oracles: list[str]) -> None:
    out = tmp_path / "t"
    assert run_cli(["bench", "localisers", "--maps", "map1,map2", "--localisers", "test-oracle,test-dead-reckoning",
                "--trials", "2", "--scenario", "tracking", "--tracking-steps", "6", "--out", str(out)]) == 0
    assert not (out / "runs.csv").exists()
    cols, data = rows(out / "tracking.csv")
    assert tuple(cols) == bench.TRACKING_COLUMNS
    assert len(data) == 2 * 2 * 2
    for r in data:
        assert int(r["steps"]) == 6
        if r["localiser"] == "test-oracle":  # exactly its offset after every action
            assert float(r["rmse_cm"]) == pytest.approx(1.5, abs=1e-6)
            assert float(r["rmse_heading_deg"]) == pytest.approx(2.5, abs=1e-6)
        else:  # dead reckoning drifts with the motion noise, and never below zero
            assert float(r["rmse_cm"]) > 0.0
        assert int(r["collisions"]) == 0
        # map1 and map2 are small: every scan has readings, so the RMSE with echo is the RMSE
        assert int(r["blind_steps"]) == 0 and float(r["rmse_echo_cm"]) == pytest.approx(float(r["rmse_cm"]))
    assert "## Tracking" in (out / "summary.md").read_text()
    assert (out / "tracking.png").exists()


def test_tracking_rows_count_particles_and_time_updates(tmp_path: Path) -> None:
    out = tmp_path / "p"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf,amcl,ekf", "--trials", "1",
                "--scenario", "tracking", "--tracking-steps", "4", "--set", "amcl.min_particles=50",
                "--out", str(out)]) == 0
    _, data = rows(out / "tracking.csv")
    got = {r["localiser"]: r for r in data}
    assert float(got["paper-pf"]["median_particles"]) == float(got["paper-pf"]["max_particles"]) == 1000
    # a tight tracking belief: KLD keeps amcl near its minimum, far below its 2000 maximum
    assert 50 <= float(got["amcl"]["median_particles"]) <= float(got["amcl"]["max_particles"]) < 2000
    assert float(got["ekf"]["max_particles"]) == 1
    assert all(float(r["update_ms"]) > 0 for r in data)
    assert "particles median / max" in (out / "summary.md").read_text()


def test_scripted_drive_is_collision_free_without_noise() -> None:
    m = load_map("map3")
    rng = np.random.default_rng(4)
    start = m.random_pose(rng, 10.0)
    drive = bench.scripted_drive(m, start, 20, (6.0, 15.0), rng)
    robot = sim.SimRobot(m, start, noise=sim.MotionNoise("absolute", 0.0, 0.0), rng=1)
    pose = start
    for mv in drive:
        robot.turn(mv.turn_rad)
        out = robot.move(mv.distance_cm)
        th = wrap_angle(pose.theta + mv.turn_rad)
        pose = Pose(pose.x + mv.distance_cm * math.cos(th), pose.y + mv.distance_cm * math.sin(th), th)
        assert not out.watchdog
    assert robot.collisions == 0
    assert robot.true_pose.distance_to(pose) < 1e-6
    assert abs(angle_diff(robot.true_pose.theta, pose.theta)) < 1e-9


def test_kidnapped_scenario_recovery(tmp_path: Path, oracles: list[str]) -> None:
    out = tmp_path / "k"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "test-oracle,test-dead-reckoning",
                "--trials", "3", "--scenario", "kidnapped", "--recovery-rounds", "4", "--out", str(out)]) == 0
    cols, data = rows(out / "kidnapped.csv")
    assert tuple(cols) == bench.KIDNAPPED_COLUMNS
    assert len(data) == 2 * 3
    for r in data:
        assert float(r["kidnap_cm"]) >= 30.0
        if r["localiser"] == "test-oracle":  # it follows the truth: recovers in the first iteration
            assert r["localised"] == "true" and r["recovered"] == "true"
            assert int(r["recovery_iterations"]) == 1 and int(r["recovery_scans"]) == 1  # one look, one sweep
        else:  # it never looks at the scans: still where the robot was before the teleport
            assert r["recovered"] == "false" and int(r["recovery_scans"]) == -1
            assert float(r["error_cm"]) >= 30.0 - 3.0
    summary = (out / "summary.md").read_text()
    assert "## Kidnapped robot" in summary
    assert (out / "kidnapped.png").exists()


def test_all_scenarios_write_all_files(tmp_path: Path, oracles: list[str]) -> None:
    out = tmp_path / "all"
    assert run_cli(["bench", "localisers", "--maps", "map2", "--localisers", "test-oracle", "--trials", "1",
                "--scenario", "all", "--tracking-steps", "3", "--recovery-rounds", "2", "--out", str(out)]) == 0
    for f in ("runs.csv", "tracking.csv", "kidnapped.csv", "summary.md", "config.json"):
        assert (out / f).exists(), f
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["scenarios"] == ["global", "tracking", "kidnapped"] and cfg["sonar"] == "ideal"


def test_a_raising_localiser_is_a_failed_trial_not_a_crash(tmp_path: Path, oracles: list[str]) -> None:
    out = tmp_path / "b"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "test-oracle,test-broken", "--trials", "2",
                "--scenario", "global,tracking", "--tracking-steps", "3", "--out", str(out)]) == 0
    _, data = rows(out / "runs.csv")
    broken = [r for r in data if r["localiser"] == "test-broken"]
    # one update in the global procedure (the oracle converges at once): no failure there
    assert all(r["success"] == "true" for r in broken)
    _, tdata = rows(out / "tracking.csv")
    tb = [r for r in tdata if r["localiser"] == "test-broken"]
    assert len(tb) == 2 and all(r["rmse_cm"] == "" for r in tb)  # no value: an empty cell
    parsed = [r for r in bench.read_csv(out / "tracking.csv") if r["localiser"] == "test-broken"]
    assert all(math.isnan(r["rmse_cm"]) and r["trial"] in (0, 1) for r in parsed)
    summary = (out / "summary.md").read_text()
    assert "## Trials that raised" in summary and "LinAlgError: matrix is not positive definite" in summary
    assert "| test-oracle | 2 | 1.50 |" in summary  # the oracle's tracking RMSE is untouched


# -- bad input -------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--maps", "nomap"], "nomap"),
        (["--localisers", "nope"], "unknown nope"),
        (["--trials", "0"], "trials"),
        (["--workers", "0"], "workers"),
        (["--sonar", "radar"], "radar"),
        (["--scenario", "lost"], "unknown lost"),
        (["--tracker-prior", "oracle"], "tracker prior"),
        (["--set", "novalue"], "KEY=VALUE"),
        (["--set", "other.n=3"], "--set"),
        (["--set", "test-oracle.bogus=3"], "test-oracle has no option bogus"),
        (["--set", "bogus=3"], "no chosen localiser has an option bogus"),
        (["--noise-model", "wobbly"], "wobbly"),
        (["--scan-processing", "magic"], "magic"),
        (["--trials", "x"], "x"),
    ],
)
def test_bench_bad_input_exits_2(tmp_path: Path, oracles: list[str], capsys: pytest.CaptureFixture[str],
                                 extra: list[str], message: str) -> None:
    args = ["bench", "localisers", "--maps", "map1", "--localisers", "test-oracle", "--trials", "1",
            "--out", str(tmp_path / "o")]
    for i in range(0, len(extra), 2):  # replace or add the option
        if extra[i] in args:
            args[args.index(extra[i]) + 1] = extra[i + 1]
        else:
            args += extra[i:i + 2]
    assert run_cli(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("nxtnav: error:")
    assert message in err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--pose", "1,2"], "--pose"),
        (["--pose", "500,500,0"], "outside"),
        (["--pose", "60.5,50,0"], "outside"),  # in the notch of map1: outside the free area
        (["--pose", "3,3,0"], "collision"),  # inside, but the robot disc overlaps the walls
        (["--map", "nomap"], "nomap"),
        (["--localiser", "nope"], "unknown nope"),
        (["--sonar", "radar"], "radar"),
    ],
)
def test_localise_bad_input_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str],
                                    message: str) -> None:
    args = ["localise", "--map", "map1", "--pose", "20,20,0", "--localiser", "paper-pf", "--sonar", "ideal",
            "-o", str(tmp_path / "l.png")]
    for i in range(0, len(extra), 2):
        args[args.index(extra[i]) + 1] = extra[i + 1]
    assert run_cli(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("nxtnav: error:")
    assert message in err
    assert not (tmp_path / "l.png").exists()


def test_blind_actions_are_counted_apart(monkeypatch: pytest.MonkeyPatch, oracles: list[str]) -> None:
    """Actions whose scan has no reading are counted, and the RMSE with echo leaves them out."""
    real = sim.SimRobot.ultrascan
    calls = {"n": 0}

    def every_other_blind(self: sim.SimRobot, angles: Any = None) -> Scan:
        calls["n"] += 1
        s = real(self, angles)
        return s if calls["n"] % 2 else Scan(s.angles, np.full(len(s), np.inf), np.zeros(len(s), dtype=bool))

    monkeypatch.setattr(sim.SimRobot, "ultrascan", every_other_blind)
    task = bench.make_tasks("tracking", ["map1"], ["test-dead-reckoning"], 1, 0,
                            bench.BenchConfig(tracking_steps=6))[0]
    r = bench.run_trial(task)
    assert isinstance(r, bench.TrackingRun)
    assert r.blind_steps == 3
    e = np.asarray(r.errors_cm)
    assert r.rmse_echo_cm == pytest.approx(float(np.sqrt(np.mean(e[0::2] ** 2))))
    assert r.rmse_blind_cm == pytest.approx(float(np.sqrt(np.mean(e[1::2] ** 2))))
    summary = bench.summarise([r])["tracking"][("map1", "test-dead-reckoning")]
    assert summary["blind_fraction"] == 0.5 and summary["rmse_echo_cm"] == pytest.approx(r.rmse_echo_cm)
    assert summary["rmse_blind_cm"] == pytest.approx(r.rmse_blind_cm)


def test_dead_reckoning_baseline_is_the_prior_moved_by_odometry(oracles: list[str]) -> None:
    """A tracker that reports its prior's mean moved by the executed actions (never reading a scan) has
    exactly the run's dead-reckoning error; the baseline belongs to the trial, not to the localiser."""
    cfg = bench.BenchConfig(tracking_steps=8)
    reckoner = bench.run_trial(bench.make_tasks("tracking", ["map1"], ["test-tracker"], 1, 3, cfg)[0])
    assert isinstance(reckoner, bench.TrackingRun) and reckoner.steps == 8
    assert reckoner.dead_reckoning_rmse_cm > 0.5  # the 3 cm prior noise
    assert reckoner.rmse_cm == pytest.approx(reckoner.dead_reckoning_rmse_cm, rel=1e-9)
    oracle = bench.run_trial(bench.make_tasks("tracking", ["map1"], ["test-oracle"], 1, 3, cfg)[0])
    assert isinstance(oracle, bench.TrackingRun)
    assert oracle.dead_reckoning_rmse_cm == pytest.approx(reckoner.dead_reckoning_rmse_cm)
    assert math.isnan(oracle.rmse_blind_cm)


def test_radius_scales_the_robot_of_every_scenario(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`--radius` as in `nxtnav run`: the simulated robot, the true poses' clearance, the drive and the
    localisers' clearance follow it."""
    cfg = bench.BenchConfig(robot_radius_cm=5.0)
    assert cfg.geometry.radius_cm == 5.0 and cfg.pose_clearance_cm == 7.0
    assert bench.localiser_options(cfg, "paper-pf")["global_start.clearance_cm"] == 5.0
    default_robot = bench.localiser_options(bench.BenchConfig(), "paper-pf")
    assert default_robot["global_start.clearance_cm"] == 8.0
    out = tmp_path / "r"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf", "--trials", "2",
                "--scenario", "tracking", "--tracking-steps", "3", "--radius", "5", "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["robot_radius_cm"] == 5.0 and config["clearance_cm"] == 7.0
    assert "--radius 5" in (out / "summary.md").read_text()
    _, data = rows(out / "tracking.csv")
    assert len(data) == 2 and all(int(r["collisions"]) == 0 for r in data)
    # a robot too wide for map1's corridors at the pose is refused in one line
    capsys.readouterr()  # the benchmark's progress lines
    assert run_cli(["localise", "--map", "map1", "--pose", "20,20,0", "--radius", "25"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "radius 25" in err
    assert run_cli(["localise", "--map", "map1", "--pose", "20,20,0", "--radius", "5", "--json",
                str(tmp_path / "l.json")]) == 0
    assert json.loads((tmp_path / "l.json").read_text())["error_cm"] < 2.0
