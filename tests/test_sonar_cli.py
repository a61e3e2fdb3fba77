"""`nxtnav sonar fit|score|loo` on the shipped MIT sweeps (a one-lobe grid keeps the fits fast), and sonar
profiles that cannot be used: one line naming the file and the field, exit 2, nothing written."""

from __future__ import annotations

import csv
import json
import shutil
from collections.abc import Callable, Iterable
from pathlib import Path

import pytest
import yaml
from conftest import REAL_NXT, built_once, real_nxt_arena, run_cli

from toolkit.real_sonar.fit import load_sonar_profile
from toolkit.world import NxtSonar

pytestmark = pytest.mark.xdist_group("sonar-fit")  # one worker: `fitted` built once, none waiting on its lock

GRID = ["--widths", "20", "--criticals", "40"]
SHIPPED = ("loc_01.dat", "loc_03.dat", "loc_04.dat")
"""The shipped set's sweep files."""


def _arena(folder: Path) -> Path:
    """The shipped sweeps' arena as a map file (tests pass it with --map)."""
    path = folder / "arena.yaml"
    path.write_text(yaml.safe_dump(real_nxt_arena().to_dict(), sort_keys=False))
    return path


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with arena.yaml, and profile.yaml and fit.json from one `nxtnav sonar fit` of the MIT set."""

    def build(out: Path) -> None:
        arena = _arena(out)
        code = run_cli(["sonar", "fit", str(REAL_NXT), "--map", str(arena), "-o", str(out / "profile.yaml"),
                        *GRID, "--json", str(out / "fit.json")])
        assert code == 0

    return built_once(tmp_path_factory, "sonar-fit", build)


def test_fit_writes_a_profile_that_round_trips(fitted: Path) -> None:
    model = load_sonar_profile(fitted / "profile.yaml")
    doc = yaml.safe_load((fitted / "profile.yaml").read_text())
    assert doc["kind"] == "nxtnav-sonar-profile" and doc["sonar"] == "nxt"
    assert model.to_dict() == {"name": "nxt", **doc["params"]}
    assert (model.beam_width_deg, model.critical_incidence_deg) == (20.0, 40.0)  # the one lobe of the grid
    # the fit is not the hardware facts: the real sweeps have wrong readings and lost echoes
    hw = NxtSonar.hardware_facts()
    assert model.outlier_prob > hw.outlier_prob and model.phantom_prob > hw.phantom_prob
    fit = doc["fit"]
    assert fit["folders"] == [str(REAL_NXT)] and fit["sweeps"] == 3 and fit["widths_deg"] == [20.0]
    assert sorted(fit["headings_deg"]) == [f"andrei-alpha/robotics/loc_0{i}.dat" for i in (1, 3, 4)]
    assert "date" not in (fitted / "profile.yaml").read_text()
    report = json.loads((fitted / "fit.json").read_text())
    assert report["readings"] == fit["readings"] > 500  # stuck readings are left out, the rest count
    assert report["mean_log_likelihood"] == pytest.approx(fit["mean_log_likelihood"], abs=1e-6)
    assert report["model"]["noise_sd"] == pytest.approx(model.noise_sd, abs=1e-6)


def test_fit_again_writes_the_same_bytes(fitted: Path, tmp_path: Path) -> None:
    again = tmp_path / "again.yaml"
    assert run_cli(["sonar", "fit", str(REAL_NXT), "--map", str(fitted / "arena.yaml"), "-o", str(again),
                    *GRID]) == 0
    assert again.read_bytes() == (fitted / "profile.yaml").read_bytes()


def test_score_reports_each_model_and_sweep(fitted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "80")  # a narrow terminal: names may fold, numbers may not be cut
    out = tmp_path / "score.json"
    long_name = "a-student-with-a-long-name/robotics-coursework-2016"
    folder = _shipped_copy(tmp_path, "relabelled", dict.fromkeys(SHIPPED, long_name))
    assert run_cli(["sonar", "score", str(folder), "--map", str(fitted / "arena.yaml"), "--sonar-profile",
                    str(fitted / "profile.yaml"), "--baseline", "hardware", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "profile" in text and "hardware" in text
    doc = json.loads(out.read_text())
    assert doc["folders"] == [str(folder)]
    profile, hardware = doc["models"]
    assert (profile["label"], hardware["label"]) == ("profile", "hardware")
    assert profile["source"] == str(fitted / "profile.yaml")
    assert profile["params"] == load_sonar_profile(fitted / "profile.yaml").to_dict()
    assert hardware["params"] == NxtSonar.hardware_facts().to_dict()
    for m in (profile, hardware):
        assert {"mean_log_likelihood", "no_echo_real", "no_echo_model", "median_abs_diff_cm", "readings",
                "sweeps"} <= set(m)
        assert m["sweeps"] == len(m["per_sweep"]) == 3
        assert sum(r["readings"] for r in m["per_sweep"]) == m["readings"]
        for r in m["per_sweep"]:
            assert {"sweep", "heading_deg", "mean_log_likelihood", "no_echo_real", "no_echo_model",
                    "median_abs_diff_cm"} <= set(r)
            assert r["mean_log_likelihood"] is not None  # a floor, never -inf
            row = (f"{r['mean_log_likelihood']:.3f}", f"{100 * r['no_echo_real']:.0f} / {100 * r['no_echo_model']:.0f}",
                   f"{r['margin_nats']:+.1f}")
            assert any(all(v in line for v in row) for line in text.splitlines()), row  # one line per row
    # the same real readings; the fitted model explains them far better and expects their no-echo share
    assert profile["no_echo_real"] == hardware["no_echo_real"] > 0.05
    assert profile["mean_log_likelihood"] > hardware["mean_log_likelihood"] + 1.0
    assert abs(profile["no_echo_model"] - profile["no_echo_real"]) < abs(hardware["no_echo_model"]
                                                                        - hardware["no_echo_real"])


def test_score_without_a_profile_is_the_default_model(fitted: Path, tmp_path: Path,
                                                      twin_heading_warnings: Callable[[], list[str]]) -> None:
    """... and a sweep whose heading_deg is a quarter turn from where the model finds it is named: the
    shipped loc_03 (-90.5 in the set, about -7 by the model); the other two, 4 and 9 degrees apart, not."""
    out = tmp_path / "score.json"
    assert run_cli(["sonar", "score", str(REAL_NXT), "--map", str(fitted / "arena.yaml"), "--json", str(out)]) == 0
    (only,) = json.loads(out.read_text())["models"]
    assert only["label"] == "default" and only["params"] == NxtSonar().to_dict()
    assert [r["set_heading_deg"] for r in only["per_sweep"]] == [6.0, -90.5, 10.0]  # the set's column
    named = twin_heading_warnings()
    assert len(named) == 1 and named[0].startswith("andrei-alpha/robotics/loc_03.dat: heading_deg -90.5 is 8")


def _shipped_copy(folder: Path, name: str, repos: dict[str, str] | None = None,
                  keep: Iterable[str] = SHIPPED) -> Path:
    """A copy of the shipped set in `folder / name` with only the sweeps of `keep`, those named in `repos` said
    to come from that repository instead."""
    out = folder / name
    shutil.copytree(REAL_NXT, out)
    with (out / "sweeps.csv").open(newline="") as fh:
        rows = [{**r, "repo": (repos or {}).get(r["file"], r["repo"])} for r in csv.DictReader(fh)]
    with (out / "sweeps.csv").open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(r for r in rows if r["file"] in set(keep))
    return out


def _two_sources(folder: Path) -> Path:
    """A copy of the shipped set whose last sweep is relabelled as coming from a second repository."""
    return _shipped_copy(folder, "relabelled", {"loc_04.dat": "someone/else"})


def test_loo_holds_out_each_repository(fitted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "loo.json"
    folder = _two_sources(tmp_path)
    assert run_cli(["sonar", "loo", str(folder), "--map", str(fitted / "arena.yaml"), *GRID,
                    "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "fitted beats the hardware facts on held-out readings" in text
    doc = json.loads(out.read_text())
    assert [f["repo"] for f in doc["folds"]] == ["andrei-alpha/robotics", "someone/else"]
    assert [f["sweeps"] for f in doc["folds"]] == [2, 1]
    assert doc["readings"] == sum(f["readings"] for f in doc["folds"])
    assert doc["baseline"] == NxtSonar.hardware_facts().to_dict()
    w = [f["readings"] for f in doc["folds"]]
    for which in ("fitted", "baseline"):
        mean = doc["weighted_mean"][which]["mean_log_likelihood"]
        parts = [f[which]["mean_log_likelihood"] for f in doc["folds"]]
        assert mean == pytest.approx(sum(a * b for a, b in zip(parts, w, strict=True)) / sum(w))
    assert doc["beats_baseline"] == (doc["weighted_mean"]["fitted"]["mean_log_likelihood"]
                                     > doc["weighted_mean"]["baseline"]["mean_log_likelihood"])
    # each fold's model was fitted without the held-out sweeps: the two differ
    assert doc["folds"][0]["model"] != doc["folds"][1]["model"]


def test_loo_per_source_holds_out_each_sweep_of_its_source(fitted: Path, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """`sonar loo --per-source`: one fold per sweep of a source with two or more (a source with one is left
    out), each model fitted on the source's other sweeps alone: the same model `sonar fit` makes of those."""
    arena = str(fitted / "arena.yaml")
    ones = _shipped_copy(tmp_path, "ones", {"loc_03.dat": "someone/else"}, keep=SHIPPED[:2])  # a sweep each
    assert run_cli(["sonar", "loo", str(ones), "--map", arena, *GRID, "--per-source"]) == 2
    assert "needs a source with two or more sweeps" in capsys.readouterr().err
    out = tmp_path / "loo.json"
    folder = _two_sources(tmp_path)  # andrei-alpha: loc_01, loc_03; someone/else: loc_04
    assert run_cli(["sonar", "loo", str(folder), "--map", arena, *GRID, "--per-source", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "leave one sweep out of its source" in text and "no-echo gap per held-out sweep: median" in text
    doc = json.loads(out.read_text())
    assert doc["per_source"] is True
    assert [f["repo"] for f in doc["folds"]] == ["andrei-alpha/robotics/loc_01.dat", "andrei-alpha/robotics/loc_03.dat"]
    assert [f["sweeps"] for f in doc["folds"]] == [1, 1]
    gaps = sorted(abs(f["fitted"]["no_echo_model"] - f["fitted"]["no_echo_real"]) for f in doc["folds"])
    assert f"median {(gaps[0] + gaps[1]) / 2:.3f}, largest {gaps[1]:.3f}" in text
    alone = _shipped_copy(tmp_path, "alone", keep=["loc_03.dat"])
    assert run_cli(["sonar", "fit", str(alone), "--map", arena, *GRID, "-o", str(tmp_path / "p.yaml")]) == 0
    model, written = doc["folds"][0]["model"], load_sonar_profile(tmp_path / "p.yaml").to_dict()
    assert model.keys() == written.keys()
    for key, value in written.items():  # the profile file keeps about six figures
        assert model[key] == (pytest.approx(value, rel=1e-4) if isinstance(value, float) else value), key


def test_loo_needs_two_repositories(fitted: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["sonar", "loo", str(REAL_NXT), "--map", str(fitted / "arena.yaml"), *GRID]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "two or more repositories" in err and "andrei-alpha/robotics" in err


BAD_PROFILES = {
    "unknown.yaml": ("params:\n  noise_sd: 2\n  colour: 3\n", "params.colour"),
    "negative.yaml": ("params:\n  noise_sd: -1\n", "params.noise_sd"),
    "probability.yaml": ("params:\n  dropout_prob: 1.5\n", "params.dropout_prob"),
    "words.yaml": ("params:\n  noise_sd: two\n", "params.noise_sd"),
    "syntax.yaml": ("params: {noise_sd: [1, 2\n", "not valid YAML"),
    "text.yaml": ("just words\n", "a mapping"),
    "typo.yaml": ("parms:\n  noise_sd: 2\n", "'parms'"),
    "ideal.yaml": ("sonar: ideal\nparams: {}\n", "field 'sonar'"),
    "binary.yaml": (b"\x89PNG\r\n\x1a\n\x00\xff", "not UTF-8"),
    "huge.yaml": ("params:\n  noise_sd: " + "9" * 400 + "\n", "params.noise_sd"),
}


@pytest.mark.parametrize("name", sorted(BAD_PROFILES))
def test_a_bad_profile_is_one_line_naming_file_and_field(name: str, fitted: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    text, field = BAD_PROFILES[name]
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    out = tmp_path / "score.json"
    code = run_cli(["sonar", "score", str(REAL_NXT), "--map", str(fitted / "arena.yaml"), "--sonar-profile",
                    str(path), "--json", str(out)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("nxtnav: error: ") and "Traceback" not in err
    assert str(path) in err and field in err
    assert not out.exists()


def test_a_failed_fit_writes_nothing(fitted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    profile, report = tmp_path / "p.yaml", tmp_path / "fit.json"
    # a folder that is not a sweep set
    assert run_cli(["sonar", "fit", str(tmp_path), "--map", str(fitted / "arena.yaml"), "-o", str(profile),
                    *GRID, "--json", str(report)]) == 2
    assert "sweeps.csv" in capsys.readouterr().err
    # a bad grid value, or a --json that is a folder: refused before any work
    assert run_cli(["sonar", "fit", str(REAL_NXT), "--map", str(fitted / "arena.yaml"), "-o", str(profile),
                    "--widths", "20,0"]) == 2
    assert "--widths" in capsys.readouterr().err
    assert run_cli(["sonar", "fit", str(REAL_NXT), "--map", str(fitted / "arena.yaml"), "-o", str(profile),
                    *GRID, "--json", str(tmp_path)]) == 2
    assert "--json" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == []
