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
PACKAGE = "psmforce"
"""The one import package the distribution installs (``tests/test_wheel.py`` checks the wheel)."""
FLOORS = (
    ("psmforce.core",),
    ("psmforce.robot",),
    ("psmforce.io",),
    ("psmforce.sim", "psmforce.identification"),
    ("psmforce.estimators.data",),
    ("psmforce.estimators.networks",),
    ("psmforce.estimators.training",),
    ("psmforce.estimators.evaluation",),
    ("psmforce.estimators.runtime",),
    ("psmforce.experiments", "psmforce.live"),
    ("psmforce.cli",),
)
"""The wings of :data:`PACKAGE`, bottom floor first. A module imports its own wing and the floors
below, never a floor above, nor another wing of its own floor: the physics (robot model, recordings,
bench, identification) does not know the estimators, the estimators do not know the experiments or
the live node, and only the command line sits above them all. The package's own ``__init__`` and
the wings' ``__init__`` files belong to the floor of what they hold (a package of wings, such as
``psmforce.estimators``, to its top wing's); ``psmforce`` itself holds only
the version and imports nothing."""
RUNTIME_WINGS = tuple(w for floor in FLOORS for w in floor if w != "psmforce.experiments")
"""Every wing but the experiments: what a user's estimator, identification or live node runs.
Nothing in them exists only for the benchmarks, the studies or the tests."""
MAX_LINES = 400
SIZE_REASON = "Size:"
"""A module over :data:`MAX_LINES` lines says why in a docstring paragraph starting with this."""


def _modules() -> dict[str, Path]:
    modules = {}
    for path in sorted((ROOT / PACKAGE).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return modules


def _wing(name: str) -> tuple[int, str] | None:
    """(floor, wing) of module ``name``; None for the package's root module."""
    for level, floor in enumerate(FLOORS):
        for wing in floor:
            if name == wing or name.startswith(wing + "."):
                return level, wing
    if name == PACKAGE:
        return None
    inner = [(level, wing) for level, floor in enumerate(FLOORS) for wing in floor
             if wing.startswith(name + ".")]
    if inner:  # a package of wings (psmforce.estimators): the top floor of what it holds
        return max(inner)
    raise AssertionError(f"{name} lies in no wing of FLOORS: give it one")


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
    package = tmp_path / "psmforce" / "core"
    package.mkdir(parents=True)
    (package.parent / "__init__.py").write_text("")
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from psmforce.core.b import f\n")
    (package / "b.py").write_text("def f():\n    from psmforce.core import a\n")
    (package / "c.py").write_text("import psmforce.core.a\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert import_cycles() == [["psmforce.core.a", "psmforce.core.b"]]


def test_no_import_cycle():
    assert import_cycles() == []


def upward_imports() -> list[tuple[str, str]]:
    """Every (module, imported module) pair whose import points up :data:`FLOORS` or sideways
    into another wing of the same floor, sorted."""
    modules = _modules()
    found = []
    for name, path in modules.items():
        here = _wing(name)
        for target in _imported(name, path, modules):
            there = _wing(target)
            if here is None or there is None:
                if here is None and there is not None:
                    found.append((name, target))  # the root module imports nothing
                continue
            if there[0] > here[0] or (there[0] == here[0] and there[1] != here[1]):
                found.append((name, target))
    return sorted(found)


def _plant(root: Path, files: dict[str, str]) -> None:
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        for folder in path.relative_to(root).parents:
            if str(folder) != ".":
                (root / folder / "__init__.py").touch()
        path.write_text(text)


def test_the_layer_check_finds_planted_upward_and_sideways_imports(tmp_path, monkeypatch):
    """The check can fail: a lazy import of the estimators from the physics, and the bench
    importing identification (two wings of one floor), are both reported."""
    _plant(tmp_path, {
        "psmforce/core/filters.py": "",
        "psmforce/estimators/evaluation/metrics.py": "from psmforce.core import filters\n",
        "psmforce/sim/calibration.py":
            "def f():\n    from psmforce.estimators.evaluation.metrics import postprocess\n",
        "psmforce/sim/bench.py": "from psmforce.identification.prior import fit\n",
        "psmforce/identification/prior.py": "",
    })
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert upward_imports() == [
        ("psmforce.sim.bench", "psmforce.identification.prior"),
        ("psmforce.sim.calibration", "psmforce.estimators.evaluation.metrics")]


def test_layers_point_one_way():
    assert upward_imports() == []


def _used_by_the_library(modules: dict[str, Path]) -> set[str]:
    """Modules some module of :data:`RUNTIME_WINGS` or the command line imports, and the
    wings' ``__init__`` files (what a user imports by package)."""
    used = set()
    for name, path in modules.items():
        if _wing(name) is not None and _wing(name)[1] != "psmforce.experiments":
            used |= _imported(name, path, modules)
    return used


def experiment_only_modules() -> list[str]:
    """Modules of the runtime wings that nothing of the library imports, and that are no
    wing's public entry (a package ``__init__``, a command's module, a model's recipe): what
    only the benchmarks, studies or tests use, which belongs in ``psmforce.experiments``."""
    modules = _modules()
    used = _used_by_the_library(modules)
    entries = {name for name, path in modules.items() if path.name in ("__init__.py", "__main__.py")}
    entries |= set(ENTRY_MODULES)
    return sorted(name for name in modules
                  if _wing(name) is not None and _wing(name)[1] in RUNTIME_WINGS
                  and name not in used and name not in entries)


ENTRY_MODULES = (
    "psmforce.cli.main",  # the console script
    "psmforce.robot.example_robots",  # wrench_from_torques for any Pinocchio model (examples/)
)
"""Modules of the runtime wings that a user reaches directly rather than through another module."""


def test_the_experiment_check_finds_a_planted_benchmark_helper(tmp_path, monkeypatch):
    _plant(tmp_path, {
        "psmforce/core/files.py": "",
        "psmforce/cli/main.py": "from psmforce.core import files\n",
        "psmforce/sim/only_a_benchmark_uses_me.py": "",
    })
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    assert experiment_only_modules() == ["psmforce.sim.only_a_benchmark_uses_me"]


def test_no_module_of_the_runtime_wings_serves_only_experiments():
    assert experiment_only_modules() == []


@pytest.mark.parametrize("name", sorted(_modules()))
def test_module_size_or_reason(name):
    path = _modules()[name]
    lines = len(path.read_text().splitlines())
    if lines > MAX_LINES:
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        assert any(p.startswith(SIZE_REASON) for p in doc.split("\n\n")), (
            f"{path.relative_to(ROOT)} has {lines} lines (> {MAX_LINES}) and its docstring "
            f"gives no '{SIZE_REASON}' paragraph saying why")
