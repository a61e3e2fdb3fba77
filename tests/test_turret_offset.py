"""A robot's turret zero (`NxtSonar.turret_offset_deg`): found from a source's documented headings by
`nxtnav sonar turret`, and used by the real-sweep benchmarks to turn that source's readings into the
robot's frame."""

from __future__ import annotations

import csv
import math
import shutil
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, run_cli

from toolkit.bench.routes import model_headings
from toolkit.bench.sweeps import SweepTask, run_sweep
from toolkit.real_sonar.fit import load_sonar_profile, source_profile_name, turret_offset_deg
from toolkit.real_sonar.sweeps import Sweep, load_sweep_set
from toolkit.world import NxtSonar

REPO = "andrei-alpha/robotics"  # the shipped set's one source


def _sweep(label: str, heading_deg: float, repo: str = REPO) -> Sweep:
    return Sweep(repo, label, 0.0, 0.0, np.zeros(4), np.full(4, 50.0), heading_deg=heading_deg)


def test_the_offset_is_the_circular_mean_gap_without_twins() -> None:
    sweeps = [_sweep("a", 10.0), _sweep("b", 179.0), _sweep("c", -90.0), _sweep("d", math.nan)]
    # b's fit lies across the +-180 seam (6 degrees on), c's is its twin (95 degrees on), d has no heading
    fitted = {f"{REPO}/{k}": v for k, v in {"a": 18.0, "b": -175.0, "c": 5.0, "d": 40.0}.items()}
    assert turret_offset_deg(sweeps, fitted) == pytest.approx(7.0, abs=0.01)
    other = _sweep("e", 0.0, repo="other/robot")
    assert turret_offset_deg([sweeps[0], other], {**fitted, other.label: 3.0}) == 0.0
    assert turret_offset_deg(sweeps[3:], fitted) == 0.0


def test_a_scan_is_turned_by_the_offset() -> None:
    sw = _sweep("a", 0.0)
    assert np.allclose(sw.scan(7.5).angles - sw.scan().angles, math.radians(7.5))


def _shifted_copy(tmp_path: Path, shift_deg: float) -> Path:
    """The shipped set with every heading_deg moved by `shift_deg`: as documented by a robot whose turret
    zero lies `-shift_deg` further from its forward direction."""
    out = tmp_path / "shifted"
    shutil.copytree(REAL_NXT, out)
    with (out / "sweeps.csv").open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["heading_deg"] = f"{float(r['heading_deg']) + shift_deg:g}"
    with (out / "sweeps.csv").open("w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return out


def _turret(folder: Path, out: Path, *extra: str) -> float:
    assert run_cli(["sonar", "turret", str(folder), "-o", str(out), *extra]) == 0
    profile = load_sonar_profile(out / source_profile_name(REPO))
    assert profile == NxtSonar(turret_offset_deg=profile.turret_offset_deg)  # the default model otherwise
    return profile.turret_offset_deg


def test_sonar_turret_finds_a_moved_turret_zero(tmp_path: Path) -> None:
    shipped = _turret(REAL_NXT, tmp_path / "shipped")
    moved = _turret(_shifted_copy(tmp_path, -10.0), tmp_path / "moved")
    assert moved - shipped == pytest.approx(10.0, abs=0.02)
    assert abs(shipped) < 15.0


def test_aligned_headings_take_the_place_of_the_column(tmp_path: Path) -> None:
    """With --headings aligned the column is not read: a moved column changes nothing."""
    shipped = _turret(REAL_NXT, tmp_path / "shipped", "--headings", "aligned")
    moved = _turret(_shifted_copy(tmp_path, -10.0), tmp_path / "moved", "--headings", "aligned")
    assert moved == shipped
    assert abs(shipped - _turret(REAL_NXT, tmp_path / "column")) < 5.0  # the column was made the same way


def test_sonar_turret_refuses_a_file_as_its_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "profiles"
    target.write_text("mine\n")
    assert run_cli(["sonar", "turret", str(REAL_NXT), "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert "--output" in err and str(target) in err
    assert target.read_text() == "mine\n"
    assert run_cli(["sonar", "turret", str(REAL_NXT), "-o", str(tmp_path / "new"), "--headings", "model"]) == 2
    assert "--headings: must be column or aligned, got 'model'" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()


def test_the_model_heading_is_the_robots() -> None:
    sweeps = load_sweep_set(REAL_NXT)
    plain = model_headings(sweeps, {REPO: NxtSonar()}, [REPO])
    turned = model_headings(sweeps, {REPO: NxtSonar(turret_offset_deg=12.0)}, [REPO])
    for label, heading in plain.items():
        assert math.remainder(heading - turned[label] - 12.0, 360.0) == pytest.approx(0.0, abs=0.01)


def test_a_sweep_benchmark_reads_in_the_robots_frame() -> None:
    """One sweep localised with a heading prior: told a turret zero of 15 degrees, the estimate's heading
    is 15 degrees less (the readings turned by it), the place the same."""
    from localisation.base import HeadingPrior

    sweeps = load_sweep_set(REAL_NXT)
    index = next(i for i, s in enumerate(sweeps) if (s.x_cm, s.y_cm) == (180.0, 30.0))
    prior = HeadingPrior(math.radians(sweeps.sweeps[index].heading_deg), math.radians(20.0))

    def run(offset: float) -> tuple[float, float, float]:
        sonar = asdict(NxtSonar(turret_offset_deg=offset))
        r = run_sweep(SweepTask(str(REAL_NXT), None, index, "paper-pf", 0, sonar, {}, prior))
        return r.estimate_x_cm, r.estimate_y_cm, r.estimate_heading_deg

    x0, y0, h0 = run(0.0)
    x1, y1, h1 = run(15.0)
    assert math.hypot(x1 - x0, y1 - y0) < 3.0
    assert math.remainder(h0 - h1 - 15.0, 360.0) == pytest.approx(0.0, abs=3.0)
