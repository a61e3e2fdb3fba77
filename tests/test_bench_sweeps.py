"""`nxtnav bench sweeps` on the shipped real sweeps: the files, the scoring rules and bad input."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest
from conftest import REAL_NXT, fails_cleanly, run_cli

from toolkit.bench.sweeps import COLUMNS, SweepRun, summarise


def _run(**kw: object) -> SweepRun:
    base = dict(repo="r", file="f", x_cm=0.0, y_cm=0.0, localiser="paper-pf", seed=0, estimate_x_cm=0.0,
                estimate_y_cm=0.0, estimate_heading_deg=0.0, error_cm=0.0, converged=True, ambiguous=False,
                candidates=0, truth_in_candidates=False, time_s=0.1)
    return SweepRun(**{**base, **kw})  # type: ignore[arg-type]


def test_scoring_rules() -> None:
    assert _run(error_cm=25.0).confidently_wrong and not _run(error_cm=25.0).honest
    assert not _run(error_cm=25.0, converged=False).confidently_wrong
    assert _run(error_cm=25.0, ambiguous=True, truth_in_candidates=True).honest
    assert not _run(error_cm=25.0, ambiguous=True).honest
    assert _run(error_cm=19.0).honest
    s = summarise([_run(error_cm=5.0), _run(error_cm=15.0), _run(error_cm=40.0), _run(error_cm=40.0, converged=False)],
                  "paper-pf")
    assert (s["within_10cm"], s["within_20cm"], s["confidently_wrong"], s["honest"]) == (0.25, 0.5, 0.25, 0.5)


@pytest.mark.slow
def test_bench_sweeps_writes_every_run(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert run_cli(["bench", "sweeps", str(REAL_NXT), "--seeds", "0", "--out", str(out)]) == 0
    with (out / "sweeps.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
        assert tuple(rows[0]) == COLUMNS
    assert len(rows) == 6  # 3 sweeps x 2 localisers x 1 seed
    assert {r["localiser"] for r in rows} == {"paper-pf", "amcl"}
    for r in rows:
        err = ((float(r["estimate_x_cm"]) - float(r["x_cm"])) ** 2
               + (float(r["estimate_y_cm"]) - float(r["y_cm"])) ** 2) ** 0.5
        assert float(r["error_cm"]) == pytest.approx(err, abs=0.01)
        assert r["truth_in_candidates"] in ("True", "False")
    summary = (out / "summary.md").read_text()
    assert "| paper-pf | 3 |" in summary and "| amcl | 3 |" in summary
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["complete"] and cfg["runs_done"] == 6 and cfg["sonar"]["name"] == "nxt"


def _broken_copy(tmp_path: Path) -> Path:
    dst = tmp_path / "set"
    shutil.copytree(REAL_NXT, dst)
    return dst


@pytest.mark.parametrize(("args", "message"), [
    (["--localisers", "ekf"], "cannot localise from one sweep"),
    (["--localisers", "nope"], "nope"),
    (["--seeds", "a"], "--seeds"),
    (["--seeds", "-1"], "--seeds"),
])
def test_bad_options_exit_2_and_write_nothing(tmp_path: Path, args: list[str], message: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    fails_cleanly(["bench", "sweeps", str(REAL_NXT), "--out", str(out), *args], capsys, message)
    assert not out.exists()


def test_bad_sweep_set_exits_2_naming_the_problem(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _broken_copy(tmp_path)
    for raw in (folder / "raw" / "andrei-alpha+robotics").glob("*.dat"):  # one unusable file is left out; all:
        lines = raw.read_text().splitlines()
        lines[7] = "twelve"
        raw.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    assert run_cli(["bench", "sweeps", str(folder), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "no usable sweep" in err and "loc_01.dat:8" in err and "twelve" in err and len(err.splitlines()) == 1
    assert not out.exists()
