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


def test_the_loss_verdict_sees_a_users_file_changed_and_spares_a_declared_output(tmp_path):
    """The LOSS check can fail: a call that rewrites a file the user had in the case's folder is
    LOSS, whatever else it did; the same write to a declared output is not."""
    from types import SimpleNamespace

    from tests.robustness.harness import Attempt, Case, run_case
    shared = SimpleNamespace(root=tmp_path / "shared")
    shared.root.mkdir()

    def writes(declared: bool):
        def prepare(s, d):
            kept = d / "theirs.csv"
            kept.write_text("the user's recording")
            return Attempt(call=lambda: kept.write_text("overwritten") and None,
                           check=lambda _: (True, "done"),
                           outputs=(str(kept),) if declared else ())
        return prepare

    lost = run_case(Case("api", "overwrites", "HANDLED", writes(False)), shared,
                    tmp_path / "cases" / "000")
    assert lost.verdict == "LOSS" and "theirs.csv" in lost.detail
    asked = run_case(Case("api", "writes its output", "HANDLED", writes(True)), shared,
                     tmp_path / "cases" / "001")
    assert asked.verdict == "HANDLED"
