"""`nxtnav brick serve` (checked with nxt-python's own nxt-test), `nxtnav nxt check` and `nxtnav nxt calibrate`."""

from __future__ import annotations

import io
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from conftest import run_cli
from typer.testing import CliRunner

from toolkit.cli import nxt_cmds  # noqa: F401  (registers the nxt commands on the app, whatever ran before)
from toolkit.cli.app import app
from toolkit.robots.nxt import NxtProfile
from toolkit.robots.virtual_brick import BrickServer
from toolkit.robots.virtual_brick_world import BrickConfig, BrickWorld
from toolkit.world import Pose, RobotGeometry, load_map

BIN = Path(sys.executable).parent


@pytest.fixture
def served() -> Iterator[tuple[BrickServer, io.StringIO]]:
    log = io.StringIO()
    geo = RobotGeometry(wheel_diameter_cm=5.8, track_width_cm=12.5)  # not the profile's defaults
    world = BrickWorld(load_map("map1"), Pose.from_deg(20.0, 20.0, 90.0),
                       BrickConfig(geometry=geo, time_factor=1000.0, max_step_s=0.01), sensor_noise=0.0, log=log)
    server = BrickServer(world, port=0).start()
    yield server, log
    server.stop()


def test_nxt_test_passes_against_brick_serve(tmp_path: Path) -> None:
    assert shutil.which("nxt-test", path=str(BIN)), "nxt-test (nxt-python) is not installed next to this Python"
    log = tmp_path / "truth.jsonl"
    nxtnav = shutil.which("nxtnav", path=str(BIN)) or "nxtnav"
    serve = subprocess.Popen(
        [nxtnav, "brick", "serve", "--map", "map1", "--pose", "20,20,0", "--port", "0", "--time-factor", "50",
         "--sonar", "ideal", "--seed", "3", "--log", str(log)],  # exact readings: the protocol is under test
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert serve.stdout is not None
        first = serve.stdout.readline()
        port = re.search(r"on 127\.0\.0\.1:(\d+)", first)
        assert port, first
        for extra in ([], ["--no-sound"]):
            test = subprocess.run(
                [str(BIN / "nxt-test"), "--backend", "socket", "--server-host", "127.0.0.1", "--server-port",
                 port.group(1), *extra], capture_output=True, text=True, timeout=60)
            assert test.returncode == 0, test.stderr
            assert "NXT brick name: nxtnav-virtual" in test.stdout
            assert "Firmware version 1.31" in test.stdout and "Battery level 8000 mV" in test.stdout
            assert ("Play test sound...done." in test.stdout) is (extra == [])
    finally:
        serve.send_signal(signal.SIGTERM)
        out, err = serve.communicate(timeout=30)
    assert serve.returncode == 0, err
    assert "stopped: 2 connection(s)" in out and "0 collision(s)" in out


def test_brick_serve_option_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["brick", "serve", "--pose", "2,2,0", "--port", "0"]) == 2
    assert "collision or outside map" in capsys.readouterr().err
    assert run_cli(["brick", "serve", "--sonar", "radar", "--port", "0"]) == 2
    assert run_cli(["brick", "serve", "--time-factor", "0", "--port", "0"]) == 2
    assert run_cli(["brick", "serve", "--pose", "20,20", "--port", "0"]) == 2


def test_brick_serve_port_in_use(served: tuple[BrickServer, io.StringIO], capsys: pytest.CaptureFixture[str]) -> None:
    server, _ = served
    assert run_cli(["brick", "serve", "--port", str(server.port)]) == 2
    assert "cannot listen" in capsys.readouterr().err


def test_nxt_check_prints_battery_firmware_and_sonar(served: tuple[BrickServer, io.StringIO],
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    server, _ = served
    code = run_cli(["nxt", "check", "--nxt-backend", "socket", "--server-host", "127.0.0.1", "--server-port",
                       str(server.port)])
    out = capsys.readouterr().out
    assert code == 0
    assert "brick 'nxtnav-virtual' over ipvirtual, firmware 1.31" in out
    assert "battery 8.00 V" in out
    assert "sonar on port 4: 85 cm, 85 cm, 85 cm" in out  # 105 - 20 cm straight ahead


def test_nxt_check_without_a_brick_is_one_clear_line(capsys: pytest.CaptureFixture[str]) -> None:
    code = run_cli(["nxt", "check", "--nxt-backend", "socket", "--server-port", "1"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("nxtnav: error: no brick server at 127.0.0.1:1")
    assert run_cli(["nxt", "check", "--nxt-backend", "serial"]) == 2


def test_calibrate_from_stdin_recovers_the_brick_geometry(served: tuple[BrickServer, io.StringIO],
                                                          tmp_path: Path) -> None:
    server, log = served
    profile = tmp_path / "robot.yaml"
    NxtProfile(drive_power=60).save(profile)  # an existing profile keeps its other fields
    start = NxtProfile()
    true = server.world.geometry
    # what the brick will really do (the values a person would measure on the floor)
    drive_deg = round(start.wheel_degrees(50.0))
    driven = drive_deg / 360.0 * math.pi * true.wheel_diameter_cm
    spin_deg = round(360.0 * start.track_width_cm / true.wheel_diameter_cm)
    spun = spin_deg * true.wheel_diameter_cm / true.track_width_cm
    result = CliRunner().invoke(
        app, ["nxt", "calibrate", "--nxt-backend", "socket", "--server-port", str(server.port),
              "--profile", str(profile)],
        input=f"\n{driven:.3f}\n\n{spun:.3f}\n")
    assert result.exit_code == 0, result.output
    assert "wheel diameter 5.6 -> 5.8 cm" in result.output
    calibrated = NxtProfile.load(profile)
    assert calibrated.wheel_diameter_cm == pytest.approx(true.wheel_diameter_cm, abs=1e-3)
    assert calibrated.track_width_cm == pytest.approx(true.track_width_cm, abs=0.01)
    assert calibrated.drive_power == 60
    # the values fed in are what the truth log saw
    recs = [json.loads(line) for line in log.getvalue().splitlines()]
    assert recs[0]["pose"][1] - 20.0 == pytest.approx(driven, abs=1e-3)
    assert (recs[1]["pose"][2] - recs[0]["pose"][2]) % 360.0 == pytest.approx(spun % 360.0, abs=1e-3)


def test_calibrate_rejects_nonsense(served: tuple[BrickServer, io.StringIO], tmp_path: Path) -> None:
    server, _ = served
    result = CliRunner().invoke(
        app, ["nxt", "calibrate", "--nxt-backend", "socket", "--server-port", str(server.port),
              "--profile", str(tmp_path / "p.yaml")], input="\n-3\n")
    assert result.exit_code != 0
    assert "measured distance must be a positive number" in str(result.exception)
    assert not (tmp_path / "p.yaml").exists()


def test_nxt_check_names_a_silent_sensor_port(served: tuple[BrickServer, io.StringIO], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    server, _ = served
    profile = NxtProfile(sonar_port=1).save(tmp_path / "wrong-port.yaml")  # the sensor is on port 4
    code = run_cli(["nxt", "check", "--nxt-backend", "socket", "--server-port", str(server.port),
                       "--profile", str(profile)])
    err = capsys.readouterr().err
    assert code == 2
    assert "the ultrasonic sensor on port 1 does not answer" in err and "sonar_port" in err
    assert server.clients == 1 and not server.world.moving


def test_brick_serve_says_when_each_scheduled_fault_fires() -> None:
    from toolkit.robots.nxt import connect_robot
    from toolkit.world import LinkLostError

    nxtnav = shutil.which("nxtnav", path=str(BIN)) or "nxtnav"
    serve = subprocess.Popen(
        [nxtnav, "brick", "serve", "--port", "0", "--time-factor", "1000", "--max-step", "0.01", "--seed", "1",
         "--fault", "drop-link:0.3:60", "--fault", "stall:500:1"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert serve.stdout is not None
        port = re.search(r"on 127\.0\.0\.1:(\d+)", serve.stdout.readline())
        assert port
        assert serve.stdout.readline().strip() == "scheduled faults: drop-link:0.3:60, stall:500:1"
        robot = connect_robot("socket", host="127.0.0.1", port=int(port.group(1)))
        with pytest.raises(LinkLostError):
            for _ in range(1000):
                robot.read_sonar()
        robot.close()
        assert serve.stdout.readline().strip() == "fault drop-link:0.3:60 fired at brick time 0.30 s"
    finally:
        serve.send_signal(signal.SIGTERM)
        out, err = serve.communicate(timeout=30)
    assert serve.returncode == 0, err
    assert "fault drop-link:0.3:60: fired at brick time 0.30 s, acted 1 time(s)" in out
    assert "fault stall:500:1: did not fire" in out
