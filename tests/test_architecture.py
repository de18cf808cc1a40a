"""The package's shape: imports flow one way, and modules stay a size one can read.

The import graph is read from the source (``ast``), so imports inside functions count too: a
lazy import that closes a circle hides a design knot, it does not remove it. A submodule that
imports its own package's ``__init__`` closes a circle with it as well.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("psm_model", "hybrid", "psmforce")
"""The layers, bottom first: a module imports its own package and those below it, never one
above (the physics does not know the estimators, the estimators do not know the CLI)."""
MAX_LINES = 400
SIZE_REASON = "Size:"
"""A module over :data:`MAX_LINES` lines says why in a docstring paragraph starting with this."""


def _modules() -> dict[str, Path]:
    modules = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _imported(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules that ``name`` imports anywhere in its source."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[:len(package) - node.level + 1] + ([base] if base else []))
            targets = [base] + [f"{base}.{alias.name}" for alias in node.names]
        else:
            continue
        for target in targets:
            while target and target not in modules:  # a name inside a module: the module
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def import_cycles() -> list[list[str]]:
    """Every strongly connected group of more than one module (Tarjan), sorted."""
    modules = _modules()
    graph = {name: _imported(name, path, modules) for name, path in modules.items()}
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                cycles.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(cycles)


def test_the_cycle_finder_finds_a_planted_cycle(tmp_path, monkeypatch):
    """The check can fail: two modules that import each other (one lazily) are reported."""
    package = tmp_path / "psm_model"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from psm_model.b import f\n")
    (package / "b.py").write_text("def f():\n    from psm_model import a\n")
    (package / "c.py").write_text("import psm_model.a\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    monkeypatch.setattr(sys.modules[__name__], "PACKAGES", ("psm_model",))
    assert import_cycles() == [["psm_model.a", "psm_model.b"]]


def test_no_import_cycle():
    assert import_cycles() == []


def upward_imports() -> list[tuple[str, str]]:
    """Every (module, imported module) pair whose import points up the layers of
    :data:`PACKAGES`, sorted."""
    modules = _modules()
    layer = {package: i for i, package in enumerate(PACKAGES)}
    return sorted((name, target) for name, path in modules.items()
                  for target in _imported(name, path, modules)
                  if layer[target.split(".")[0]] > layer[name.split(".")[0]])


def test_the_layer_check_finds_a_planted_upward_import(tmp_path, monkeypatch):
    """The check can fail: a lazy import of the estimators from the physics is reported."""
    for package in ("psm_model", "hybrid"):
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "hybrid" / "metrics.py").write_text("from psm_model import filters\n")
    (tmp_path / "psm_model" / "filters.py").write_text("")
    (tmp_path / "psm_model" / "calibration.py").write_text(
        "def f():\n    from hybrid.metrics import postprocess\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    monkeypatch.setattr(sys.modules[__name__], "PACKAGES", ("psm_model", "hybrid"))
    assert upward_imports() == [("psm_model.calibration", "hybrid.metrics")]


def test_layers_point_one_way():
    assert upward_imports() == []


@pytest.mark.parametrize("name", sorted(_modules()))
def test_module_size_or_reason(name):
    path = _modules()[name]
    lines = len(path.read_text().splitlines())
    if lines > MAX_LINES:
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        assert any(p.startswith(SIZE_REASON) for p in doc.split("\n\n")), (
            f"{path.relative_to(ROOT)} has {lines} lines (> {MAX_LINES}) and its docstring "
            f"gives no '{SIZE_REASON}' paragraph saying why")
