"""The shipped data (the repository's maps/, installed as toolkit.data), its notices, and the version.

`make dist-check` builds the wheel and uses it from a fresh environment; these tests check, in the
clone, what that relies on: the data found through importlib.resources, the documentation's
``maps/...`` paths working from any folder, and a notice for every folder of data made elsewhere.
"""

from __future__ import annotations

import re
from importlib import metadata
from pathlib import Path

import pytest
from conftest import run_cli

import toolkit
from toolkit.world import NxtSonar, load_map
from toolkit.world.bundled import data_notices, data_path, data_root

REPO = Path(__file__).resolve().parents[1]
MAPS = REPO / "maps"


def test_data_root_is_the_repository_maps_folder() -> None:
    # an editable install maps the package toolkit.data onto the top-level maps/ folder
    assert data_root().resolve() == MAPS.resolve()


def test_documented_paths_resolve_from_any_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert data_path("maps/real-nxt/sweeps.csv").resolve() == (MAPS / "real-nxt" / "sweeps.csv").resolve()
    assert data_path("maps/external").resolve() == (MAPS / "external").resolve()
    assert load_map("maps/map3.yaml").name == "map3"


def test_other_paths_are_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert data_path("maps/no-such-file.yaml") == Path("maps/no-such-file.yaml")
    assert data_path("elsewhere/map1.yaml") == Path("elsewhere/map1.yaml")
    own = tmp_path / "maps" / "map1.yaml"  # a file of the user's own wins over the shipped one
    own.parent.mkdir()
    own.write_text("boundary: [[0, 0], [10, 0], [10, 10], [0, 10]]\n")
    assert data_path("maps/map1.yaml") == Path("maps/map1.yaml")
    assert load_map("maps/map1.yaml").area == pytest.approx(100.0)


def test_commands_read_shipped_data_from_any_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert run_cli(["import", "sweeps", "maps/real-nxt", "-o", "real.jsonl"]) == 0
    assert "3 sweeps on map co333-arena" in capsys.readouterr().out
    assert (tmp_path / "real.jsonl").is_file()
    from toolkit.cli.options import sonar_profile

    assert sonar_profile(Path("maps/real-nxt/sonar-profiles/nxt-fitted.yaml"), "nxt") == NxtSonar()


def test_missing_documented_path_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert run_cli(["import", "sweeps", "maps/no-such-set", "-o", "x.jsonl"]) == 2
    err = capsys.readouterr().err
    assert "maps/no-such-set" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x.jsonl").exists()


def _data_folders() -> list[str]:
    return sorted(p.name for p in MAPS.iterdir() if p.is_dir() and p.name != "__pycache__")


def test_every_data_folder_has_its_notices_listed() -> None:
    rows = data_notices()
    assert rows, "maps/NOTICES.md lists no data"
    for folder in _data_folders():
        assert any(r.folder.strip("/").split("/")[0] == folder for r in rows), (
            f"maps/{folder}/ has no row in maps/NOTICES.md: list its source, licence and notice files there")
    for r in rows:
        assert r.licence and r.source and r.notices, f"maps/NOTICES.md: incomplete row for {r.folder}"
        for notice in r.notices:
            assert (MAPS / notice).is_file(), f"maps/NOTICES.md names {notice}, which is not in maps/"
            assert notice.startswith(r.folder), f"maps/NOTICES.md: {notice} is not in its row's folder {r.folder}"


def test_every_licence_file_is_listed() -> None:
    listed = {n for r in data_notices() for n in r.notices}
    found = {str(p.relative_to(MAPS)) for p in MAPS.rglob("*")
             if p.is_file() and re.match(r"(LICEN[CS]E|NOTICE|COPYING)", p.name) and p.name != "NOTICES.md"}
    assert found, "no licence files under maps/"
    assert found <= listed, f"licence files not listed in maps/NOTICES.md: {sorted(found - listed)}"


def test_licence_file_is_the_declared_mit_licence() -> None:
    text = (REPO / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License")
    assert metadata.metadata("nxtnav")["License-Expression"] == "MIT"


def test_version_option(capsys: pytest.CaptureFixture[str]) -> None:
    # the distribution's version is read from toolkit.__version__ (pyproject.toml: dynamic); make
    # dist-check compares the installed wheel's --version with it
    assert run_cli(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"nxtnav {toolkit.__version__}"
    assert re.fullmatch(r"\d+\.\d+\.\d+", toolkit.__version__)


def test_changelog_names_the_current_version() -> None:
    text = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    versions = re.findall(r"^## \[?(\d+\.\d+\.\d+)\]?", text, re.MULTILINE)
    assert versions, "CHANGELOG.md has no '## X.Y.Z' section"
    assert versions[0] == toolkit.__version__, "the newest CHANGELOG section is not the package's version"
