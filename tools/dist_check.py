"""Build the wheel and the sdist, install the wheel in a fresh environment and use it as a new user would.

    .venv/bin/python tools/dist_check.py            # what `make dist-check` runs
    .venv/bin/python tools/dist_check.py --keep     # keep the temporary folder to look inside

Steps, each timed: `python -m build` (the sdist, then the wheel built from the sdist) into ``dist/``;
both archives hold every file of ``maps/`` and the LICENSE; a virtual environment is made in a
temporary folder outside the repository and the wheel installed in it (with its dependencies; by uv
when `make install` put it beside this Python, else by pip, as the README's `pip install` would);
from that folder, with ``$NXTNAV_MAPS`` and ``$PYTHONPATH`` unset, ``nxtnav --version`` prints the
version, ``nxtnav maps list`` lists the same maps as the clone (read from the installed package, not
from the clone), every data notice of ``maps/NOTICES.md`` is installed, ``nxtnav import sweeps
maps/real-nxt`` reads the shipped sweeps and ``nxtnav run`` completes a mission. Any failure stops
with one line naming the step and exit status 1.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "maps"
WHEEL_DATA = "toolkit/data"


class CheckFailed(Exception):
    """A step of the check found the distribution wrong; the message says what."""


@contextmanager
def step(name: str) -> Iterator[None]:
    """Print the step's name, then its time once it has passed."""
    print(f"-- {name}", flush=True)
    t0 = time.perf_counter()
    yield
    print(f"   ok ({time.perf_counter() - t0:.1f} s)", flush=True)


def run(argv: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    """Run a command; its standard output, or `CheckFailed` with its error output."""
    proc = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        tail = "\n".join((proc.stderr or proc.stdout).strip().splitlines()[-15:])
        raise CheckFailed(f"{' '.join(argv)} (in {cwd}) exited {proc.returncode}:\n{tail}")
    return proc.stdout


UV = importlib.util.find_spec("uv") is not None
"""Whether uv is installed beside this Python (`make install` puts it there): the archives' build
environments and the fresh venv's install then go through it."""


def data_files() -> list[str]:
    """The files of ``maps/`` (relative paths), as the distributions must carry them."""
    return sorted(str(p.relative_to(DATA)) for p in DATA.rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts)


def version() -> str:
    """The version the source declares (``toolkit.__version__``)."""
    text = (REPO / "toolkit" / "__init__.py").read_text(encoding="utf-8")
    found = re.search(r'^__version__ = "([^"]+)"', text, re.MULTILINE)
    if not found:
        raise CheckFailed("toolkit/__init__.py declares no __version__")
    return found.group(1)


def build(dist: Path) -> tuple[Path, Path]:
    """`python -m build` into `dist` (emptied first): the sdist and the wheel."""
    shutil.rmtree(dist, ignore_errors=True)
    installer = ["--installer", "uv"] if UV else []  # the build environments made by uv: the same, faster
    run([sys.executable, "-m", "build", *installer, "--outdir", str(dist), str(REPO)], cwd=REPO)
    sdists, wheels = sorted(dist.glob("*.tar.gz")), sorted(dist.glob("*.whl"))
    if len(sdists) != 1 or len(wheels) != 1:
        raise CheckFailed(f"expected one sdist and one wheel in {dist}, found {[p.name for p in dist.iterdir()]}")
    return sdists[0], wheels[0]


def check_archives(sdist: Path, wheel: Path) -> None:
    """Both archives hold the LICENSE and every data file."""
    expected = data_files()
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    missing = [f for f in ["LICENSE", *(f"maps/{f}" for f in expected)] if f not in names]
    if missing:
        raise CheckFailed(f"{sdist.name} lacks {', '.join(missing)}")
    with zipfile.ZipFile(wheel) as whl:
        names = set(whl.namelist())
    missing = [f"{WHEEL_DATA}/{f}" for f in expected if f"{WHEEL_DATA}/{f}" not in names]
    if not any(n.endswith(".dist-info/licenses/LICENSE") for n in names):
        missing.append("*.dist-info/licenses/LICENSE")
    if missing:
        raise CheckFailed(f"{wheel.name} lacks {', '.join(missing)}")


def user_env(venv: Path) -> dict[str, str]:
    """The environment of a user of the fresh venv: its bin first, no map folders, no source path."""
    env = {k: v for k, v in os.environ.items() if k not in ("NXTNAV_MAPS", "PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["COLUMNS"] = "400"  # rich tables: whole paths
    return env


def listed_maps(output: str) -> dict[str, str]:
    """Name -> file of the rows of ``nxtnav maps list``."""
    rows = {}
    for line in output.splitlines():
        cells = [c.strip() for c in line.strip().strip("│").split("│")]
        if len(cells) == 6 and cells[0] and cells[0] != "name":
            rows[cells[0]] = cells[1]
    return rows


def check_installed(venv: Path, work: Path, want_version: str) -> None:
    """The commands a new user runs first, from `work` (outside the repository)."""
    env = user_env(venv)
    nxtnav = str(venv / "bin" / "nxtnav")
    with step("nxtnav --version"):
        out = run([nxtnav, "--version"], work, env).strip()
        if out != f"nxtnav {want_version}":
            raise CheckFailed(f"nxtnav --version printed {out!r}, expected 'nxtnav {want_version}'")
    with step("nxtnav maps list"):
        rows = listed_maps(run([nxtnav, "maps", "list"], work, env))
        os.environ.pop("NXTNAV_MAPS", None)
        from toolkit.world import list_maps

        if sorted(rows) != sorted(list_maps()):
            raise CheckFailed(f"the wheel lists {sorted(rows)}, the clone {sorted(list_maps())}")
        outside = [f for f in rows.values() if not f.startswith(str(venv))]
        if outside:
            raise CheckFailed(f"maps read from outside the installed package: {outside}")
        print(f"   {len(rows)} maps: {', '.join(sorted(rows))}")
    with step("data notices installed"):
        code = ("from toolkit.world.bundled import data_notices, data_root\n"
                "root = data_root()\n"
                "for n in data_notices():\n"
                "    for f in n.notices:\n"
                "        assert (root / f).is_file(), f'{f} missing'\n"
                "print(root, len(data_notices()))")
        print("  ", run([str(venv / "bin" / "python"), "-c", code], work, env).strip())
    with step("nxtnav import sweeps maps/real-nxt"):
        run([nxtnav, "import", "sweeps", "maps/real-nxt", "-o", "real-nxt.jsonl"], work, env)
    with step("nxtnav run"):
        run([nxtnav, "run", "--json", "mission.json"], work, env)
        report = json.loads((work / "mission.json").read_text(encoding="utf-8"))
        if report.get("success") is not True:
            raise CheckFailed(f"nxtnav run did not succeed: {report.get('status')}")
        print(f"   {report.get('status')}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dist", type=Path, default=REPO / "dist", help="where the archives go (default dist/)")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder (its path is printed)")
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="nxtnav-dist-check-"))
    try:
        with step("python -m build (sdist, then the wheel from it)"):
            sdist, wheel = build(args.dist)
            print(f"   {sdist.name}, {wheel.name}")
        with step("archives hold LICENSE and every file of maps/"):
            check_archives(sdist, wheel)
        venv = tmp / "venv"
        with step(f"fresh venv in {tmp}, the wheel installed"):
            run([sys.executable, "-m", "venv", str(venv)], tmp)
            python = str(venv / "bin" / "python")
            if UV:  # what pip would install (the wheel's own requirements), in a fraction of pip's time
                run([sys.executable, "-m", "uv", "pip", "install", "--quiet", "--python", python, str(wheel)], tmp)
            else:
                run([python, "-m", "pip", "install", "--quiet", "--no-compile", str(wheel)], tmp)
        work = tmp / "work"
        work.mkdir()
        check_installed(venv, work, version())
    except CheckFailed as exc:
        print(f"dist-check: FAILED: {exc}", file=sys.stderr)
        return 1
    finally:
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    print("dist-check: passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
