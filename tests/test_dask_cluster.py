"""`--dask ADDRESS` against a real Dask cluster: a `dask scheduler` and two `dask worker` processes
started here, on free loopback ports, each in a folder of its own (as on other machines).

For `nxtnav paper` and every benchmark that takes `--dask`, the cluster's results equal the local
process pool's for the same seed (timings aside), the tasks ran on the cluster's workers, and
Ctrl-C keeps the finished missions, marks them incomplete and leaves nothing behind on the cluster.
"""

from __future__ import annotations

import csv
import json
import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import REAL_NXT, nxtnav_exe, run_cli, wait_until
from distributed import Client

from toolkit.bench.planners.records import TIMING_COLUMNS

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("dask-cluster")]  # one cluster per test run

REPO = Path(__file__).resolve().parents[1]
DASK = Path(sys.executable).parent / "dask"
WORKERS = 2
TIMINGS = TIMING_COLUMNS | {"preprocess_s", "update_ms", "wall_s"}
"""Columns that hold wall-clock measures: they differ from run to run whatever the executor."""
WORKER_ENV = {**os.environ, "MALLOC_MMAP_THRESHOLD_": str(64 << 20)}
"""The workers' environment. A nanny starts its worker with glibc's ``MALLOC_TRIM_THRESHOLD_`` set (Dask's
``distributed.nanny.pre-spawn-environ``), which also fixes glibc's mmap threshold at 128 KiB: every larger
array is then mapped and unmapped afresh, and the localisers' tasks took twice the CPU time they take in a
local pool. A fixed 64 MiB threshold gives them back their speed; it changes no result."""


class Cluster:
    """The address of a running scheduler and a client to look at it."""

    def __init__(self, address: str, client: Client) -> None:
        self.address = address
        self.client = client

    def executed(self) -> dict[str, int]:
        """Tasks each worker has run so far."""
        done: dict[str, int] = self.client.run(lambda dask_worker: dask_worker.state.executed_count)
        return done

    def tasks_held(self) -> int:
        """Tasks the scheduler still knows of (0 once every client's work is finished or dropped)."""
        held: int = self.client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))
        return held


def _start(argv: list[str], cwd: Path, log: Path) -> subprocess.Popen[bytes]:
    with log.open("wb") as out:  # the child keeps its own descriptor
        return subprocess.Popen(argv, cwd=cwd, stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
                                env=WORKER_ENV)


def _end(procs: list[subprocess.Popen[bytes]]) -> None:
    """End each process's whole session (a worker's nanny and its worker process), politely first."""
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    """A scheduler on a port it picks itself (its address read from its scheduler file) and two
    single-threaded workers, each process in its own session and folder; all ended afterwards."""
    root = tmp_path_factory.mktemp("dask-cluster")
    scheduler_file = root / "scheduler.json"
    procs: list[subprocess.Popen[bytes]] = []
    try:
        procs.append(_start([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                             "--scheduler-file", str(scheduler_file)], root, root / "scheduler.log"))
        for i in range(WORKERS):
            home = root / f"worker{i}"
            home.mkdir()
            procs.append(_start([str(DASK), "worker", "--scheduler-file", str(scheduler_file), "--host", "127.0.0.1",
                                 "--nworkers", "1", "--nthreads", "1", "--no-dashboard", "--name", f"w{i}"],
                                home, home / "worker.log"))
        with Client(scheduler_file=str(scheduler_file), timeout=60) as client:
            client.wait_for_workers(WORKERS, timeout=180)
            yield Cluster(json.loads(scheduler_file.read_text())["address"], client)
    finally:
        _end(procs)


def _untimed(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in TIMINGS} for r in rows]


def _csv(path: Path) -> list[dict[str, Any]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _both(args: list[str], tmp_path: Path, cluster: Cluster) -> tuple[Path, Path, int]:
    """Run a benchmark on the cluster and on a local pool of as many workers: both output folders
    and the number of tasks the cluster's workers ran."""
    before = sum(cluster.executed().values())
    assert run_cli([*args, "--out", str(tmp_path / "dask"), "--dask", cluster.address]) == 0
    ran = sum(cluster.executed().values()) - before
    assert run_cli([*args, "--out", str(tmp_path / "pool"), "--workers", str(WORKERS)]) == 0
    return tmp_path / "dask", tmp_path / "pool", ran


def _untimed_tables(doc: Any) -> Any:
    """The paper's JSON without its wall-clock and CPU times (`completion_*`, `cpu_*`)."""
    if isinstance(doc, dict):
        return {k: _untimed_tables(v) for k, v in doc.items() if not k.startswith(("completion", "cpu"))}
    if isinstance(doc, list):
        return [_untimed_tables(v) for v in doc]
    return doc


def test_paper_on_the_cluster_equals_the_local_pool(tmp_path: Path, cluster: Cluster) -> None:
    args = ["paper", "--trials", "2", "--seed", "0"]
    before = cluster.executed()
    assert run_cli([*args, "--dask", cluster.address, "--json", str(tmp_path / "dask.json")]) == 0
    after = cluster.executed()
    assert run_cli([*args, "--workers", str(WORKERS), "--json", str(tmp_path / "pool.json")]) == 0
    dask, pool = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("dask", "pool"))
    missions = 3 * 2 * 2  # maps x noise models x trials
    assert sum(after.values()) - sum(before.values()) == missions
    assert all(after[w] > before[w] for w in after), f"a worker ran none of the missions: {before} -> {after}"
    assert [t["noise_model"] for t in dask] == ["botsim", "absolute"]
    assert all(t["complete"] and t["missions_done"] == missions for t in dask)
    assert _untimed_tables(dask) == _untimed_tables(pool)
    assert dask[0]["rows"][0]["completion_s"] > 0  # the timings left out were there


def test_bench_planners_on_the_cluster_equals_the_local_pool(tmp_path: Path, cluster: Cluster) -> None:
    args = ["bench", "planners", "--maps", "map1,map2", "--planners", "min-turn,astar", "--runs", "2",
            "--time-limit", "0.5", "--exec-repeats", "3", "--seed", "0", "--no-plots"]
    dask, pool, ran = _both(args, tmp_path, cluster)
    runs = _csv(dask / "runs.csv")
    assert len(runs) == 8 and ran == 2 + 8  # a reference per map's preset query, then every run
    # astar builds its grid once per process and counts that grid's checks in the run that built it,
    # so its counter depends on which process ran which query, like a timing; min-turn's is compared
    def comparable(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{k: v for k, v in r.items() if not (r["planner"] == "astar" and k == "collision_checks")}
                for r in _untimed(rows)]

    assert comparable(runs) == comparable(_csv(pool / "runs.csv"))
    assert _untimed(_csv(dask / "references.csv")) == _untimed(_csv(pool / "references.csv"))
    paths = [_untimed([json.loads(x) for x in (d / "paths.jsonl").read_text().splitlines()]) for d in (dask, pool)]
    assert len(paths[0]) == 8 and paths[0] == paths[1]


def test_bench_localisers_on_the_cluster_equals_the_local_pool(tmp_path: Path, cluster: Cluster) -> None:
    args = ["bench", "localisers", "--maps", "map1", "--localisers", "paper-pf,amcl", "--trials", "2",
            "--scenario", "all", "--seed", "0"]
    dask, pool, ran = _both(args, tmp_path, cluster)
    assert ran == 2 * 2 * 3  # localisers x trials x scenarios
    for name in ("runs.csv", "tracking.csv", "kidnapped.csv"):
        rows = _csv(dask / name)
        assert len(rows) == 4, name
        assert _untimed(rows) == _untimed(_csv(pool / name)), name


def test_bench_scen_on_the_cluster_equals_the_local_pool(tmp_path: Path, cluster: Cluster) -> None:
    scen = REPO / "maps" / "external" / "arena2.map.scen"
    args = ["bench", "scen", str(scen), "--kind", "octile", "--planners", "astar,shortest", "--limit", "6", "--check"]
    dask, pool, ran = _both(args, tmp_path, cluster)
    rows = _csv(dask / "scen.csv")
    assert len(rows) == ran == 12
    assert all(r["success"] == "true" for r in rows)
    assert _untimed(rows) == _untimed(_csv(pool / "scen.csv"))


def test_bench_sweeps_on_the_cluster_equals_the_local_pool(tmp_path: Path, cluster: Cluster) -> None:
    args = ["bench", "sweeps", str(REAL_NXT), "--localisers", "paper-pf,amcl", "--seeds", "0"]
    dask, pool, ran = _both(args, tmp_path, cluster)
    rows = _csv(dask / "sweeps.csv")
    assert len(rows) == ran == 6
    assert _untimed(rows) == _untimed(_csv(pool / "sweeps.csv"))


def test_bench_faults_on_the_cluster_equals_the_local_pool(tmp_path: Path, cluster: Cluster) -> None:
    # faults on the brick's clock only (a dropped link or a stall lasts wall-clock seconds, which a
    # loaded machine stretches differently from run to run)
    args = ["bench", "faults", "--missions", "1", "--seed", "0", "--faults", "sonar-stuck,sonar-garbage,motor-slip"]
    before = sum(cluster.executed().values())
    assert run_cli([*args, "--json", str(tmp_path / "dask.json"), "--dask", cluster.address]) == 0
    assert sum(cluster.executed().values()) - before == 1
    assert run_cli([*args, "--json", str(tmp_path / "pool.json"), "--workers", str(WORKERS)]) == 0
    dask, pool = (json.loads((tmp_path / f"{name}.json").read_text()) for name in ("dask", "pool"))
    assert dask["missions"][0]["faults"] and dask["missions"][0]["reproduced"]
    assert _untimed(dask["missions"]) == _untimed(pool["missions"])


def test_ctrl_c_on_the_cluster_keeps_the_finished_missions_and_drops_the_rest(tmp_path: Path,
                                                                              cluster: Cluster) -> None:
    out, err_file = tmp_path / "table.json", tmp_path / "err.txt"
    argv = [nxtnav_exe(), "paper", "--trials", "200", "--maps", "map1", "--noise-model", "botsim",
            "--dask", cluster.address, "--json", str(out)]
    with err_file.open("w") as err:
        proc = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=err, text=True,
                                start_new_session=True,  # its own group, as a terminal's foreground job
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        wait_until(lambda: "missions: 1/200 " in err_file.read_text() or proc.poll() is not None, 300.0,
                   "the first mission's progress line")
        assert proc.poll() is None, "the command ended before it could be interrupted"
        os.killpg(proc.pid, signal.SIGINT)
        stdout, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130
    lines = err_file.read_text().splitlines()
    progress = [ln for ln in lines if re.fullmatch(r"missions: \d+/200 \(\d+ %\), \d+ s", ln)]
    assert progress and progress[0].startswith("missions: 1/200 ")
    rest = [ln for ln in lines if ln.strip() and ln not in progress]
    assert len(rest) == 1 and rest[0].startswith("nxtnav: interrupted:") and str(out) in rest[0], rest
    tables = json.loads(out.read_text())
    assert tables and all(t["complete"] is False for t in tables)
    done = tables[0]["missions_done"]
    assert 0 < done < tables[0]["missions_planned"] == 200
    assert tables[0]["rows"][0]["trials"] == done
    assert "INCOMPLETE" in stdout
    # the client's unfinished missions are dropped from the cluster, whose workers stay up
    wait_until(lambda: cluster.tasks_held() == 0, 60.0, "the cluster dropping the interrupted client's tasks")
    assert len(cluster.client.scheduler_info()["workers"]) == WORKERS
