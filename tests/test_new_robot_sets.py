"""A new robot's sweep set, written its own way, through the real-sweep commands: the shipped MIT sweeps
re-written as another robot or a spreadsheet could have written them give the same figures; a sweep file
that cannot be used is left out and named; a sweep far from its documented waypoint is named."""

from __future__ import annotations

import csv
import json
import logging
import shutil
from pathlib import Path

import pytest
import yaml
from conftest import REAL_NXT, built_once, real_nxt_arena, run_cli

GRID = ["--widths", "40", "--criticals", "40"]
Rows = list[dict[str, str]]


def _copy(tmp_path: Path, name: str = "set") -> Path:
    """A copy of the shipped set with its arena as a map file (every command takes it with --map)."""
    out = tmp_path / name
    shutil.copytree(REAL_NXT, out)
    (out / "arena.yaml").write_text(yaml.safe_dump(real_nxt_arena().to_dict(), sort_keys=False))
    return out


def _rows(folder: Path) -> Rows:
    with (folder / "sweeps.csv").open(newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _write(folder: Path, rows: Rows, columns: list[str], *, bom: bool = False, newline: str = "\n") -> None:
    with (folder / "sweeps.csv").open("w", newline="", encoding="utf-8-sig" if bom else "utf-8") as fh:
        out = csv.DictWriter(fh, fieldnames=columns, lineterminator=newline, extrasaction="ignore")
        out.writeheader()
        out.writerows(rows)


def _readings(folder: Path, row: dict[str, str]) -> list[str]:
    return (folder / row["raw"]).read_text().split()


def _fit(folder: Path, out: Path) -> dict:
    """`nxtnav sonar fit` of `folder` (one lobe); its JSON report."""
    report = out / f"{folder.name}.json"
    code = run_cli(["sonar", "fit", str(folder), "--map", str(folder / "arena.yaml"), *GRID,
                    "-o", str(out / f"{folder.name}.yaml"), "--json", str(report)])
    assert code == 0
    return json.loads(report.read_text())


@pytest.fixture(scope="module")
def shipped_fit(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The fit of the shipped set as it is: what every re-written copy must give again."""

    def build(out: Path) -> None:
        folder = _copy(out)
        (out / "fit.json").write_text(json.dumps(_fit(folder, out)))

    return json.loads((built_once(tmp_path_factory, "new-robot-fit", build) / "fit.json").read_text())


def _spreadsheet(folder: Path) -> None:
    """sweeps.csv as a spreadsheet saves it: a byte-order mark, CRLF, the columns reversed, two more."""
    rows = _rows(folder)
    columns = [*reversed(list(rows[0])), "operator", "notes"]
    for r in rows:
        r.update(operator="me", notes="battery low, re-run")
    _write(folder, rows, columns, bom=True, newline="\r\n")


def _held_as_stuck(folder: Path) -> None:
    """Every source's long runs of one reading read as a stuck sensor (left out whole): a held echo's
    first reading in time depends on the way the turret turned, a stuck run does not."""
    rows = _rows(folder)
    for r in rows:
        r["held_runs"] = "stuck"
    _write(folder, rows, list(rows[0]))


def _other_turret(folder: Path) -> None:
    """Every sweep taken by a turret turning the other way: the readings in the reverse order of time, the
    first one taken where the old last one was (the same angles, each with its own reading)."""
    rows = _rows(folder)
    for r in rows:
        old = _readings(folder, r)
        sign = 1 if r["direction"] == "ccw" else -1
        last = float(r["start_deg"]) + sign * (len(old) - 1) * float(r["step_deg"])
        (folder / r["raw"]).write_text("\n".join(reversed(old)) + "\n")
        r.update(direction="cw" if sign == 1 else "ccw", start_deg=f"{last % 360:g}")
    _write(folder, rows, list(rows[0]))


def _same_fit(report: dict, shipped: dict) -> None:
    assert report["sweeps"] == shipped["sweeps"] == 3
    assert report["readings"] == shipped["readings"]
    assert report["headings_deg"] == pytest.approx(shipped["headings_deg"], abs=1e-6)
    assert report["mean_log_likelihood"] == pytest.approx(shipped["mean_log_likelihood"], abs=1e-3)


def test_a_table_saved_by_a_spreadsheet_fits_as_the_shipped_one(tmp_path: Path, shipped_fit: dict) -> None:
    folder = _copy(tmp_path)
    _spreadsheet(folder)
    _same_fit(_fit(folder, tmp_path), shipped_fit)


def test_a_turret_turning_the_other_way_fits_the_same(tmp_path: Path) -> None:
    base, turned = _copy(tmp_path, "base"), _copy(tmp_path, "turned")
    for folder in (base, turned):
        _held_as_stuck(folder)
    _other_turret(turned)
    assert _readings(turned, _rows(turned)[0]) != _readings(base, _rows(base)[0])
    _same_fit(_fit(turned, tmp_path), _fit(base, tmp_path))


def test_an_unusable_sweep_file_is_left_out_and_named(tmp_path: Path, caplog: pytest.LogCaptureFixture,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    folder = _copy(tmp_path)
    raw = folder / "raw" / "andrei-alpha+robotics" / "loc_03.dat"
    raw.write_text("\n".join(raw.read_text().split()[:357]) + "\n")  # the sensor's log ended early
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING):
        code = run_cli(["bench", "sweeps", str(folder), "--map", str(folder / "arena.yaml"), "--localisers",
                        "paper-pf", "--seeds", "0", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    with (out / "sweeps.csv").open() as fh:
        assert sorted(r["file"] for r in csv.DictReader(fh)) == ["loc_01.dat", "loc_04.dat"]
    why = f"{raw}: 357 readings, but sweeps.csv says n_bins = 360"
    assert why in (out / "summary.md").read_text()
    assert any(why in r.getMessage() and "left out" in r.getMessage() for r in caplog.records), caplog.text
    # every sweep unusable: one line, exit 2, nothing written
    for other in raw.parent.glob("*.dat"):
        other.write_text("")
    capsys.readouterr()
    assert run_cli(["bench", "sweeps", str(folder), "--map", str(folder / "arena.yaml"), "--localisers",
                    "paper-pf", "--seeds", "0", "--out", str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no usable sweep" in err[0] and "0 readings" in err[0], err
    assert not (tmp_path / "none").exists()


def test_a_sweep_far_from_its_documented_waypoint_is_named(tmp_path: Path, caplog: pytest.LogCaptureFixture,
                                                           shipped_fit: dict) -> None:
    folder = _copy(tmp_path)
    rows = _rows(folder)
    (moved,) = [r for r in rows if r["file"] == "loc_01.dat"]
    moved.update(x_cm="126", y_cm="54")  # taken at (180, 30), documented at another waypoint of the course
    _write(folder, rows, list(rows[0]))
    with caplog.at_level(logging.WARNING):
        report = _fit(folder, tmp_path)
    assert report["sweeps"] == 3  # named, not dropped: the user decides
    named = [r.getMessage() for r in caplog.records if "does not fit its waypoint" in r.getMessage()]
    assert len(named) == 1 and "andrei-alpha/robotics/loc_01.dat" in named[0] and "(126, 54)" in named[0], named
    assert report["mean_log_likelihood"] < shipped_fit["mean_log_likelihood"]


def test_a_source_with_one_waypoint_is_left_out_of_routes_and_challenges_and_named(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    from toolkit.real_sonar.sweep_sonar import load_challenge_set

    folder = _copy(tmp_path)
    rows = [r for r in _rows(folder) if r["file"] != "loc_04.dat"]  # two waypoints: two short routes
    rows.append({**rows[0], "repo": "other/robot"})  # another robot that swept at (180, 30) only
    _write(folder, rows, list(rows[0]))
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING):
        code = run_cli(["bench", "routes", str(folder), "--map", str(folder / "arena.yaml"), "--localisers",
                        "paper-pf", "--seeds", "0", "--out", str(out)])
        load_challenge_set(folder, real_nxt_arena())
        challenge = run_cli(["bench", "challenge", str(folder), "--map", str(folder / "arena.yaml"), "--localisers",
                             "paper-pf", "--seeds", "0", "--out", str(tmp_path / "challenge")])
    assert code == 0 and challenge == 0
    summary = (tmp_path / "challenge" / "summary.md").read_text()
    assert "Left out (a challenge needs sweeps at two or more waypoints): other/robot" in summary
    assert "| paper-pf | all | 2 |" in summary  # andrei-alpha's two starts only
    with (out / "routes.csv").open() as fh:
        assert {r["repo"] for r in csv.DictReader(fh)} == {"andrei-alpha/robotics"}
    named = [r.getMessage() for r in caplog.records if "other/robot" in r.getMessage()]
    assert len(named) == 2 and all("one waypoint only (180, 30)" in n and "left out" in n for n in named), named
    assert "a route needs two" in named[0] and "a challenge needs two" in named[1]


def test_sweeps_without_headings_can_be_aligned_for_a_challenge(tmp_path: Path) -> None:
    from toolkit.bench.routes import aligned_headings
    from toolkit.real_sonar.sweep_sonar import load_challenge_set
    from toolkit.real_sonar.sweeps import SweepSetError, load_sweep_set

    folder = _copy(tmp_path)
    rows = _rows(folder)
    shipped = {r["file"]: float(r["heading_deg"]) for r in rows}
    _write(folder, rows, [c for c in rows[0] if c != "heading_deg"])  # a set like kentheo's: no headings
    with pytest.raises(SweepSetError, match="has no heading_deg"):
        load_challenge_set(folder, real_nxt_arena())
    headings = aligned_headings(load_sweep_set(folder, real_nxt_arena()))
    aligned = {sw.file: sw.heading_deg for sw in load_challenge_set(folder, real_nxt_arena(), headings)}
    assert aligned == pytest.approx(shipped, abs=1.0)  # found as the shipped column was
