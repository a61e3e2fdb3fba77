"""The Rerun view (extra ``viz``): saved .rrd files read back with Rerun's own reader hold every entity.

A mission streamed live (`nxtnav run --view-save`) and the same mission's recording drawn
afterwards (`nxtnav view REC --save`) log the same entities the same number of times; an exported
bag (`nxtnav view DIR`) draws the same entities again. The core packages never import rerun.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest
from conftest import built_once, run_cli

pytest.importorskip("rerun")

from toolkit.view.scene import ENTITIES


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
    code = ("import sys, toolkit, localisation, planners, toolkit.mission, toolkit.recording, toolkit.replay, "
            "toolkit.timeline, toolkit.ros2_export, toolkit.cli; toolkit.cli._load(); "
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
    from toolkit.replay import read_recording

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
