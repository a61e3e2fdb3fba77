"""Every measured table of the results pages says when, on which code and by which command.

The results pages (``RESULTS_PAGES``) state the convention in their opening paragraph. The line just
above a measured table (the nearest non-blank line) reads ``Measured YYYY-MM-DD at commit HASH: HOW``
(``date unknown`` in place of the date where the history does not tell); a table of definitions,
options or formats carries ``<!-- reference table -->`` there instead, so the decision is visible.
Every date on such a line is an ISO date not in the future; inside a git clone every commit named on
it resolves with ``git rev-parse --verify`` and was made on or before the date given (not checked
outside a clone or in a shallow one).
"""

from __future__ import annotations

import datetime as dt
import re
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
RESULTS_PAGES = ("planners.md", "localisers.md", "missions.md", "real-sonar.md", "ros-bags.md", "scaling.md")
REFERENCE_MARK = "<!-- reference table -->"
CONVENTION_START = "Each measured table on this page has a line above it, `Measured DATE at commit HASH: COMMAND`"
MEASURED = re.compile(
    r"^Measured (?P<date>\d{4}-\d{2}-\d{2}|date unknown) at commit (?P<commit>[0-9a-f]{7,40})"
    r"(?: \((?P<detail>.+)\))?: (?P<how>\S.*)$"
)
ISO_DATE = re.compile(r"\b\d{4}-\d{2}-\d{2}\b")
COMMIT_NAME = re.compile(r"(?:\bat (?:commit )?|\bcode of )([0-9a-f]{7,40})\b")
"""A commit named on a Measured line: ``at commit HASH``, ``at HASH`` or ``code of HASH``."""
DELIMITER_ROW = re.compile(r"^\s*\|(\s*:?-+:?\s*\|)+\s*$")


@dataclass(frozen=True)
class Table:
    """A Markdown table of a page: where it starts and the nearest non-blank line above it."""

    page: str
    line: int
    """1-based line number of the table's header row."""
    above: str


def find_tables(page: str, text: str) -> list[Table]:
    """The tables of a Markdown text outside fenced code blocks.

    Parameters
    ----------
    page : str
        The page's name, carried into each table for messages.
    text : str
        The Markdown source.

    Returns
    -------
    list of Table
        In the order of the text.
    """
    lines = text.split("\n")
    tables: list[Table] = []
    in_fence = False
    index = 0
    while index < len(lines):
        line = lines[index]
        if line.lstrip().startswith("```"):
            in_fence = not in_fence
        elif not in_fence and line.lstrip().startswith("|") and index + 1 < len(lines) \
                and DELIMITER_ROW.match(lines[index + 1]):
            above = next((earlier for earlier in reversed(lines[:index]) if earlier.strip()), "")
            tables.append(Table(page, index + 1, above.strip()))
            while index < len(lines) and lines[index].lstrip().startswith("|"):
                index += 1
            continue
        index += 1
    return tables


def unlabelled_tables(tables: list[Table]) -> list[str]:
    """Tables with neither a ``Measured ...`` line nor the reference mark just above, as ``page:line``."""
    return [f"{table.page}:{table.line}" for table in tables
            if table.above != REFERENCE_MARK and not MEASURED.match(table.above)]


def _page_tables(page: str) -> list[Table]:
    return find_tables(page, (REPO / "docs" / page).read_text(encoding="utf-8"))


def _measured_lines() -> list[tuple[str, str]]:
    return [(f"{table.page}:{table.line}", table.above)
            for page in RESULTS_PAGES for table in _page_tables(page) if MEASURED.match(table.above)]


def _in_full_git_clone() -> bool:
    """Whether the repository is a git clone with its whole history (not a shallow one)."""
    if shutil.which("git") is None:
        return False
    probe = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--is-inside-work-tree", "--is-shallow-repository"],
                           capture_output=True, text=True, check=False)
    return probe.returncode == 0 and probe.stdout.split() == ["true", "false"]


def _commit_day(name: str) -> dt.date | None:
    """The committer date of a commit of this clone, or None when it does not resolve."""
    verify = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--verify", "--quiet", f"{name}^{{commit}}"],
                            capture_output=True, text=True, check=False)
    if verify.returncode != 0:
        return None
    shown = subprocess.run(["git", "-C", str(REPO), "show", "-s", "--format=%cs", verify.stdout.strip()],
                           capture_output=True, text=True, check=True)
    return dt.date.fromisoformat(shown.stdout.strip())


@pytest.mark.parametrize("page", RESULTS_PAGES)
def test_every_table_is_dated_or_marked_reference(page: str) -> None:
    tables = _page_tables(page)
    assert tables, f"no table found in docs/{page}"
    assert unlabelled_tables(tables) == [], (
        "a table needs 'Measured YYYY-MM-DD at commit HASH: COMMAND' or "
        f"'{REFERENCE_MARK}' on the nearest non-blank line above it")


@pytest.mark.parametrize("page", RESULTS_PAGES)
def test_page_states_the_convention_at_the_top(page: str) -> None:
    text = (REPO / "docs" / page).read_text(encoding="utf-8")
    opening = text.split("\n## ", 1)[0]
    assert CONVENTION_START in opening, f"docs/{page} does not state the convention before its first section"


@pytest.mark.parametrize("page", RESULTS_PAGES)
def test_reference_marks_stand_above_tables(page: str) -> None:
    text = (REPO / "docs" / page).read_text(encoding="utf-8")
    marked = sum(1 for table in find_tables(page, text) if table.above == REFERENCE_MARK)
    marks = sum(1 for line in text.split("\n") if line.strip() == REFERENCE_MARK)
    assert marks == marked, f"docs/{page}: a reference mark with no table below it"


def test_checker_catches_a_table_without_its_line() -> None:
    page = "\n".join([
        "# Page", "", "<!-- reference table -->", "", "| a | b |", "|---|---|", "| 1 | 2 |", "",
        "Some prose.", "", "| c |", "|---:|", "| 3 |", "",
        "```", "| inside a fence |", "|---|", "```", "",
        "Measured 2026-11-30 at commit 85dfcbe: the commands above", "", "| d |", "|---|", "| 4 |",
    ])
    tables = find_tables("page.md", page)
    assert [table.line for table in tables] == [5, 11, 22]
    assert unlabelled_tables(tables) == ["page.md:11"]


def test_measured_lines_carry_valid_dates_not_in_the_future() -> None:
    lines = _measured_lines()
    assert lines
    today = dt.datetime.now(dt.UTC).date()
    for where, line in lines:
        for text in ISO_DATE.findall(line):
            try:
                day = dt.date.fromisoformat(text)
            except ValueError:
                pytest.fail(f"{where}: {text} is not a valid date")
            assert day <= today, f"{where}: {text} is in the future"


def test_measured_commits_exist_and_precede_their_dates() -> None:
    if not _in_full_git_clone():
        pytest.skip("not inside a git clone with its whole history: the commits cannot be checked")
    for where, line in _measured_lines():
        match = MEASURED.match(line)
        assert match is not None
        for name in COMMIT_NAME.findall(line):
            made = _commit_day(name)
            assert made is not None, f"{where}: commit {name} does not resolve in this clone"
            if name == match["commit"] and match["date"] != "date unknown":
                stated = dt.date.fromisoformat(match["date"])
                assert made <= stated, f"{where}: {name} was made on {made}, after the date given ({stated})"
