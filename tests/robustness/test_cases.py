"""The robustness suite's shape: every artefact module contributes cases, each case is named
once, and every case states a verdict the harness knows."""

from __future__ import annotations

from importlib import import_module

from tests.robustness.cases import MODULES, all_cases
from tests.robustness.harness import EXPECTED


def test_every_artefact_module_contributes_cases_named_once():
    per_module = {name: import_module(f"tests.robustness.cases.{name}").cases()
                  for name in MODULES}
    assert all(per_module.values()), [n for n, c in per_module.items() if not c]
    everything = all_cases()
    assert len(everything) == sum(map(len, per_module.values()))
    keys = [(c.kind, c.name) for c in everything]
    assert len(set(keys)) == len(keys), "a case named twice would hide one verdict"
    assert {c.expect for c in everything} <= set(EXPECTED)
