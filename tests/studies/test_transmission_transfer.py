"""The transfer study's rules: which 60 s a lab records, and the verdict per folder."""

from __future__ import annotations

from types import SimpleNamespace

from studies.transmission_transfer import GOAL_RATIO, calibration_files, verdicts


def _rec(stop, freq, load):
    return SimpleNamespace(stop_index=stop, frequency_index=freq, load_index=load)


def test_the_calibration_spans_the_load_range_at_distinct_stopping_positions():
    folder = [_rec(z, 0, y) for z in range(5) for y in range(4)]
    chosen = calibration_files(folder)
    assert [r.load_index for r in chosen] == [0, 2, 3]
    assert len({r.stop_index for r in chosen}) == 3
    flat = [_rec(None, x, y) for x in range(5) for y in range(4)]
    assert [r.load_index for r in calibration_files(flat)] == [0, 2, 3]


def _folder(recal, in_session, constant):
    def score(v):
        return {"whole": {"torque_rmse_mNm": v}, "closing": {"torque_rmse_mNm": v}}
    return {"recalibrated": score(recal), "in_session": score(in_session),
            "constant_calibration_mean": score(constant)}


def test_the_verdict_names_a_miss_and_a_loss_to_the_constant():
    v = verdicts({"ok": _folder(6.0, 5.0, 14.0), "far": _folder(8.0, 5.0, 14.0),
                  "worse": _folder(20.0, 15.0, 18.0), "source": {"in_session": {}}})
    assert v["ok"]["whole"] == {"ratio": 1.2, "within_goal": True, "beats_constant": True}
    assert v["far"]["whole"]["ratio"] > GOAL_RATIO and not v["far"]["whole"]["within_goal"]
    assert not v["worse"]["closing"]["beats_constant"]
    assert "source" not in v


def test_the_pitch_wrap_term_is_declared_off_unless_switched_on():
    from studies.transmission_transfer import DECLARED_FIXED, declared_fixed
    assert declared_fixed(None) == DECLARED_FIXED
    assert DECLARED_FIXED["capstan_mu_pitch"] == DECLARED_FIXED["capstan_mu_abs_pitch"] == 0.0
    for wrap, name in (("antagonistic", "capstan_mu_pitch"),
                       ("symmetric", "capstan_mu_abs_pitch")):
        assert set(declared_fixed(wrap)) == set(DECLARED_FIXED) - {name}


def test_reused_records_come_only_from_a_matching_run(tmp_path):
    import json

    import pytest

    from studies.transmission_transfer_learned import (INPUTS, MODELS, _finetune_settings,
                                                       reused_records)
    records = [{"model": m, "seed": 1} for m in MODELS]
    records += [{"model": "hybrid_physics_recalibrated_only", "seed": 1},
                {"model": "hybrid_selected", "seed": 1}]
    run = {"inputs": list(INPUTS), "seeds": [1], "finetune": _finetune_settings(),
           "models": list(MODELS), "records": records}
    path = tmp_path / "old.json"
    path.write_text(json.dumps(run))
    kept, taken = reused_records(path, ["hybrid"], [1])
    assert taken == [m for m in MODELS if m != "hybrid"]
    assert {r["model"] for r in kept} == set(taken)      # the hybrid's rows are all rerun
    kept, taken = reused_records(path, [m for m in MODELS if m != "hybrid"], [1])
    assert taken == ["hybrid"]                           # with its physics-only rows
    assert {r["model"] for r in kept} == {"hybrid", "hybrid_physics_recalibrated_only",
                                          "hybrid_selected"}
    with pytest.raises(ValueError, match="seeds"):
        reused_records(path, ["hybrid"], [1, 2])
    path.write_text(json.dumps({**run, "finetune": {**run["finetune"], "time_limit_s": 1.0}}))
    with pytest.raises(ValueError, match="finetune"):
        reused_records(path, ["hybrid"], [1])
    path.write_text(json.dumps({**run, "models": ["hybrid", "fcn"]}))
    with pytest.raises(ValueError, match="no records of lstm"):
        reused_records(path, ["hybrid"], [1])
    path.write_text("{not json")
    with pytest.raises(ValueError, match="not a readable JSON"):
        reused_records(path, ["hybrid"], [1])


def test_the_recalibration_keeps_the_residual_only_where_its_validation_loss_is_lower():
    from studies.transmission_transfer_learned import selected

    network = {"model": "hybrid", "seed": 3, "folder": "f", "protocol": "recalibrated",
               "metrics": {"whole": {"torque_rmse_mNm": 7.0}}, "fit": {"best_val_loss": 0.2}}
    physics_alone = {"whole": {"torque_rmse_mNm": 5.0}}
    off = selected(network, physics_alone, physics_val_loss=0.1)
    assert off["selection"]["kept"] == "physics alone" and off["metrics"] is physics_alone
    assert (off["model"], off["seed"], off["folder"]) == ("hybrid_selected", 3, "f")
    on = selected(network, physics_alone, physics_val_loss=0.3)
    assert on["selection"]["kept"] == "residual network"
    assert on["metrics"] == network["metrics"]
    assert on["selection"]["network_val_loss"] == 0.2
