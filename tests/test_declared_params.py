"""Declared parameters (`toolkit.world.Params`): checks, the planners' declarations against their
constructors, `--set` on `plan`, `nxtnav planners|localisers show`, and docs/parameters.md kept equal."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli

from planners import PLANNERS, PlanningProblem, make_planner
from planners.declarations import planner_kwargs, planner_params
from toolkit.parameter_docs import parameters_markdown
from toolkit.world import ConfigError, Param, Params, load_map, make_checker

DOCS = Path(__file__).resolve().parents[1] / "docs" / "parameters.md"


def test_docs_page_equals_the_declarations() -> None:
    assert DOCS.read_text() == parameters_markdown(), "python -m toolkit.parameter_docs > docs/parameters.md"


@pytest.mark.parametrize(("text", "value"), [("3", 3), ("3.0", 3), ("null", None)])
def test_an_int_option_reads_yaml(text: str, value: int | None) -> None:
    p = Param("n", int, 1, "count", low=1, optional=True)
    assert p.parse(text) == value


@pytest.mark.parametrize(("text", "value"), [("1e9", 1e9), ("2E-3", 0.002), ("1.0e+3", 1000.0), ("7", 7.0)])
def test_a_float_option_reads_exponents(text: str, value: float) -> None:
    assert Param("x", float, 1.0, "length", low=0.0).parse(text) == value


@pytest.mark.parametrize(("param", "text", "message"), [
    (Param("n", int, 1, "count", low=1), "0", "0 is out of its range [1, inf)"),
    (Param("n", int, 1, "count"), "2.5", "expected an integer"),
    (Param("x", float, 0.5, "share", low=0.0, high=1.0), "1.5", "out of its range [0, 1]"),
    (Param("x", float, 0.5, "share"), ".nan", "finite"),
    (Param("m", str, "a", "mode", choices=("a", "b")), "c", "is not one of a, b"),
    (Param("f", bool, True, "flag"), "yes please", "true or false"),
    (Param("v", float, (1.0, 2.0), "pair", size=2), "[1, 2, 3]", "expected 2 numbers"),
    (Param("n", int, 1, "count"), "null", "got null"),
])
def test_bad_values_name_the_option_and_the_rule(param: Param, text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=param.name) as err:
        param.parse(text)
    assert message in str(err.value)


def test_a_declaration_must_fit_itself() -> None:
    with pytest.raises(ConfigError, match="out of its range"):
        Param("n", int, 0, "count", low=1)
    with pytest.raises(TypeError, match="declared twice"):
        Params(Param("n", int, 1, "a"), Param("n", int, 1, "b"))
    with pytest.raises(ConfigError, match="no option 'x'; declared: n"):
        Params(Param("n", int, 1, "a")).get("x")


def _path(name: str, options: dict[str, object]) -> np.ndarray:
    m = load_map("map1")
    assert m.start is not None and m.target is not None
    problem = PlanningProblem(m, make_checker(m, 8.0), m.start, m.target, 0.2, np.random.default_rng(4))
    return make_planner(name, **planner_kwargs(name, options)).plan(problem).path


@pytest.mark.parametrize("name", PLANNERS.names())
def test_declared_planner_defaults_are_the_constructor_defaults(name: str) -> None:
    params = planner_params(name)
    assert params is not None and len(params) > 0
    declared = params.defaults()
    np.testing.assert_array_equal(_path(name, {}), _path(name, declared))


def test_an_ompl_parameter_reaches_ompl() -> None:
    # RRT* with a range of 2 cm needs more, shorter edges than with OMPL's default range
    base, short = _path("rrtstar", {"stop_at_first": True}), _path("rrtstar", {"stop_at_first": True, "Range": 2.0})
    assert not np.array_equal(base, short)
    with pytest.raises(ConfigError, match="no setting"):
        make_planner("rrtstar", settings={"NoSuchThing": 1})


def test_show_lists_declarations(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "250")  # rich wraps and cuts to the terminal's width
    assert run_cli(["planners", "show", "min-turn"]) == 0
    out = capsys.readouterr().out
    assert "n_samples" in out and "[1, inf)" in out
    assert run_cli(["planners", "show", "ompl:BITstar"]) == 0
    assert "SamplesPerBatch" in capsys.readouterr().out
    assert run_cli(["localisers", "show", "ekf"]) == 0
    out = capsys.readouterr().out
    assert "jacobian_step" in out and "lobe" in out and "thin ray" in out
    assert run_cli(["planners", "show", "nope"]) == 2
    assert "unknown planner 'nope'" in capsys.readouterr().err


@pytest.mark.parametrize(("sets", "message"), [
    (["n_samples=0"], "--set min-turn.n_samples: 0 is out of its range [1, inf)"),
    (["min-turn.bogus=1"], "min-turn has no option bogus; its options: n_samples"),
    (["bogus=1"], "no chosen planner has an option bogus"),
    (["astar.resolution=1"], "options for astar, which is not among min-turn"),
])
def test_plan_set_is_checked(sets: list[str], message: str, tmp_path: Path,
                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "p.png"
    argv = ["plan", "-o", str(out), "--exec-repeats", "0"]
    for s in sets:
        argv += ["--set", s]
    assert run_cli(argv) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_bench_planners_set_reaches_the_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "b"
    base = ["bench", "planners", "--maps", "map1", "--planners", "min-turn", "--runs", "2", "--time-limit", "0.05",
            "--exec-repeats", "0", "--no-plots", "--simplify", "none"]
    assert run_cli([*base, "--set", "min-turn.n_samples=0", "--out", str(out)]) == 2
    assert "min-turn.n_samples: 0 is out of its range [1, inf)" in capsys.readouterr().err
    assert not out.exists()
    assert run_cli([*base, "--set", "min-turn.n_samples=5", "--out", str(out)]) == 0
    config = json.loads((out / "config.json").read_text())
    assert config["config"]["planner_options"] == {"min-turn": {"n_samples": 5}}
