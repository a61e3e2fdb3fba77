"""Documented commands are tests: every shell block of README.md and docs/ runs, or its marker says why not.

The blocks and checks (tests marked ``docs``, ``make docs-commands``) run ``nxtnav`` (the console script's
entry point, forked from a process that imported it once: tools/warm_nxtnav.py) in a temporary folder
outside the repository (tools/docs_commands.py says how); the tests
of the runner itself (the marker syntax, the substitutions, what counts as a failure) run with the
rest of the suite.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import shutil
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from conftest import built_once, load_tool

REPO = Path(__file__).resolve().parents[1]


docs_commands = load_tool("docs_commands")
BLOCKS, CHECKS = docs_commands.collect(REPO)
SHARED_SCRIPTS = {script for script, count in Counter(docs_commands.ci_script(block) for block in BLOCKS
                                                      if block.skip_reason is None).items() if count > 1}
"""The CI scripts that two or more blocks run word for word (the same command on two pages)."""


def _page(tmp_path: Path, text: str) -> Path:
    page = tmp_path / "page.md"
    page.write_text(text, encoding="utf-8")
    return page


def _shared_outcome(block: Any, factory: pytest.TempPathFactory) -> Any:
    """How `block`'s script ran, run once per test run for every block that runs the same script (a
    script in a fresh folder does the same each time); with pytest-xdist, the workers share it."""
    script = docs_commands.ci_script(block)

    def run(folder: Path) -> None:
        outcome = docs_commands.run_block(block)
        (folder / "outcome.json").write_text(json.dumps(dataclasses.asdict(outcome)), encoding="utf-8")

    name = "docs-script-" + hashlib.sha1(script.encode()).hexdigest()[:12]
    folder = built_once(factory, name, run)
    return docs_commands.Outcome(**json.loads((folder / "outcome.json").read_text(encoding="utf-8")))


@pytest.mark.docs
@pytest.mark.parametrize("block", BLOCKS, ids=[block.where for block in BLOCKS])
def test_documented_block_runs(block: Any, tmp_path_factory: pytest.TempPathFactory) -> None:
    if block.skip_reason is not None:
        pytest.skip(f"{block.where}: {block.skip_reason}")
    script = docs_commands.ci_script(block)
    outcome = _shared_outcome(block, tmp_path_factory) if script in SHARED_SCRIPTS else docs_commands.run_block(block)
    excerpt = docs_commands.output_excerpt(outcome.output)
    assert outcome.failure is None, f"{block.where}: {outcome.failure}\n{script}\n---\n{excerpt}"


@pytest.mark.docs
@pytest.mark.parametrize("check", CHECKS, ids=[check.where for check in CHECKS])
def test_stated_figure_holds(check: Any) -> None:
    outcome = docs_commands.run_check(check)
    excerpt = docs_commands.output_excerpt(outcome.output)
    assert outcome.failure is None, f"{check.status}: {outcome.failure}\n---\n{excerpt}"


def test_every_block_is_counted_and_the_readme_has_blocks_and_a_check() -> None:
    readme_blocks = [block for block in BLOCKS if block.path == "README.md"]
    assert readme_blocks, "no shell block found in README.md"
    assert any(check.path == "README.md" for check in CHECKS), "the README's caption check is gone"
    summary = docs_commands.summary(BLOCKS, CHECKS)
    assert summary.startswith(f"{len(BLOCKS)} shell blocks: ")


def test_markers_attach_to_the_block_below(tmp_path: Path) -> None:
    page = _page(
        tmp_path,
        "text\n\n<!-- docs-run: skip: needs a real NXT -->\n```bash\nnxtnav nxt check\n```\n\n"
        "<!-- docs-run: ci: --runs 50 => --runs 2; # slow => -->\n```sh\nnxtnav bench planners --runs 50 # slow\n```\n"
        "\n```python\nprint('not a shell block')\n```\n\n```console\n$ nxtnav --version\nnxtnav 0.1.0\n```\n",
    )
    blocks, checks = docs_commands.parse_page(page, tmp_path)
    assert [block.line for block in blocks] == [4, 9, 17]
    assert blocks[0].skip_reason == "needs a real NXT"
    assert blocks[1].substitutions == (("--runs 50", "--runs 2"), ("# slow", ""))
    assert docs_commands.ci_script(blocks[1]) == "nxtnav bench planners --runs 2 "
    assert docs_commands.ci_script(blocks[2]) == "nxtnav --version"
    assert checks == []


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("<!-- docs-run: skip: a display -->\n\n```bash\nnxtnav view x\n```\n", "not directly above a shell block"),
        ("<!-- docs-run: skip:  -->\n```bash\nnxtnav view x\n```\n", "skip needs a reason"),
        ("<!-- docs-run: later: soon -->\n```bash\nnxtnav run\n```\n", "unknown docs-run marker 'later'"),
        ("<!-- docs-run skip: no colon -->\n```bash\nnxtnav run\n```\n", "malformed docs-run marker"),
        ("<!-- docs-run: ci: --runs 50 -->\n```bash\nnxtnav run\n```\n", "has no '=>'"),
        ("<!-- docs-run: skip: why -->\n```python\nprint(1)\n```\n", "not a shell block"),
        ("```bash\nmake test\n```\n", "needs a skip marker"),
        ("<!-- docs-run: check: nxtnav run => m.json -->\n", "check needs"),
        ("<!-- docs-run: check: nxtnav run --json m.json => m.json: error about 1 -->\n", "is not 'FIELD == VALUE'"),
    ],
)
def test_a_malformed_or_stray_marker_is_an_error(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(docs_commands.DocsMarkerError, match=message):
        docs_commands.parse_page(_page(tmp_path, text), tmp_path)


def test_a_fence_without_a_language_is_an_error_naming_its_line(tmp_path: Path) -> None:
    page = _page(tmp_path, "# Page\n\n```text\nnxtnav: error: output\n```\n\n```\nnxtnav bench planners\n```\n")
    with pytest.raises(docs_commands.DocsMarkerError, match=r"page.md:7: a fence without a language"):
        docs_commands.parse_page(page, tmp_path)
    indented = _page(tmp_path, "1. Run it:\n\n   ~~~\n   nxtnav run\n   ~~~\n")
    with pytest.raises(docs_commands.DocsMarkerError, match=r"page.md:3: a fence without a language"):
        docs_commands.parse_page(indented, tmp_path)


def test_the_runner_refuses_an_unlabelled_fence_with_one_line_and_exit_2(tmp_path: Path) -> None:
    (tmp_path / "tools").mkdir()
    shutil.copy(REPO / "tools" / "docs_commands.py", tmp_path / "tools")  # its repository is the one it sits in
    (tmp_path / "docs" / "guide").mkdir(parents=True)
    (tmp_path / "README.md").write_text("```bash\nnxtnav --version\n```\n", encoding="utf-8")
    deep = tmp_path / "docs" / "guide" / "deep.md"
    deep.write_text("text\n\n```\nnxtnav run\n```\n", encoding="utf-8")
    command = [sys.executable, str(tmp_path / "tools" / "docs_commands.py"), "--summary"]
    refused = subprocess.run(command, capture_output=True, text=True, check=False, cwd=tmp_path)
    assert refused.returncode == 2 and refused.stdout == ""
    assert refused.stderr.splitlines() == [
        "docs_commands: error: docs/guide/deep.md:3: a fence without a language"
        " (```bash for commands, ```text for output)"
    ]
    deep.write_text("text\n\n```bash\nnxtnav run\n```\n", encoding="utf-8")
    accepted = subprocess.run(command, capture_output=True, text=True, check=False, cwd=tmp_path)
    assert accepted.returncode == 0, accepted.stderr
    assert accepted.stdout.startswith("2 shell blocks: 2 run in CI")


def test_every_fence_of_readme_and_docs_has_a_language_generated_pages_included() -> None:
    pages = docs_commands.doc_pages(REPO)
    assert {REPO / "docs" / "reference" / "cli.md", REPO / "docs" / "parameters.md"} <= set(pages)
    for page in pages:
        docs_commands.parse_page(page, REPO)  # raises DocsMarkerError naming file:line of an unlabelled fence


def test_a_substitution_that_no_longer_matches_is_an_error(tmp_path: Path) -> None:
    page = _page(
        tmp_path, "<!-- docs-run: ci: --runs 50 => --runs 2 -->\n```bash\nnxtnav bench planners --runs 20\n```\n"
    )
    with pytest.raises(docs_commands.DocsMarkerError, match=r"page.md:2: ci substitution '--runs 50' matches nothing"):
        docs_commands.parse_page(page, tmp_path)


def test_a_nonzero_exit_a_traceback_and_a_timeout_fail_a_block(tmp_path: Path) -> None:
    assert docs_commands.run_script("echo fine", tmp_path).failure is None
    assert docs_commands.run_script("false; echo not reached", tmp_path).failure == "exit status 1"
    assert docs_commands.run_script("false | cat", tmp_path).failure == "exit status 1"  # pipefail
    crash = docs_commands.run_script("python -c 'import json; json.loads(\"{\")' || true", tmp_path)
    assert crash.returncode == 0 and crash.failure == "a Python traceback in the output"
    slow = docs_commands.run_script("sleep 30", tmp_path, timeout_s=0.5)
    assert slow.failure == "still running after 0.5 s" and slow.seconds < 10


def test_a_block_runs_outside_the_repository_with_this_nxtnav_first_on_path(tmp_path: Path) -> None:
    outcome = docs_commands.run_script('pwd; command -v nxtnav; echo "repo=$DOCS_REPO"', tmp_path)
    folder, nxtnav, repo = outcome.output.split()
    assert Path(folder).resolve() == tmp_path.resolve()
    real = Path(sys.executable).parent / "nxtnav"
    # the warm stand-in (tools/warm_nxtnav.py), which runs this console script's entry point, or it itself
    assert Path(nxtnav) == real or f'"{real}"' in Path(nxtnav).read_text()
    assert repo == f"repo={REPO}"


def test_a_background_job_is_stopped_when_its_block_ends(tmp_path: Path) -> None:
    outcome = docs_commands.run_script("sleep 300 & echo $! > pid", tmp_path)
    assert outcome.failure is None and outcome.seconds < 10
    pid = int((tmp_path / "pid").read_text())
    assert not Path(f"/proc/{pid}").exists() or "zombie" in Path(f"/proc/{pid}/status").read_text()


@pytest.mark.parametrize(
    ("actual", "condition", "holds"),
    [
        (0.10790, ("final_error_cm", "==", "0.11"), True),
        (0.10790, ("final_error_cm", "==", "0.5"), False),
        (0.10790, ("final_error_cm", "==", "0.1"), True),
        (0.3, ("final_error_cm", "<=", "0.5"), True),
        (0.7, ("final_error_cm", "<", "0.5"), False),
        ("reached", ("outcome", "==", "reached"), True),
        ("stuck", ("outcome", "==", "reached"), False),
    ],
)
def test_a_check_compares_at_the_rounding_the_text_uses(actual: object, condition: tuple, holds: bool) -> None:
    difference = docs_commands.compare(actual, docs_commands.Condition(*condition))
    assert (difference is None) == holds, difference


def test_a_check_reads_a_dotted_field_of_the_json(tmp_path: Path) -> None:
    page = _page(
        tmp_path,
        '<!-- docs-run: check: echo \'{"rows": [{"e": 0.108}], "ok": true}\' > r.json => r.json: rows.0.e == 0.11;'
        " rows.0.e < 0.2 -->\n<!-- docs-run: check: echo '{}' > r.json => r.json: rows.0.e == 0.11 -->\n",
    )
    _, (good, missing) = docs_commands.parse_page(page, tmp_path)
    assert docs_commands.run_check(good).failure is None
    assert docs_commands.run_check(missing).failure == "r.json: \"no field 'rows' (of 'rows.0.e')\""
