"""The Rerun view (extra ``viz``): saved .rrd files read back with Rerun's own reader hold every entity.

A mission streamed live (`nxtnav run --view-save`) and the same mission's recording drawn
afterwards (`nxtnav view REC --save`) log the same entities the same number of times; an exported
bag (`nxtnav view DIR`) draws the same entities again. The core packages never import rerun.

A view that cannot be (no display, no `viz` extra, no viewer program, a viewer that quits at start)
is one line and exit 2 within seconds, nothing written, through the real console script; with a
viewer, the whole run reaches it and the viewer stays open; `make view-check` leaves no process.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import warnings
from collections import Counter
from pathlib import Path

import pytest
from conftest import built_once, nxtnav_exe, run_cli, wait_until

pytest.importorskip("rerun")

from rerun.error_utils import RerunWarning

from toolkit.view.check import group_alive
from toolkit.view.scene import ENTITIES
from toolkit.view.viewer import DISPLAY_VARIABLES, viewer_binary


def _mission(out: Path) -> None:
    assert run_cli(["run", "--map", "map1", "--record", str(out / "m1.jsonl"),
                    "--view-save", str(out / "live.rrd")]) == 0


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return built_once(tmp_path_factory, "map1-mission-view", _mission)


def _rows(rrd: Path) -> Counter[str]:
    """Rows logged per entity path (leading slash dropped), read with Rerun's RRD reader."""
    from rerun.chunk import RrdReader

    rows: Counter[str] = Counter()
    for chunk in RrdReader(rrd).stream().to_chunks():
        rows[chunk.entity_path.lstrip("/")] += chunk.num_rows
    return rows


def test_core_packages_do_not_import_rerun() -> None:
    code = ("import sys, toolkit, localisation, planners, toolkit.mission, toolkit.recordings.recorder, "
            "toolkit.recordings.replay, "
            "toolkit.recordings.timeline, toolkit.ros.export, toolkit.cli; toolkit.cli._load(); "
            "import toolkit.view; bad = sorted(m for m in sys.modules if m.split('.')[0] in ('rerun', "
            "'rerun_bindings')); print(bad); sys.exit(1 if bad else 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.slow
def test_live_view_saves_every_entity(mission: Path) -> None:
    rows = _rows(mission / "live.rrd")
    assert set(ENTITIES) <= set(rows)
    assert rows["world/map/walls"] == 1 and rows["world/map/cspace"] == 1  # static, once


@pytest.mark.slow
def test_recording_view_equals_the_live_view(mission: Path, tmp_path: Path) -> None:
    from toolkit.recordings.replay import read_recording

    out = tmp_path / "rec.rrd"
    assert run_cli(["view", str(mission / "m1.jsonl"), "--save", str(out)]) == 0
    live, rec = _rows(mission / "live.rrd"), _rows(out)
    assert {k: rec[k] for k in ENTITIES} == {k: live[k] for k in ENTITIES}
    events = [e["type"] for _, e in read_recording(mission / "m1.jsonl").events]
    assert rec["world/estimate"] == events.count("estimate") and rec["world/plan"] == events.count("plan")
    assert rec["world/sweep/echoes"] == events.count("scan")


@pytest.mark.slow
def test_exported_bag_view_has_every_entity(mission: Path, tmp_path: Path) -> None:
    bag, out = tmp_path / "bag", tmp_path / "bag.rrd"
    assert run_cli(["export", str(mission / "m1.jsonl"), "--mcap", str(bag)]) == 0
    assert run_cli(["view", str(bag), "--save", str(out)]) == 0
    rows, live = _rows(out), _rows(mission / "live.rrd")
    assert set(ENTITIES) <= set(rows)
    for name in ("world/estimate", "world/particles", "world/plan", "world/sweep/echoes"):
        assert rows[name] == live[name]


def test_view_of_a_folder_that_is_not_an_export(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    assert run_cli(["view", str(tmp_path), "--save", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a bag written by nxtnav export" in err
    assert not (tmp_path / "x.rrd").exists()


# --- the view that cannot be: one line, exit 2, in seconds, nothing written (the user's commands) ---

HANG_S = 60.0
"""A view that cannot open must not hang (the trial waited 22 s or for ever): the command is killed after
this (s) and the test fails. How fast it fails is measured, not asserted (wall time depends on the
machine); that no mission work ran first is asserted by its empty standard output."""

NO_DISPLAY_ENV = {k: v for k, v in os.environ.items() if k not in (*DISPLAY_VARIABLES, "RERUN_CLI_PATH")}
"""This environment without a display server named and without an override of the viewer program."""

linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="display variables are Linux's")


def _dead_display() -> str:
    """An X display name no server answers on (no socket for it on this machine)."""
    n = next(n for n in range(99, 200) if not Path(f"/tmp/.X11-unix/X{n}").exists())
    return f":{n}"


def _nxtnav(args: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    # Ctrl-C as a terminal gives it: not ignored from the start, as it is for whatever a shell starts in the
    # background without job control (pytest itself so started would hand that on to the viewer)
    return subprocess.run([nxtnav_exe(), *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=HANG_S,
                          preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _fails_fast(args: list[str], cwd: Path, env: dict[str, str], *needles: str) -> str:
    """Run `nxtnav ARGS` in `cwd`: exit 2, one error line holding `needles`, no hang, no file added."""
    before = sorted(p.name for p in cwd.iterdir())
    proc = _nxtnav(args, cwd, env)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert len(lines) == 1 and lines[0].startswith("nxtnav: error: "), proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert sorted(p.name for p in cwd.iterdir()) == before
    return lines[0]


@pytest.fixture
def recording(mission: Path, tmp_path: Path) -> Path:
    """A folder outside the repository holding a mission's recording, run.jsonl."""
    shutil.copy(mission / "m1.jsonl", tmp_path / "run.jsonl")
    return tmp_path


def _shim(folder: Path, package: str, body: str) -> dict[str, str]:
    """An environment whose Python finds `package` in `folder` first, with `body` as its __init__."""
    (folder / package).mkdir(parents=True)
    (folder / package / "__init__.py").write_text(body)
    return {**NO_DISPLAY_ENV, "PYTHONPATH": os.pathsep.join(filter(None, [str(folder),
                                                                          os.environ.get("PYTHONPATH")]))}


@linux_only
@pytest.mark.parametrize(("args", "save_option"), [(["run", "--map", "map1", "--view"], "--view-save"),
                                                   (["view", "run.jsonl"], "--save")])
def test_no_display_is_one_line(recording: Path, args: list[str], save_option: str) -> None:
    line = _fails_fast(args, recording, NO_DISPLAY_ENV, "no display", f"{save_option} FILE.rrd", "rerun FILE.rrd")
    assert "DISPLAY" in line and "WAYLAND_DISPLAY" in line


@linux_only
@pytest.mark.parametrize("args", [["run", "--map", "map1", "--view"], ["view", "run.jsonl"]])
def test_a_display_no_server_answers_is_one_line(recording: Path, args: list[str]) -> None:
    """DISPLAY names a display, but no X server is there: the viewer starts, quits, and its reason is said."""
    env = {**NO_DISPLAY_ENV, "DISPLAY": _dead_display()}
    _fails_fast(args, recording, env, "the Rerun viewer quit at start", "X server")


@pytest.mark.parametrize("args", [["run", "--map", "map1", "--view"], ["run", "--map", "map1", "--view-save", "v.rrd"],
                                  ["view", "run.jsonl"], ["view", "run.jsonl", "--save", "v.rrd"]])
def test_without_the_viz_extra_is_one_line(tmp_path: Path, args: list[str]) -> None:
    """`import rerun` fails (the extra is not installed): the install line for a wheel and for a clone,
    said before the recording is read (here it is not one) and before any mission work."""
    env = _shim(tmp_path / "shim", "rerun", "raise ImportError('rerun-sdk is not installed (test shim)')\n")
    work = tmp_path / "work"
    work.mkdir()
    (work / "run.jsonl").write_text("not a recording\n")
    _fails_fast(args, work, env, "needs Rerun", "pip install 'nxtnav[viz]'", "pip install -e '.[viz]'")


@linux_only
def test_without_the_viewer_program_is_one_line(tmp_path: Path) -> None:
    """The rerun_cli package holds no viewer binary and none is on PATH."""
    path = "/usr/bin:/bin"
    if shutil.which("rerun", path=path) is not None:
        pytest.skip("a rerun program is installed system-wide")
    env = {**_shim(tmp_path / "shim", "rerun_cli", ""), "PATH": path, "DISPLAY": _dead_display()}
    work = tmp_path / "work"
    work.mkdir()
    _fails_fast(["run", "--map", "map1", "--view"], work, env, "--view", "viewer program is missing",
                "pip install 'nxtnav[viz]'")


def test_a_viewer_override_that_is_not_there_is_one_line(tmp_path: Path) -> None:
    env = {**NO_DISPLAY_ENV, "DISPLAY": _dead_display(), "RERUN_CLI_PATH": str(tmp_path / "no-rerun")}
    _fails_fast(["run", "--map", "map1", "--view"], tmp_path, env, "RERUN_CLI_PATH", str(tmp_path / "no-rerun"))


@linux_only
@pytest.mark.slow
def test_live_view_reaches_the_viewer_and_leaves_it_open(mission: Path, tmp_path: Path) -> None:
    """`nxtnav run --view` with a display: the viewer nxtnav starts gets the whole run and stays open.

    The viewer is the real Rerun program, told to save what it receives (`rerun --save`), so this
    machine needs no screen; it gets the same entities, the same number of times, as --view-save."""
    seen, pid_file, script = tmp_path / "seen.rrd", tmp_path / "viewer.pid", tmp_path / "viewer.sh"
    script.write_text(f'#!/bin/sh\necho $$ > "{pid_file}"\nexec "{viewer_binary()}" --save "{seen}" "$@"\n')
    script.chmod(0o755)
    env = {**NO_DISPLAY_ENV, "DISPLAY": _dead_display(), "RERUN_CLI_PATH": str(script)}
    proc = _nxtnav(["run", "--map", "map1", "--view"], tmp_path, env)
    assert proc.returncode == 0, proc.stderr
    pid = int(pid_file.read_text())
    try:
        assert group_alive(pid), "the viewer closed when the mission ended"
    finally:
        os.killpg(pid, signal.SIGINT)
        try:
            wait_until(lambda: not group_alive(pid), 20.0, "the viewer ends on Ctrl-C")
        finally:  # a viewer that outlived Ctrl-C fails the test, and is not left running for the next one
            if group_alive(pid):
                with contextlib.suppress(ProcessLookupError):  # it may end between the look and the kill
                    os.killpg(pid, signal.SIGKILL)
    with warnings.catch_warnings():  # a stream saved by the viewer has no footer; Rerun warns and scans it
        warnings.filterwarnings("ignore", message="RRD file has no footer", category=RerunWarning)
        rows = _rows(seen)
    live = _rows(mission / "live.rrd")
    assert {k: rows[k] for k in ENTITIES} == {k: live[k] for k in ENTITIES}


@pytest.mark.slow
def test_view_check_leaves_no_process_and_no_tracked_file(mission: Path, tmp_path: Path) -> None:
    """`tools/view_check.py RUN.rrd` (make view-check): a screenshot in out/ of the folder it runs in,
    and no viewer process left (the trial found `rerun --web-viewer` still running)."""
    pytest.importorskip("playwright")
    if shutil.which("chromium") is None:
        pytest.skip("no chromium (make view-check installs it)")
    rrd = tmp_path / "run.rrd"
    shutil.copy(mission / "live.rrd", rrd)
    tool = Path(__file__).parents[1] / "tools" / "view_check.py"
    proc = subprocess.run([sys.executable, str(tool), str(rrd)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300, check=False)
    assert proc.returncode == 0, proc.stderr
    png = tmp_path / "out" / "rerun-view.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    left = subprocess.run(["pgrep", "-fa", str(rrd)], capture_output=True, text=True, check=False)
    assert left.returncode == 1, left.stdout
