"""studies/hybrid_calibrated_design.py: it chooses, so it refuses a seed a claim rests on, and its
variants change one thing each against the comparison's hybrid."""

import pytest

from studies import hybrid_calibrated_design as study
from psmforce.experiments.seeds import COMPARISON_SEEDS


def test_a_fresh_seed_is_refused_before_anything_is_simulated(tmp_path, capsys):
    seed = COMPARISON_SEEDS[0.1][0]
    rc = study.main(["--seed", str(seed), "--work", str(tmp_path / "w"),
                     "--json", str(tmp_path / "out.json")])
    assert rc == 2 and "not a design seed" in capsys.readouterr().err
    assert not (tmp_path / "w").exists() and not (tmp_path / "out.json").exists()


def test_each_hybrid_variant_changes_one_thing_from_the_default():
    assert study.VARIANTS["default"] == study.Variant() and study.Variant().changes() == []
    for name, variant in study.VARIANTS.items():
        if name not in study.REFERENCES and name != "default":
            assert variant.model == "hybrid" and len(variant.changes()) == 1, name
    assert study.VARIANTS["transformer"].changes() == ["model"]
    assert study.VARIANTS["paper_task"].changes() == ["use_prior", "lateral_base", "axial_base"]
    assert study.Variant(config={"d_model": 8}, regime="paper").changes() == ["config", "regime"]
    assert set(study.LABELS) == set(study.VARIANTS)


def _variant(fx: float) -> dict:
    return {"parameters": 100, "epochs": 3, "stopped_by": "patience",
            "validation_causal_nrmse_pct": {"Fx": fx, "Fy": 2.0, "Fz": 3.0},
            "validation_causal_rmse_n_by_condition": {"Free": {"Fx": 0.01, "Fy": 0.02, "Fz": 0.03}},
            "test_causal_nrmse_pct": {"Fx": 1.0, "Fy": 1.0, "Fz": 1.0}}


def test_the_table_lists_the_variants_in_their_declared_order_with_their_figures():
    result = {"points": {"p": {"version": "2.3", "scale": 0.1, "seed": 1, "variants": {
        "transformer": _variant(1.25), "default": _variant(1.75)}}}}
    text = study.table(result)
    rows = [line for line in text.splitlines() if line.startswith("| hybrid") or
            line.startswith("| paper")]
    assert rows[0].startswith("| hybrid (as compared) | 100 | 3 (patience) | 1.75 |")
    assert rows[1].startswith("| paper transformer (reference) |") and "| 1.25 |" in rows[1]
    assert "0.010 / 0.020 / 0.030" in rows[0] and "design seed 1" in text
    assert "Trials" not in text                      # a record without its counts shows none
    result["points"]["p"]["variants"]["default"]["trials"] = {
        "validation": {"Free": 2, "Palpation": 2}, "test": {"Palpation": 18}}
    assert "Trials (per condition): validation Free 2, Palpation 2; test Palpation 18." \
        in study.table(result)
    assert study.table({}).strip() == "No point yet."


def _nrmse(fx, fy, fz) -> dict:
    return {"validation_causal_nrmse_pct": {"Fx": fx, "Fy": fy, "Fz": fz}}


def _point(seed, **variants) -> dict:
    return {"version": "2.3", "scale": 0.1, "seed": seed, "variants": variants}


def test_the_rule_carries_a_variant_only_if_it_lowers_both_lateral_axes_on_every_seed():
    default = _nrmse(2.0, 2.0, 2.0)
    result = {"points": {
        "a": _point(1, default=default, paper_width=_nrmse(1.8, 1.9, 2.0),
                    paper_regime=_nrmse(1.8, 1.9, 2.0), transformer=_nrmse(1.0, 1.0, 1.0),
                    paper_task=_nrmse(1.0, 1.0, 1.0)),
        "b": _point(2, default=default, paper_width=_nrmse(1.9, 1.9, 2.09),
                    paper_regime=_nrmse(1.9, 2.01, 1.0), prior_crosstalk=_nrmse(1.9, 1.9, 2.11))}}
    verdicts = study.carried(result)
    # Fz up 4.5 % against lateral drops of 5 %: within the rule; Fy up on seed 2: dropped
    assert verdicts == {"paper_width": [1, 2], "paper_regime": [], "prior_crosstalk": []}
    assert "transformer" not in verdicts and "paper_task" not in verdicts  # references
    result["points"]["b"]["variants"]["paper_width"] = _nrmse(1.9, 1.9, 2.2)  # Fz up 10 %
    assert study.carried(result)["paper_width"] == []
    assert study.carried({"points": {"a": _point(1, paper_width=default)}}) == {}


def test_a_record_read_back_is_checked_and_names_its_file(tmp_path):
    import json

    import pytest
    folder = tmp_path / "seed1_scale0.1" / "variants"
    folder.mkdir(parents=True)
    good = {**_variant(1.5), "parameters": 10}
    (folder / "default.json").write_text(json.dumps(good))
    assert study.assemble(tmp_path, tmp_path / "out.json")["points"]["2.3 scale 0.1 seed 1"][
        "variants"]["default"] == good
    (folder / "paper_width.json").write_text('{"parameters": 10')           # cut short
    with pytest.raises(ValueError, match=r"paper_width.json: not JSON"):
        study.assemble(tmp_path, tmp_path / "out.json")
    (folder / "paper_width.json").write_text('{"parameters": 10}')
    with pytest.raises(ValueError, match=r"paper_width.json: lacks epochs"):
        study.assemble(tmp_path, tmp_path / "out.json")
    (folder / "paper_width.json").unlink()
    (folder / "wider.json").write_text(json.dumps(good))
    with pytest.raises(ValueError, match=r"wider.json: not a training of this study"):
        study.assemble(tmp_path, tmp_path / "out.json")


def test_records_the_json_holds_survive_a_fresh_work_folder(tmp_path):
    """A run on a new machine (no ``runs/``) adds to the committed JSON instead of replacing
    it."""
    import json
    folder = tmp_path / "old" / "seed1_scale0.1" / "variants"
    folder.mkdir(parents=True)
    good = {**_variant(1.5), "parameters": 10}
    (folder / "default.json").write_text(json.dumps(good))
    out = tmp_path / "out.json"
    out.write_text(json.dumps(study.assemble(tmp_path / "old", out)))
    fresh = tmp_path / "new" / "seed2_scale0.1" / "variants"
    fresh.mkdir(parents=True)
    (fresh / "paper_width.json").write_text(json.dumps({**_variant(1.4), "parameters": 20}))
    points = study.assemble(tmp_path / "new", out)["points"]
    assert points["2.3 scale 0.1 seed 1"]["variants"]["default"] == good
    assert points["2.3 scale 0.1 seed 2"]["variants"]["paper_width"]["parameters"] == 20


class _Trial:
    """The little of a Trial that scoring reads: a path, a condition, the targets."""

    def __init__(self, path: str, truth):
        self.path, self.condition, self._truth = path, "Palpation", truth

    def __len__(self):
        return len(self._truth)

    def matrix(self, columns, dtype):
        return self._truth.astype(dtype)


def test_the_error_split_puts_an_offset_a_slow_wave_and_a_fast_one_where_they_belong():
    import numpy as np

    from psmforce.estimators.evaluation.evaluate import EVAL_START

    n = EVAL_START + 2000                    # 20 s at 100 Hz
    t = np.arange(n) / 100.0
    truth = np.zeros((n, 3))
    offsets = {"a": 0.3, "b": -0.3}          # one per trial: RMS 0.3 N
    slow = 0.2 * np.sqrt(2) * np.sin(2 * np.pi * 0.1 * t)   # 10 s period: RMS 0.2 N
    fast = 0.1 * np.sqrt(2) * np.sin(2 * np.pi * 10.0 * t)  # 10 Hz, whole cycles in 1 s
    trials = [_Trial(k, truth) for k in offsets]
    pred = {}
    for k, off in offsets.items():
        p = np.zeros((n, 3))
        p[:, 0] = off
        p[:, 1] = slow - slow[EVAL_START:].mean()
        p[:, 2] = fast
        pred[k] = p
    split = study.error_split(pred, trials)
    assert split["Fx"]["offset"] == pytest.approx(0.3) and split["Fx"]["fast"] < 1e-9
    assert split["Fy"]["slow"] == pytest.approx(0.2, rel=0.05) and split["Fy"]["fast"] < 0.01
    assert split["Fz"]["fast"] == pytest.approx(0.1, rel=0.01) and split["Fz"]["slow"] < 0.005
    assert split["Fy"]["offset"] < 1e-9 and split["Fz"]["offset"] < 1e-3
