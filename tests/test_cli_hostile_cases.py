"""Every bad input of the hostile-input table (tests/hostile_cases.py, the cases `docs/hostile_inputs.py`
prints): the expected exit code, and for a failure one line ``nxtnav: ...`` on stderr, no traceback,
nothing written."""

from __future__ import annotations

import shlex
import warnings
from pathlib import Path

import pytest
from conftest import nxtnav_exe, run_cli
from hostile_cases import Case, cases, prepare

CASES = cases()


@pytest.fixture(scope="module")
def scratch(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The folder holding the files the cases name (broken maps, a bad range-table cache, ...)."""
    folder = tmp_path_factory.mktemp("hostile")
    prepare(folder, nxtnav_exe())
    return folder


def _tree(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_size for p in folder.rglob("*")}


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[f"{c.expect}: {c.command}" for c in CASES])
def test_a_hostile_input_is_handled_cleanly(case: Case, scratch: Path, monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(scratch)
    for name, value in case.env.items():
        monkeypatch.setenv(name, str(scratch / value))
    before = _tree(scratch)
    with warnings.catch_warnings():
        warnings.simplefilter("default")  # a warning is a line on stderr, as in a terminal, not an error
        code = run_cli(shlex.split(case.command))  # a traceback would escape here and fail the test
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert code == case.expect, err
    if case.expect == 0:
        assert len(err) <= 1, err  # at most one warning
        return
    assert len(err) == 1 and err[0].startswith("nxtnav: "), err
    if case.expect == 2:
        assert _tree(scratch) == before  # bad input: nothing written
