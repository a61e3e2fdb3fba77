"""One objective for every planner: what each can minimise, the references, and the command line.

Every cost here is the robot model's (`toolkit.world.RobotTiming`): a lattice path or an OMPL path under
``robot-time`` must never cost less than the ``fastest`` reference of its query, and the reference must
agree with a hand count on a map small enough to reason about.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli

from planners import PLANNERS, PlanningProblem, make_planner
from toolkit.world import ConfigError, RobotTiming, load_map, make_checker, map_from_dict, objective_cost

TIMING = RobotTiming(drive_speed_cm_s=10.0, turn_rate_deg_s=45.0)
WALL = map_from_dict({"name": "one-wall",
                      "boundary": [[0, 0], [48, 0], [48, 40], [52, 40], [52, 0], [100, 0], [100, 60], [0, 60]]})
"""A 100 x 60 cm room with a wall from the floor up to y = 40 in the middle: the robot goes over it."""


def _problem(m: object, start: tuple[float, float], goal: tuple[float, float], radius: float = 0.0,
             seed: int = 0) -> PlanningProblem:
    return PlanningProblem(m, make_checker(m, radius), np.array(start), np.array(goal), 0.3,  # type: ignore[arg-type]
                           np.random.default_rng(seed), TIMING)


def test_fastest_over_one_wall_by_hand() -> None:
    """Point robot from (20, 20) to (80, 20): up to the wall's top corners and down again. The taut path
    bends at (48, 40) and (52, 40); its robot time is its length at 10 cm/s plus its turns at 45 deg/s."""
    res = make_planner("fastest").plan(_problem(WALL, (20, 20), (80, 20)))
    assert res.success and res.objective == "robot-time"
    a = math.atan2(20, 28)  # rising from (20, 20) to (48, 40)
    by_hand = (2 * math.hypot(28, 20) + 4) / 10 + 2 * math.degrees(a) / 45
    assert res.objective_cost == pytest.approx(by_hand, abs=1e-3)
    assert objective_cost("robot-time", res.path, TIMING) == pytest.approx(res.objective_cost)


@pytest.mark.parametrize("name", ["astar", "rrtstar", "min-turn"])
def test_no_planner_beats_the_robot_time_reference(name: str) -> None:
    m = load_map("map1")
    start, goal = (float(m.start[0]), float(m.start[1])), (float(m.target[0]), float(m.target[1]))  # type: ignore[index]
    ref = make_planner("fastest").plan(_problem(m, start, goal, 8.0))
    res = make_planner(name, objective="robot-time").plan(_problem(m, start, goal, 8.0))
    assert ref.success and res.success and res.objective == "robot-time"
    assert res.objective_cost >= ref.objective_cost * (1 - 1e-6)
    assert res.objective_cost == pytest.approx(objective_cost("robot-time", res.path, TIMING))


def test_lattice_astar_matches_the_reference_where_the_lattice_holds_the_optimum() -> None:
    """Over the wall with corners on the lattice and 45-degree bends the lattice path is the taut path."""
    m = map_from_dict({"name": "step",
                       "boundary": [[0, 0], [40, 0], [40, 20], [60, 20], [60, 0], [100, 0], [100, 60], [0, 60]]})
    problem = _problem(m, (21, 1), (79, 1))  # the taut path: 45 degrees up, along the top, 45 degrees down
    ref = make_planner("fastest").plan(problem)
    lattice = make_planner("astar", resolution=1.0, objective="robot-time").plan(problem)
    assert ref.success and lattice.success
    assert lattice.objective_cost >= ref.objective_cost * (1 - 1e-9)
    assert lattice.objective_cost == pytest.approx(ref.objective_cost, rel=1e-6)
    turns = make_planner("astar", resolution=1.0, objective="turns").plan(problem)
    length = make_planner("astar", resolution=1.0).plan(problem)
    assert turns.objective_cost <= objective_cost("turns", length.path)


def test_every_planner_says_what_it_minimises() -> None:
    for name in PLANNERS.names():
        cls = PLANNERS.class_of(name)
        assert cls.objectives and set(cls.objectives) <= {"length", "turns", "robot-time"}, name
        assert make_planner(name).minimises == cls.objectives[0]
    with pytest.raises(ConfigError, match=r"planner 'shortest' cannot optimise objective 'turns'; it optimises length"):
        make_planner("shortest", objective="turns")
    with pytest.raises(ConfigError, match=r"unknown objective 'speed'"):
        make_planner("rrtstar", objective="speed")


@pytest.mark.parametrize(("args", "words"), [
    (["--objective", "speed"], "unknown objective 'speed'"),
    (["--planner", "shortest", "--objective", "robot-time"], "planner 'shortest' cannot optimise objective "
                                                              "'robot-time'; it optimises length"),
    (["--planner", "ompl:RRTConnect", "--objective", "robot-time"], "planner 'ompl:RRTConnect' cannot optimise "
                                                                    "objective 'robot-time'; it optimises length"),
    (["--drive-speed", "0"], "--drive-speed"),
    (["--turn-rate", "inf"], "--turn-rate"),
    (["--turn-rate", "nan"], "--turn-rate"),
])
def test_plan_refuses_a_bad_objective_or_robot_before_planning(args: list[str], words: str, tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["plan", "--exec-repeats", "0", "-o", str(tmp_path / "p.png"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("nxtnav: error:") and words in err[0], err
    assert not any(tmp_path.iterdir())


def test_plan_json_reports_the_robot_cost(tmp_path: Path) -> None:
    out = tmp_path / "p.json"
    assert run_cli(["plan", "--map", "map1", "--planner", "astar", "--objective", "robot-time", "--turn-rate", "60",
                    "--exec-repeats", "0", "-o", str(tmp_path / "p.png"), "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    timing = RobotTiming(turn_rate_deg_s=60.0)
    assert doc["objective"] == "robot-time"
    assert doc["robot_time_s"] == pytest.approx(objective_cost("robot-time", doc["path"], timing))
    assert doc["objective_cost"] == pytest.approx(doc["robot_time_s"])
    assert 0 < doc["reference_cost"] <= doc["objective_cost"] and doc["predicted_error_cm"] > 0


def test_bench_runs_csv_has_the_objective_columns(tmp_path: Path) -> None:
    out = tmp_path / "b"
    assert run_cli(["bench", "planners", "--maps", "map1", "--planners", "astar,min-turn", "--runs", "1",
                    "--objective", "robot-time", "--exec-repeats", "0", "--simplify", "none", "--no-plots",
                    "--out", str(out)]) == 0
    with (out / "runs.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["objective"] for r in rows} == {"robot-time"}
    for r in rows:
        assert float(r["reference_cost"]) <= float(r["objective_cost"]) == pytest.approx(float(r["robot_time_s"]))
        assert float(r["predicted_error_cm"]) > 0
    assert "BUG" not in (out / "summary.md").read_text()


def test_bench_default_planners_under_robot_time_leave_out_those_that_cannot(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The default list holds PRM (length only): asked for robot time without --planners, the bench runs
    the others and names PRM on stderr; a list the user gave with PRM stays an error."""
    out = tmp_path / "b"
    assert run_cli(["bench", "planners", "--maps", "map1", "--runs", "1", "--time-limit", "0.05",
                    "--objective", "robot-time", "--exec-repeats", "0", "--simplify", "none", "--no-plots",
                    "--out", str(out)]) == 0
    assert "left out of the default planners" in capsys.readouterr().err
    with (out / "runs.csv").open(newline="") as fh:
        ran = {r["planner"] for r in csv.DictReader(fh)}
    assert "prm" not in ran and {"min-turn", "astar", "rrtstar"} <= ran
    assert run_cli(["bench", "planners", "--maps", "map1", "--planners", "prm,astar", "--runs", "1",
                    "--objective", "robot-time", "--out", str(tmp_path / "c")]) == 2


@pytest.mark.parametrize("command", [["run", "--planner", "min-link"], ["paper", "--trials", "1",
                                                                        "--stack", "shortest/paper-pf"]])
def test_missions_refuse_an_objective_their_planner_cannot_minimise(command: list[str],
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli([*command, "--objective", "robot-time"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot optimise objective 'robot-time'" in err[0], err


def test_a_mission_plans_under_the_objective(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    assert run_cli(["run", "--map", "map1", "--planner", "astar", "--objective", "robot-time", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["objective"] == "robot-time" and doc["success"]
    first = np.asarray(doc["plans"][0], dtype=float)
    assert objective_cost("turns", first) <= 4  # a lattice path under robot time bends rarely; by length it zigzags


def test_bench_objectives_runs_each_planner_under_what_it_can_minimise(tmp_path: Path) -> None:
    out = tmp_path / "o"
    assert run_cli(["bench", "objectives", "--maps", "map1", "--planners", "astar,min-turn", "--runs", "1",
                    "--exec-repeats", "0", "--no-plots", "--out", str(out)]) == 0
    with (out / "objectives.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    pairs = {(r["planner"], r["objective"]) for r in rows}
    assert pairs == {("astar", "length"), ("astar", "turns"), ("astar", "robot-time"), ("min-turn", "turns"),
                     ("min-turn", "robot-time")}
    for r in rows:  # nothing beats the least robot time of the query
        assert float(r["robot_time_s"]) >= float(r["fastest_time_s"]) * (1 - 1e-9)
    by = {(r["planner"], r["objective"]): float(r["robot_time_s"]) for r in rows}
    assert by[("astar", "robot-time")] < by[("astar", "length")]  # the lattice's zigzag costs turns
    summary = (out / "objectives.md").read_text()
    assert "## map1" in summary and "No run costs less than the reference optimum" in summary
    assert "BUG" not in summary


def test_bench_objectives_takes_set_and_its_own_configuration_back(tmp_path: Path) -> None:
    """A planner option through --set reaches the runs; --config of the written config.json runs the same
    benchmark again (the same rows, wall-clock columns aside)."""
    args = ["bench", "objectives", "--maps", "map1", "--planners", "astar", "--runs", "1", "--exec-repeats", "0",
            "--no-plots"]
    first, again, other = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    assert run_cli([*args, "--set", "astar.resolution=5", "--out", str(first)]) == 0
    assert run_cli(["bench", "objectives", "--config", str(first / "config.json"), "--out", str(again)]) == 0
    assert run_cli([*args, "--out", str(other)]) == 0

    def rows(folder: Path) -> list[dict[str, str]]:  # planning's wall time and its collision checks left out:
        with (folder / "objectives.csv").open(newline="") as fh:  # a second run in one process finds grids cached
            return [{k: v for k, v in r.items() if k not in ("time_s", "collision_checks")} for r in csv.DictReader(fh)]

    assert rows(first) == rows(again)
    assert rows(first) != rows(other)  # a 5 cm grid instead of 2 cm: other paths
    conf = json.loads((first / "config.json").read_text())["configuration"]
    assert conf["command"] == "bench objectives" and conf["set"] == ["astar.resolution=5"]


def test_ompl_robot_time_cost_is_asymmetric_as_the_objective_tells_ompl() -> None:
    """A motion and its reverse turn by different angles: the objective says it is not symmetric (else
    OMPL's RRT* rewires with the reverse motion's cost), and OMPL's path cost agrees with a hand count."""
    import ompl.geometric as og

    from planners.ompl_objective import RobotTimeObjective, se2_space

    space, si = se2_space(WALL.bounds, make_checker(WALL, 0.0))
    si.setup()
    objective = RobotTimeObjective(si, TIMING, (0.0, 0.0), (100.0, 60.0))
    assert objective.isSymmetric() is False

    def state(x: float, y: float, yaw: float) -> object:
        s = space.allocState()
        s.setX(x)
        s.setY(y)
        s.setYaw(yaw)
        return s

    a, b = state(10.0, 10.0, 0.0), state(40.0, 10.0, math.pi / 2)  # a faces along the motion, b turned left
    forward, backward = og.PathGeometric(si), og.PathGeometric(si)
    for path, states in ((forward, (a, b)), (backward, (b, a))):
        for s in states:
            path.append(s)
    # a -> b: drive 30 cm, turn 90 deg into b's heading; b -> a: turn 90 deg to face -x, drive, turn 180 deg
    assert forward.cost(objective).value() == pytest.approx(3.0 + 2.0)
    assert backward.cost(objective).value() == pytest.approx(2.0 + 3.0 + 4.0)


def test_bench_objectives_draws_robot_time_over_time_in_seconds(tmp_path: Path) -> None:
    """The cost-over-time curves under robot-time: axis named in seconds, no run below `fastest`."""
    import matplotlib.pyplot as plt

    from toolkit.bench.planners import BenchmarkConfig
    from toolkit.bench.planners.objectives import run_objectives, write_objectives
    from toolkit.bench.planners.plots import draw_cost_over_time

    config = BenchmarkConfig(maps=("map1",), planners=("rrtstar", "min-turn"), runs=2, time_limit=0.05,
                             exec_repeats=0, simplify="none", queries="random")
    sweep = run_objectives(config)
    files = write_objectives(sweep, tmp_path)
    assert {"pareto_map1", "cost_over_time"} <= set(files) and files["cost_over_time"].stat().st_size > 0
    fig, ax = plt.subplots()
    draw_cost_over_time(sweep.results["robot-time"], "map1", ax)
    assert ax.get_ylabel() == "best robot time (s) / fastest's (s)"
    curves = [line.get_ydata() for line in ax.get_lines() if line.get_label() == "rrtstar"]
    assert curves and all(np.min(np.asarray(y, dtype=float)) >= 1 - 1e-9 for y in curves)
    plt.close(fig)


def test_fastest_reference_runs_on_a_large_map() -> None:
    """On a map of more than 200 walls `fastest` searches `shortest`'s 16-gon graph: never slower than
    `shortest`'s own path, whose robot time it bounds from below."""
    from toolkit.bench.planners.runner import planner_for

    m = load_map("turtlebot3_world")
    problem = _problem(m, (-60.0, -60.0), (60.0, 60.0), 8.0)
    fast = planner_for("fastest", m).plan(problem)
    short = planner_for("shortest", m).plan(problem)
    assert fast.success and short.success, (fast.message, short.message)
    assert fast.objective_cost <= objective_cost("robot-time", short.path, TIMING) * (1 + 1e-9)


def test_bench_objectives_refuses_unknown_queries(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    assert run_cli(["bench", "objectives", "--queries", "some", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--queries must be presets or random, got 'some'" in err[0], err
    assert not out.exists()


@pytest.mark.parametrize("name", ["prm", "ompl:PRMstar"])
def test_undirected_roadmaps_refuse_robot_time(name: str, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """A roadmap edge has one cost for both directions; robot time turns differently each way."""
    assert PLANNERS.class_of(name).objectives_for(name) == ("length",)
    with pytest.raises(ConfigError, match="undirected roadmap"):
        make_planner(name, objective="robot-time")
    figure = tmp_path / "p.png"
    assert run_cli(["plan", "--map", "map1", "--planner", name, "--objective", "robot-time", "-o", str(figure)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot optimise objective 'robot-time'" in err[0], err
    assert not figure.exists()


def test_bench_objectives_says_bug_for_a_run_below_the_optimum() -> None:
    """A path cheaper than its query's reference is a bug of the planner or of the reference: the
    summary names it (here one real run's reference raised by hand, as a broken reference would report it)."""
    from dataclasses import replace

    from toolkit.bench.planners import BenchmarkConfig
    from toolkit.bench.planners.objectives import ObjectiveSweep, format_objectives, run_objectives

    sweep = run_objectives(BenchmarkConfig(maps=("map1",), planners=("astar",), runs=1, exec_repeats=0,
                                           simplify="none"))
    assert "BUG" not in format_objectives(sweep)
    timed = sweep.results["robot-time"]
    broken = tuple(replace(r, reference_cost=2.0 * r.objective_cost) for r in timed.records)
    sweep = ObjectiveSweep({**sweep.results, "robot-time": replace(timed, records=broken)})
    assert "BUG: 1 run(s) cost less than the reference optimum of their query: astar under robot-time." \
        in format_objectives(sweep)
