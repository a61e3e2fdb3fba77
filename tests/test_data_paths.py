"""Every kind of option that reads a file or folder takes the documentation's ``maps/...`` paths from
any folder: the real `nxtnav` command, run in a temporary folder outside the repository, finds the
shipped copy (`toolkit.world.bundled.data_path`, the one resolver behind them all).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from conftest import nxtnav_exe

EXE = nxtnav_exe()
PROFILE = "maps/real-nxt/sonar-profiles/nxt-fitted.yaml"

COMMANDS = {
    "import bag BAG --map": (["import", "bag", "maps/jarvis/jarvis_circular_path_fast.bag", "--map",
                              "maps/jarvis/i-108_10mm.yaml", "--scan-topic", "/driver_laser_navigation/laser_scan",
                              "--truth-topic", "/pose_ground_truth", "--every", "20", "--beams", "30",
                              "-o", "jarvis.jsonl"], "jarvis.jsonl"),
    "import sweeps DIR --map": (["import", "sweeps", "maps/real-nxt", "--map", "maps/real-nxt/arena.yaml",
                                 "-o", "real.jsonl"], "real.jsonl"),
    "maps import FILE": (["maps", "import", "maps/external/depot.yaml", "-o", "depot.yaml"], "depot.yaml"),
    "bench scen FILE --map": (["bench", "scen", "maps/external/arena2.map.scen", "--map", "maps/external/arena2.map",
                               "--kind", "octile", "--planners", "astar", "--limit", "2", "--out", "scen"],
                              "scen/scen.csv"),
    "scan --map --sonar-profile": (["scan", "--map", "maps/map1.yaml", "--pose", "20,20,0", "--sonar", "nxt",
                                    "--sonar-profile", PROFILE, "--json", "scan.json"], "scan.json"),
}
SLOW_COMMANDS = {
    "sonar plot DIR --map --sonar-profile": (["sonar", "plot", "maps/real-nxt", "--map", "maps/real-nxt/arena.yaml",
                                              "--sonar-profile", PROFILE, "--out", "plots"],
                                             "plots/real_sonar_radar.png"),
    "bench sweeps DIR --map --sonar-profile": (["bench", "sweeps", "maps/real-nxt", "--map",
                                                "maps/real-nxt/arena.yaml", "--localisers", "amcl", "--seeds", "0",
                                                "--sonar-profile", PROFILE, "--out", "sweeps"],
                                               "sweeps/sweeps.csv"),
}


def _run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([EXE, *args], cwd=cwd, capture_output=True, text=True, timeout=300)


def _check(args: list[str], output: str, cwd: Path) -> None:
    assert not (cwd / "maps").exists()  # nothing of the repository's here: the shipped copy is found
    proc = _run(args, cwd)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr, proc.stderr
    assert "not found" not in proc.stderr and (cwd / output).is_file(), proc.stderr


@pytest.mark.parametrize("kind", list(COMMANDS))
def test_documented_paths_work_from_any_folder(kind: str, tmp_path: Path) -> None:
    _check(*COMMANDS[kind], tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(SLOW_COMMANDS))
def test_documented_paths_work_from_any_folder_slow(kind: str, tmp_path: Path) -> None:
    _check(*SLOW_COMMANDS[kind], tmp_path)


@pytest.mark.parametrize("args", [
    ["import", "bag", "maps/jarvis/no-such.bag", "--map", "maps/jarvis/i-108_10mm.yaml", "--scan-topic", "/s",
     "-o", "x.jsonl"],
    ["replay", "maps/no-such.jsonl"],
    ["export", "maps/no-such.jsonl", "--mcap", "x-bag"],
])
def test_a_missing_documented_path_is_one_line_naming_it(args: list[str], tmp_path: Path) -> None:
    proc = _run(args, tmp_path)
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    missing = next(a for a in args if a.startswith("maps/") and "no-such" in a)
    assert missing in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == []
