"""`nxtnav --help` and argument errors answer without loading the numerical back ends: matplotlib,
filterpy, OMPL and FCL load only inside the commands that use them. Each case runs in a fresh
interpreter (this one has imported everything already)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

HEAVY = ("matplotlib", "filterpy", "ompl", "fcl")

_PROBE = """
import json, sys
from toolkit.cli import main
try:
    main(sys.argv[1:])
except SystemExit as exc:
    code = int(exc.code or 0)
else:
    code = 0
print(json.dumps({"code": code, "loaded": sorted(m for m in HEAVY if m in sys.modules)}))
""".replace("HEAVY", repr(HEAVY))


def _loaded(argv: list[str]) -> tuple[int, list[str]]:
    proc = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    return int(out["code"]), list(out["loaded"])


@pytest.mark.parametrize("argv, code", [
    (["--help"], 0),
    (["localise", "--no-such-option"], 2),
    (["plan", "--no-such-option"], 2),
    (["run", "--no-such-option"], 2),
])
def test_help_and_usage_errors_load_no_back_end(argv: list[str], code: int) -> None:
    got, loaded = _loaded(argv)
    assert got == code
    assert loaded == []


def test_the_probe_sees_a_back_end_when_one_loads(tmp_path: Path) -> None:
    # `maps show` draws with matplotlib: the probe must report it, or the test above proves nothing
    got, loaded = _loaded(["maps", "show", "map1", "-o", str(tmp_path / "m.png")])
    assert got == 0 and (tmp_path / "m.png").stat().st_size > 0
    assert "matplotlib" in loaded


def test_the_app_module_alone_loads_none() -> None:
    code = f"import sys, toolkit.cli.app; print(sorted(m for m in {HEAVY!r} if m in sys.modules))"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"
