"""Documented commands are tests: every fenced shell block of README.md and docs/ runs, or says why not.

    python tools/docs_commands.py --list            # every block and check, file:line and what CI does with it
    python tools/docs_commands.py --run             # run them all here (what `make docs-commands` runs in pytest)
    python tools/docs_commands.py --run README.md:  # only those whose file:line starts with this
    python tools/docs_commands.py --summary         # the counts: blocks run in CI, skipped, checks

A block is a fenced ```bash, ```sh, ```shell or ```console block (of ```console, only the ``$ `` lines run). Each
runs on its own, in a fresh temporary folder outside the repository, under ``bash -e -o pipefail``,
with the ``nxtnav`` of the Python that runs this file first on PATH (warm: its entry point forked from a
process that has imported the toolkit once, tools/warm_nxtnav.py; ``NXTNAV_DOCS_WARM=0`` starts the
console script itself every time), ``$DOCS_REPO`` naming the
repository (for its ``tools/``) and ``MPLBACKEND=Agg``. It fails on a nonzero exit or a Python
traceback in its output. A block is self-contained: a file it reads is one it made earlier, or one
shipped with nxtnav (``maps/...``). Processes it leaves in the background are stopped when it ends.

Markers are HTML comments (the site does not show them) directly above the fence (no blank line
between), one or more, each on a line of its own:

    <!-- docs-run: skip: REASON -->
        The block does not run in CI: REASON says what it needs (a real NXT, a display, a cluster,
        a clone from the internet, hours of benchmark). Blocks of ``make`` targets are skipped too:
        CI runs those targets itself (.ci/run), and a block that runs make without a skip is an error.

    <!-- docs-run: ci: OLD => NEW; OLD2 => NEW2 -->
        Literal substitutions made before CI runs the block, in order, each replacing every
        occurrence: smaller sizes (``--runs 50 => --runs 2``), or a line that cannot run in CI made a
        comment that says why (``nxtnav nxt check => # needs a real NXT``). A substitution that
        matches nothing is an error, so a marker cannot outlive the command it changes. OLD and NEW
        hold neither ``;`` nor ``=>``.

A check anywhere in a page (typically next to the figure or sentence it backs):

    <!-- docs-run: check: COMMAND => FILE: FIELD == VALUE; FIELD2 <= VALUE2 -->
        COMMAND runs in a fresh folder (as a block does), then each FIELD of the JSON file FILE
        (dotted, list items by number: ``results.0.ape_rmse_cm``) is compared with VALUE: ``==``
        rounds the number to VALUE's decimals (``0.11`` compares to two), so the check holds the
        figure the text states; ``<=``, ``>=``, ``<``, ``>`` compare as they are; a non-number VALUE
        is compared as text.

Any other ``docs-run`` comment, or a skip/ci marker not followed by a shell block, is an error. So is
a fence without a language: every block says what it holds (```bash for commands, ```text for output,
```yaml, ```ini, ...), so no command escapes the runner unlabelled.
"""

from __future__ import annotations

import argparse
import atexit
import functools
import importlib.util
import json
import operator
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
SHELL_LANGUAGES = ("bash", "sh", "console", "shell")
MARKER = re.compile(r"^\s*<!--\s*docs-run:\s*(?P<kind>[a-z-]+)\s*:(?P<body>.*?)-->\s*$")
ANY_MARKER = re.compile(r"<!--\s*docs-run\b")
FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})\s*(?P<info>[\w+-]*)")
TRACEBACK = "Traceback (most recent call last)"
MAKE_LINE = re.compile(r"^\s*make(\s|$)", re.MULTILINE)
COMPARISONS: dict[str, Callable[[float, float], bool]] = {
    "==": operator.eq,
    "<=": operator.le,
    ">=": operator.ge,
    "<": operator.lt,
    ">": operator.gt,
}
CONDITION = re.compile(r"^\s*(?P<field>[\w.-]+)\s*(?P<op>==|<=|>=|<|>)\s*(?P<value>.+?)\s*$")
DEFAULT_TIMEOUT_S = 600.0


class DocsMarkerError(ValueError):
    """A docs-run marker is malformed, unknown, misplaced, or no longer matches its block."""


@dataclass(frozen=True)
class Block:
    """One fenced shell block of a page, with what its markers say CI does with it.

    Attributes
    ----------
    path : str
        The page, relative to the repository (``docs/missions.md``).
    line : int
        Line of the opening fence (1-based).
    language : str
        The fence's info string (``bash``, ``sh``, ``console``).
    text : str
        The block as written, without its fences.
    skip_reason : str or None
        Why CI does not run it (a skip marker), or None.
    substitutions : tuple of (str, str)
        The ci marker's literal substitutions, in order.
    """

    path: str
    line: int
    language: str
    text: str
    skip_reason: str | None = None
    substitutions: tuple[tuple[str, str], ...] = ()

    @property
    def where(self) -> str:
        """``file:line`` of the opening fence."""
        return f"{self.path}:{self.line}"

    @property
    def status(self) -> str:
        """What CI does with the block, in a few words."""
        if self.skip_reason is not None:
            return f"skip: {self.skip_reason}"
        if self.substitutions:
            return "run, with " + "; ".join(f"{old} => {new}" for old, new in self.substitutions)
        return "run"


@dataclass(frozen=True)
class Condition:
    """One comparison of a check: a JSON field against the value the text states."""

    field: str
    op: str
    value: str


@dataclass(frozen=True)
class Check:
    """A figure of the text and the command that produces it (a ``check`` marker)."""

    path: str
    line: int
    command: str
    json_file: str
    conditions: tuple[Condition, ...] = field(default_factory=tuple)

    @property
    def where(self) -> str:
        """``file:line`` of the marker."""
        return f"{self.path}:{self.line}"

    @property
    def status(self) -> str:
        """The check in a few words."""
        tests = "; ".join(f"{c.field} {c.op} {c.value}" for c in self.conditions)
        return f"check: {self.command} => {self.json_file}: {tests}"


@dataclass(frozen=True)
class Outcome:
    """How a block or a check ran: exit status, the output (stdout and stderr), seconds, and what failed."""

    returncode: int
    output: str
    seconds: float
    failure: str | None


def doc_pages(root: Path = REPO) -> list[Path]:
    """README.md and every Markdown page under docs/, in a stable order."""
    pages = [root / "README.md"] if (root / "README.md").is_file() else []
    return pages + sorted((root / "docs").rglob("*.md"))


def parse_substitutions(body: str, where: str) -> tuple[tuple[str, str], ...]:
    """The ``OLD => NEW; ...`` pairs of a ci marker (NEW may be empty: the text is removed)."""
    pairs = []
    for item in body.split(";"):
        if not item.strip():
            continue
        if "=>" not in item:
            raise DocsMarkerError(f"{where}: ci substitution {item.strip()!r} has no '=>' (OLD => NEW)")
        old, new = (part.strip() for part in item.split("=>", 1))
        if not old:
            raise DocsMarkerError(f"{where}: ci substitution {item.strip()!r} replaces nothing")
        pairs.append((old, new))
    if not pairs:
        raise DocsMarkerError(f"{where}: ci marker without a substitution")
    return tuple(pairs)


def parse_check(body: str, path: str, line: int) -> Check:
    """A check marker's body, ``COMMAND => FILE: FIELD OP VALUE; ...``, as a Check."""
    where = f"{path}:{line}"
    if "=>" not in body:
        raise DocsMarkerError(f"{where}: check needs 'COMMAND => FILE: FIELD == VALUE'")
    command, target = (part.strip() for part in body.rsplit("=>", 1))
    json_file, colon, tests = target.partition(":")
    if not command or not colon or not json_file.strip():
        raise DocsMarkerError(f"{where}: check needs 'COMMAND => FILE: FIELD == VALUE', got {body.strip()!r}")
    conditions = []
    for text in filter(str.strip, tests.split(";")):
        match = CONDITION.match(text)
        if match is None:
            raise DocsMarkerError(f"{where}: check condition {text.strip()!r} is not 'FIELD == VALUE'")
        conditions.append(Condition(match["field"], match["op"], match["value"]))
    if not conditions:
        raise DocsMarkerError(f"{where}: check without a condition")
    return Check(path, line, command, json_file.strip(), tuple(conditions))


def _closing_fence(lines: list[str], start: int, fence: str) -> int:
    """Index of the line that closes the fence opened at `start` (the page's end when none does)."""
    for index in range(start + 1, len(lines)):
        stripped = lines[index].strip()
        if stripped.startswith(fence[0] * len(fence)) and not stripped.strip(fence[0]):
            return index
    return len(lines)


def _block_from_markers(markers: list[tuple[int, str, str]], path: str, line: int, language: str, text: str) -> Block:
    """The block opened at `line`, with the skip and ci markers just above it."""
    skip_reason: str | None = None
    substitutions: tuple[tuple[str, str], ...] = ()
    for marker_line, kind, body in markers:
        where = f"{path}:{marker_line}"
        if kind == "skip":
            if not body.strip():
                raise DocsMarkerError(f"{where}: skip needs a reason (<!-- docs-run: skip: REASON -->)")
            skip_reason = body.strip()
        else:
            substitutions += parse_substitutions(body, where)
    block = Block(path, line, language, text, skip_reason, substitutions)
    if language not in SHELL_LANGUAGES:
        raise DocsMarkerError(f"{block.where}: a docs-run marker above a ```{language} block, not a shell block")
    if skip_reason is None and MAKE_LINE.search(ci_script(block)):
        raise DocsMarkerError(f"{block.where}: a block that runs make needs a skip marker (CI runs make itself)")
    return block


def parse_page(page: Path, root: Path = REPO) -> tuple[list[Block], list[Check]]:
    """The shell blocks and the checks of one Markdown page.

    Raises
    ------
    DocsMarkerError
        A marker is malformed, of an unknown kind, or a skip/ci marker stands above no shell block;
        or a fence has no language.
    """
    path = page.relative_to(root).as_posix() if page.is_relative_to(root) else str(page)
    lines = page.read_text(encoding="utf-8").splitlines()
    blocks: list[Block] = []
    checks: list[Check] = []
    pending: list[tuple[int, str, str]] = []  # skip/ci markers waiting for the fence below them
    index = 0
    while index < len(lines):
        line = lines[index]
        marker = MARKER.match(line)
        fence = FENCE.match(line)
        if marker is not None:
            kind, body = marker["kind"], marker["body"]
            if kind == "check":
                checks.append(parse_check(body, path, index + 1))
            elif kind in ("skip", "ci"):
                pending.append((index + 1, kind, body))
            else:
                raise DocsMarkerError(f"{path}:{index + 1}: unknown docs-run marker {kind!r} (skip, ci or check)")
            index += 1
            continue
        if ANY_MARKER.search(line):
            raise DocsMarkerError(f"{path}:{index + 1}: malformed docs-run marker (<!-- docs-run: KIND: ... -->)")
        if fence is not None:
            end = _closing_fence(lines, index, fence["fence"])
            language = fence["info"].lower()
            if not language:
                raise DocsMarkerError(
                    f"{path}:{index + 1}: a fence without a language (```bash for commands, ```text for output)"
                )
            indent = len(fence["indent"])
            text = "\n".join(body_line[indent:] for body_line in lines[index + 1 : end])
            if language in SHELL_LANGUAGES or pending:
                blocks.append(_block_from_markers(pending, path, index + 1, language, text))
            pending = []
            index = end + 1
            continue
        if pending:
            raise DocsMarkerError(f"{path}:{pending[0][0]}: docs-run marker not directly above a shell block")
        index += 1
    if pending:
        raise DocsMarkerError(f"{path}:{pending[0][0]}: docs-run marker not directly above a shell block")
    return blocks, checks


def collect(root: Path = REPO, pages: Iterable[Path] | None = None) -> tuple[list[Block], list[Check]]:
    """Every shell block and check of README.md and docs/ (or of `pages`)."""
    blocks: list[Block] = []
    checks: list[Check] = []
    for page in doc_pages(root) if pages is None else pages:
        page_blocks, page_checks = parse_page(page, root)
        blocks += page_blocks
        checks += page_checks
    return blocks, checks


def console_commands(text: str) -> str:
    """The commands of a ```console block: its ``$ `` lines (and their backslash continuations)."""
    commands: list[str] = []
    continued = False
    for line in text.splitlines():
        if line.startswith("$ ") or continued:
            commands.append(line[2:] if line.startswith("$ ") and not continued else line)
            continued = line.rstrip().endswith("\\")
    return "\n".join(commands)


def ci_script(block: Block) -> str:
    """The script CI runs for `block`: its commands with the ci marker's substitutions made.

    Raises
    ------
    DocsMarkerError
        A substitution matches nothing in the block (the marker no longer fits the command).
    """
    script = console_commands(block.text) if block.language == "console" else block.text
    for old, new in block.substitutions:
        if old not in script:
            raise DocsMarkerError(f"{block.where}: ci substitution {old!r} matches nothing in the block")
        script = script.replace(old, new)
    return script


def command_environment(repo: Path = REPO) -> dict[str, str]:
    """The environment of a block: the `nxtnav` next to this Python first on PATH, no display needed."""
    env = dict(os.environ)
    bin_dir = str(Path(sys.executable).parent)
    env["PATH"] = os.pathsep.join([bin_dir, env.get("PATH", "")])
    env["MPLBACKEND"] = "Agg"
    env["DOCS_REPO"] = str(repo)
    env.pop("PYTEST_CURRENT_TEST", None)
    return env


@functools.cache
def _warm_server() -> Any:
    """The warm `nxtnav` server of this process (tools/warm_nxtnav.py), started on first use and stopped at exit."""
    spec = importlib.util.spec_from_file_location("warm_nxtnav", Path(__file__).with_name("warm_nxtnav.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    server = module.WarmServer(command_environment())
    atexit.register(server.stop)
    return server


def block_environment() -> dict[str, str]:
    """`command_environment` with the warm `nxtnav` stand-in first on PATH (tools/warm_nxtnav.py; its
    server starts with the first block of this process), unless ``NXTNAV_DOCS_WARM=0``."""
    env = command_environment()
    if os.environ.get("NXTNAV_DOCS_WARM", "1") == "0":
        return env
    return dict(_warm_server().environment(env))


def run_script(script: str, folder: Path, timeout_s: float = DEFAULT_TIMEOUT_S) -> Outcome:
    """Run `script` under ``bash -e -o pipefail`` in `folder`; stop what it left running when it ends.

    Returns
    -------
    Outcome
        Its exit status, its output, the wall-clock seconds, and why it failed (nonzero exit, a
        traceback in the output, or the timeout in seconds), or None.
    """
    started = time.monotonic()
    # the output goes to a file, not a pipe: a background job that keeps it open must not hold the block
    with tempfile.TemporaryFile(mode="w+", encoding="utf-8", errors="replace") as log:
        process = subprocess.Popen(
            ["bash", "-e", "-o", "pipefail", "-c", script],
            cwd=folder,
            env=block_environment(),
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: background jobs (`brick serve &`) are stopped with it
        )
        try:
            process.wait(timeout=timeout_s)
            failure = None
        except subprocess.TimeoutExpired:
            failure = f"still running after {timeout_s:g} s"
        _stop_group(process.pid)
        process.wait()
        log.seek(0)
        output = log.read()
    seconds = time.monotonic() - started
    if failure is None and process.returncode != 0:
        failure = f"exit status {process.returncode}"
    if failure is None and TRACEBACK in output:
        failure = "a Python traceback in the output"
    return Outcome(process.returncode, output, seconds, failure)


def _stop_group(pgid: int) -> None:
    """Stop every process left in the process group `pgid` (the block's own background jobs)."""
    try:
        os.killpg(pgid, signal.SIGTERM)
    except ProcessLookupError:
        return
    time.sleep(0.2)
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def output_excerpt(output: str, lines: int = 40) -> str:
    """The part of a failed command's output to show: from its first traceback on, else its last lines."""
    text = output.rstrip().splitlines()
    start = next((i for i, line in enumerate(text) if TRACEBACK in line), max(0, len(text) - lines))
    return "\n".join(text[start : start + lines])


def run_block(block: Block, timeout_s: float = DEFAULT_TIMEOUT_S) -> Outcome:
    """Run one block (its CI form) in a fresh temporary folder outside the repository."""
    script = ci_script(block)
    with tempfile.TemporaryDirectory(prefix="docs-run-") as folder:
        return run_script(script, Path(folder), timeout_s)


def json_field(document: object, dotted: str) -> object:
    """The value at a dotted path of a JSON document (list items by number)."""
    value = document
    for key in dotted.split("."):
        if isinstance(value, list) and key.lstrip("-").isdigit():
            value = value[int(key)]
        elif isinstance(value, dict) and key in value:
            value = value[key]
        else:
            raise KeyError(f"no field {key!r} (of {dotted!r})")
    return value


def compare(actual: object, condition: Condition) -> str | None:
    """None when `actual` meets the condition, else a sentence saying how it differs."""
    try:
        stated = float(condition.value)
    except ValueError:
        if condition.op == "==" and str(actual) == condition.value.strip("\"'"):
            return None
        return f"{condition.field} is {actual!r}, the text says {condition.op} {condition.value}"
    if not isinstance(actual, int | float):
        return f"{condition.field} is {actual!r}, not a number"
    if condition.op == "==":
        decimals = len(condition.value.partition(".")[2])
        measured = round(float(actual), decimals)
        if measured == stated:
            return None
        return f"{condition.field} is {actual!r} (to {decimals} decimals: {measured}), the text says {condition.value}"
    if COMPARISONS[condition.op](float(actual), stated):
        return None
    return f"{condition.field} is {actual!r}, the text says {condition.op} {condition.value}"


def run_check(check: Check, timeout_s: float = DEFAULT_TIMEOUT_S) -> Outcome:
    """Run a check's command in a fresh temporary folder and compare its JSON with the stated figures."""
    with tempfile.TemporaryDirectory(prefix="docs-check-") as folder:
        outcome = run_script(check.command, Path(folder), timeout_s)
        if outcome.failure is not None:
            return outcome
        json_path = Path(folder) / check.json_file
        if not json_path.is_file():
            return Outcome(outcome.returncode, outcome.output, outcome.seconds, f"{check.json_file} not written")
        document = json.loads(json_path.read_text(encoding="utf-8"))
    differences = []
    for condition in check.conditions:
        try:
            difference = compare(json_field(document, condition.field), condition)
        except (KeyError, IndexError) as exc:
            difference = f"{check.json_file}: {exc}"
        if difference is not None:
            differences.append(difference)
    failure = "; ".join(differences) or None
    return Outcome(outcome.returncode, outcome.output, outcome.seconds, failure)


def print_listing(blocks: list[Block], checks: list[Check]) -> None:
    """Each block and check with file:line and status, then the counts."""
    for block in blocks:
        print(f"{block.where}: {block.status}")
    for check in checks:
        print(f"{check.where}: {check.status}")
    print(summary(blocks, checks))


def summary(blocks: list[Block], checks: list[Check]) -> str:
    """``N shell blocks: R run in CI (S with smaller sizes), K skipped; C checks``."""
    skipped = sum(block.skip_reason is not None for block in blocks)
    resized = sum(block.skip_reason is None and bool(block.substitutions) for block in blocks)
    return (
        f"{len(blocks)} shell blocks: {len(blocks) - skipped} run in CI ({resized} with CI substitutions), "
        f"{skipped} skipped with a reason; {len(checks)} checks of stated figures"
    )


def run_all(blocks: list[Block], checks: list[Check], prefix: str, timeout_s: float) -> int:
    """Run every block and check whose file:line starts with `prefix`; 0 when all pass, else 1."""
    failures = 0
    total_s = 0.0
    items: list[Block | Check] = [*blocks, *checks]
    for item in items:
        if not item.where.startswith(prefix):
            continue
        if isinstance(item, Block) and item.skip_reason is not None:
            print(f"{item.where}: skipped ({item.skip_reason})")
            continue
        outcome = run_block(item, timeout_s) if isinstance(item, Block) else run_check(item, timeout_s)
        total_s += outcome.seconds
        verdict = "ok" if outcome.failure is None else f"FAILED: {outcome.failure}"
        print(f"{item.where}: {verdict} ({outcome.seconds:.1f} s)", flush=True)
        if outcome.failure is not None:
            failures += 1
            print("    " + output_excerpt(outcome.output).replace("\n", "\n    "), flush=True)
    print(f"{failures} failed; {total_s:.0f} s running commands")
    return 1 if failures else 0


def main(argv: list[str] | None = None) -> int:
    """The command line: --list (the default), --summary or --run [PREFIX]."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--list", action="store_true", help="every block and check with file:line and status")
    parser.add_argument("--summary", action="store_true", help="only the counts of blocks run, skipped and checked")
    parser.add_argument("--run", nargs="?", const="", metavar="PREFIX", help="run the blocks whose file:line starts so")
    parser.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, help="seconds per block (default 600)")
    args = parser.parse_args(argv)
    try:
        blocks, checks = collect()
    except DocsMarkerError as exc:
        print(f"docs_commands: error: {exc}", file=sys.stderr)
        return 2
    if args.run is not None:
        print(summary(blocks, checks), flush=True)
        return run_all(blocks, checks, args.run, args.timeout)
    if args.summary:
        print(summary(blocks, checks))
    else:
        print_listing(blocks, checks)
    return 0


if __name__ == "__main__":
    sys.exit(main())
