"""`nxtnav figures`: every figure the README and docs show exists, is generated, and is a valid PNG."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from PIL import Image

from toolkit.cli import main
from toolkit.cli.figure_jobs import FIGURE_JOBS, SCREENSHOTS, WORK, FigureJob, figure_names

ROOT = Path(__file__).resolve().parents[1]
IMG = ROOT / "docs" / "img"
MAX_BYTES = 150_000
_IMAGE_REF = re.compile(r"!\[[^\]]*\]\(([^)\s]+)\)|<img [^>]*src=\"([^\"]+)\"")


def referenced_images() -> dict[str, list[str]]:
    """Image file (relative to docs/img) -> the Markdown files that show it."""
    refs: dict[str, list[str]] = {}
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for m in _IMAGE_REF.finditer(doc.read_text(encoding="utf-8")):
            target = (doc.parent / (m.group(1) or m.group(2))).resolve()
            assert target.parent == IMG, f"{doc.name} shows {target}, which is not in docs/img"
            refs.setdefault(target.name, []).append(doc.name)
    return refs


def assert_png(path: Path) -> None:
    assert path.is_file(), f"{path} is missing"
    assert path.stat().st_size < MAX_BYTES, f"{path.name}: {path.stat().st_size} bytes"
    with Image.open(path) as im:
        assert im.format == "PNG", path.name
        im.verify()
    with Image.open(path) as im:
        w, h = im.size
    assert 300 <= w <= 2400 and 150 <= h <= 2400, (path.name, w, h)


def test_the_docs_show_figures_and_every_one_is_generated() -> None:
    refs = referenced_images()
    for key in ("mission_map3.png", "planners_exec_vs_turns.png", "real_sonar_radar.png"):
        assert "README.md" in refs.get(key, []), f"README.md does not show {key}"
    for doc in ("planners.md", "localisers.md", "missions.md"):
        assert any(doc in docs for docs in refs.values()), f"docs/{doc} shows no figure"
    unknown = sorted(set(refs) - set(figure_names()) - set(SCREENSHOTS))
    assert not unknown, f"figures shown but made by no FigureJob (nor listed as a screenshot): {unknown}"


def test_docs_img_holds_only_generated_figures_all_valid() -> None:
    names = set(figure_names())
    assert not names & set(SCREENSHOTS)
    for path in IMG.iterdir():
        assert path.name == "README.md" or path.name in names | set(SCREENSHOTS), \
            f"docs/img/{path.name} is not generated"
    for name in referenced_images():
        assert_png(IMG / name)


def test_a_job_substitutes_its_folder_and_quick_setting() -> None:
    job = FigureJob("x", ("bench", "planners", "--runs", "20", "--out", f"{WORK}/p"), {"a.png": "p/a.png"},
                    "caption", {"--runs": "2", "--exec-repeats": "5"})
    assert job.args("/tmp/w") == ["bench", "planners", "--runs", "20", "--out", "/tmp/w/p"]
    assert job.args("/tmp/w", quick=True) == ["bench", "planners", "--runs", "2", "--out", "/tmp/w/p",
                                              "--exec-repeats", "5"]
    assert job.command() == "nxtnav bench planners --runs 20 --out out/p"
    assert len(set(figure_names())) == len(figure_names())  # no two jobs write the same figure


@pytest.mark.slow
def test_the_figure_command_writes_every_shown_figure(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)  # as make figures runs it: the replay job reads a recording of the repository
    out = tmp_path / "img"
    main(["figures", "--quick", "--out", str(out)])
    made = {p.name for p in out.glob("*.png")}
    assert made == set(figure_names())
    for name in set(referenced_images()) - set(SCREENSHOTS):
        assert_png(out / name)
    index = (out / "README.md").read_text(encoding="utf-8")
    assert "Reduced setting" in index
    for job in FIGURE_JOBS:
        assert job.command() in index


def test_table_one_figure_has_a_box_per_map_and_noise_model_and_the_paper_stars() -> None:
    import matplotlib.pyplot as plt

    from toolkit.bench.paper import PAPER_TABLE, PaperResult, PaperTrial
    from toolkit.bench.paper_plots import draw_paper_table

    results = [PaperResult(PaperTrial(m, i, i, nm), i != 1, "ok", 0.1, 0.2 + 0.1 * i, 100.0 + i, 0, 100.0, 0, 1, 0)
               for m in ("map1", "map3") for nm in ("botsim", "absolute") for i in range(3)]
    fig = draw_paper_table(results)
    err_ax, len_ax = fig.axes[:2]
    labels = [t.get_text() for t in err_ax.get_xticklabels()]
    assert labels == ["map1\nbotsim", "map1\nabsolute", "map3\nbotsim", "map3\nabsolute"]
    stars = [c for c in len_ax.collections if c.get_label() == "paper (mean)"]
    assert [y for _, y in stars[0].get_offsets()] == [PAPER_TABLE[m]["path_length_cm"]
                                                      for m in ("map1", "map1", "map3", "map3")]
    assert "12 missions (8 reached the target, ideal sonar)" in fig.get_suptitle()
    plt.close(fig)
