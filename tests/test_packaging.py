"""The library declares compatible ranges; the exact tested set is ``constraints.txt``, which
the README's two commands and CI install with (a lab installs psmforce beside what it has; a
reproduction gets exactly what was tested)."""

from __future__ import annotations

from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib")  # Python 3.11+
from packaging.requirements import Requirement  # noqa: E402
from packaging.utils import canonicalize_name  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _declared() -> list[Requirement]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = [r for group in project["optional-dependencies"].values() for r in group]
    return [Requirement(r) for r in project["dependencies"] + extras]


def _pins() -> dict[str, str]:
    pins = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        line = line.split("#")[0].strip()
        if line:
            name, sep, version = line.partition("==")
            assert sep and version, f"constraints.txt: {line!r} is not NAME==VERSION"
            assert canonicalize_name(name) not in pins, f"constraints.txt: {name} twice"
            pins[canonicalize_name(name)] = version
    return pins


def test_every_dependency_is_declared_as_a_range_not_a_pin():
    exact = [str(r) for r in _declared() if any(s.operator in ("==", "===")
                                                   for s in r.specifier)]
    assert exact == [], f"pin these in constraints.txt, declare a range: {exact}"
    unbounded = [str(r) for r in _declared() if r.name != "setuptools"
                 and not any(s.operator in ("<", "~=") for s in r.specifier)]
    assert unbounded == [], f"give these an upper bound (a major release may break): {unbounded}"


def test_the_constraints_pin_every_dependency_within_its_declared_range():
    pins = _pins()
    for requirement in _declared():
        name = canonicalize_name(requirement.name)
        if name == "setuptools":  # a build tool the venv brings
            continue
        assert name in pins, f"constraints.txt does not pin {requirement.name}"
        assert requirement.specifier.contains(pins[name], prereleases=True), \
            f"constraints.txt pins {requirement.name}=={pins[name]}, outside {requirement}"
    assert pins["torch"] == "2.13.0"  # the CPU build on disk; a range alone pulls a CUDA build


def test_the_readme_commands_and_ci_install_the_tested_set():
    head = (ROOT / "README.md").read_text().split("```")[1]
    commands = [ln for ln in head.splitlines() if "pip install" in ln]
    assert len(commands) == 2 and all("-c constraints.txt" in c for c in commands)
    assert "-c constraints.txt" in (ROOT / ".ci" / "run").read_text()
