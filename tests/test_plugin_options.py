"""Plug-in options (`toolkit.world.Options`): one model per planner and localiser, from which come the
constructors' options, `--set` on `plan` and `localise`, `nxtnav planners|localisers show`, docs/parameters.md
and the JSON Schemas of docs/reference/schemas (both kept equal to the models). The same page documents the
settings sections of `--set` (mission, challenge, robot, sonar) from their models."""

from __future__ import annotations

import inspect
import json
from pathlib import Path
from typing import Literal

import numpy as np
import pytest
from conftest import fails_cleanly, run_cli

from localisation import LOCALISERS
from localisation.declarations import AmclOptions, AmclSensor
from planners import PLANNERS, PlanningProblem, make_planner
from planners.declarations import planner_kwargs, planner_options
from toolkit.mission import MissionConfig
from toolkit.mission.challenge import ChallengeConfig
from toolkit.parameter_docs import SCHEMA_FOLDER, SCHEMA_PATTERNS, option_schemas, parameters_markdown
from toolkit.world import ConfigError, Options, configure, load_map, make_checker, option
from toolkit.world.params import describe, parse_sets

DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_docs_page_equals_the_models() -> None:
    assert (DOCS / "parameters.md").read_text() == parameters_markdown(), \
        "python tools/parameter_docs.py > docs/parameters.md"


def test_the_committed_schemas_equal_the_models() -> None:
    folder = DOCS / SCHEMA_FOLDER
    made = option_schemas()
    # the folder also holds the file formats' schemas (tools/schemas.py): only this page's are compared
    plugin_files = [path for pattern in SCHEMA_PATTERNS for path in folder.glob(pattern)]
    assert sorted(p.name for p in plugin_files) == sorted(made), \
        "python tools/parameter_docs.py --schemas docs/reference/schemas"
    for name, text in made.items():
        assert (folder / name).read_text() == text, name
    amcl = json.loads(made["localiser-amcl.json"])
    z_hit = amcl["$defs"]["AmclSensor"]["properties"]["z_hit"]
    assert z_hit["minimum"] == 0.0 and z_hit["default"] == 0.95
    assert amcl["$defs"]["AmclSensor"]["properties"]["sigma_hit"]["robot"] is True
    assert amcl["properties"]["model"]["enum"] == ["auto", "beam", "field", "nxt-beam"]
    mission = json.loads(made["mission.json"])
    assert mission["$defs"]["DriveConfig"]["properties"]["max_legs"]["minimum"] == 1
    assert json.loads(made["challenge.json"])["$defs"]["ChallengeFix"]["properties"]["oracle"]["default"] == "none"


def _leaf_paths(cls: type, prefix: str) -> list[str]:
    """Every leaf field of a pydantic model or dataclass, walked by pydantic's own field table."""
    out = []
    for name, info in cls.__pydantic_fields__.items():  # type: ignore[attr-defined]
        kind = info.annotation
        if isinstance(kind, type) and hasattr(kind, "__pydantic_fields__"):
            out += _leaf_paths(kind, f"{prefix}{name}.")
        else:
            out.append(f"{prefix}{name}")
    return out


def _documented_rows(section: str) -> dict[str, list[str]]:
    """The rows of docs/parameters.md whose option starts with `section` (``mission.``), by option: the cells."""
    rows = {}
    for line in (DOCS / "parameters.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith(f"| `{section}"):
            rows[cells[0].strip("`")] = cells[1:]
    return rows


@pytest.mark.parametrize(("section", "model"), [("mission.", MissionConfig), ("challenge.", ChallengeConfig)])
def test_every_mission_and_challenge_setting_has_a_row_under_its_set_path(section: str, model: type) -> None:
    rows = _documented_rows(section)
    assert sorted(rows) == sorted(_leaf_paths(model, section))
    assert rows[f"{section}fix.rule" if section == "mission." else f"{section}fix.oracle"][2].startswith("one of ")


@pytest.mark.parametrize(("key", "argv"), [
    ("mission.drive.max_legs", ["run", "--map", "map1"]),
    ("challenge.fix.gate_sigmas", ["bench", "challenge", "maps/real-nxt", "--out", "out"]),
    ("robot.timing.drive_speed_cm_s", ["localise", "--pose", "20,20,0"]),
    ("sonar.beam_rays", ["localise", "--pose", "20,20,0", "--sonar", "nxt"]),
])
def test_a_documented_setting_is_the_one_the_command_checks(key: str, argv: list[str], tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str],
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    # the page's row names a key the command takes and the range it enforces: a value below it is refused
    # with that key and that range, before anything runs or is written
    range_text = _documented_rows(key)[key][2]
    assert range_text.endswith("inf)") or range_text.endswith("]")
    monkeypatch.chdir(tmp_path)
    line = fails_cleanly([*argv, "--set", f"{key}=-1"], capsys, key.partition(".")[2], f"-1 is out of its range "
                         f"{range_text}")
    assert "no option" not in line
    assert list(tmp_path.iterdir()) == []


class _Group(Options):
    n: int | None = option(1, "count", ge=1)
    x: float = option(0.5, "share", ge=0.0, le=1.0)
    pair: tuple[float, float] = option((1.0, 2.0), "pair")


class _Plugin(Options):
    mode: Literal["a", "b"] = option("a", "mode")
    flag: bool = option(True, "flag")
    group: _Group = _Group()


@pytest.mark.parametrize(("text", "value"), [("3", 3), ("3.0", 3), ("null", None)])
def test_an_int_option_reads_yaml(text: str, value: int | None) -> None:
    assert parse_sets(_Plugin, {"group.n": text}) == {"group.n": value}


@pytest.mark.parametrize(("text", "value"), [("1e-1", 0.1), ("2E-3", 0.002), ("1.0e-0", 1.0), ("1", 1.0)])
def test_a_float_option_reads_exponents(text: str, value: float) -> None:
    assert configure(_Plugin, None, parse_sets(_Plugin, {"group.x": text})).group.x == value


@pytest.mark.parametrize(("key", "text", "message"), [
    ("group.n", "0", "group.n: 0 is out of its range [1, inf)"),
    ("group.n", "2.5", "group.n: expected an integer, got 2.5"),
    ("group.n", "true", "group.n: expected an integer, got True"),
    ("group.x", "1.5", "group.x: 1.5 is out of its range [0, 1]"),
    ("group.x", ".nan", "group.x: expected a finite number"),
    ("mode", "c", "mode: 'c' is not one of a, b"),
    ("mode", "3", "mode: '3' is not one of a, b"),
    ("flag", "yes please", "flag: expected true or false, got 'yes please'"),
    ("flag", "1", "flag: expected true or false, got 1"),
    ("group.pair", "[1, 2, 3]", "group.pair: expected 2 numbers"),
    ("group.x", "null", "group.x: must be a float, got null"),
    ("x", "0.1", "x: the options are grouped: use group.x"),
    ("group.y", "1", "no option 'group.y'; options: mode, flag and the groups group.*"),
])
def test_bad_values_name_the_option_and_the_rule(key: str, text: str, message: str) -> None:
    with pytest.raises(ConfigError) as err:
        parse_sets(_Plugin, {key: text})
    assert message in str(err.value)


def test_python_takes_a_model_or_overrides_by_path_or_by_name() -> None:
    by_model = configure(AmclOptions, AmclOptions(sensor=AmclSensor(z_hit=0.9)))
    assert by_model == configure(AmclOptions, None, {"sensor.z_hit": 0.9}) == configure(AmclOptions, None,
                                                                                       {"z_hit": 0.9})
    assert configure(AmclOptions, by_model, {"min_particles": 50}).sensor.z_hit == 0.9  # on top of the model
    # a run's robot options come by path, a mission file's may name the option: the later one wins
    assert configure(AmclOptions, None, {"lobe.beam_width_deg": 20.0, "beam_width_deg": 10.0}).lobe.beam_width_deg == 10


@pytest.mark.parametrize("cls", [*(PLANNERS.get(n) for n in PLANNERS.names()),
                                 *(LOCALISERS.get(n) for n in LOCALISERS.names())], ids=lambda c: c.__qualname__)
def test_no_constructor_takes_more_than_twelve_parameters_and_names_are_unique(cls: type) -> None:
    assert len(inspect.signature(cls.__init__).parameters) <= 12
    names = [o.name.rpartition(".")[2] for o in describe(cls.options_model)]
    assert len(names) == len(set(names))  # a bare name in Python overrides names one option


def _path(name: str, options: dict[str, object]) -> np.ndarray:
    m = load_map("map1")
    assert m.start is not None and m.target is not None
    problem = PlanningProblem(m, make_checker(m, 8.0), m.start, m.target, 0.2, np.random.default_rng(4))
    return make_planner(name, **planner_kwargs(name, options)).plan(problem).path


@pytest.mark.parametrize("name", PLANNERS.names())
def test_a_planner_given_its_models_defaults_plans_as_given_none(name: str) -> None:
    model = planner_options(name)
    assert model is not None and model.model_fields
    m = load_map("map1")
    assert m.start is not None and m.target is not None
    problem = PlanningProblem(m, make_checker(m, 8.0), m.start, m.target, 0.2, np.random.default_rng(4))
    cls = PLANNERS.get(name)
    given = cls(cls.options_model()).plan(problem).path  # type: ignore[call-arg]
    np.testing.assert_array_equal(_path(name, {}), given)


def test_an_ompl_parameter_reaches_ompl() -> None:
    # RRT* with a range of 2 cm needs more, shorter edges than with OMPL's default range
    base, short = _path("rrtstar", {"stop_at_first": True}), _path("rrtstar", {"stop_at_first": True, "Range": 2.0})
    assert not np.array_equal(base, short)
    with pytest.raises(ConfigError, match="no setting"):
        make_planner("rrtstar", settings={"NoSuchThing": 1})


def test_show_lists_the_options(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "250")  # rich wraps and cuts to the terminal's width
    assert run_cli(["planners", "show", "min-turn"]) == 0
    out = capsys.readouterr().out
    assert "n_samples" in out and "[1, inf)" in out
    assert run_cli(["planners", "show", "ompl:BITstar"]) == 0
    assert "SamplesPerBatch" in capsys.readouterr().out
    assert run_cli(["localisers", "show", "ekf"]) == 0
    out = capsys.readouterr().out
    assert "jacobian_step" in out and "lobe" in out and "thin ray" in out
    assert "sensor.sensor_sigma_cm" in out and "sigma_points" not in out
    assert run_cli(["localisers", "show", "amcl", "--json"]) == 0
    shown = {o["name"]: o for o in json.loads(capsys.readouterr().out)["options"]}
    assert shown["sensor.z_hit"]["range"] == "[0, inf)" and shown["sensor.sigma_hit"]["robot"] is True
    assert run_cli(["planners", "show", "nope"]) == 2
    assert "unknown planner 'nope'" in capsys.readouterr().err


@pytest.mark.parametrize("section", ["mission", "robot"])
def test_settings_show_prints_the_rows_of_the_page(section: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["settings", "show", section, "--json"]) == 0
    shown = {o["name"]: o for o in json.loads(capsys.readouterr().out)["settings"]}
    rows = _documented_rows(f"{section}.")
    assert set(shown) == set(rows)
    assert all(rows[name][2] == o["range"] and rows[name][0] == o["type"] for name, o in shown.items())


def test_settings_show_prints_the_chosen_sonar_models_fields(capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["settings", "show", "sonar", "--sonar", "nxt", "--json"]) == 0
    nxt = {o["name"] for o in json.loads(capsys.readouterr().out)["settings"]}
    assert run_cli(["settings", "show", "sonar", "--json"]) == 0
    ideal = {o["name"] for o in json.loads(capsys.readouterr().out)["settings"]}
    assert ideal == {"sonar.noise_sd"} and {"sonar.noise_sd", "sonar.dropout_prob"} <= nxt


def test_settings_show_refuses_an_unknown_section_and_a_stray_sonar(capsys: pytest.CaptureFixture[str]) -> None:
    fails_cleanly(["settings", "show", "nope"], capsys, "no settings section 'nope'", "mission, challenge")
    fails_cleanly(["settings", "show", "robot", "--sonar", "nxt"], capsys, "--sonar: only with the sonar section")


@pytest.mark.parametrize(("sets", "message"), [
    (["n_samples=0"], "--set min-turn.n_samples: 0 is out of its range [1, inf)"),
    (["min-turn.n_samples=abc"], "--set min-turn.n_samples: expected an integer, got 'abc'"),
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


def test_localise_set_takes_dotted_group_paths(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    js = tmp_path / "l.json"
    base = ["localise", "--pose", "20,20,0", "--localiser", "amcl"]
    assert run_cli([*base, "--set", "amcl.sensor.z_hit=0.9", "--set", "min_particles=60", "--json", str(js)]) == 0
    assert json.loads(js.read_text())["localiser"] == "amcl"
    for value, message in (("amcl.z_hit=0.9", "--set amcl.z_hit: the options are grouped: use amcl.sensor.z_hit"),
                           ("z_hit=0.9", "--set z_hit: the options are grouped: use sensor.z_hit"),
                           ("sensor.z_hit=-1", "--set amcl.sensor.z_hit: -1 is out of its range [0, inf)")):
        assert run_cli([*base, "--set", value, "--json", str(tmp_path / "x.json")]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1, err
        assert not (tmp_path / "x.json").exists()
