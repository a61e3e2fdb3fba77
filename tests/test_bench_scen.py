"""`nxtnav bench scen`: the exact planners against optimal lengths published by others."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
from conftest import run_cli

from toolkit.bench.scen import SCEN_COLUMNS, ScenConfig, read_scen, run_scen, select_queries, summarise
from toolkit.world import NxtnavError, import_map

EXTERNAL = Path(__file__).resolve().parents[1] / "maps" / "external"
ARENA = EXTERNAL / "arena2.map"
ARENA_SCEN = EXTERNAL / "arena2.map.scen"
CAPE = EXTERNAL / "AcrosstheCape.map"
CAPE_SCEN = EXTERNAL / "AcrosstheCape.map.scen"


def test_astar_reproduces_the_octile_optima() -> None:
    m = import_map(ARENA)
    queries = select_queries(read_scen(ARENA_SCEN, m, "octile"), 120)
    assert len(queries) == 120 and queries[-1].index == 909  # the longest queries are included
    result = run_scen(ScenConfig(str(ARENA_SCEN), str(ARENA), "octile", ("astar",)), queries)
    (s,) = summarise(result)
    assert s.exact and s.success == 120 and s.mismatches == 0 and s.below_optimum == 0
    assert s.max_rel_error < 1e-6


@pytest.mark.slow
def test_shortest_reproduces_the_any_angle_optima() -> None:
    m = import_map(CAPE)
    queries = select_queries(read_scen(CAPE_SCEN, m, "any-angle"), 12)
    result = run_scen(ScenConfig(str(CAPE_SCEN), str(CAPE), "any-angle", ("shortest",)), queries)
    (s,) = summarise(result)
    assert s.exact and s.success == 12 and s.mismatches == 0 and s.below_optimum == 0


def test_cli_writes_csv_summary_and_ompl_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    code = run_cli(["bench", "scen", str(ARENA_SCEN), "--kind", "octile", "--planners", "astar,shortest",
                "--limit", "6", "--out", str(out), "--check"])
    assert code == 0
    with (out / "scen.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == SCEN_COLUMNS and len(rows) == 12
    assert {r["planner"] for r in rows} == {"astar", "shortest"}
    # any-angle paths are never longer than octile ones
    by = {(r["planner"], r["query"]): float(r["length"]) for r in rows}
    assert all(by[("shortest", q)] <= by[("astar", q)] + 1e-9 for _, q in by)
    assert "| astar | 6/6 | yes | 0 | 0 |" in (out / "summary.md").read_text()
    log = (out / "scen.log").read_text().splitlines()
    assert log[0].startswith("nxtnav version") and "2 planners" in log


def test_check_fails_on_a_wrong_optimum(tmp_path: Path) -> None:
    lines = ARENA_SCEN.read_text().splitlines()[:4]
    fields = lines[3].split("\t")
    fields[8] = f"{float(fields[8]) + 1.0:.8f}"
    lines[3] = "\t".join(fields)
    bad = tmp_path / "arena2.map.scen"
    bad.write_text("\n".join(lines) + "\n")
    args = ["bench", "scen", str(bad), "--map", str(ARENA), "--kind", "octile", "--planners", "astar",
            "--out", str(tmp_path / "o")]
    assert run_cli(args) == 0
    assert run_cli([*args, "--check"]) == 1


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda f: f.__setitem__(1, "other.map"), "the query is for map 'other.map', not 'arena2.map'"),
        (lambda f: f.__setitem__(4, "0"), r"start \(0, \d+\) is not a free cell"),
        (lambda f: f.__setitem__(8, "x"), "a field is not a number"),
        (lambda f: f.pop(), "expected 9 fields"),
        (lambda f: f.__setitem__(2, "300"), "map size 300 x 209 differs"),
    ],
)
def test_bad_scenario_files(tmp_path: Path, capsys: pytest.CaptureFixture[str], edit, message: str) -> None:
    lines = ARENA_SCEN.read_text().splitlines()[:3]
    fields = lines[2].split("\t")
    edit(fields)
    lines[2] = "\t".join(fields)
    bad = tmp_path / "bad.scen"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(NxtnavError, match=message):
        read_scen(bad, import_map(ARENA), "octile")
    args = ["bench", "scen", str(bad), "--map", str(ARENA), "--kind", "octile", "--out", str(tmp_path / "o")]
    assert run_cli(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line 3" in err[0] and str(bad) in err[0]


def test_maps_import_writes_a_loadable_exact_map(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "arena.yaml"
    assert run_cli(["maps", "import", str(ARENA), "-o", str(out)]) == 0
    from toolkit.world import load_map

    m = load_map(out)
    assert m.polygon.equals(import_map(ARENA).polygon) and m.grid is not None
    assert run_cli(["maps", "import", str(ARENA), "-o", str(out)]) == 2  # no silent overwrite
    assert "exists" in capsys.readouterr().err
    assert run_cli(["maps", "import", str(tmp_path / "none.map"), "-o", str(tmp_path / "x.yaml")]) == 2


@pytest.mark.parametrize("case", ["short row", "missing image", "pgm size"])
def test_maps_import_bad_files_exit_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                   case: str) -> None:
    if case == "short row":
        src = tmp_path / "t.map"
        src.write_text("type octile\nheight 2\nwidth 3\nmap\n...\n..\n")
    else:
        src = tmp_path / "m.yaml"
        src.write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
                       "occupied_thresh: 0.65\nfree_thresh: 0.2\n")
        if case == "pgm size":
            (tmp_path / "m.pgm").write_bytes(b"P5\n40 40\n255\n" + bytes(300))
    assert run_cli(["maps", "import", str(src), "-o", str(tmp_path / "out.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nxtnav: error: ") and ("m.pgm" in err[0] or "t.map" in err[0])
    assert not (tmp_path / "out.yaml").exists()
