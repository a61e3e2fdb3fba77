"""`nxtnav bench routes` on the shipped real sweeps (one source, three waypoints), per-source sonar profiles
(`sonar fit --per-source`, `--sonar-profile DIR`), and bad input: one line, exit 2, nothing written."""

from __future__ import annotations

import csv
import json
import math
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import REAL_NXT, fails_cleanly, run_cli

from localisation.models import MotionModel
from toolkit.bench.routes import COLUMNS, make_route_tasks, model_headings, odometry, plan_routes, run_route
from toolkit.real_sonar.fit import load_sonar_profile, save_sonar_profile, source_profile_name
from toolkit.real_sonar.sweeps import SweepSetError, load_sweep_set
from toolkit.world import MotionNoise, NxtSonar, Pose

FEW = ["--localisers", "paper-pf", "--seeds", "0", "--set", "paper-pf.n_particles=200"]


def _copy(tmp_path: Path, rows: slice | None = None, edit: dict[str, str] | None = None,
          relabel: tuple[int, str] | None = None) -> Path:
    """A copy of the shipped set with some of its rows, a field changed in every row, or its sweeps from
    row `relabel[0]` on relabelled as source `relabel[1]`'s."""
    dst = tmp_path / "set"
    shutil.copytree(REAL_NXT, dst)
    with (dst / "sweeps.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    table = table[rows] if rows is not None else table
    for row in table:
        row.update(edit or {})
    if relabel is not None:
        for row in table[relabel[0]:]:
            row["repo"] = relabel[1]
    with (dst / "sweeps.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    return dst


def test_routes_visit_every_waypoint_once_in_the_course_order() -> None:
    sweeps = load_sweep_set(REAL_NXT)
    course = sweeps.waypoints("andrei-alpha/robotics")
    routes = plan_routes(sweeps, orders=2)
    assert [r.name for r in routes] == ["course-0", "course-1", "course-2", "random-0", "random-1"]
    assert routes[1].waypoints == (course[1], course[2], course[0])
    for r in routes:
        assert sorted(r.waypoints) == sorted(course)
    assert plan_routes(sweeps, orders=2) == routes  # the random orders are seeded
    reversed_order = list(reversed(course))
    assert plan_routes(sweeps, order=reversed_order)[0].waypoints == tuple(reversed_order)


def test_odometry_without_noise_is_the_true_motion() -> None:
    start, end = Pose(180.0, 30.0, math.radians(6.0)), Pose(126.0, 168.0, math.radians(-90.5))
    rng = np.random.default_rng(0)
    model = MotionModel()
    pose = start.as_array()
    for m in odometry(start, end, MotionNoise("botsim", 0.0, 0.0), rng):
        pose = model.mean(pose, m)
    assert pose == pytest.approx(end.as_array(), abs=1e-9)
    noisy = odometry(start, end, MotionNoise("botsim", 0.1, 0.05), rng)
    assert noisy[0].distance_cm != pytest.approx(math.hypot(54.0, 138.0), abs=1e-6)


def test_bench_routes_writes_every_step(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert run_cli(["bench", "routes", str(REAL_NXT), *FEW, "--out", str(out)]) == 0
    with (out / "routes.csv").open(newline="") as fh:
        reader = csv.DictReader(fh)
        assert tuple(reader.fieldnames or ()) == COLUMNS
        rows = list(reader)
    assert len(rows) == 3 * 3  # 3 course orders x 3 waypoints, one localiser, one seed
    assert [r["step"] for r in rows[:3]] == ["1", "2", "3"]
    for route in ("course-0", "course-1", "course-2"):
        mine = [r for r in rows if r["route"] == route]
        assert len({(r["waypoint_x_cm"], r["waypoint_y_cm"]) for r in mine}) == 3
    for r in rows:
        assert float(r["error_cm"]) >= 0 and 0 <= float(r["heading_error_deg"]) <= 180
        assert (r["ambiguous"] == "True") == (int(r["candidates"]) > 1)
    doc = json.loads((out / "summary.json").read_text())
    steps = doc["localisers"]["paper-pf"]["steps"]
    assert sorted(steps) == ["1", "2", "3"] and all(s["runs"] == 3 for s in steps.values())
    step2 = [float(r["error_cm"]) <= 10.0 for r in rows if r["step"] == "2"]
    assert doc["localisers"]["paper-pf"]["within_10cm_after_second"] == pytest.approx(sum(step2) / 3)
    assert doc["localisers"]["paper-pf"]["within_10cm_after_second_by_source"] == \
        {"andrei-alpha/robotics": pytest.approx(sum(step2) / 3)}  # the shipped set's one source
    assert (out / "route.png").stat().st_size > 10_000
    assert "within 10 cm after the second sweep" in capsys.readouterr().out


def test_the_second_sweeps_share_is_given_per_source(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _copy(tmp_path)
    with (folder / "sweeps.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    with (folder / "sweeps.csv").open("a", newline="") as fh:  # the same sweeps again, from a second robot
        csv.DictWriter(fh, fieldnames=list(table[0])).writerows([{**row, "repo": "other/robot"} for row in table])
    out = tmp_path / "out"
    assert run_cli(["bench", "routes", str(folder), *FEW, "--out", str(out)]) == 0
    with (out / "routes.csv").open(newline="") as fh:
        second = [r for r in csv.DictReader(fh) if r["step"] == "2"]
    doc = json.loads((out / "summary.json").read_text())["localisers"]["paper-pf"]
    by_source = doc["within_10cm_after_second_by_source"]
    want = {repo: np.mean([float(r["error_cm"]) <= 10.0 for r in second if r["repo"] == repo])
            for repo in ("andrei-alpha/robotics", "other/robot")}
    assert by_source == pytest.approx(want)
    assert doc["within_10cm_after_second"] == pytest.approx(np.mean(list(want.values())))  # 3 routes each
    shown = ", ".join(f"{repo} {share:.0%}" for repo, share in want.items())
    assert f"after the second sweep, by source: {shown}" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["--orders", "-1"], "--orders"),
    (["--order", "sideways"], "unknown order"),
    (["--order", "180:30,30:54"], "is not in the order"),
    (["--localisers", "ekf"], "cannot localise globally"),
    (["--noise", "1,-0.1,0"], "--noise"),
    (["--headings", "sideways"], "--headings"),
])
def test_bad_options_exit_2_and_write_nothing(tmp_path: Path, args: list[str], message: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    fails_cleanly(["bench", "routes", str(REAL_NXT), *FEW, "--out", str(out), *args], capsys, message)
    assert not out.exists()


@pytest.mark.parametrize(("copy", "message"), [
    ({"rows": slice(0, 1)}, "no source has sweeps at two or more waypoints"),
    ({"edit": {"heading_deg": ""}}, "has no heading_deg"),
])
def test_bad_sweep_sets_exit_2_and_write_nothing(tmp_path: Path, copy: dict[str, object], message: str,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    folder = _copy(tmp_path, **copy)  # type: ignore[arg-type]
    out = tmp_path / "out"
    assert run_cli(["bench", "routes", str(folder), *FEW, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()
    with pytest.raises(SweepSetError, match=message):
        plan_routes(load_sweep_set(folder))


def test_model_headings_stand_in_for_a_missing_column(tmp_path: Path) -> None:
    sweeps = load_sweep_set(_copy(tmp_path, edit={"heading_deg": ""}))
    assert len(plan_routes(sweeps, need_headings=False)) == 3
    headings = model_headings(sweeps, {"andrei-alpha/robotics": NxtSonar()}, ["andrei-alpha/robotics"])
    assert sorted(headings) == sorted(sw.label for sw in sweeps)
    shipped = {sw.label: sw.heading_deg for sw in load_sweep_set(REAL_NXT)}
    # the model's heading of the sweep at (180, 30) is the column's within a few degrees
    label = "andrei-alpha/robotics/loc_01.dat"
    assert abs(headings[label] - shipped[label]) < 10.0


@pytest.mark.slow
def test_per_source_profiles_are_fitted_on_each_source_alone(tmp_path: Path) -> None:
    folder = _copy(tmp_path, relabel=(2, "someone/else"))
    profiles = tmp_path / "profiles"
    assert run_cli(["sonar", "fit", str(folder), "--per-source", "--widths", "20", "--criticals", "40",
                    "-o", str(profiles), "--json", str(tmp_path / "fit.json")]) == 0
    names = sorted(p.name for p in profiles.iterdir())
    assert names == sorted([source_profile_name("andrei-alpha/robotics"), source_profile_name("someone/else")])
    docs = {n: yaml.safe_load((profiles / n).read_text()) for n in names}
    assert docs["andrei-alpha+robotics.yaml"]["fit"]["sweeps"] == 2
    assert docs["someone+else.yaml"]["fit"]["sweeps"] == 1
    models = [load_sonar_profile(profiles / n) for n in names]
    assert models[0] != models[1]  # each fitted on its own sweeps


def test_a_folder_of_profiles_needs_one_per_source(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = _copy(tmp_path, relabel=(1, "someone/else"))  # two waypoints: the source bench routes routes
    profiles = tmp_path / "profiles"
    profiles.mkdir()
    save_sonar_profile(NxtSonar(), profiles / source_profile_name("andrei-alpha/robotics"))
    out = tmp_path / "out"
    for command in (["bench", "routes"], ["bench", "sweeps"]):
        assert run_cli([*command, str(folder), *FEW[:4], "--sonar-profile", str(profiles), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "no profile someone+else.yaml for source someone/else" in err[0], err
        assert not out.exists()


@pytest.mark.slow
def test_bench_sweeps_gives_each_source_its_profile(tmp_path: Path) -> None:
    folder = _copy(tmp_path, relabel=(2, "someone/else"))
    profiles = tmp_path / "profiles"
    profiles.mkdir()
    save_sonar_profile(NxtSonar(), profiles / source_profile_name("andrei-alpha/robotics"))
    save_sonar_profile(NxtSonar(bias_cm=2.0), profiles / source_profile_name("someone/else"))
    out = tmp_path / "out"
    assert run_cli(["bench", "sweeps", str(folder), *FEW[:4], "--sonar-profile", str(profiles),
                    "--out", str(out)]) == 0
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["sonar"]["someone/else"]["bias_cm"] == 2.0
    assert cfg["sonar"]["andrei-alpha/robotics"]["bias_cm"] == NxtSonar().bias_cm
    assert "Sonar model (`nxt`) of someone/else" in (out / "summary.md").read_text()


@pytest.mark.parametrize(("surprise_mass", "honest"), [(None, True), (0.0, False)])
def test_a_drive_the_odometry_did_not_predict_leaves_paper_pf_ambiguous(surprise_mass: float | None,
                                                                       honest: bool) -> None:
    """The shipped sweeps, course-0, seed 0: the odometry drives the first sweep's belief 95 cm from the
    second waypoint and the second sweep fits a twin there. paper-pf converged on the twin, confidently
    wrong; the prediction held under 1 % of the belief near it, so the fix is now called ambiguous with
    the poses the sweep alone allows, the truth among them (``tracking.surprise_mass=0``: as before)."""
    sweeps = load_sweep_set(REAL_NXT, "co333-arena")
    route = plan_routes(sweeps)[0]
    options = {} if surprise_mass is None else {"paper-pf": {"tracking.surprise_mass": surprise_mass}}
    task = make_route_tasks(sweeps, "co333-arena", [route], ["paper-pf"], [0], {route.repo: NxtSonar()},
                            MotionNoise("botsim", 0.1, 0.005), options)[0]
    second = run_route(task)[1]
    assert second.error_cm > 20.0  # the twin, either way
    assert second.confidently_wrong is not honest
    assert (second.ambiguous and second.truth_in_candidates) is honest


@pytest.mark.parametrize(("headings", "named"), [([], 1), (["--headings", "model"], 0)])
def test_a_twin_heading_taken_as_the_truth_is_named(
        tmp_path: Path, twin_heading_warnings: Callable[[], list[str]], headings: list[str], named: int) -> None:
    """Routes judged by the set's heading_deg warn about a sweep whose heading is a quarter turn from where
    the model finds it (the shipped loc_03: -90.5 against about -7); with the model's headings, nothing."""
    assert run_cli(["bench", "routes", str(REAL_NXT), *FEW, *headings, "--out", str(tmp_path / "out")]) == 0
    said = twin_heading_warnings()
    assert len(said) == named
    assert all(s.startswith("andrei-alpha/robotics/loc_03.dat: heading_deg -90.5 is 8") for s in said)
