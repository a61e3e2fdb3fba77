"""The how-to guides for extending nxtnav (docs/howto/*.md) are executed, so that following a page
literally gives a plug-in that passes the suite.

For each page: its ```python blocks run in order in a fresh process (the first is the plug-in's module,
named by its first line ``# MODULE.py``, the others run in a fresh module after it), and in that same
process the suite's own tests that are parametrised over the registries run with the plug-in
registered (``pytest -p`` a plug-in that executes the page before collection). Running in a subprocess
keeps the plug-in out of every other test's registries. The ```bash blocks are documented commands,
run like every other by `tools/docs_commands.py` (the pytest tier ``docs``, `make docs-commands`): a
`nxtnav planners check` there exits 1 on any problem. Here, the module a bash block writes with
``cat > FILE <<'EOF'`` must be the page's python block of that name, character for character.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
HOWTO = REPO / "docs" / "howto"
FENCE = re.compile(r"^```(\w+)\n(.*?)^```\n", re.S | re.M)
SKIP_MARK = "<!-- docs-run: skip:"
HEREDOC = re.compile(r"^cat > (\S+) <<'EOF'\n(.*?)^EOF\n", re.S | re.M)

RUNNER = '''"""Execute a how-to page's python blocks before pytest collects (loaded with -p)."""
import json, os, sys, types

with open(os.environ["NXTNAV_HOWTO_BLOCKS"], encoding="utf-8") as _file:
    _blocks = json.load(_file)
for _name, _code in _blocks:
    _module = types.ModuleType(_name)
    _module.__file__ = _name + ".py"
    sys.modules[_name] = _module
    exec(compile(_code, _name + ".py", "exec"), _module.__dict__)
'''


@dataclass(frozen=True)
class Page:
    """A how-to page and the suite's tests its plug-in must pass (pytest arguments; none: the page's
    own code alone)."""

    file: str
    suite: tuple[str, ...]
    least_passed: int = 0


PAGES = [
    Page("planner.md", ("tests/test_planners.py", "tests/test_plugin_options.py",
                        "tests/test_planners_reproducible.py", "-k", "roadmap"), 14),
    Page("localiser.md", ("tests/test_localisation_options.py::test_every_localiser_is_told_the_same_robot",
                          "tests/test_localisation_options.py::test_every_facet_is_mapped_or_refused_with_a_reason"
                          "[simple-mcl]",
                          "tests/test_localisation_options.py::test_options_as_a_model_or_as_overrides_are_one_localiser"
                          "[simple-mcl]",
                          "tests/test_localisation_options.py::test_a_changed_option_reaches_the_constructor"
                          "[simple-mcl]"), 8),
    Page("sonar-model.md", ("tests/test_world_sonar.py::test_seeded",), 1),
    Page("fault.md", ("tests/test_brick_faults.py", "-k", "spec or garbage or stuck"), 10),
    Page("robot-backend.md", ()),
]


def blocks(page: str, language: str) -> list[str]:
    """The fenced blocks of `language` in the page, in order, less those after a docs-run skip mark."""
    text = (HOWTO / page).read_text(encoding="utf-8")
    return [m.group(2) for m in FENCE.finditer(text)
            if m.group(1) == language and SKIP_MARK not in text[:m.start()].rstrip().rsplit("\n", 1)[-1]]


def named_python_blocks(page: str) -> list[tuple[str, str]]:
    """The python blocks as (module name, code): the first is named by its ``# MODULE.py`` line."""
    code = blocks(page, "python")
    first = re.match(r"# (\w+)\.py\n", code[0])
    assert first, f"{page}: the first python block must start with '# MODULE.py'"
    return [(first.group(1), code[0])] + [(f"howto_usage_{i}", c) for i, c in enumerate(code[1:], 1)]


@pytest.mark.parametrize("page", [p.file for p in PAGES])
def test_every_module_a_shell_block_writes_is_the_pages_python_block(page: str) -> None:
    python = {name + ".py": code for name, code in named_python_blocks(page)}
    written = [m.groups() for block in blocks(page, "bash") for m in HEREDOC.finditer(block)]
    for file, text in written:
        assert text == python.get(file), f"{page}: the {file} written by the shell block differs from its listing"


def test_every_howto_page_is_tested_and_in_the_nav() -> None:
    nav = (REPO / "mkdocs.yml").read_text(encoding="utf-8")
    assert {p.name for p in HOWTO.glob("*.md")} == {p.file for p in PAGES}
    assert all(f"howto/{p.file}" in nav for p in PAGES)


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.file)
def test_a_pages_plugin_passes_the_suites_tests(page: Page, tmp_path: Path) -> None:
    (tmp_path / "howto_page.py").write_text(RUNNER, encoding="utf-8")
    (tmp_path / "blocks.json").write_text(json.dumps(named_python_blocks(page.file)), encoding="utf-8")
    env = {**os.environ, "NXTNAV_HOWTO_BLOCKS": str(tmp_path / "blocks.json"),
           "PYTHONPATH": os.pathsep.join([str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])])}
    if page.suite:
        argv = [sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", "-p", "no:cacheprovider", "-p", "howto_page",
                *page.suite]
    else:
        argv = [sys.executable, "-c", "import howto_page"]
    done = subprocess.run(argv, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-4000:]
    if page.suite:
        passed = re.search(r"(\d+) passed", done.stdout)
        assert passed and int(passed.group(1)) >= page.least_passed, done.stdout[-2000:]
        assert " failed" not in done.stdout and " error" not in done.stdout
