"""`nxtnav maps`, `nxtnav scan` and `nxtnav bench world` from the command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from conftest import run_cli

from toolkit.world import load_map, ray_cast
from toolkit.world.generated import random_grid_map


def test_maps_list(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["maps", "list"]) == 0
    out = capsys.readouterr().out
    for name in ("map1", "map2", "map3"):
        assert name in out


def test_maps_show_writes_png(tmp_path: Path) -> None:
    out = tmp_path / "sub" / "m.png"
    assert run_cli(["maps", "show", "map3", "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_maps_list_and_show_the_co333_arena(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["maps", "list"]) == 0
    assert "co333-arena" in capsys.readouterr().out
    out = tmp_path / "arena.png"
    assert run_cli(["maps", "show", "co333-arena", "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_thin_walls_are_drawn_thick() -> None:
    from toolkit.plotting import draw_map, new_axes

    m = load_map("co333-arena")
    fig, ax = new_axes()
    artists = draw_map(m, ax)
    thin = [a for a in artists if a.get_label() == "thin wall"]
    edges = [a for a in artists if a not in thin and hasattr(a, "get_segments")]
    assert len(thin) == 1 and len(edges) == 1
    np.testing.assert_array_equal(np.asarray(thin[0].get_segments()), [[[84, 126], [84, 168]]])
    assert len(edges[0].get_segments()) == len(m.boundary)  # the stub is drawn once, as a thin wall
    assert min(thin[0].get_linewidths()) >= 3.0 > max(edges[0].get_linewidths())
    plt.close(fig)


def test_scan_json(tmp_path: Path) -> None:
    png, js = tmp_path / "s.png", tmp_path / "s.json"
    assert run_cli(["scan", "--map", "map1", "--pose", "20,85,0", "--sonar", "ideal", "--seed", "3",
                "-o", str(png), "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    assert doc["pose"] == [20.0, 85.0, 0.0]
    assert len(doc["angles_deg"]) == len(doc["ranges_cm"]) == 360
    exact = ray_cast(load_map("map1").walls, [20, 85], np.radians(doc["angles_deg"]))
    assert np.max(np.abs(np.array(doc["ranges_cm"]) - exact)) < 5.0  # 1 cm noise, 5 sigma
    assert png.exists()


@pytest.mark.parametrize(("spec", "direction", "expected_deg"), [
    ("0:1:360", "cw", -np.arange(360.0)),
    ("0:5:72", "ccw", 5.0 * np.arange(72)),
    ("180:5:72", "cw", 180.0 - 5.0 * np.arange(72)),
    ("-90:2.5:3", "ccw", [-90.0, -87.5, -85.0]),
    ("30:1:1", "cw", [30.0]),
])
def test_scan_at_any_angles(tmp_path: Path, spec: str, direction: str, expected_deg: list[float]) -> None:
    js = tmp_path / "s.json"
    assert run_cli(["scan", "--map", "map1", "--pose", "20,85,30", "--sonar", "ideal", "--sensor-noise", "0",
                    "--angles", spec, "--direction", direction, "--json", str(js)]) == 0
    doc = json.loads(js.read_text())
    start, step, count = (float(v) for v in spec.split(":"))
    assert doc["sweep"] == {"start_deg": start, "step_deg": step, "count": count, "direction": direction}
    assert len(doc["angles_deg"]) == len(doc["ranges_cm"]) == int(count)
    assert np.allclose(doc["angles_deg"], expected_deg, rtol=0, atol=1e-9)
    # reading k looks along heading + angle k: the exact range there (no noise asked)
    exact = ray_cast(load_map("map1").walls, [20, 85], np.radians(30.0 + np.asarray(doc["angles_deg"])))
    assert np.allclose(doc["ranges_cm"], exact, rtol=0, atol=1e-9)


def test_scan_mirrors_a_real_sweep_reading_for_reading(tmp_path: Path) -> None:
    from conftest import REAL_NXT, real_nxt_arena

    from toolkit.real_sonar.sweeps import load_sweep_set

    real = load_sweep_set(REAL_NXT, map=real_nxt_arena()).sweeps[0]  # 360 readings, 1 degree apart, cw
    js = tmp_path / "s.json"
    assert run_cli(["scan", "--pose", "20,85,0", "--angles", f"0:{real.step_deg:g}:{real.readings.size}",
                    "--direction", real.direction, "--json", str(js)]) == 0
    assert np.allclose(np.radians(json.loads(js.read_text())["angles_deg"]), real.angles, rtol=0, atol=1e-12)


def test_scan_nxt_has_nulls_for_no_echo(tmp_path: Path) -> None:
    js = tmp_path / "s.json"
    assert run_cli(["scan", "--map", "map1", "--pose", "20,85,0", "--sonar", "nxt", "-o", str(tmp_path / "s.png"),
                "--json", str(js)]) == 0
    ranges = json.loads(js.read_text())["ranges_cm"]
    assert None in ranges and all(r is None or r == int(r) for r in ranges)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["scan", "--map", "map1", "--pose", "20,85", "-o", "x.png"], "--pose: expected 3"),
        (["scan", "--map", "nomap", "--pose", "1,1,0", "-o", "x.png"], "unknown map 'nomap'"),
        (["scan", "--map", "map1", "--pose", "500,1,0", "-o", "x.png"], "outside the free area"),
        (["scan", "--map", "map1", "--pose", "20,20,0", "--sonar", "radar", "-o", "x.png"], "unknown sonar model"),
        (["maps", "show", "missing.yaml", "-o", "x.png"], "not found"),
    ],
)
def test_errors_are_one_line_exit_2(tmp_path: Path, args: list[str], message: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "toolkit.cli", *args], cwd=tmp_path, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, proc.stderr
    assert message in lines[0]
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "x.png").exists()


def test_bench_world_prints_rates(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["bench", "world", "--poses", "50", "--repeats", "1", "--segments", "200"]) == 0
    out = capsys.readouterr().out
    assert "M rays/s" in out and "checks/s" in out


def test_bench_world_json_on_a_generated_grid(tmp_path: Path) -> None:
    out = tmp_path / "w.json"
    args = ["bench", "world", "--random-grid", "24", "--poses", "20", "--repeats", "1", "--segments", "300",
            "--no-peer", "--json", str(out)]
    assert run_cli(args) == 0
    doc = json.loads(out.read_text())
    assert doc["edges"] == len(random_grid_map(24, rng=0).walls) > 100
    for key in ("rays_per_s", "segment_checks_per_s", "point_checks_per_s", "cspace_build_s",
                "range_model_build_s", "range_model_bytes"):
        assert doc[key] > 0, key
    assert doc["range_model_bytes"] <= 1024 * 2**20


@pytest.mark.parametrize("budget", ["0", "-1", "0.5"])
def test_bench_world_range_budget_errors(budget: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "toolkit.cli", "bench", "world", "--random-grid", "64",
                           "--poses", "5", "--repeats", "1", "--segments", "50", "--no-peer",
                           "--range-memory-mb", budget], capture_output=True, text=True, check=False)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "--range-memory-mb" in lines[0] and "Traceback" not in proc.stderr


def test_scan_radius_draws_a_scaled_robot_that_must_fit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    js = tmp_path / "s.json"
    assert run_cli(["scan", "--map", "map1", "--pose", "30,30,0", "--radius", "12", "--json", str(js)]) == 0
    assert json.loads(js.read_text())["radius_cm"] == 12.0
    capsys.readouterr()
    assert run_cli(["scan", "--map", "map1", "--pose", "30,30,0", "--radius", "40"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "radius 40" in err
    assert run_cli(["scan", "--map", "map1", "--pose", "30,30,0", "--radius", "0"]) == 2
