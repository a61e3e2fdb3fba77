"""The layers of docs/conventions.md, read from the source: `toolkit.world` imports nothing else of the
project; `planners` and `localisation` import only `toolkit.world` (and themselves). Every import counts,
also those inside functions."""

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
    assert "toolkit.world" in imports and "toolkit.recording" in imports  # `..world`, and one under TYPE_CHECKING
