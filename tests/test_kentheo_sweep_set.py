"""tools/kentheo_sweep_set.py on a stand-in repository with the same layout (git, two commits)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import load_tool

from toolkit.real_sonar.sweeps import load_sweep_set

tool = load_tool("kentheo_sweep_set")


def _git(repo: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True).stdout.strip()


def _sweep(tag: int) -> str:
    return "".join(f"{(tag + k) % 200 + 20}\n" for k in range(360))


@pytest.fixture
def clone(tmp_path: Path) -> tuple[Path, tuple[str, str]]:
    repo = tmp_path / "Robotics_CO333"
    repo.mkdir()
    _git(repo, "init", "-q")
    _git(repo, "config", "user.email", "t@example.org")
    _git(repo, "config", "user.name", "t")
    for i in range(5):
        (repo / f"loc_{i:02d}.dat").write_text(_sweep(1000 + i))
    _git(repo, "add", ".")
    _git(repo, "commit", "-qm", "master")
    master = _git(repo, "rev-parse", "HEAD")
    for folder, count in tool.BATCHES.items():
        (repo / folder).mkdir(parents=True)
        for n in range(count):
            (repo / folder / f"loc_{n:02d}.dat").write_text("" if (folder, n) == ("database/batch1", 49)
                                                            else _sweep(n))
    _git(repo, "add", ".")
    _git(repo, "commit", "-qm", "working")
    return repo, (master, _git(repo, "rev-parse", "HEAD"))


def test_every_sweep_at_its_waypoint(clone: tuple[Path, tuple[str, str]], tmp_path: Path) -> None:
    repo, commits = clone
    out = tmp_path / "set"
    assert tool.build(repo, out, commits=commits) == (129, 1)  # 5 + 49 + 75; the empty batch1/loc_49 skipped
    sweeps = load_sweep_set(out, "co333-arena").sweeps
    assert len(sweeps) == 129
    where = {s.file: (s.x_cm, s.y_cm) for s in sweeps}
    assert where["loc_03.dat"] == (138, 54) and where["database/batch1/loc_12.dat"] == (180, 54)
    assert where["database/batch2/loc_74.dat"] == (138, 168)
    first = next(s for s in sweeps if s.file == "database/batch2/loc_07.dat")
    assert np.array_equal(first.readings, [float(v) for v in _sweep(7).split()])


def test_certain_only_and_bad_input(clone: tuple[Path, tuple[str, str]], tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    repo, commits = clone
    assert tool.build(repo, tmp_path / "ten", certain_only=True, commits=commits) == (10, 0)
    # a folder in use is refused, and a failed build leaves nothing behind
    with pytest.raises(tool.BuildError, match="not an empty folder"):
        tool.build(repo, tmp_path / "ten", commits=commits)
    with pytest.raises(tool.BuildError, match="cannot read"):
        tool.build(repo, tmp_path / "bad", commits=(commits[0], "0" * 40))
    assert not (tmp_path / "bad").exists() and not (tmp_path / "bad.partial").exists()
    assert tool.main([str(tmp_path / "nothing"), "-o", str(tmp_path / "x")]) == 2
    assert len(capsys.readouterr().err.splitlines()) == 1
