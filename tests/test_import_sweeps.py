"""`nxtnav import sweeps`: a sweep set as a recording of global-localisation episodes, scored by
`nxtnav replay` on position only (a real sweep's heading is not known)."""

from __future__ import annotations

import csv
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import REAL_NXT, real_nxt_arena, run_cli

import localisation  # noqa: F401  (registers every localiser)
from localisation.base import make_localiser
from toolkit.mission import localiser_options
from toolkit.real_sonar.sweeps import load_sweep_set
from toolkit.recordings.imported import import_sweep_set
from toolkit.recordings.recorder import FORMAT_VERSION, Recorder
from toolkit.recordings.replay import RecordingError, read_recording, replay
from toolkit.world import NO_ECHO, Map, RobotModel, load_map, make_sonar


def _map_args(tmp_path: Path) -> list[str]:
    """``--map`` for the shipped set: none when the folder has its arena.yaml, else the outer walls."""
    if (REAL_NXT / "arena.yaml").is_file():
        return []
    path = tmp_path / "arena.yaml"
    m = real_nxt_arena()
    path.write_text(yaml.safe_dump({"name": m.name, "boundary": m.boundary.tolist()}))
    return ["--map", str(path)]


def _import(tmp_path: Path, folder: Path = REAL_NXT) -> Path:
    rec = tmp_path / "real-nxt.jsonl"
    assert run_cli(["import", "sweeps", str(folder), *_map_args(tmp_path), "-o", str(rec)]) == 0
    return rec


def test_the_recording_holds_one_episode_per_sweep(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _import(tmp_path)
    assert "3 sweeps on map" in capsys.readouterr().out
    rec = read_recording(path)
    assert rec.truncated is None and rec.localiser is None
    assert rec.header["version"] == FORMAT_VERSION
    assert rec.header["sonar"]["model"] == "nxt" and rec.header["seed"] is None
    assert [s["label"] for s in rec.header["source"]["sweeps"]] == [
        f"andrei-alpha/robotics/loc_0{k}.dat" for k in (1, 3, 4)]
    assert all("heading_deg" not in s for s in rec.header["source"]["sweeps"])  # the aligned heading is no truth
    kinds = [e["type"] for _, e in rec.events]
    assert kinds == ["scan", "reset", "update"] * 3 + ["end"]
    sweeps = load_sweep_set(REAL_NXT, map=rec.map)
    scans = [e for _, e in rec.events if e["type"] == "scan"]
    for sweep, e in zip(sweeps, scans, strict=True):
        assert e["true_pose"] == [sweep.x_cm, sweep.y_cm, None]
        assert e["t"] is None and e["t_start"] is None and e["label"] == sweep.label
        assert len(e["ranges_cm"]) == 360
    assert all(e["prior"] is None for _, e in rec.events if e["type"] == "reset")
    assert [e["index"] for _, e in rec.events if e["type"] == "update"] == [list(range(360))] * 3


def test_replay_scores_position_only_and_repeats_itself(tmp_path: Path) -> None:
    path = _import(tmp_path)
    docs = []
    for k in range(2):
        js = tmp_path / f"replay{k}.json"
        assert run_cli(["replay", str(path), "--localisers", "paper-pf", "--json", str(js)]) == 0
        doc = json.loads(js.read_text())
        for row in doc["summary"].values():
            row.pop("cpu_s")  # timings aside
        docs.append(doc)
    assert docs[0] == docs[1]  # seeded: the same numbers twice
    doc = docs[0]
    assert doc["truth"] is True and doc["truth_heading"] is False
    ups = [s for s in doc["steps"] if s["call"] == "update"]
    assert [s["truth"] for s in ups] == [[180.0, 30.0, None], [126.0, 168.0, None], [30.0, 54.0, None]]
    for s in ups:
        e = s["estimates"]["paper-pf"]
        assert isinstance(e["error_cm"], float) and math.isfinite(e["error_cm"])
        assert e["heading_error_deg"] is None
        assert e["error_cm"] == pytest.approx(math.dist(e["pose"][:2], s["truth"][:2]))
    summary = doc["summary"]["paper-pf"]
    assert summary["updates"] == 3 and summary["final_heading_error_deg"] is None
    assert math.isfinite(summary["rmse_cm"]) and math.isfinite(summary["median_error_cm"])


@pytest.mark.parametrize("extra", [{}, {"n_particles": 700}])
def test_replay_is_a_global_reset_and_one_update_per_sweep(tmp_path: Path, extra: dict[str, int]) -> None:
    """The replayed estimates are, bit for bit, those of paper-pf with the options matched to the nxt
    sonar (and the replay's `options` on top), reset globally and given each sweep's scan (guards the
    episodes' shape and the options)."""
    rec = read_recording(_import(tmp_path))
    report = replay(rec, ["paper-pf"], seed=5, options={"paper-pf": extra})
    real = RobotModel.build("nxt", readings="real")
    loc = make_localiser("paper-pf", rec.map, rng=5, **{**localiser_options("paper-pf", real), **extra})
    ups = [s for s in report.steps if s.call == "update"]
    for sweep, step in zip(load_sweep_set(REAL_NXT, map=rec.map), ups, strict=True):
        loc.reset(None)
        loc.update(sweep.scan())
        got = step.estimates["paper-pf"]
        assert got is not None
        assert got.pose == loc.estimate().pose and np.array_equal(got.cov, loc.estimate().cov)
        assert step.label == sweep.label and not step.truth_heading
        assert math.isnan(step.heading_error_deg("paper-pf"))


def _simulated_set(tmp_path: Path, m: Map) -> Path:
    """The shipped set's waypoints and angles with readings of the simulated nxt sonar, at the heading
    that best aligns each real sweep (``heading_deg``)."""
    out = tmp_path / "simulated"
    out.mkdir()
    shutil.copy(REAL_NXT / "sweeps.csv", out / "sweeps.csv")
    with (out / "sweeps.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    sonar = make_sonar("nxt")
    for k, (row, sweep) in enumerate(zip(rows, load_sweep_set(REAL_NXT, map=m), strict=True)):
        heading = math.radians(float(row["heading_deg"]))
        readings = sonar.measure(m.walls, [sweep.x_cm, sweep.y_cm], heading + sweep.angles, rng=k)
        raw = out / row["raw"]
        raw.parent.mkdir(parents=True, exist_ok=True)
        raw.write_text("".join(f"{int(v)}\n" for v in readings))
    return out


@pytest.mark.slow
def test_simulated_sweeps_at_the_same_poses_are_found(tmp_path: Path) -> None:
    """A guard against a scoring or angle slip: readings simulated at the waypoints, at the same angles,
    put paper-pf on the waypoint (it is the real readings that are hard, not the plumbing)."""
    m = real_nxt_arena()
    path = tmp_path / "sim.jsonl"
    imported = import_sweep_set(load_sweep_set(_simulated_set(tmp_path, m), map=m), path)
    assert imported.episodes == 3 and imported.readings == 1080
    report = replay(read_recording(path), ["paper-pf"])
    errors = [s.error_cm("paper-pf") for s in report.steps if s.call == "update"]
    assert len(errors) == 3 and max(errors) < 5.0, errors


def test_no_echo_readings_travel_as_invalid_255s(tmp_path: Path) -> None:
    """loc_04's 78 no-echo readings of the file, then the repeats of its held 36 cm (readings 224-359; the
    set's ``held_runs`` is ``no-echo``): all invalid 255s in the recording."""
    rec = read_recording(_import(tmp_path))
    loc04 = [e for _, e in rec.events if e["type"] == "scan"][2]
    assert loc04["invalid"] == [*range(78), *range(224, 360)]
    assert all(loc04["ranges_cm"][i] == NO_ECHO for i in loc04["invalid"])
    assert loc04["ranges_cm"][223] == 36.0  # the held run's first reading is a measured echo


def _write(tmp_path: Path, version: int, scan_fields: str) -> Path:
    m = load_map("map1")
    path = tmp_path / "r.jsonl"
    with path.open("w") as fh:
        Recorder(fh, map=m, robot={"kind": "nxt"}, sonar={"model": "nxt"}, seed=None)
    head = json.loads(path.read_text())
    head["version"] = version
    scan = ('{"type":"scan","id":0,' + scan_fields + ',"angles_rad":[0.0,1.0],"ranges_cm":[10.0,20.0],'
            '"invalid":[]}')
    path.write_text(json.dumps(head) + "\n" + scan + '\n{"type":"end","status":null,"success":null}\n')
    return path


@pytest.mark.parametrize(("version", "fields", "message"), [
    (1, '"t_start":0,"t":1,"true_pose":[20,20,null]', "null heading, which needs format version 2"),
    (1, '"t_start":null,"t":null,"true_pose":[20,20,0]', "field 't' must be a number, got null"),
    (2, '"t_start":null,"t":null,"true_pose":[20,null,null]', "field 'true_pose': item 1"),
    (2, '"t_start":null,"t":null,"true_pose":[20,20,null],"label":7', "field 'label' must be a string"),
    (FORMAT_VERSION + 1, '"t_start":0,"t":1,"true_pose":null', f"format version {FORMAT_VERSION + 1} is not"),
])
def test_version_2_fields_are_checked(tmp_path: Path, version: int, fields: str, message: str) -> None:
    with pytest.raises(RecordingError, match=message):
        read_recording(_write(tmp_path, version, fields))


def test_version_2_fields_read(tmp_path: Path) -> None:
    rec = read_recording(_write(tmp_path, 2, '"t_start":null,"t":null,"true_pose":[20,20,null],"label":"x"'))
    assert rec.truncated is None and rec.calls == 0


def test_a_null_clock_is_only_for_scans(tmp_path: Path) -> None:
    path = _write(tmp_path, 2, '"t_start":0,"t":1,"true_pose":null')
    lines = path.read_text().splitlines()
    lines.insert(1, '{"type":"turn","t":null,"angle_rad":0.1,"odometry":null,"true_pose":null}')
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match="line 2: field 't' must be a number"):
        read_recording(path)


@pytest.mark.parametrize(("args", "needle"), [
    (["import", "sweeps", "nowhere", "-o", "r.jsonl"], "nowhere/sweeps.csv: does not exist"),
    (["import", "sweeps", str(REAL_NXT), "--map", "nomap", "-o", "r.jsonl"], "unknown map 'nomap'"),
    (["import", "sweeps", str(REAL_NXT), "--map", "map1", "-o", "r.jsonl"], "outside the free space of map 'map1'"),
    (["import", "sweeps", str(REAL_NXT), "--map", "map1", "-o", "blocker/r.jsonl"], "--output"),
    (["import", "sweeps", "held", "-o", "r.jsonl"], "sweeps.csv:2: field 'held_runs' must be 'stuck' or 'no-echo', "
                                                     "got 'maybe'"),
])
def test_import_bad_input_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str], args: list[str], needle: str) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "blocker").write_text("a file where a folder is expected")
    shutil.copytree(REAL_NXT, tmp_path / "held")  # the shipped set, its first sweep's held_runs unknown
    table = tmp_path / "held" / "sweeps.csv"
    table.write_text(table.read_text().replace(",no-echo,", ",maybe,", 1))
    assert run_cli(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nxtnav: error:") and needle in err[0], err
    assert not (tmp_path / "r.jsonl").exists()
