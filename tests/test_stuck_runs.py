"""A stuck sonar told from a wall: runs of equal readings judged against the map's echoes
(`localisation.stuck`), on simulated sweeps, on real stuck sweeps, and through `nxtnav import sweeps`
and `nxtnav replay` as a user runs them."""

from __future__ import annotations

import csv
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import REAL_NXT, nxtnav_exe, real_nxt_arena

from localisation.scan import drop_stuck, stuck_mask, sweep_fault
from localisation.stuck import NO_MAP_STUCK_ARC_DEG, STUCK_ARC_DEG, echo_table, equal_runs, judge_runs
from toolkit.sweeps import load_sweep_set, sweep_angles
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


def test_the_shipped_sweeps_long_runs_are_not_what_the_walls_echo() -> None:
    """The three shipped sweeps hold runs of one value over 103-137 degrees. At their waypoints the pose
    their other readings point to leaves most of each run facing no wall within reach, or only far ones:
    the sensor repeated its last echo. It never reads no-echo after its first echo."""
    sweeps = load_sweep_set(REAL_NXT)
    for sw in sweeps:
        scan = sw.scan()
        runs = equal_runs(scan)
        assert [r.length for r in runs] == [{"loc_01.dat": 109, "loc_03.dat": 103, "loc_04.dat": 137}[sw.file]]
        first_echo = int(np.argmax(scan.valid))
        assert scan.valid[first_echo:].all()  # no 255 after the first echo
        stuck, _ = judge_runs(scan, sweeps.map, position=(sw.x_cm, sw.y_cm))
        assert stuck == runs


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


@pytest.mark.slow
def test_import_and_replay_of_the_shipped_sweeps_name_each_held_run_once(tmp_path: Path) -> None:
    """The trial's commands on the shipped set: each sweep's held run is said once (not once per
    localiser), with the reason, and the replay completes."""
    imported = _nxtnav("import", "sweeps", str(REAL_NXT), "-o", "real.jsonl", cwd=tmp_path)
    assert imported.returncode == 0, imported.stderr
    replayed = _nxtnav("replay", "real.jsonl", "--localisers", "paper-pf,amcl", "--json", "replay.json", cwd=tmp_path)
    assert replayed.returncode == 0, replayed.stderr
    warnings = [line for line in replayed.stderr.splitlines() if "stuck sonar" in line]
    assert [w.split("stuck sonar: ")[1].split(" over")[0] for w in warnings] == [
        "109 readings repeat 33 cm", "103 readings repeat 44 cm", "137 readings repeat 36 cm"]
    assert all("the map's walls do not explain" in w for w in warnings)
