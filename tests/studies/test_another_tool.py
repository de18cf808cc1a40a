"""Another tool (issue 13, item 4): the bench's instrument drawn per tool, and the few-shot
calibration of a trained model to it (psmforce/estimators/training/calibrate.py, ``psmforce calibrate``)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import torch

from psmforce.estimators.training.calibrate import (MIN_FREE_TRIALS, MIN_TRACTION_TRIALS,
                                                    CalibrationError, calibrate)
from psmforce.estimators.training.checkpoint import load_checkpoint
from psmforce.estimators.data.dataset import DatasetError, load_dataset
from psmforce.estimators.evaluation.evaluate import evaluate
from psmforce.estimators.data.hybrid_inputs import prior_from_json
from psmforce.estimators.evaluation.metrics import AXES
from psmforce.estimators.training.train import TrainConfig, train
from psmforce.io.recording import HEX10, TARGETS
from psmforce.sim import InstrumentParams, SimulationConfigError, simulate
from psmforce.cli.main import main

torch.set_num_threads(1)
CHEAP = TrainConfig(progress=False, max_batches_per_epoch=2, max_val_batches=2)
"""Smoke settings: these tests check the mechanics, not how well anything converges."""


def _files(root):
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*.csv"))}


# ------------------------------------------------------------------ the tool on the bench

@pytest.mark.slow
def test_tool_sample_is_recorded_reproducible_and_default_unchanged(tmp_path):
    simulate("automated", scale=0.01, seed=2, out=tmp_path / "a", tool_seed=4, tool_spread=2.0)
    assert main(["simulate", "--scale", "0.01", "--seed", "2", "--tool-seed", "4",
                 "--tool-spread", "2", "--out", str(tmp_path / "b")]) == 0
    simulate("automated", scale=0.01, seed=2, out=tmp_path / "nominal")
    meta = json.loads((tmp_path / "a" / "metadata.json").read_text())
    assert meta["tool"]["seed"] == 4 and meta["tool"]["spread"] == 2.0
    assert meta["instrument"] == InstrumentParams().sample(4, 2.0).to_dict()
    nominal = json.loads((tmp_path / "nominal" / "metadata.json").read_text())
    assert "tool" not in nominal and nominal["instrument"] == InstrumentParams().to_dict()
    assert _files(tmp_path / "a") == _files(tmp_path / "b")          # CLI = API, bit-exact
    drawn, nom = _files(tmp_path / "a"), _files(tmp_path / "nominal")
    assert drawn.keys() == nom.keys()                                 # same protocol ...
    assert all(drawn[k] != nom[k] for k in drawn)                     # ... another instrument


@pytest.mark.parametrize("kwargs, message", [({"tool_seed": -1}, "tool_seed"),
                                             ({"tool_seed": 1.5}, "tool_seed"),
                                             ({"tool_seed": 1, "tool_spread": math.nan},
                                              "tool_spread"),
                                             ({"tool_seed": 1, "tool_spread": -0.5},
                                              "tool_spread")])
def test_bad_tool_options_fail_before_writing(tmp_path, kwargs, message):
    with pytest.raises(SimulationConfigError, match=message):
        simulate("automated", scale=0.01, out=tmp_path / "x", **kwargs)
    assert not (tmp_path / "x").exists()


def test_tool_spread_without_tool_seed_is_refused(tmp_path, capsys):
    assert main(["simulate", "--scale", "0.01", "--tool-spread", "2",
                 "--out", str(tmp_path / "x")]) == 2
    assert "--tool-spread" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


# ------------------------------------------------------------------ calibration

@pytest.fixture(scope="module")
def benches(tmp_path_factory):
    """A nominal bench with a smoke-trained hybrid and FCN, and a bench of another tool (2x the
    nominal spread)."""
    root = tmp_path_factory.mktemp("another_tool")
    simulate("automated", scale=0.01, seed=1, out=root / "nominal")
    simulate("automated", scale=0.02, seed=2, out=root / "tool", tool_seed=3, tool_spread=2.0)
    for model in ("hybrid", "fcn"):
        train(root / "nominal", model, root / f"{model}.pt", epochs=1, train_config=CHEAP)
    return root


def _lateral_base_error(prior, trials) -> float:
    """Mean square (N^2, fx and fy) of HEX10 force - prior - ATI force: the error of the
    hybrid's lateral base (the compensated HEX10), on trials the prior was not fitted on. (Its
    fz is no base: the hybrid's axial base is the insertion effort.)"""
    err = np.concatenate([t.matrix(HEX10, np.float64)[:, :2] - prior.predict(t.frame)[:, :2]
                          - t.matrix(TARGETS, np.float64)[:, :2] for t in trials])
    return float(np.mean(err ** 2))


@pytest.mark.slow
def test_calibrate_refits_the_prior_and_names_its_trials(benches, tmp_path):
    out = tmp_path / "cal.pt"
    summary = calibrate(benches / "hybrid.pt", benches / "tool", out, minutes=1.0, epochs=1,
                        train_config=CHEAP)
    old, new = load_checkpoint(benches / "hybrid.pt"), load_checkpoint(out)
    record = new.provenance["calibration"]
    assert record == summary["calibration"]
    assert new.provenance["calibrated_from"] == str(benches / "hybrid.pt")
    assert record["tool"]["seed"] == 3 and record["tool"]["spread"] == 2.0
    tool = load_dataset(benches / "tool")
    train_paths = {t.path: t.condition for t in tool.select(split="train")}
    paths = [t["path"] for t in record["trials"]]
    assert paths and all(train_paths[p] in ("Free", "Traction") for p in paths)
    assert {t["role"] for t in record["trials"]} == {"train", "validation"}
    assert sum(t["condition"] == "Free" for t in record["trials"]) >= MIN_FREE_TRIALS
    assert sum(t["condition"] == "Traction" for t in record["trials"]) >= MIN_TRACTION_TRIALS
    assert 0 < record["minutes_used"] <= 1.0 and record["minutes_requested"] == 1.0
    assert record["prior_refit"]["refitted_on"] == [t["path"] for t in record["trials"]
                                                    if t["role"] == "train"]
    # the refitted prior compensates the new tool's internal force better on its test trials
    # (8 of 8 tools drawn at 1x and 2x spread did so when this test was written)
    test = tool.select(split="test")
    old_prior, new_prior = prior_from_json(old.prior_json), prior_from_json(new.prior_json)
    assert _lateral_base_error(new_prior, test) < 0.8 * _lateral_base_error(old_prior, test)
    assert new_prior.insertion.to_dict() == old_prior.insertion.to_dict()   # the arm's, kept
    # only the last block moved, and the checkpoint serves the new tool's data
    changed = {k for k, v in new.model.state_dict().items()
               if not torch.equal(v, old.model.state_dict()[k])}
    assert changed and changed <= {k for m in new.model.finetune_modules()
                                   for k in _names(new.model, m)}
    metrics = evaluate(out, benches / "tool", tmp_path / "eval", plots=False)
    assert all(np.isfinite(metrics["overall"][a]["nrmse_pct"]) for a in AXES)


def _names(model, module) -> set[str]:
    ids = {id(p) for p in module.parameters()}
    return {k for k, p in model.named_parameters() if id(p) in ids}


@pytest.mark.slow
def test_calibrate_a_baseline_finetunes_its_last_block_only(benches, tmp_path):
    out = tmp_path / "fcn_cal.pt"
    calibrate(benches / "fcn.pt", benches / "tool", out, minutes=1.0, epochs=1,
              train_config=CHEAP)
    ckpt = load_checkpoint(out)
    record = ckpt.provenance["calibration"]
    assert record["prior_refit"] is None and not ckpt.prior_json
    assert 0 < record["trainable_parameters"] < sum(p.numel() for p in ckpt.model.parameters())


@pytest.mark.slow
def test_calibration_is_deterministic(benches):
    tool = load_dataset(benches / "tool")
    from psmforce.estimators.training.calibrate import calibration_trials
    first = [t.path for t in calibration_trials(tool, 1.0)]
    assert first == [t.path for t in calibration_trials(load_dataset(benches / "tool"), 1.0)]
    assert first[0].startswith("train/Free/")       # free space first, then interleaved
    longer = [t.path for t in calibration_trials(tool, 1.2)]
    assert longer[:len(first)] == first              # more minutes extend the same order


@pytest.mark.slow
def test_calibrate_bad_inputs_are_refused_naming_the_problem(benches, tmp_path, capsys):
    out = tmp_path / "cal.pt"
    with pytest.raises(DatasetError, match="does not exist"):
        calibrate(benches / "hybrid.pt", tmp_path / "missing", out)
    with pytest.raises(CalibrationError, match="too few minutes.*--minutes"):
        calibrate(benches / "hybrid.pt", benches / "tool", out, minutes=0.05)
    with pytest.raises(CalibrationError, match="asked for 500 min"):
        calibrate(benches / "hybrid.pt", benches / "tool", out, minutes=500)
    with pytest.raises(CalibrationError, match="minutes"):
        calibrate(benches / "hybrid.pt", benches / "tool", out, minutes=math.nan)
    # a dataset without free-space recordings cannot refit the prior
    meta = json.loads((benches / "tool" / "metadata.json").read_text())
    meta["trials"] = [t for t in meta["trials"] if t["condition"] != "Free"]
    no_free = tmp_path / "no_free"
    no_free.mkdir()
    for t in meta["trials"]:
        target = no_free / t["path"]
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes((benches / "tool" / t["path"]).read_bytes())
    (no_free / "metadata.json").write_text(json.dumps(meta))
    with pytest.raises(CalibrationError, match="no free-space trials"):
        calibrate(benches / "hybrid.pt", no_free, out)
    assert main(["calibrate", str(benches / "hybrid.pt"), "--data", str(benches / "tool"),
                 "--out", str(out), "--minutes", "0.05"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("psmforce calibrate: error: too few minutes")
    assert not out.exists()


def _free_dataset(root, forces_n=(0.0, 0.0, 0.0), n: int = 3000):
    import pandas as pd
    from psmforce.estimators.data.dataset import Dataset, Trial
    trials = []
    for k, force in enumerate(forces_n):
        frame = pd.DataFrame({"time": np.arange(n) / 100.0, **{c: np.full(n, force)
                                                               for c in TARGETS}})
        trials.append(Trial(f"Free/f{k}.csv", "Free", "train", frame))
    trials.append(Trial("Traction/t.csv", "Traction", "train", trials[0].frame.copy()))
    return Dataset(root, trials, {})


def test_free_space_trials_take_free_recordings_and_declare_zero_force(tmp_path):
    from psmforce.estimators.training.calibrate import free_space_trials
    chosen = free_space_trials(_free_dataset(tmp_path, (0.1, 0.2, 0.3)), minutes=1.0)
    assert [t.path for t in chosen] == ["Free/f0.csv", "Free/f1.csv"]   # 0.5 min each
    assert all(float(np.abs(t.matrix(TARGETS)).max()) == 0.0 for t in chosen)


def test_free_space_calibration_refuses_a_contact_and_too_few_minutes(tmp_path):
    from psmforce.estimators.training.calibrate import free_space_trials
    with pytest.raises(CalibrationError, match=r"f1.csv: declared free space, but its ATI reads "
                                               r"2.00 N"):
        free_space_trials(_free_dataset(tmp_path, (0.0, 2.0, 0.0)), minutes=1.0)
    with pytest.raises(CalibrationError, match=r"hold 1 free-space recordings .* give "
                                               r"--minutes 1"):
        free_space_trials(_free_dataset(tmp_path), minutes=0.6)


@pytest.mark.slow
def test_calibrate_without_an_ati_refits_the_prior_on_free_space(benches, tmp_path):
    out = tmp_path / "free.pt"
    summary = calibrate(benches / "hybrid.pt", benches / "tool", out, minutes=30.0, epochs=1,
                        train_config=CHEAP, free_space=True)
    record = summary["calibration"]
    assert record["reference"].startswith("none") and record["rule"].startswith("train split, "
                                                                                 "condition Free")
    assert {t["condition"] for t in record["trials"]} == {"Free"}
    assert {t["role"] for t in record["trials"]} == {"train", "validation"}
    assert record["prior_refit"]["refitted_on"]
    old, new = load_checkpoint(benches / "hybrid.pt"), load_checkpoint(out)
    assert new.prior_json != old.prior_json


@pytest.mark.slow
def test_a_per_mount_refit_moves_only_the_pretension_and_force_offsets(benches, tmp_path):
    """prior_refit="per_mount" (docs/ati_free.md section 3): the checkpoint's prior with only
    FORCE_PER_MOUNT re-estimated on the free-space recordings; refused with an ATI."""
    from psmforce.identification.prior_law import NAMES
    from psmforce.identification.prior_remount import FORCE_PER_MOUNT
    out = tmp_path / "mount.pt"
    summary = calibrate(benches / "hybrid.pt", benches / "tool", out, minutes=30.0, epochs=1,
                        train_config=CHEAP, free_space=True, prior_refit="per_mount")
    refit = summary["calibration"]["prior_refit"]
    assert refit["refit"] == "per_mount"
    assert set(refit["held_from_checkpoint"]) == set(NAMES) - set(FORCE_PER_MOUNT)
    old, new = load_checkpoint(benches / "hybrid.pt").prior(), load_checkpoint(out).prior()
    moved = {n for n, a, b in zip(NAMES, old.params, new.params) if a != b}
    assert moved and moved <= set(FORCE_PER_MOUNT)
    with pytest.raises(CalibrationError,
                       match="'per_mount' and 'identified' only without an ATI"):
        calibrate(benches / "hybrid.pt", benches / "tool", tmp_path / "x.pt",
                  prior_refit="per_mount")


@pytest.mark.slow
def test_an_identified_refit_holds_what_the_load_path_identified(benches, tmp_path,
                                                                  monkeypatch):
    """prior_refit="identified" (docs/ati_free.md section 4.3): each parameter the instrument's
    identification through the load path identified, or estimated (its design value rejected,
    ``hold_rule="unresolved"``), is held at its value in the estimator's prior, the sensor's
    offsets excepted (this mount's, refitted); the rest is refitted as "all" does. Refused
    without known loads. With ``network_off="carried"`` the lateral axis whose cross-talk was
    carried is answered by the prior alone (docs/ati_free.md section 4.5); with
    ``finetune=False`` the same prior under the network as trained. The identification
    itself is tests/estimators/test_ati_free.py's; here it is replaced by a report with known
    values."""
    from psmforce.cli.excitation import weight_poses
    from psmforce.estimators.training import calibrate as calibration
    from psmforce.identification.prior_law import NAMES
    from psmforce.sim.ati_free import FREE_SPACE, KNOWN_LOADS, simulate_ati_free
    simulate_ati_free(tmp_path / "g", seed=3, scale=0.01, free_minutes=0.3,
                      weight_poses=weight_poses(), masses_kg=(0.1,), hold_s=2.0, tool_seed=3,
                      tool_spread=2.0)
    identified = {"pretension_total": 7.5, "pulley_radius_pitch": 1.8e-3, "bias_fx": 0.2,
                  "crosstalk_fy": 0.004}
    old = load_checkpoint(benches / "hybrid.pt").prior()
    estimated = {"pulley_radius_blade": {"value": 1.6e-3, "uncertainty": 3e-4}}
    report = {"parameters": dict(zip(NAMES, old.params.tolist())) | identified
              | {"pulley_radius_blade": 1.6e-3},
              "identified": list(identified), "estimated": estimated, "fixed": {},
              "at_bound": [], "verdict": "test",
              "converged": True, "reading": "load path"}
    monkeypatch.setattr(calibration, "identify_instrument", lambda *a, **k: None)
    monkeypatch.setattr(calibration, "instrument_report", lambda prior: report)
    out = tmp_path / "identified.pt"
    summary = calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, out, minutes=0.3,
                        epochs=1, train_config=CHEAP, free_space=True,
                        known_loads=tmp_path / "g" / KNOWN_LOADS, prior_refit="identified",
                        network_off="carried")
    refit = summary["calibration"]["prior_refit"]
    carried = {"pretension_total": 7.5, "pulley_radius_pitch": 1.8e-3,
               "pulley_radius_blade": 1.6e-3, "crosstalk_fy": 0.004}
    assert refit["refit"] == "identified" and refit["held_at_identified"] == carried
    assert set(refit["held_from_checkpoint"]).isdisjoint(carried)
    new = dict(zip(NAMES, load_checkpoint(out).prior().params.tolist()))
    assert {n: new[n] for n in carried} == carried
    assert new["bias_fx"] != 0.2                       # an offset is refitted, not carried
    # crosstalk_fy carried, crosstalk_fx not: the prior alone answers Fy, the hybrid Fx and Fz
    record = load_checkpoint(out)
    assert record.physics_only_axes == ("Fy",)
    assert summary["calibration"]["physics_only_axes"] == {
        "axes": ["Fy"], "rule": "carried",
        "why": {"Fy": "crosstalk_fy held at its identified value in the prior"}}
    from psmforce.estimators.data.dataset import Dataset
    from psmforce.estimators.evaluation.evaluate import predict_trial
    tool = load_dataset(benches / "tool")
    record.derive(Dataset(tool.root, tool.select(split="test")[:1], tool.metadata))
    trial = tool.select(split="test")[0]
    estimate = predict_trial(record, trial)
    np.testing.assert_allclose(estimate[:, 1], trial.frame[record.base_columns[1]], atol=1e-9)
    assert not np.allclose(estimate[:, 0], trial.frame[record.base_columns[0]], atol=1e-3)
    # without finetuning: the same refit of the prior, the source network unchanged
    kept = tmp_path / "kept.pt"
    plain = calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, kept, minutes=0.3,
                      epochs=1, train_config=CHEAP, free_space=True,
                      known_loads=tmp_path / "g" / KNOWN_LOADS, prior_refit="identified",
                      network_off=("Fx", "Fy"), finetune=False)
    assert plain["calibration"]["finetuned"] is False and plain["epochs_run"] == 0
    unfinetuned, source = load_checkpoint(kept), load_checkpoint(benches / "hybrid.pt")
    assert np.array_equal(unfinetuned.prior().params, record.prior().params)
    assert unfinetuned.physics_only_axes == ("Fx", "Fy")
    assert all(torch.equal(a, b) for a, b in zip(unfinetuned.model.state_dict().values(),
                                                 source.model.state_dict().values()))
    assert not all(torch.equal(a, b) for a, b in zip(record.model.state_dict().values(),
                                                     source.model.state_dict().values()))
    # the network reading the prior it was trained with: the refit is the physics axes' own
    own = tmp_path / "own.pt"
    trained = calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, own, minutes=0.3,
                        epochs=1, train_config=CHEAP, free_space=True,
                        known_loads=tmp_path / "g" / KNOWN_LOADS, prior_refit="identified",
                        network_off=("Fx", "Fy"), finetune=False, network_prior="trained")
    assert trained["calibration"]["network_prior"] == "trained"
    assert plain["calibration"]["network_prior"] == "calibrated"
    both = load_checkpoint(own)
    assert both.prior_json == source.prior_json
    assert np.array_equal(both.physics_prior().params, record.prior().params)
    assert both.physics_only_axes == ("Fx", "Fy")
    assert all(torch.equal(a, b) for a, b in zip(both.model.state_dict().values(),
                                                 source.model.state_dict().values()))
    from studies.ati_free import _network_prior   # the study's row is what the command writes
    rebuilt = load_checkpoint(_network_prior(benches / "hybrid.pt", kept, tmp_path / "np.pt"))
    assert (rebuilt.prior_json, rebuilt.physics_only_axes) == (both.prior_json,
                                                                both.physics_only_axes)
    assert np.array_equal(rebuilt.physics_prior().params, both.physics_prior().params)

    def estimate(checkpoint):   # the trial's derived columns are each checkpoint's own
        checkpoint.derive(Dataset(tool.root, [trial], tool.metadata))
        return predict_trial(checkpoint, trial)
    with_own = estimate(both)
    np.testing.assert_allclose(with_own[:, :2], estimate(unfinetuned)[:, :2],
                               atol=1e-9)   # the same refitted prior's base laterally
    np.testing.assert_allclose(with_own[:, 2], estimate(source)[:, 2], atol=1e-9)
    assert not np.allclose(with_own[:, 2], estimate(unfinetuned)[:, 2], atol=1e-6)  # its inputs
    with pytest.raises(CalibrationError, match="'trained' needs network_off axes"):
        calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, network_prior="trained")
    with pytest.raises(CalibrationError, match="'trained': .*fcn.pt holds a 'fcn' model "
                                               "without a prior"):
        calibrate(benches / "fcn.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, network_off=("Fx",), network_prior="trained")
    with pytest.raises(CalibrationError, match="network_prior must be one of"):
        calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, network_off=("Fx",), network_prior="source")
    with pytest.raises(CalibrationError, match="without a prior, so nothing would be"):
        calibrate(benches / "fcn.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, finetune=False)
    with pytest.raises(CalibrationError, match="finetune must be True or False"):
        calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, finetune="no")
    with pytest.raises(CalibrationError, match="network_off: .*needs a residual model"):
        calibrate(benches / "fcn.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, known_loads=tmp_path / "g" / KNOWN_LOADS,
                  prior_refit="identified", network_off="carried")
    assert not (tmp_path / "x.pt").exists()
    with pytest.raises(CalibrationError, match="clenched_lateral: only with known_loads or "
                                               "prior_refit='identified'"):
        calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, clenched_lateral=True)
    with pytest.raises(CalibrationError, match="clenched_lateral must be True or False"):
        calibrate(benches / "hybrid.pt", tmp_path / "g" / FREE_SPACE, tmp_path / "x.pt",
                  free_space=True, prior_refit="identified", clenched_lateral="yes")

