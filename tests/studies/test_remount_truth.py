"""The re-mount study's truth (studies/remount.py, docs/ati_free.md section 3): each re-mount's
per-mount values are compared with the re-mounted bench's own, ``default_bench_truth`` of
``Remount.draw(k).apply(InstrumentParams())``, and the committed JSONs carry exactly that."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from studies.remount import (NEAR_ZERO, TRUTH_MAPPING, against_truth,  # noqa: E402
                             per_mount_truth)
from psmforce.experiments.prior_recovery import default_bench_truth  # noqa: E402
from psmforce.identification.prior_remount import MOUNT_ANGLES, PER_MOUNT  # noqa: E402
from psmforce.sim.mounting import Remount  # noqa: E402
from psmforce.sim.params import InstrumentParams  # noqa: E402

JSONS = [ROOT / "results" / "benchmarks" / f for f in ("remount.json", "remount_fresh.json")]


def _remounted(seed: int) -> InstrumentParams:
    return Remount.draw(seed).apply(InstrumentParams())


def test_the_truth_is_the_remounted_benchs_own_values():
    tool = _remounted(1)
    truth = per_mount_truth(tool)
    assert list(truth) == list(PER_MOUNT) + list(MOUNT_ANGLES) == list(TRUTH_MAPPING)
    bench = default_bench_truth(tool)
    assert all(truth[n] == bench[n] for n in PER_MOUNT)
    # re-mount 1 moves the pretension by its drawn change, the offsets by theirs
    change = Remount.draw(1)
    assert truth["pretension_total"] == pytest.approx(6.0 + change.pretension_change_n)
    assert [truth[f"bias_f{a}"] for a in "xyz"] == pytest.approx(
        [b + d for b, d in zip(InstrumentParams().hex10_residual_bias_n,
                               change.hex10_offset_change_n)])
    assert [truth[n] for n in MOUNT_ANGLES] == pytest.approx(list(change.rotation_change_rad))
    assert truth["bias_tx"] == truth["bias_ty"] == truth["bias_tz"] == 0.0


def test_errors_are_relative_for_the_pretension_absolute_near_zero():
    truth = {"pretension_total": 6.8, "bias_fx": 0.05, "bias_tx": 0.0}
    before = {"pretension_total": 6.0, "bias_fx": 0.0, "bias_tx": 0.0}
    after = {"pretension_total": 7.6, "bias_fx": 0.08, "bias_tx": 0.001}
    rows = against_truth(before, after, truth, ["pretension_total", "bias_fx"])
    p, fx, tx = rows["pretension_total"], rows["bias_fx"], rows["bias_tx"]
    assert p["compare_by"] == "relative error" and p["error"] == pytest.approx(0.8)
    assert p["relative_error"] == pytest.approx(0.8 / 6.8) and p["within_tolerance"] is False
    assert p["relative_error_before"] == pytest.approx(0.8 / 6.8)
    assert against_truth(before, {**after, "pretension_total": 7.2}, truth, [])[
        "pretension_total"]["within_tolerance"] is True
    assert fx["compare_by"] == "error" and fx["error"] == pytest.approx(0.03)
    assert "within_tolerance" not in fx and fx["re_estimated"] and not tx["re_estimated"]
    assert tx["relative_error"] is None and tx["error"] == pytest.approx(0.001)
    assert set(NEAR_ZERO) == set(PER_MOUNT[1:]) | set(MOUNT_ANGLES)


@pytest.mark.parametrize("path", JSONS, ids=lambda p: p.name)
def test_the_committed_runs_record_that_truth_and_the_fits_against_it(path):
    result = json.loads(path.read_text())
    assert result["truth_mapping"] == TRUTH_MAPPING and "default_bench_truth" in result["truth"]
    assert result["truth_before_remount"] == pytest.approx(per_mount_truth(InstrumentParams()))
    for run in result["runs"]:
        truth = per_mount_truth(_remounted(run["remount_seed"]))
        assert run["truth"] == pytest.approx(truth)
        for mode in run["modes"].values():
            for variant, rec in mode["recalibrations"].items():
                rows = rec["against_truth"]
                assert {n: r["truth"] for n, r in rows.items()} == pytest.approx(truth)
                assert {n: r["recalibrated"] for n, r in rows.items()} == rec["fit"]["after"]
                assert {n: r["before"] for n, r in rows.items()} == rec["fit"]["before"]
                assert {n for n, r in rows.items() if r["re_estimated"]} == set(
                    rec["fit"]["re_estimated"])
    for mode, summary in result["summary"].items():
        for variant in result["variants"]:
            counted = summary[variant]["pretension_against_truth"]
            within = [r["remount_seed"] for r in result["runs"] if r["modes"][mode][
                "recalibrations"][variant]["against_truth"]["pretension_total"]["within_tolerance"]]
            assert counted["within"] == within
