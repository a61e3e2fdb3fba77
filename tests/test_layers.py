"""The layers of docs/conventions.md, read from the source: `toolkit.world` imports nothing else of the
project; `planners` and `localisation` import only `toolkit.world` (and themselves); above them every
module of the project has a rank (`RANKS`) and imports nothing of a higher one, so the mission never
imports the benchmarks or the CLI, the robots never import the mission, the benchmarks never import
the CLI. Every import counts, also those inside functions."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PROJECT = ("toolkit", "planners", "localisation")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def project_imports(path: Path) -> set[str]:
    """The project modules `path` imports (relative imports resolved)."""
    package = _module_name(path) if path.name == "__init__.py" else _module_name(path).rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                names = [".".join([*base, node.module] if node.module else base)]
            else:
                names = [node.module or ""]
        found.update(n for n in names if n.split(".")[0] in PROJECT)
    return found


def _files(package: str) -> list[Path]:
    return sorted((ROOT / package.replace(".", "/")).rglob("*.py"))


def _inside(module: str, allowed: tuple[str, ...]) -> bool:
    return any(module == a or module.startswith(a + ".") for a in allowed)


LAYERS = {
    "toolkit.world": ("toolkit.world",),
    "planners": ("planners", "toolkit.world"),
    "localisation": ("localisation", "toolkit.world"),
}


@pytest.mark.parametrize("layer", sorted(LAYERS))
def test_layer_imports_only_what_it_may(layer: str) -> None:
    files = _files(layer)
    assert files, f"no source files under {layer}"
    bad = {f"{p.relative_to(ROOT)} imports {m}" for p in files for m in project_imports(p)
           if not _inside(m, LAYERS[layer])}
    assert not bad, "\n".join(sorted(bad))


def test_the_reader_sees_relative_and_nested_imports(tmp_path: Path) -> None:
    # the checker itself must catch what it is there for: an upward import inside a function
    probe = ROOT / "localisation" / "procedure.py"
    assert "localisation.base" in project_imports(probe)
    assert "toolkit.world" in project_imports(probe)
    mission = ROOT / "toolkit" / "mission" / "runner.py"
    imports = project_imports(mission)
    # `..world`, and one under TYPE_CHECKING
    assert "toolkit.world" in imports and "toolkit.recordings.recorder" in imports


#: The rank of each part of the project, lowest first: a module may import its own rank and those below.
RANKS: dict[str, int] = {
    "toolkit.world": 0,
    "planners": 1, "localisation": 1, "toolkit.robots": 1,
    # shared services: files, formats, data sets and the plots of them
    "toolkit.seeds": 2, "toolkit.number_format": 2, "toolkit.plotting": 2,
    "toolkit.real_sonar": 2, "toolkit.recordings": 2, "toolkit.ros": 2,
    "toolkit.mission": 3, "toolkit.view": 3,
    "toolkit.bench": 4,
    "toolkit.cli": 5, "toolkit": 5,  # the package's own __init__ (its version) and the CLI on top
    "toolkit.parameter_docs": 5,  # the parameter reference: every model, the mission's and the CLI's flags
}


def _part(module: str) -> str:
    """The entry of `RANKS` a module belongs to: its longest matching prefix (`toolkit` itself only
    for the package's ``__init__``)."""
    for prefix in sorted(RANKS, key=len, reverse=True):
        if module == prefix or (prefix != "toolkit" and module.startswith(prefix + ".")):
            return prefix
    raise KeyError(f"{module} has no rank in RANKS")


def test_every_module_has_a_rank() -> None:
    unranked = []
    for module in (_module_name(p) for pkg in PROJECT for p in _files(pkg)):
        try:
            _part(module)
        except KeyError:
            unranked.append(module)
    assert not unranked, f"modules without a rank in RANKS: {unranked}"


def test_no_module_imports_a_higher_rank() -> None:
    bad = []
    for pkg in PROJECT:
        for path in _files(pkg):
            own = _part(_module_name(path))
            for imported in project_imports(path):
                other = _part(imported)
                if RANKS[other] > RANKS[own] or (RANKS[other] == RANKS[own] == 1 and other != own):
                    bad.append(f"{path.relative_to(ROOT)} ({own}, rank {RANKS[own]}) imports {imported} "
                               f"(rank {RANKS[other]})")
    assert not bad, "\n".join(sorted(bad))


@pytest.mark.parametrize(("low", "high"), [("toolkit.mission", "toolkit.bench"), ("toolkit.mission", "toolkit.cli"),
                                           ("toolkit.robots", "toolkit.mission"), ("toolkit.bench", "toolkit.cli")])
def test_the_named_rules_follow_from_the_ranks(low: str, high: str) -> None:
    assert RANKS[low] < RANKS[high]


def _imported_modules(path: Path, modules: set[str]) -> set[str]:
    """The project modules (files) `path` imports: ``from pkg import name`` counts as importing
    ``pkg.name`` where that is a module of its own (``from . import messages``), else ``pkg``."""
    package = _module_name(path) if path.name == "__init__.py" else _module_name(path).rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join([*parts[: len(parts) - (node.level - 1)], *([node.module] if node.module else [])])
            found.update(f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names)
    return found & modules


def _import_graph() -> dict[str, set[str]]:
    """Each project module (file) and the project modules it imports, at any depth of the file."""
    modules = {_module_name(p): p for pkg in PROJECT for p in _files(pkg)}
    return {m: _imported_modules(p, set(modules)) - {m} for m, p in modules.items()}


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    m = stack.pop()
                    on_stack.discard(m)
                    component.append(m)
                    if m == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_import_circle() -> None:
    # every import counts, also those inside functions and under TYPE_CHECKING: a circle there is one a
    # refactoring turns into an import error; shared types belong in a module both sides import
    circles = _circles(_import_graph())
    assert not circles, "\n".join(" <-> ".join(c) for c in circles)


def test_the_circle_finder_finds_a_circle() -> None:
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _circles({"a": {"b"}, "b": set()}) == []
