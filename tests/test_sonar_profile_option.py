"""`--sonar-profile FILE` of scan, localise, run, paper, bench localisers and brick serve: the profile's
`nxt` model draws the simulated readings and reaches the localisers, the results record its parameters,
and `--sensor-noise` / `--noise`'s sensor value is the ideal sonar's only."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from conftest import run_cli

from toolkit.bench.localisers import BenchConfig
from toolkit.real_sonar.fit import load_sonar_profile
from toolkit.recordings.recorder import decode_options, encode_options, sonar_from_dict
from toolkit.robots.sim import SimRobot, simulated_sonar
from toolkit.robots.virtual_brick_world import BrickWorld
from toolkit.world import ConfigError, IdealSonar, NxtnavError, NxtSonar, Pose, load_map

BIN = Path(sys.executable).parent


def _profile(folder: Path, name: str = "profile.yaml", **params: float) -> Path:
    path = folder / name
    path.write_text(yaml.safe_dump({"kind": "nxtnav-sonar-profile", "sonar": "nxt", "params": params}))
    return path


def test_a_hand_written_profile_may_use_exponents(tmp_path: Path) -> None:
    """YAML 1.1 reads ``8e-3`` as a text; a profile's parameter is a number all the same."""
    path = tmp_path / "hand.yaml"
    path.write_text("params:\n  dropout_prob: 8e-3\n  reach_cm: 5.8E1\n")
    model = load_sonar_profile(path)
    assert model.dropout_prob == 0.008 and model.reach_cm == 58.0
    path.write_text("params:\n  dropout_prob: 8e-3x\n")
    with pytest.raises(NxtnavError, match=r"params\.dropout_prob must be a number, got '8e-3x'"):
        load_sonar_profile(path)


def _scan(tmp_path: Path, *extra: str) -> list[float | None]:
    out = tmp_path / "scan.json"
    assert run_cli(["scan", "--map", "map1", "--pose", "50,30,0", "--seed", "1", "--json", str(out), *extra]) == 0
    return list(json.loads(out.read_text())["ranges_cm"])


def test_scan_draws_its_readings_from_the_profile(tmp_path: Path) -> None:
    half = _profile(tmp_path, dropout_prob=0.5, far_dropout_prob=0.5)
    default = _scan(tmp_path, "--sonar", "nxt")
    lossy = _scan(tmp_path, "--sonar", "nxt", "--sonar-profile", str(half))
    assert len(default) == len(lossy) == 360
    assert sum(r is None for r in default) / 360 < 0.15  # few: specular loss and 2 % dropouts
    assert 0.4 < sum(r is None for r in lossy) / 360 < 0.6  # about half: the profile's dropouts
    doc = json.loads((tmp_path / "scan.json").read_text())
    assert doc["sonar_model"] == load_sonar_profile(half).to_dict()
    assert doc["sonar_model"]["dropout_prob"] == 0.5


def test_sensor_noise_is_the_ideal_sonars_only(tmp_path: Path) -> None:
    # the nxt sonar's noise comes from its model: --sensor-noise changes nothing
    assert _scan(tmp_path, "--sonar", "nxt", "--sensor-noise", "0") == _scan(tmp_path, "--sonar", "nxt",
                                                                              "--sensor-noise", "5")
    assert _scan(tmp_path, "--sensor-noise", "0") != _scan(tmp_path, "--sensor-noise", "5")
    assert simulated_sonar("nxt", 5.0) == NxtSonar()
    assert simulated_sonar("ideal", 5.0) == IdealSonar(noise_sd=5.0)
    fitted = NxtSonar(noise_sd=4.0)
    assert simulated_sonar(fitted, 1.0) is fitted
    m = load_map("map1")
    assert SimRobot(m, Pose(20, 20, 0), sonar="nxt", sensor_noise=5.0).sonar == NxtSonar()
    world = BrickWorld(m, Pose(20, 20, 0), sonar="nxt", sensor_noise=5.0)
    try:
        assert world.sonar == NxtSonar()
    finally:
        world.close()


PROFILE_COMMANDS = [
    ["scan", "--pose", "50,30,0"],
    ["localise", "--pose", "50,30,0"],
    ["run"],
    ["paper", "--trials", "1"],
    ["bench", "localisers", "--trials", "1", "--out", "OUT"],
    ["brick", "serve", "--port", "0"],
]
"""Every command that takes --sonar-profile (OUT: a folder the test names)."""


@pytest.mark.parametrize("argv", PROFILE_COMMANDS)
def test_a_profile_with_the_ideal_sonar_is_refused(argv: list[str], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    profile = _profile(tmp_path, noise_sd=2.0)
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in argv]
    assert run_cli([*argv, "--sonar", "ideal", "--sonar-profile", str(profile)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--sonar-profile" in err and "nxt" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv", PROFILE_COMMANDS)
def test_a_bad_profile_is_one_line_everywhere(argv: list[str], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("params:\n  noise_sd: -1\n")
    argv = [str(tmp_path / "out") if a == "OUT" else a for a in argv]
    assert run_cli([*argv, "--sonar", "nxt", "--sonar-profile", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(bad) in err and "params.noise_sd" in err
    assert not (tmp_path / "out").exists()


def test_localise_records_the_profile(tmp_path: Path) -> None:
    profile = _profile(tmp_path, noise_sd=2.5, beam_width_deg=30.0, beam_rays=13)
    out = tmp_path / "loc.json"
    assert run_cli(["localise", "--map", "map1", "--pose", "50,30,0", "--localiser", "ekf", "--sonar", "nxt",
                    "--sonar-profile", str(profile), "--seed", "2", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["sonar"] == "nxt"
    assert doc["sonar_model"] == load_sonar_profile(profile).to_dict()
    assert (doc["sonar_model"]["noise_sd"], doc["sonar_model"]["beam_width_deg"]) == (2.5, 30.0)


def test_bench_config_hands_the_model_to_simulator_and_localisers(tmp_path: Path) -> None:
    fitted = NxtSonar(noise_sd=2.5, beam_width_deg=30.0, beam_rays=13, critical_incidence_deg=55.0)
    cfg = BenchConfig(sonar="nxt", sonar_model=fitted)
    assert cfg.simulated_sonar is fitted
    lobe = cfg.robot_options("paper-pf")
    assert (lobe["ranges.beam_width_deg"], lobe["ranges.beam_rays"], lobe["ranges.critical_incidence_deg"]) == (
        30.0, 13, 55.0)
    assert lobe["sensor.sonar_model"] == fitted.simulated()
    assert cfg.to_dict()["sonar_model"] == fitted.to_dict()
    assert BenchConfig(sonar="nxt").robot_options("paper-pf")["ranges.beam_width_deg"] == NxtSonar().beam_width_deg
    with pytest.raises(NxtnavError, match="nxt"):
        BenchConfig(sonar="ideal", sonar_model=fitted)


def test_bench_localisers_records_the_profile(tmp_path: Path) -> None:
    profile = _profile(tmp_path, noise_sd=2.5, beam_width_deg=30.0, beam_rays=13)
    out = tmp_path / "bench"
    assert run_cli(["bench", "localisers", "--maps", "map1", "--localisers", "ekf", "--trials", "1", "--sonar",
                    "nxt", "--sonar-profile", str(profile), "--seed", "1", "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["sonar_model"] == load_sonar_profile(profile).to_dict()
    summary = (out / "summary.md").read_text()
    assert "a sonar profile: noise 2.5 cm, lobe 30 degrees" in summary
    assert f"--sonar-profile {profile}" in summary


def test_run_with_a_profile_records_it_and_replays_bit_for_bit(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    profile = _profile(tmp_path, noise_sd=1.5, beam_width_deg=25.0, beam_rays=11)
    model = load_sonar_profile(profile)
    record, report = tmp_path / "run.jsonl", tmp_path / "run.json"
    code = run_cli(["run", "--map", "map1", "--seed", "6", "--sonar", "nxt", "--sonar-profile", str(profile),
                    "--record", str(record), "--json", str(report)])
    assert code in (0, 1)  # the mission's outcome is not the point here
    assert json.loads(report.read_text())["sonar_model"] == model.to_dict()
    lines = [json.loads(line) for line in record.read_text().splitlines()]
    assert lines[0]["sonar"]["params"] == model.to_dict()
    (event,) = [e for e in lines if e["type"] == "localiser"]
    # paper-pf is told the profile's model, as the simulator draws it (each reading independent)
    assert event["options"]["sensor.sonar_model"] == model.simulated().to_dict()
    assert event["options"]["ranges.beam_width_deg"] == 25.0
    capsys.readouterr()
    assert run_cli(["replay", str(record), "--localisers", "paper-pf,pf-systematic"]) == 0
    assert "paper-pf: replayed estimates equal the" in capsys.readouterr().out


def test_paper_records_the_profile_in_its_tables(tmp_path: Path) -> None:
    profile = _profile(tmp_path, noise_sd=1.5)
    out = tmp_path / "paper.json"
    assert run_cli(["paper", "--trials", "1", "--maps", "map1", "--noise-model", "botsim", "--sonar", "ideal,nxt",
                    "--sonar-profile", str(profile), "--json", str(out)]) == 0
    tables = {t["sonar"]: t for t in json.loads(out.read_text())}
    assert tables["nxt"]["sonar_model"] == load_sonar_profile(profile).to_dict()
    assert tables["ideal"]["sonar_model"] == IdealSonar(noise_sd=1.0).to_dict()  # the profile is nxt's only


def test_sonar_models_in_recorded_options() -> None:
    fitted = NxtSonar(noise_sd=2.5)
    encoded = encode_options({"sonar_model": fitted, "motion_noise": 0.1})
    assert json.loads(json.dumps(encoded)) == {"sonar_model": fitted.to_dict(), "motion_noise": 0.1}
    assert decode_options(encoded) == {"sonar_model": fitted, "motion_noise": 0.1}
    for bad in ({"noise_sd": 1.0}, {"name": "nxt", "colour": 1}, {"name": "nxt", "noise_sd": -1.0},
                {"name": "radar"}):
        with pytest.raises(ConfigError):
            sonar_from_dict(bad)


def test_brick_serve_reads_with_the_profile(tmp_path: Path) -> None:
    silent = _profile(tmp_path, dropout_prob=1.0, far_dropout_prob=1.0)
    nxtnav = shutil.which("nxtnav", path=str(BIN)) or "nxtnav"
    serve = subprocess.Popen(
        [nxtnav, "brick", "serve", "--map", "map1", "--pose", "20,20,0", "--port", "0", "--time-factor", "50",
         "--seed", "3", "--sonar", "nxt", "--sonar-profile", str(silent)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert serve.stdout is not None
        first = serve.stdout.readline()
        assert f"sonar nxt (profile {silent})" in first
        port = re.search(r"on 127\.0\.0\.1:(\d+)", first)
        assert port, first
        check = subprocess.run([nxtnav, "nxt", "check", "--nxt-backend", "socket", "--server-port", port.group(1)],
                               capture_output=True, text=True, timeout=60)
        assert check.returncode == 0, check.stderr
        assert "sonar on port 4: no echo, no echo, no echo" in check.stdout  # every echo lost, as profiled
    finally:
        serve.send_signal(signal.SIGTERM)
        serve.communicate(timeout=30)
    assert serve.returncode == 0
