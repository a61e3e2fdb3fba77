"""Recordings the way the documentation uses them, through the real `nxtnav` command in a temporary
folder outside the repository: record then replay (README), export and import back (docs/recording.md,
docs/ros-bags.md), a recording cut short, the /scan limits of an NXT export, outputs that cannot be
written, and the replay's progress.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import built_once, kept_run, nxtnav_exe, run_cli

from toolkit.recordings.recorder import scan_from_fields
from toolkit.recordings.replay import read_recording

pytestmark = pytest.mark.xdist_group("readme-recording")  # one worker: `work` built once, none waiting on its lock

EXE = nxtnav_exe()
LOCALISERS = "amcl,paper-pf,pf-systematic"
F32 = float(np.finfo(np.float32).eps)


def _nxtnav(*args: str, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    proc = subprocess.run([EXE, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)
    assert "Traceback" not in proc.stderr, proc.stderr
    return proc


def _one_error_line(proc: subprocess.CompletedProcess[str]) -> str:
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and lines[0].startswith("nxtnav: error: "), proc.stderr
    return lines[0]


def _record_and_replay(folder: Path) -> None:
    """The README's two commands in `folder`, what each gave kept (`kept_run`): the recording and its replay."""
    kept_run(folder, "run", [EXE, "run", "--map", "map1", "--localiser", "amcl", "--record", "run.jsonl"])
    kept_run(folder, "replay", [EXE, "replay", "run.jsonl", "--localisers", LOCALISERS, "--json", "replay.json",
                                "-o", "replay.png"])


@pytest.fixture(scope="module")
def work(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder outside the repository holding the README's recording: ``nxtnav run --map map1
    --localiser amcl --record run.jsonl`` (a path of about 1 m, five scans), and its replay (`replayed`).

    Both commands run once per test run (`built_once`); each worker's tests write in a copy of that folder."""
    folder = tmp_path_factory.mktemp("user-paths")
    shutil.copytree(built_once(tmp_path_factory, "readme-recording", _record_and_replay), folder, dirs_exist_ok=True)
    proc = kept_run(folder, "run")
    assert "Traceback" not in proc.stderr, proc.stderr
    assert proc.returncode == 0, proc.stderr
    return folder


@pytest.fixture(scope="module")
def replayed(work: Path) -> dict[str, Any]:
    """The README's replay of it, ``nxtnav replay run.jsonl --localisers amcl,paper-pf,pf-systematic --json
    replay.json -o replay.png``, as JSON (the command's output is kept under "stdout")."""
    proc = kept_run(work, "replay")
    assert "Traceback" not in proc.stderr, proc.stderr
    assert proc.returncode == 0, proc.stderr
    doc: dict[str, Any] = json.loads((work / "replay.json").read_text())
    doc["stdout"] = proc.stdout
    return doc


def test_readme_replay_reports_a_short_path_rpe_as_missing_with_the_reason(work: Path,
                                                                           replayed: dict[str, Any]) -> None:
    """The RPE compares poses 1 m apart along the true path; this path holds no such pair, so the
    table shows "–", the JSON null, and both say why, with the path's length as the truth gives it."""
    assert (work / "replay.png").stat().st_size > 10_000
    truths = np.array([s["truth"] for s in replayed["steps"] if s["call"] == "update"])
    length_m = float(np.sum(np.hypot(*np.diff(truths[:, :2], axis=0).T))) / 100.0
    assert 0.5 < length_m < 1.5  # the README's mission: about a metre
    for name in LOCALISERS.split(","):
        row = replayed["summary"][name]
        assert row["rpe_per_m_cm"] is None and row["ape_rmse_cm"] is not None and row["ape_note"] is None
        note = row["rpe_note"]
        assert f"the {length_m:.2f} m path" in note and "1 m apart" in note, note
        assert re.search(rf"^\| {name} \|.*\| – \| [0-9.]+ \|$", replayed["stdout"], re.MULTILINE), replayed["stdout"]
    assert f"RPE – for every localiser: {replayed['summary']['amcl']['rpe_note']}" in replayed["stdout"]


def _cut(text: str, how: str) -> str:
    lines = text.splitlines(keepends=True)
    if how == "mid-line":  # the writer stopped inside a line
        keep = len(lines) // 2
        return "".join(lines[:keep]) + lines[keep][: len(lines[keep]) // 2]
    return "".join(lines[:-1])  # every line whole, but no 'end' line


@pytest.mark.parametrize(("how", "said"), [("mid-line", r"line \d+: cut short"),
                                           ("no end", r"stops without an 'end' line")])
def test_export_warns_about_a_cut_recording_as_replay_does(work: Path, how: str, said: str) -> None:
    cut = work / f"cut-{how.replace(' ', '-')}.jsonl"
    cut.write_text(_cut((work / "run.jsonl").read_text(), how))
    export = _nxtnav("export", cut.name, "--mcap", f"{cut.stem}-bag", cwd=work)
    replay = _nxtnav("replay", cut.name, "--localisers", "amcl", cwd=work)
    assert export.returncode == 0 and replay.returncode == 0
    warnings = [[ln for ln in p.stderr.splitlines() if ln.startswith("nxtnav: warning: ")] for p in (export, replay)]
    assert len(warnings[0]) == 1 and warnings[0] == warnings[1], warnings
    assert re.search(said, warnings[0][0]) and cut.name in warnings[0][0]


def _updates(doc: dict[str, Any]) -> list[dict[str, Any]]:
    return [s for s in doc["steps"] if s["call"] == "update"]


def test_an_export_imports_back_and_replays_to_the_same_estimates(work: Path, replayed: dict[str, Any]) -> None:
    """export -> import bag -> replay, with the flags docs/recording.md gives (``--no-deskew``: the
    robot stands while it sweeps, and the reading times of a sweep of windows are more than a
    LaserScan's one time step can hold).

    What travels exactly: the true poses (float64 in the messages: equal to 1e-9 cm) and the readings
    (float32 in a LaserScan: equal to 2 float32 epsilons). What does not: the localisers on the
    imported recording are told a laser (2 cm noise) instead of the ideal sonar (1 cm), are given
    each sweep's odometry as one turn-drive-turn, and draw other random numbers. Their estimates then
    differ by the filters' own scatter, which here is under 1 cm (median spread); 2 cm and 3 degrees
    is that with a margin, and an order of magnitude under what a wrong frame, scale or offset makes.
    """
    assert _nxtnav("export", "run.jsonl", "--mcap", "run-bag", cwd=work).returncode == 0
    imported = _nxtnav("import", "bag", "run-bag", "--map", "map1", "--scan-topic", "/scan", "--truth-topic",
                       "/ground_truth", "--no-deskew", "-o", "back.jsonl", cwd=work)
    assert imported.returncode == 0, imported.stderr
    back = _nxtnav("replay", "back.jsonl", "--localisers", LOCALISERS, "--json", "back.json", cwd=work)
    assert back.returncode == 0, back.stderr
    original, again = _updates(replayed), _updates(json.loads((work / "back.json").read_text()))
    assert len(again) == len(original) == 5
    for a, b in zip(original, again, strict=True):
        assert b["truth"] == pytest.approx(a["truth"], abs=1e-9)
        for name in LOCALISERS.split(","):
            pa, pb = a["estimates"][name]["pose"], b["estimates"][name]["pose"]
            assert math.dist(pa[:2], pb[:2]) <= 2.0, (name, pa, pb)
            assert abs((pa[2] - pb[2] + 180.0) % 360.0 - 180.0) <= 3.0, (name, pa, pb)
    scans = [scan_from_fields(e) for _, e in read_recording(work / "run.jsonl").events if e["type"] == "scan"]
    scans_back = [scan_from_fields(e) for _, e in read_recording(work / "back.jsonl").events if e["type"] == "scan"]
    assert len(scans_back) == len(scans)
    for s, t in zip(scans, scans_back, strict=True):
        assert np.array_equal(s.valid, t.valid)
        assert np.allclose(t.ranges[t.valid], s.ranges[s.valid], rtol=2 * F32, atol=0)


def test_importing_an_export_with_a_wrong_base_frame_names_the_frames(work: Path) -> None:
    if not (work / "frames-bag").exists():
        assert _nxtnav("export", "run.jsonl", "--mcap", "frames-bag", cwd=work).returncode == 0
    proc = _nxtnav("import", "bag", "frames-bag", "--map", "map1", "--scan-topic", "/scan", "--base-frame", "robot",
                   "-o", "x.jsonl", cwd=work)
    line = _one_error_line(proc)
    assert "'robot'" in line and "base_link, map, odom, sonar_link" in line and "{" not in line
    assert not (work / "x.jsonl").exists()


def _scans_of(bag: Path) -> list[Any]:
    """The /scan messages of a bag, decoded by rosbags with the definitions the bag carries."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    with Reader(bag) as reader:
        for c in reader.connections:
            store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
        return [store.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/scan"]


def _mcap_scans_of(bag: Path) -> list[Any]:
    """The same, decoded by the mcap package's reader and its ROS 2 decoder (mcap-ros2-support)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (file,) = bag.glob("*.mcap")
    with file.open("rb") as fh:
        return [decoded for _, channel, _, decoded in make_reader(fh, decoder_factories=[DecoderFactory()])
                .iter_decoded_messages(log_time_order=True) if channel.topic == "/scan"]


def test_nxt_scans_obey_their_limits_as_rep_117_says(work: Path) -> None:
    """Every finite /scan range lies within [range_min, range_max], the NXT model's 6 and 255 cm; a
    reading under 6 cm (the NXT's noise there) is -inf, no echo +inf, one for one with the recording."""
    from toolkit.world import NxtSonar

    run = _nxtnav("run", "--map", "map1", "--sonar", "nxt", "--record", "nxt.jsonl", cwd=work)
    assert run.returncode in (0, 1), run.stderr  # the mission may fail; the recording is written
    assert _nxtnav("export", "nxt.jsonl", "--mcap", "nxt-bag", cwd=work).returncode == 0
    model = NxtSonar()
    scans = [scan_from_fields(e) for _, e in read_recording(work / "nxt.jsonl").events if e["type"] == "scan"]
    readers = [_scans_of(work / "nxt-bag"), _mcap_scans_of(work / "nxt-bag")]
    assert len(readers[0]) == len(readers[1]) == len(scans) > 0
    close = 0
    for scan, msg in ((s, m) for messages in readers for s, m in zip(scans, messages, strict=True)):
        assert (msg.range_min, msg.range_max) == pytest.approx((model.min_range_cm / 100, model.max_range_cm / 100),
                                                               rel=F32)
        ranges = np.asarray(msg.ranges, dtype=np.float64)
        ranges = ranges[~np.isnan(ranges)]
        finite = ranges[np.isfinite(ranges)]
        assert np.all((finite >= msg.range_min) & (finite <= msg.range_max))
        too_close = scan.valid & (scan.ranges < model.min_range_cm)
        assert np.array_equal(np.isneginf(ranges), too_close)
        assert np.array_equal(np.isposinf(ranges), ~scan.valid)
        close += int(too_close.sum())
    assert close > 0, "no reading under range_min in this run: the test would not see a wrong encoding"


@pytest.mark.parametrize("where", ["run.jsonl/bag", "/proc/nxtnav-bag"])
def test_an_export_that_cannot_be_written_names_the_users_path(work: Path, where: str) -> None:
    line = _one_error_line(_nxtnav("export", "run.jsonl", "--mcap", where, cwd=work))
    assert where in line and "partial" not in line, line


def test_replay_shows_its_progress_once_it_runs_long(work: Path, capsys: pytest.CaptureFixture[str],
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """The bar appears after `PROGRESS_AFTER_S` (here 0) and counts the recording's localiser calls;
    on stderr, so the table on stdout is unchanged."""
    import toolkit.cli.progress as progress_module

    monkeypatch.setattr(progress_module, "PROGRESS_AFTER_S", 0.0)
    calls = read_recording(work / "run.jsonl").calls
    assert run_cli(["replay", str(work / "run.jsonl"), "--localisers", "amcl"]) == 0
    out, err = capsys.readouterr()
    assert f"replay: {calls}/{calls} (100 %)" in err and "replay:" not in out
