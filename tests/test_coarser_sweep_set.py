"""tools/coarser_sweep_set.py on the shipped MIT sweeps: every K-th reading, a set every command loads."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, load_tool

from toolkit.real_sonar.sweeps import load_sweep_set

tool = load_tool("coarser_sweep_set")


def test_every_fifth_reading_is_a_set_of_72_readings_five_degrees_apart(tmp_path: Path) -> None:
    out = tmp_path / "every5"
    assert tool.main([str(REAL_NXT), "-o", str(out), "--every", "5"]) == 0
    fine, coarse = load_sweep_set(REAL_NXT), load_sweep_set(out)
    assert [s.label for s in coarse.sweeps] == [s.label for s in fine.sweeps]
    for a, b in zip(fine.sweeps, coarse.sweeps, strict=True):
        assert (b.x_cm, b.y_cm, b.heading_deg, b.direction) == (a.x_cm, a.y_cm, a.heading_deg, a.direction)
        assert len(b.readings) == 72 and b.step_deg == 5 * a.step_deg
        assert np.array_equal(b.readings, a.readings[::5])
        assert np.allclose(b.scan().angles, a.scan().angles[::5])  # the turret's angles of the kept readings


def test_bad_requests_write_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        tool.main([str(REAL_NXT), "-o", str(tmp_path / "x"), "--every", "7"])  # 360 readings: no multiple of 7
    assert stop.value.code == 2 and not (tmp_path / "x").exists()
    assert "andrei-alpha/robotics/loc_01.dat (360 readings): not a multiple of 7" in capsys.readouterr().err
    (tmp_path / "taken").mkdir()
    with pytest.raises(SystemExit) as stop:
        tool.main([str(REAL_NXT), "-o", str(tmp_path / "taken"), "--every", "5"])
    assert stop.value.code == 2 and "already exists" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        tool.main([str(REAL_NXT), "-o", str(tmp_path / "y"), "--every", "1"])
    assert not (tmp_path / "y").exists()
    with (REAL_NXT / "sweeps.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 3  # the source set is only read
