"""The localiser benchmark and `nxtnav localise` with the real localisers, against the simulator's truth."""

from __future__ import annotations

import contextlib
import csv
import json
import math
import socket
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli

import localisation  # noqa: F401  (registers every localiser)
from toolkit.bench import localisers as bench
from toolkit.robots.sim import SimRobot
from toolkit.seeds import derive_seed
from toolkit.world import NxtSonar, Pose, angle_diff, load_map


def test_localise_cli_json_matches_truth(tmp_path: Path) -> None:
    png, js = tmp_path / "l.png", tmp_path / "l.json"
    assert run_cli(["localise", "--map", "map1", "--pose", "20,20,30", "--localiser", "paper-pf", "--sonar", "ideal",
                "--seed", "1", "-o", str(png), "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    for key in ("estimate", "truth", "error_cm", "heading_error_deg", "iterations", "scans", "time_s"):
        assert key in doc
    est, truth = np.array(doc["estimate"]), np.array(doc["truth"])
    if doc["scans"] == 2:  # one iteration: the robot only turned in place, so the truth is still at (20, 20)
        assert truth[:2] == pytest.approx([20.0, 20.0], abs=1e-9)
    assert doc["error_cm"] == pytest.approx(float(np.hypot(*(est[:2] - truth[:2]))))
    assert doc["heading_error_deg"] == pytest.approx(math.degrees(angle_diff(math.radians(est[2]),
                                                                             math.radians(truth[2]))))
    assert doc["success"] is (doc["error_cm"] <= 2.0 and abs(doc["heading_error_deg"]) <= 3.0)
    assert doc["success"]  # the ideal sonar on map1 from a roomy pose
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_localise_once_truth_is_the_simulators() -> None:
    m = load_map("map2")
    out, robot, _ = bench.localise_once(m, Pose(30, 20, 1.0), "paper-pf", rng=3)
    assert isinstance(robot, SimRobot)
    assert out.truth == robot.true_pose
    assert out.error_cm == pytest.approx(out.estimate.distance_to(robot.true_pose))
    assert out.success is bench.is_success(out.error_cm, out.heading_error_deg)


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_trackers_get_a_noisy_truth_prior(name: str) -> None:
    m = load_map("map1")
    cfg = bench.BenchConfig(tracker_prior="noisy-truth")
    out, _, _ = bench.localise_once(m, Pose(25, 80, 0.3), name, config=cfg, rng=2)
    assert out.prior == "noisy-truth"
    assert out.error_cm < 10.0  # it tracks from a 3 cm / 5 degree prior; it does not get lost


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        return list(csv.DictReader(fh))


def test_process_pool_matches_in_process(tmp_path: Path) -> None:
    args = ["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf", "--trials", "2", "--seed", "4"]
    assert run_cli([*args, "--out", str(tmp_path / "a")]) == 0
    assert run_cli([*args, "--out", str(tmp_path / "b"), "--workers", "2"]) == 0
    a, b = _rows(tmp_path / "a" / "runs.csv"), _rows(tmp_path / "b" / "runs.csv")
    assert len(a) == len(b) == 2
    for ra, rb in zip(a, b, strict=True):  # same seeds, same results, whatever the executor
        for k in ("trial", "seed", "success", "error_cm", "heading_error_deg", "iterations", "scans"):
            assert ra[k] == rb[k]


@contextlib.contextmanager
def _port_taken(port: int) -> Iterator[None]:
    """`port` taken on every interface for the block (by this socket, or already by something else)."""
    sock = socket.socket()
    try:
        with contextlib.suppress(OSError):  # taken already: just as good
            sock.bind(("0.0.0.0", port))
            sock.listen(1)
        yield
    finally:
        sock.close()


def test_dask_local_tiny_run(tmp_path: Path) -> None:
    """A local cluster starts while Dask's usual dashboard port is taken (another run on the machine)."""
    out = tmp_path / "d"
    with _port_taken(8787):
        assert run_cli(["bench", "localisers", "--maps", "map2", "--localisers", "paper-pf", "--trials", "2",
                        "--seed", "4", "--workers", "1", "--dask", "local", "--out", str(out)]) == 0
    rows = _rows(out / "runs.csv")
    assert [int(r["trial"]) for r in rows] == [0, 1]
    assert all(int(r["seed"]) == derive_seed(4, "map2", int(r["trial"])) for r in rows)


def test_the_bench_tells_every_localiser_its_robot_model() -> None:
    nxt = bench.BenchConfig(sonar="nxt", noise_model="absolute", motion_noise=0.4)
    model = NxtSonar()
    for name in ("paper-pf", "pf-systematic"):
        opts = bench.localiser_options(nxt, name)
        assert (opts["ranges.beam_width_deg"], opts["ranges.beam_rays"], opts["ranges.critical_incidence_deg"],
                opts["ranges.max_range_cm"]) == (model.beam_width_deg, model.beam_rays, model.critical_incidence_deg,
                                                  model.max_range_cm)
        assert opts["sensor.sonar_model"] == model.simulated() and opts["motion.noise_model"] == "absolute"
        assert "ranges.beam_width_deg" not in bench.localiser_options(bench.BenchConfig(sonar="ideal"), name)
        off = bench.localiser_options(bench.BenchConfig(sonar="nxt", lobe="off"), name)
        assert "ranges.beam_width_deg" not in off and "sensor.sonar_model" not in off
        assert off["sensor.sensor_sigma_cm"] == 3.0
    # explicit options win over the model
    cfg = bench.BenchConfig(sonar="nxt", localiser_options={"paper-pf": {"ranges.beam_width_deg": 10.0}})
    assert bench.localiser_options(cfg, "paper-pf")["ranges.beam_width_deg"] == 10.0
    for name in ("ekf", "ukf"):
        opts = bench.localiser_options(nxt, name)
        assert not any("beam_width_deg" in k for k in opts)
        assert opts["sensor.sensor_sigma_cm"] == 3.0 and opts["motion.motion_noise"] == 0.4


def test_kidnapped_recovery_does_not_raise() -> None:
    # regression: after a kidnapping the filter pruned dead particles but looked up its best fit with
    # residuals of the resampled cloud (IndexError); this trial of the benchmark (seed 0) hit it
    task = bench.make_tasks("kidnapped", ["map1"], ["paper-pf"], 19, 0, bench.BenchConfig())[18]
    r = bench.run_trial(task)
    assert not r.failure, r.failure
    assert r.localised and r.recovered and math.isfinite(r.error_cm) and r.error_cm <= 2.0
