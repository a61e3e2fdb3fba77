"""A --dask address that names no scheduler is bad input: one line naming the option, exit 2, no output."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import run_cli


@pytest.mark.parametrize("command", [
    ["paper", "--trials", "1", "--maps", "map1", "--noise-model", "botsim"],
    ["bench", "sweeps", "maps/real-nxt", "--localisers", "amcl", "--seeds", "0"],
])
def test_a_malformed_dask_address_is_one_line(command: list[str], tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert run_cli([*command, "--dask", "no-port-here", "--json" if command[0] == "paper" else "--out",
                    str(out)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("nxtnav:")]
    assert err == ["nxtnav: error: --dask no-port-here: cannot reach a Dask scheduler there: "
                   "missing port number in address 'no-port-here'"]
    assert not out.exists() or not any(out.iterdir())
