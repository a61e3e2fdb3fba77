"""Sweep sets (`toolkit.real_sonar.sweeps`): the shipped MIT sweeps read as they are; bad input is one line naming
the file and the line or field."""

from __future__ import annotations

import csv
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, real_nxt_arena

from toolkit.real_sonar.sweeps import SweepSetError, load_sweep_set, sweep_angles
from toolkit.world import NO_ECHO, ConfigError, NxtnavError


def test_the_shipped_mit_set() -> None:
    ss = load_sweep_set(REAL_NXT, map=real_nxt_arena())
    assert len(ss) == 3 and ss.repos == ["andrei-alpha/robotics"]
    assert [s.file for s in ss] == ["loc_01.dat", "loc_03.dat", "loc_04.dat"]
    assert [(s.x_cm, s.y_cm) for s in ss] == [(180.0, 30.0), (126.0, 168.0), (30.0, 54.0)]
    for s in ss:
        assert s.readings.size == 360 and s.direction == "cw"
        assert s.extra["licence"] == "MIT" and s.extra["commit"].startswith("e4f0f30")
        assert np.allclose(np.diff(np.degrees(s.angles)), -1.0)  # clockwise: one degree less per reading
        assert s.angles[0] == 0.0
        scan = s.scan()
        assert len(scan) == 360  # no reading is left out: 255 is evidence, not a gap
        # the set declares held_runs = no-echo: the repeats of a held echo read as no echo as well
        assert s.held_runs == "no-echo" and s.held is not None
        no_echo = (s.readings == NO_ECHO) | s.held
        assert np.array_equal(~scan.valid, no_echo)
        assert np.all(scan.ranges[~scan.valid] == NO_ECHO)
        assert np.array_equal(scan.ranges[scan.valid], s.readings[~no_echo])
        assert s.no_echo_share == pytest.approx(no_echo.mean())
        held = np.flatnonzero(s.held)
        assert np.all(s.readings[held] == s.readings[held - 1])  # each held reading repeats the one before
        raw = (REAL_NXT / s.raw).read_text().split()
        assert [float(v) for v in raw] == s.readings.tolist()  # the file as it is, in the order taken
    # guard against a vacuous check above: loc_04 has 78 no-echo readings in its file (loc_01 and loc_03
    # none), and each sweep one long held run (its first reading stays an echo)
    assert [int(np.sum(s.readings == NO_ECHO)) for s in ss] == [0, 0, 78]
    assert [s.held_count for s in ss] == [108, 102, 136]
    assert int(np.sum(~ss.sweeps[2].scan().valid)) == 78 + 136


def test_sweep_angles_both_ways() -> None:
    assert np.allclose(np.degrees(sweep_angles(4, 5.0, "ccw", 10.0)), [10, 15, 20, 25])
    assert np.allclose(np.degrees(sweep_angles(4, 5.0, "cw", 180.0)), [180, 175, 170, 165])
    with pytest.raises(ConfigError, match="'cw' or 'ccw'"):
        sweep_angles(4, 5.0, "up")


def _copy(tmp_path: Path) -> Path:
    """A writable copy of the shipped set (the copy lives in a test's own folder)."""
    out = tmp_path / "set"
    shutil.copytree(REAL_NXT, out)
    return out


def _edit_table(folder: Path, edit: Callable[[list[list[str]]], None]) -> None:
    path = folder / "sweeps.csv"
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    edit(rows)
    with path.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)


def _set(rows: list[list[str]], line: int, column: str, value: str) -> None:
    rows[line - 1][rows[0].index(column)] = value


def _drop_column(rows: list[list[str]], column: str) -> None:
    i = rows[0].index(column)
    for r in rows:
        del r[i]


def _raw(folder: Path, name: str = "loc_03.dat") -> Path:
    return folder / "raw" / "andrei-alpha+robotics" / name


def _bad_line(folder: Path) -> None:
    p = _raw(folder)
    lines = p.read_text().splitlines()
    lines[41] = "4O"  # the letter O for a zero: line 42
    p.write_text("\n".join(lines) + "\n")


def _short_file(folder: Path) -> None:
    p = _raw(folder)
    p.write_text("\n".join(p.read_text().splitlines()[:359]) + "\n")


def _not_text(folder: Path) -> None:
    _raw(folder).write_bytes(bytes(range(256)))


# (how to break a copy of the shipped set, the file the message names, what else it must say)
BROKEN: list[tuple[str, Callable[[Path], None], str, str]] = [
    ("missing column", lambda f: _edit_table(f, lambda r: _drop_column(r, "direction")),
     "sweeps.csv:1", "missing column direction"),
    ("two missing columns", lambda f: _edit_table(f, lambda r: (_drop_column(r, "x_cm"), _drop_column(r, "raw"))),
     "sweeps.csv:1", "missing columns raw, x_cm"),
    ("short row", lambda f: _edit_table(f, lambda r: r[2].__delitem__(slice(10, None))),
     "sweeps.csv:3", "10 fields, but the header has 16 columns"),
    ("long row", lambda f: _edit_table(f, lambda r: r[3].append("x")),
     "sweeps.csv:4", "17 fields"),
    ("n_bins not whole", lambda f: _edit_table(f, lambda r: _set(r, 2, "n_bins", "360.5")),
     "sweeps.csv:2", "'n_bins' must be a whole number"),
    ("step zero", lambda f: _edit_table(f, lambda r: _set(r, 3, "step_deg", "0")),
     "sweeps.csv:3", "'step_deg' must be a positive number"),
    ("waypoint outside", lambda f: _edit_table(f, lambda r: _set(r, 4, "x_cm", "300")),
     "sweeps.csv:4", "waypoint (300, 54) lies outside the free space"),
    ("waypoint not a number", lambda f: _edit_table(f, lambda r: _set(r, 4, "y_cm", "north")),
     "sweeps.csv:4", "field 'y_cm' is not a number: 'north'"),
    ("bad direction", lambda f: _edit_table(f, lambda r: _set(r, 2, "direction", "clockwise")),
     "sweeps.csv:2", "field 'direction' must be 'cw' or 'ccw', got 'clockwise'"),
    ("empty raw", lambda f: _edit_table(f, lambda r: _set(r, 3, "raw", " ")),
     "sweeps.csv:3", "field 'raw' is empty"),
    ("empty repo", lambda f: _edit_table(f, lambda r: _set(r, 3, "repo", "")),
     "sweeps.csv:3", "field 'repo' is empty"),
    ("bad invalid values", lambda f: _edit_table(f, lambda r: _set(r, 2, "invalid_values", "255;none")),
     "sweeps.csv:2", "'invalid_values' is not a list of numbers"),
    ("no rows", lambda f: _edit_table(f, lambda r: r.__delitem__(slice(1, None))), "sweeps.csv", "no sweeps"),
    ("empty table", lambda f: (f / "sweeps.csv").write_text(""), "sweeps.csv", "empty file"),
    ("column twice", lambda f: _edit_table(f, lambda r: _set(r, 1, "licence", "repo")),
     "sweeps.csv:1", "column repo named more than once"),
    ("missing sweeps.csv", lambda f: (f / "sweeps.csv").unlink(), "sweeps.csv", "does not exist"),
]


# (how to break one sweep's readings file, the file the message names, what else it must say)
UNUSABLE: list[tuple[str, Callable[[Path], None], str, str]] = [
    ("non-numeric reading", _bad_line, "loc_03.dat:42", "not a number: '4O'"),
    ("wrong number of readings", _short_file, "loc_03.dat", "359 readings, but sweeps.csv says n_bins = 360"),
    ("raw file not text", _not_text, "loc_03.dat", "not UTF-8"),
    ("raw file missing", lambda f: _raw(f, "loc_04.dat").unlink(), "loc_04.dat", "cannot read the sweep file"),
    ("n_bins huge", lambda f: _edit_table(f, lambda r: _set(r, 2, "n_bins", "1e15")),
     "loc_01.dat", "360 readings, but sweeps.csv says n_bins = 1000000000000000"),
]


@pytest.mark.parametrize(("break_it", "where", "says"), [b[1:] for b in UNUSABLE], ids=[b[0] for b in UNUSABLE])
def test_a_sweep_whose_readings_cannot_be_used_is_left_out_and_named(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, break_it: Callable[[Path], None], where: str,
        says: str) -> None:
    folder = _copy(tmp_path)
    break_it(folder)
    sweeps = load_sweep_set(folder, map=real_nxt_arena())
    assert len(sweeps) == 2 and where.split(":")[0] not in {Path(s.raw).name for s in sweeps}
    (why,) = sweeps.left_out
    assert str(folder) in why and where in why and says in why, why
    assert any(why in r.getMessage() and "left out" in r.getMessage() for r in caplog.records), caplog.text
    for raw in (folder / "raw" / "andrei-alpha+robotics").glob("*.dat"):  # every sweep unusable: refused
        raw.write_text("x\n")
    with pytest.raises(SweepSetError, match=r"sweeps\.csv: no usable sweep: .*not a number: 'x'.*, and 2 more"):
        load_sweep_set(folder, map=real_nxt_arena())


def test_a_byte_order_mark_crlf_and_a_negative_invalid_value_are_read(tmp_path: Path) -> None:
    folder = _copy(tmp_path)
    def minus_one_invalid(rows: list[list[str]]) -> None:
        for line in (2, 3, 4):
            _set(rows, line, "invalid_values", "255;-1")

    _edit_table(folder, minus_one_invalid)
    table = folder / "sweeps.csv"
    table.write_bytes(b"\xef\xbb\xbf" + table.read_bytes().replace(b"\r\n", b"\n").replace(b"\n", b"\r\n"))
    raw = _raw(folder)
    lines = raw.read_text().splitlines()
    lines[41] = "-1"
    raw.write_text("\r\n".join(lines) + "\r\n")
    sweeps = load_sweep_set(folder, map=real_nxt_arena())
    assert [s.label for s in sweeps] == [s.label for s in load_sweep_set(REAL_NXT, map=real_nxt_arena())]
    (at_03,) = [s for s in sweeps if s.file == "loc_03.dat"]
    assert at_03.missing.sum() == 1 and len(at_03.scan()) == 359


@pytest.mark.parametrize(("break_it", "where", "says"), [b[1:] for b in BROKEN], ids=[b[0] for b in BROKEN])
def test_bad_sweep_sets_say_where(tmp_path: Path, break_it: Callable[[Path], None], where: str, says: str) -> None:
    folder = _copy(tmp_path)
    load_sweep_set(folder, map=real_nxt_arena())  # the copy is good before it is broken
    break_it(folder)
    with pytest.raises(SweepSetError) as err:
        load_sweep_set(folder, map=real_nxt_arena())
    msg = str(err.value)
    assert isinstance(err.value, NxtnavError)
    assert "\n" not in msg
    assert str(folder) in msg and where in msg and says in msg, msg


def test_line_numbers_count_blank_lines(tmp_path: Path) -> None:
    folder = _copy(tmp_path)
    text = (folder / "sweeps.csv").read_text().splitlines()
    text.insert(2, "")  # a blank line before the second sweep: its row is now on line 4
    (folder / "sweeps.csv").write_text("\n".join(text) + "\n")
    assert len(load_sweep_set(folder, map=real_nxt_arena())) == 3
    _edit_table(folder, lambda r: _set(r, 4, "direction", "up"))  # csv.reader: the blank row is row 3
    with pytest.raises(SweepSetError, match=r"sweeps\.csv:4: field 'direction'"):
        load_sweep_set(folder, map=real_nxt_arena())


def test_no_map_is_named(tmp_path: Path) -> None:
    folder = _copy(tmp_path)
    (folder / "arena.yaml").unlink(missing_ok=True)
    with pytest.raises(SweepSetError, match=r"no arena\.yaml; name the map with --map"):
        load_sweep_set(folder)
