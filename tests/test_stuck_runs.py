"""A stuck sonar told from a wall: runs of equal readings judged against the map's echoes
(`localisation.stuck`), on simulated sweeps, on real stuck sweeps, and through `nxtnav import sweeps`
and `nxtnav replay` as a user runs them."""

from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, kept_run, nxtnav_exe, real_nxt_arena

from localisation.scan import drop_stuck, stuck_mask, sweep_fault
from localisation.stuck import NO_MAP_STUCK_ARC_DEG, STUCK_ARC_DEG, echo_table, equal_runs, judge_runs
from toolkit.real_sonar.sweeps import load_sweep_set, sweep_angles
from toolkit.world import NO_ECHO, Map, NxtSonar, Scan, load_map

STUCK_DATA = Path(__file__).parent / "data" / "real-nxt-stuck"
"""Two real MIT-licensed sweeps whose sensor stopped refreshing (their README)."""
CORNER = (180.0, 30.0)
"""The arena waypoint 30 cm from two walls (cm)."""


def _simulated(m: Map, xy: tuple[float, float], heading_deg: float = 0.0) -> Scan:
    """A noise-free sweep (360 readings, one a degree, counter-clockwise from the heading) of the `nxt`
    sonar's lobe at `xy`: each reading the model's echo rounded to whole cm, 255 where nothing echoes."""
    angles = sweep_angles(360, 1.0, "ccw", 0.0)
    echo = np.asarray(NxtSonar().echo_distance(m.walls, np.asarray(xy), math.radians(heading_deg) + angles))
    ranges = np.where(np.isfinite(echo), np.rint(echo), NO_ECHO)
    return Scan(angles, ranges, ranges < NO_ECHO)


def _corner_sweep() -> tuple[Scan, slice]:
    """The simulated sweep at (180, 30) of the arena with its corner read as one value, 32 cm, over the
    arc where the lobe's echo lies within 30-35 cm (what a real sensor reads there), and that arc."""
    scan = _simulated(real_nxt_arena(), CORNER)
    near = (scan.ranges >= 30) & (scan.ranges <= 35)
    # the sweep starts facing the right wall: the corner arc wraps around reading 0; rotate it to start there
    first = int(np.flatnonzero(~near)[-1]) + 1
    order = np.r_[first:360, 0:first]
    rolled = Scan(scan.angles[order], scan.ranges[order], scan.valid[order])
    length = int(np.argmin(near[order]))
    ranges = rolled.ranges.copy()
    ranges[:length] = 32.0
    return Scan(rolled.angles, ranges, rolled.valid), slice(0, length)


def test_a_corner_read_as_one_value_over_a_long_arc_is_kept() -> None:
    scan, arc = _corner_sweep()
    runs = equal_runs(scan)
    assert runs[0].length == arc.stop >= 150  # a long physical run (guard); the noise-free top wall holds more
    assert min(r.arc_deg for r in runs) >= STUCK_ARC_DEG  # what the run-length rule alone dropped
    m = real_nxt_arena()
    assert not stuck_mask(scan, m).any()  # every pose of the map
    assert not stuck_mask(scan, m, position=CORNER).any()  # at its waypoint
    assert not stuck_mask(scan).any()  # no map: only runs longer than a wall can hold
    assert sweep_fault(scan, m) is None
    kept, dropped = drop_stuck(scan, m)
    assert dropped == 0 and len(kept) == 360


def test_a_run_the_walls_do_not_explain_is_stuck() -> None:
    """The corner sweep again, with 120 degrees facing away from the corner stuck at 20 cm (no wall lies
    nearer than 30 cm): stuck with or without the waypoint; without a map, too short to tell."""
    scan, arc = _corner_sweep()
    ranges = scan.ranges.copy()
    held = slice(arc.stop + 20, arc.stop + 140)
    ranges[held] = 20.0
    spoiled = Scan(scan.angles, ranges, np.ones(360, dtype=bool))
    m = real_nxt_arena()
    for position in (None, CORNER):
        stuck, explained = judge_runs(spoiled, m, position=position)
        assert [(r.start, r.length, r.value_cm) for r in stuck] == [(held.start, 120, 20.0)]
        assert [r.length for r in explained] == [arc.stop]  # the corner stays
    assert not stuck_mask(spoiled).any()  # 120 degrees: a wall could hold it, as far as run length says
    fault = sweep_fault(spoiled, m)
    assert fault is not None and fault.startswith("stuck: the sonar repeated 20 cm over 120 readings (45 degrees")
    kept, dropped = drop_stuck(spoiled, m)
    assert dropped == 120 and not np.any(kept.ranges == 20.0)


def test_a_run_longer_than_any_wall_holds_is_stuck_without_a_map() -> None:
    scan, arc = _corner_sweep()
    ranges = scan.ranges.copy()
    assert arc.stop < NO_MAP_STUCK_ARC_DEG <= 210
    ranges[100:310] = 61.0  # 210 degrees of one value (the corner keeps its first 100)
    spoiled = Scan(scan.angles, ranges, np.ones(360, dtype=bool))
    assert np.flatnonzero(stuck_mask(spoiled)).tolist() == list(range(100, 310))


@pytest.mark.parametrize(("file", "waypoint", "value", "length"), [
    ("loc_00.dat", (84.0, 30.0), 88.0, 160),
    ("loc_02.dat", (126.0, 54.0), 55.0, 250),
])
def test_real_stuck_sweeps_are_caught(file: str, waypoint: tuple[float, float], value: float, length: int) -> None:
    readings = np.array([float(v) for v in (STUCK_DATA / file).read_text().split()])
    scan = Scan(sweep_angles(360, 1.0, "cw", 0.0), readings, readings < NO_ECHO)
    m = real_nxt_arena()
    for position in (waypoint, None):
        stuck, _ = judge_runs(scan, m, position=position)
        assert [(r.value_cm, r.length) for r in stuck] == [(value, length)]
        assert stuck[0].start + stuck[0].length == 360  # the sweep's last readings


def test_the_shipped_sweeps_hold_their_last_echo_and_read_it_as_no_echo() -> None:
    """The three shipped sweeps hold runs of one value over 103-137 degrees, which the walls do not
    explain at their waypoints, and never read no echo after their first echo: the sensor repeated its
    last echo. Their source says so (``held_runs`` ``no-echo``): each run's repeats are read as no echo,
    its first reading stays an echo, and nothing is left for the stuck check to drop."""
    sweeps = load_sweep_set(REAL_NXT)
    for sw in sweeps:
        assert sw.held_runs == "no-echo"
        raw = Scan(sw.angles, sw.readings, sw.readings < NO_ECHO)  # the file as it is
        (run,) = equal_runs(raw)
        assert run.length == {"loc_01.dat": 109, "loc_03.dat": 103, "loc_04.dat": 137}[sw.file]
        first_echo = int(np.argmax(raw.valid))
        assert raw.valid[first_echo:].all()  # no 255 after the first echo
        stuck, _ = judge_runs(raw, sweeps.map, position=(sw.x_cm, sw.y_cm))
        assert stuck == [run]
        assert sw.held is not None and np.flatnonzero(sw.held).tolist() == list(
            range(run.start + 1, run.start + run.length))
        scan = sw.scan()
        assert len(scan) == 360 and scan.valid[run.start] and scan.ranges[run.start] == run.value_cm
        assert not scan.valid[run.start + 1:run.start + run.length].any()
        assert np.all(scan.ranges[run.start + 1:run.start + run.length] == NO_ECHO)
        assert equal_runs(scan) == [] and drop_stuck(scan, sweeps.map)[1] == 0


def _without_held_runs(folder: Path, value: str | None = None) -> Path:
    """A copy of the shipped set in `folder` whose sweeps.csv has no ``held_runs`` column (or `value` in it)."""
    shutil.copytree(REAL_NXT, folder)
    with (folder / "sweeps.csv").open(newline="") as fh:
        rows = list(csv.reader(fh))
    k = rows[0].index("held_runs")
    for row in rows:
        if value is None:
            del row[k]
        elif row is not rows[0]:
            row[k] = value
    with (folder / "sweeps.csv").open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)
    return folder


def test_a_set_without_the_column_reads_the_runs_as_before(tmp_path: Path) -> None:
    """No ``held_runs`` (or ``stuck``): the files are read as they are, and the runs are stuck."""
    for folder in (_without_held_runs(tmp_path / "none"), _without_held_runs(tmp_path / "stuck", "stuck")):
        sweeps = load_sweep_set(folder)
        for sw in sweeps:
            assert sw.held_runs == "stuck" and sw.held is None and sw.held_count == 0
            scan = sw.scan()
            assert np.array_equal(scan.ranges, sw.readings)
            stuck, _ = judge_runs(scan, sweeps.map, position=(sw.x_cm, sw.y_cm))
            assert [r.length for r in stuck] == [{"loc_01.dat": 109, "loc_03.dat": 103, "loc_04.dat": 137}[sw.file]]


def test_the_echo_table_is_the_sonar_models_lobe() -> None:
    """The table's echoes are `NxtSonar.echo_distance` with its lobe sampled every degree."""
    m = load_map("map1")
    table = echo_table(m)
    rng = np.random.default_rng(2)
    rows, dirs = rng.integers(0, len(table.xy), 40), rng.integers(0, 360, 40)
    fine = NxtSonar(beam_rays=41)  # one ray a degree over the 40-degree lobe
    direct = [float(fine.echo_distance(m.walls, table.xy[r], math.radians(d))) for r, d in zip(rows, dirs, strict=True)]
    np.testing.assert_allclose(table.echo_cm[rows, dirs], direct, rtol=1e-5)
    assert np.all(table.nearest_cm <= table.echo_cm)  # no echo comes from nearer than the nearest surface
    assert bool(np.all(m.is_free(table.xy)))


def _sweep_set(folder: Path, scans: list[tuple[str, Scan]]) -> Path:
    """A sweep set in `folder`: the arena and one 360-reading counter-clockwise sweep per (file, scan)
    at the corner waypoint."""
    folder.mkdir()
    shutil.copy(REAL_NXT / "arena.yaml", folder / "arena.yaml")
    with (folder / "sweeps.csv").open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["repo", "file", "raw", "x_cm", "y_cm", "n_bins", "step_deg", "direction", "start_deg"])
        for name, scan in scans:
            start = math.degrees(float(scan.angles[0]))
            (folder / name).write_text("".join(f"{int(v)}\n" for v in scan.ranges))
            out.writerow(["simulated", name, name, *CORNER, 360, 1.0, "ccw", f"{start:.6f}"])
    return folder


def _nxtnav(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([nxtnav_exe(), *args], cwd=cwd, capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_import_and_replay_keep_a_physical_run_and_drop_a_stuck_one(tmp_path: Path) -> None:
    """The user's path on a sweep set: `nxtnav import sweeps`, then `nxtnav replay` with the trial's
    localisers. The corner read as one value is used without a word; the same sweep with an arc stuck
    at 20 cm is said once, with its reason."""
    corner, _ = _corner_sweep()
    ranges = corner.ranges.copy()
    ranges[200:320] = 20.0
    spoiled = Scan(corner.angles, ranges, ranges < NO_ECHO)
    sweeps = _sweep_set(tmp_path / "sweeps", [("corner.dat", corner), ("spoiled.dat", spoiled)])
    imported = _nxtnav("import", "sweeps", str(sweeps), "-o", "sim.jsonl", cwd=tmp_path)
    assert imported.returncode == 0, imported.stderr
    replayed = _nxtnav("replay", "sim.jsonl", "--localisers", "paper-pf,amcl", "--json", "replay.json", cwd=tmp_path)
    assert replayed.returncode == 0, replayed.stderr
    assert "Traceback" not in replayed.stderr
    warnings = [line for line in replayed.stderr.splitlines() if "stuck sonar" in line]
    assert len(warnings) == 1, replayed.stderr  # the spoiled sweep, once for both localisers
    assert "120 readings repeat 20 cm" in warnings[0] and "the map's walls do not explain" in warnings[0]
    assert (tmp_path / "replay.json").is_file()


def _ran_cleanly(imported: subprocess.CompletedProcess[str],
                 replayed: subprocess.CompletedProcess[str]) -> tuple[subprocess.CompletedProcess[str],
                                                                      subprocess.CompletedProcess[str]]:
    assert imported.returncode == 0, imported.stderr
    assert replayed.returncode == 0, replayed.stderr
    assert "Traceback" not in replayed.stderr
    return imported, replayed


def _replay(folder: Path, cwd: Path) -> tuple[subprocess.CompletedProcess[str], subprocess.CompletedProcess[str]]:
    """The trial's commands on a sweep set: `nxtnav import sweeps`, then `nxtnav replay` with paper-pf and amcl."""
    imported = _nxtnav("import", "sweeps", str(folder), "-o", "real.jsonl", cwd=cwd)
    replayed = _nxtnav("replay", "real.jsonl", "--localisers", "paper-pf,amcl", "--json", "replay.json", cwd=cwd)
    return _ran_cleanly(imported, replayed)


@pytest.mark.slow
def test_import_and_replay_of_the_shipped_sweeps_keep_every_reading(shipped_sweeps_replayed: Path) -> None:
    """The trial's commands on the shipped set: the held repeats travel as no echo (said by the import),
    no reading is dropped as stuck and no warning is given; the two sweeps that are not at a twin of
    their place are found, and the one at (180, 30) is not claimed as converged. The two commands are
    `_replay`'s on REAL_NXT, run once for this test and test_replay_explains.py (conftest)."""
    folder = shipped_sweeps_replayed
    imported, replayed = _ran_cleanly(kept_run(folder, "import"), kept_run(folder, "replay"))
    assert "(424 no-echo, 39%; 346 of them repeat a held echo: held_runs = no-echo)" in imported.stdout
    scans = [json.loads(line) for line in (folder / "real.jsonl").read_text().splitlines()]
    scans = [e for e in scans if e.get("type") == "scan"]
    assert [len(e["ranges_cm"]) for e in scans] == [360] * 3
    assert [len(e["invalid"]) for e in scans] == [108, 102, 78 + 136]
    assert "stuck" not in replayed.stderr, replayed.stderr
    doc = json.loads((folder / "replay.json").read_text())
    ups = {s["label"].rsplit("/", 1)[1]: s["estimates"] for s in doc["steps"] if s["call"] == "update"}
    for name in ("paper-pf", "amcl"):
        assert ups["loc_03.dat"][name]["error_cm"] < 10.0 and ups["loc_04.dat"][name]["error_cm"] < 10.0
        assert ups["loc_01.dat"][name]["converged"] is False


@pytest.mark.slow
def test_import_and_replay_of_a_set_without_the_column_name_each_stuck_run_once(tmp_path: Path) -> None:
    """The same sweeps without ``held_runs``: each sweep's run is said once (not once per localiser),
    with the reason, and the replay completes."""
    _, replayed = _replay(_without_held_runs(tmp_path / "set"), tmp_path)
    warnings = [line for line in replayed.stderr.splitlines() if "stuck sonar" in line]
    assert [w.split("stuck sonar: ")[1].split(" over")[0] for w in warnings] == [
        "109 readings repeat 33 cm", "103 readings repeat 44 cm", "137 readings repeat 36 cm"]
    assert all("the map's walls do not explain" in w for w in warnings)


@pytest.mark.slow
def test_import_and_replay_catch_the_real_stuck_sweeps(tmp_path: Path) -> None:
    """The two real sweeps whose sensor stopped refreshing, as a sweep set of their own (no ``held_runs``):
    imported as they are, and their stuck runs dropped by the replay, each said once."""
    folder = tmp_path / "stuck"
    folder.mkdir()
    shutil.copy(REAL_NXT / "arena.yaml", folder / "arena.yaml")
    with (folder / "sweeps.csv").open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["repo", "file", "raw", "x_cm", "y_cm", "n_bins", "step_deg", "direction", "start_deg"])
        for name, (x, y) in (("loc_00.dat", (84, 30)), ("loc_02.dat", (126, 54))):
            shutil.copy(STUCK_DATA / name, folder / name)
            out.writerow(["andrei-alpha/robotics", name, name, x, y, 360, 1.0, "cw", 0.0])
    imported, replayed = _replay(folder, tmp_path)
    assert "held echo" not in imported.stdout
    warnings = [line for line in replayed.stderr.splitlines() if "stuck sonar" in line]
    assert [w.split("stuck sonar: ")[1].split(" over")[0] for w in warnings] == [
        "160 readings repeat 88 cm", "250 readings repeat 55 cm"]


def test_a_stuck_sweep_turned_by_whole_bins_is_said_once(caplog: pytest.LogCaptureFixture,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The challenge hands back one real sweep turned by whole bins at every visit (its turret angles turned):
    its stuck run is the same run, said once; another sweep's is said too."""
    arena = load_map(REAL_NXT / "arena.yaml")
    sweeps = {name: np.loadtxt(STUCK_DATA / name) for name in ("loc_00.dat", "loc_02.dat")}
    angles = sweep_angles(360, 1.0, "cw", 0.0)
    monkeypatch.setattr("localisation.scan._WARNED", {})  # what this process said before is not this test's
    caplog.set_level("WARNING", logger="localisation.scan")
    for name, (x, y) in (("loc_00.dat", (84.0, 30.0)), ("loc_02.dat", (126.0, 54.0))):
        ranges = sweeps[name]
        for turn in (0.0, 7.0, 90.0):  # the challenge turns a sweep's turret angles by whole bins
            _, dropped = drop_stuck(Scan(angles + np.radians(turn), ranges, ranges < NO_ECHO), arena, position=(x, y))
            assert dropped > 0
    said = [r.getMessage() for r in caplog.records if "stuck sonar" in r.getMessage()]
    assert len(said) == 2, said


def test_an_echo_table_is_kept_on_disk_and_read_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                     caplog: pytest.LogCaptureFixture) -> None:
    """With ``$NXTNAV_CACHE_DIR``, a table built is written there and a new process (here: an empty memory
    cache) reads the same arrays back; an unreadable file is said and built again."""
    from localisation import stuck

    monkeypatch.setenv("NXTNAV_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(stuck, "_TABLES", {})
    m = load_map("map1")
    built = stuck.echo_table(m)
    files = list(tmp_path.glob("echo_table_*.npz"))
    assert len(files) == 1
    monkeypatch.setattr(stuck, "_TABLES", {})
    read = stuck.echo_table(m)
    assert read is not built
    for field in ("xy", "nearest_cm", "echo_cm"):
        assert np.array_equal(getattr(read, field), getattr(built, field)), field
    assert read.spacing_cm == built.spacing_cm
    files[0].write_bytes(b"not a table")
    monkeypatch.setattr(stuck, "_TABLES", {})
    again = stuck.echo_table(m)
    assert np.array_equal(again.echo_cm, built.echo_cm)
    assert any("ignoring unreadable echo table cache" in r.getMessage() for r in caplog.records)
