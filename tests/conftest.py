"""Shared fixtures and helpers: the bundled maps, the command line in this process and as a console script."""

from __future__ import annotations

import contextlib
import fcntl
import importlib.util
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest

from toolkit.world import Map, load_map, map_from_dict


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The slow end-to-end checks and the documented commands first, the quick tests after (a stable
    sort: each keeps its order): pytest-xdist's workers then finish together instead of one running a
    long notebook while the other has nothing left. With ``--dist loadgroup``, each test of an
    ``xdist_group`` is named after its group (`_name_groups`)."""
    items.sort(key=lambda item: 0 if item.get_closest_marker("slow") or item.get_closest_marker("docs") else 1)
    if config.getoption("loadgroup", default=False):
        _name_groups(items)


def _name_groups(items: list[pytest.Item]) -> None:
    """Give each test marked ``xdist_group(NAME)`` the node id ``ID@NAME``, by which ``--dist loadgroup`` sends
    the tests of one group to one worker.

    pytest-xdist 3.8 sets ``item._nodeid`` for this, which pytest 9 no longer reads (a node's id is its
    ``_id``), so without this every group was spread over both workers: the Dask cluster's tests each
    started a cluster on both, and each worker built the module fixtures of test_bench_planners,
    test_sonar_cli and test_recording_user_paths (or waited on the other's `built_once` lock)."""
    from _pytest.nodeid import NodeId

    for item in items:
        names = sorted({str(m.args[0] if m.args else m.kwargs.get("name", "default"))
                        for m in item.iter_markers("xdist_group")})
        nodeid = item.nodeid
        if names and nodeid.rfind("@") <= nodeid.rfind("]") and isinstance(getattr(item, "_id", None), NodeId):
            item._id = NodeId.parse(f"{nodeid}@{'_'.join(names)}")


RANGE_CACHE_ENV = "NXTNAV_CACHE_DIR"
"""The range tables' disk cache (`localisation.range_table`): one folder for the whole run (`pytest_configure`)."""


def pytest_configure(config: pytest.Config) -> None:
    """One range-table cache folder for the run, unless ``$NXTNAV_CACHE_DIR`` is set already: the first
    process that needs a map's table builds it and saves it there, and every later command of the run
    (the CLI tests' subprocesses, the documented blocks, the process pools) loads it instead of building
    it again (the CO333 arena's lobed table takes over a second). Set here, before pytest-xdist starts
    its workers, so that they and every command they run inherit it; removed when the run ends."""
    if hasattr(config, "workerinput") or os.environ.get(RANGE_CACHE_ENV) is not None:
        return
    folder = tempfile.mkdtemp(prefix="nxtnav-range-tables-")
    os.environ[RANGE_CACHE_ENV] = folder

    def remove() -> None:
        os.environ.pop(RANGE_CACHE_ENV, None)
        shutil.rmtree(folder, ignore_errors=True)

    config.add_cleanup(remove)


def pytest_sessionstart(session: pytest.Session) -> None:
    """Before pytest-xdist starts its workers, compile numba's kernels once when its cache is cold (a fresh
    clone), so that the workers and the commands they run do not all compile the same kernels at the start
    (tests/numba_warm_up.py says why; it returns after a second when the cache is warm). A run without
    workers compiles each kernel once anyway and skips this."""
    config = session.config
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    with contextlib.suppress(subprocess.TimeoutExpired):  # it only saves time: the tests run whatever it did
        subprocess.run([sys.executable, str(Path(__file__).with_name("numba_warm_up.py"))],
                       cwd=Path(__file__).parents[1], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, timeout=300, check=False)


BOTSIM_MAPS = ("map1", "map2", "map3")
ALL_MAPS = (*BOTSIM_MAPS, "pillars")

REAL_NXT = Path(__file__).parents[1] / "maps" / "real-nxt"
"""The shipped sweep set: the three MIT-licensed real NXT sweeps (maps/real-nxt/README.md)."""
ARENA_BOUNDARY = [[0, 0], [0, 168], [84, 168], [84, 210], [168, 210], [168, 84], [210, 84], [210, 0]]
"""The CO333 arena's outer walls (cm), without its free-standing stub wall."""


def real_nxt_arena() -> Map:
    """The arena of the shipped sweeps: the folder's arena.yaml when it is there, else its outer walls."""
    yaml = REAL_NXT / "arena.yaml"
    if yaml.is_file():
        return load_map(yaml)
    return map_from_dict({"name": "co333-arena", "boundary": ARENA_BOUNDARY})


@pytest.fixture(params=ALL_MAPS)
def any_map(request: pytest.FixtureRequest) -> Map:
    return load_map(request.param)


@pytest.fixture(params=BOTSIM_MAPS)
def botsim_map(request: pytest.FixtureRequest) -> Map:
    return load_map(request.param)


@pytest.fixture
def twin_heading_warnings(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> Callable[[], list[str]]:
    """What the test logged about a `heading_deg` that is a twin (`toolkit.real_sonar.fit.heading_disagreements`),
    as a function to call after the command; a set's warnings are said once a process, so here afresh."""
    monkeypatch.setattr("toolkit.real_sonar.sweeps._WARNED", set())
    caplog.set_level(logging.WARNING)
    return lambda: [r.getMessage() for r in caplog.records if "the sweep most likely at" in r.getMessage()]


def wait_until(condition: Callable[[], object], timeout: float, what: str) -> None:
    """Return as soon as `condition()` is true; fail naming `what` when it is still false after `timeout` s.

    For a state another process or thread changes without telling (a file it writes, a process
    that ends): the condition is looked at every 20 ms, and the wait ends on it, not on the clock."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() >= deadline:
            raise AssertionError(f"{what}: still not so after {timeout:g} s")
        time.sleep(0.02)  # the pause between two looks at the condition (the one poll of the suite)


def load_tool(name: str) -> ModuleType:
    """``tools/NAME.py`` as a module (tools/ is not a package), registered in `sys.modules` as NAME so that
    its dataclasses and pickles resolve."""
    spec = importlib.util.spec_from_file_location(name, Path(__file__).resolve().parents[1] / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def run_cli(argv: list[str]) -> int:
    """Run the `nxtnav` command in this process; its exit code."""
    from toolkit.cli import main

    try:
        main(argv)
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def fails_cleanly(argv: list[str], capsys: pytest.CaptureFixture[str], *needles: str) -> str:
    """Run `argv` in this process: it must exit 2 with one line ``nxtnav: error: ...`` on stderr holding
    every needle; that line."""
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("nxtnav: error:"), err
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


def nxtnav_exe() -> str:
    """The `nxtnav` console script next to this Python (`make install` puts it there)."""
    exe = shutil.which("nxtnav", path=str(Path(sys.executable).parent))
    assert exe is not None, "the nxtnav console script is not installed next to this Python: run make install"
    return exe


def built_once(factory: pytest.TempPathFactory, name: str, build: Callable[[Path], None]) -> Path:
    """A folder that `build` fills once per test run, shared by the pytest-xdist workers of that run.

    Without xdist it is a fresh temporary folder. With it, the first worker to ask builds it under
    the run's common temporary folder while the others wait on a file lock, then read it.
    """
    if "PYTEST_XDIST_WORKER" not in os.environ:
        out = factory.mktemp(name)
        build(out)
        return out
    shared = factory.getbasetemp().parent  # the run's folder; each worker's basetemp lies inside it
    out, done = shared / name, shared / f"{name}.built"
    with (shared / f"{name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(out, ignore_errors=True)  # a build that failed half way is done again
            out.mkdir()
            build(out)
            done.touch()
    return out


def kept_run(folder: Path, name: str, argv: list[str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run `argv` (the `nxtnav` console script and its arguments) in `folder` and keep what it gave, exit code,
    stdout and stderr, as ``NAME.run.json`` there; without `argv`, what an earlier run kept under `name`.

    For a command several tests assert on: run once in a `built_once` folder, each test reads it back."""
    kept = folder / f"{name}.run.json"
    if argv is not None:
        proc = subprocess.run(argv, cwd=folder, capture_output=True, text=True, timeout=600)
        kept.write_text(json.dumps({"args": argv, "returncode": proc.returncode, "stdout": proc.stdout,
                                    "stderr": proc.stderr}), encoding="utf-8")
    run = json.loads(kept.read_text(encoding="utf-8"))
    return subprocess.CompletedProcess(run["args"], run["returncode"], run["stdout"], run["stderr"])


def _import_and_replay_the_shipped_sweeps(folder: Path) -> None:
    kept_run(folder, "import", [nxtnav_exe(), "import", "sweeps", str(REAL_NXT), "-o", "real.jsonl"])
    kept_run(folder, "replay", [nxtnav_exe(), "replay", "real.jsonl", "--localisers", "paper-pf,amcl",
                                "--json", "replay.json"])


@pytest.fixture(scope="session")
def shipped_sweeps_replayed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder outside the repository where a user's two commands on the shipped sweeps ran, once per test run:
    ``nxtnav import sweeps maps/real-nxt -o real.jsonl``, then ``nxtnav replay real.jsonl --localisers
    paper-pf,amcl --json replay.json``; what each gave is ``kept_run(folder, "import")`` and ``(.., "replay")``.

    Tests only read it (test_stuck_runs.py and test_replay_explains.py assert on these same two runs)."""
    return built_once(tmp_path_factory, "shipped-sweeps-replayed", _import_and_replay_the_shipped_sweeps)
