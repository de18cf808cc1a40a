"""The hybrid's heteroscedastic option (issue #13, item 3): a mean and a std per axis, learned
from data whose noise varies, equal on every backend, carried by streaming and the export."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import torch

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.networks.causal import CausalTransformer
from psmforce.estimators.data.dataset import Trial
from psmforce.estimators.evaluation.evaluate import evaluate, predict_trial
from psmforce.estimators.runtime.export import ExportError, export, run_export
from psmforce.estimators.data.hybrid_inputs import hybrid_columns
from psmforce.estimators.networks.recipes import Inputs
from psmforce.estimators.runtime.steppers import (NumpyStepper, OnnxStepper, TorchStepper,
                                                  state_spec, step_onnx_bytes)
from psmforce.estimators.runtime.streaming import Flags, StreamingError, StreamingEstimator
from psmforce.estimators.training.train import (TrainConfig, TrainingError, _loss, finetune_model,
                                                make_setup, train, train_model)
from psmforce.estimators.networks.uncertainty import (LOGVAR_MAX, LOGVAR_MIN, beta_nll,
                                                      soft_clamp_logvar)
from psmforce.cli.main import main
from tests.estimators.test_recipes import data  # noqa: F401  (the small bench, a module fixture)
from tests.estimators.test_streaming import (StandInPrior, model_and_scalers, one_thread, recording)  # noqa: F401

SMALL = {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8}
NOISE_GAIN = np.array([1.0, 0.7, 0.5])
"""Noise std of each target axis per unit of the ``noise_level`` input."""


def _wide_variance_model() -> CausalTransformer:
    """An uncertainty model whose raw log-variance spans far beyond the clamp range."""
    model, _, _ = model_and_scalers(7, uncertainty=True)
    with torch.no_grad():
        model.decoder[2].weight[3:] *= 40.0
    return model


def test_the_default_network_is_unchanged_and_the_option_is_checked():
    plain, wide = CausalTransformer(7), CausalTransformer(7, uncertainty=True)
    assert not plain.predicts_variance and plain.decoder[2].out_features == 3
    assert wide.predicts_variance and wide.decoder[2].out_features == 6
    assert plain.state_dict().keys() == wide.state_dict().keys()
    with pytest.raises(ValueError, match="uncertainty must be true or false"):
        CausalTransformer(7, uncertainty="false")


def test_the_log_variance_is_clamped_smoothly():
    raw = torch.tensor([-1e9, -30.0, -3.0, 0.0, 30.0, 1e9], requires_grad=True)
    clamped = soft_clamp_logvar(raw)
    clamped.sum().backward()
    assert torch.isfinite(clamped).all() and torch.isfinite(raw.grad).all()
    assert (clamped >= LOGVAR_MIN).all() and (clamped <= LOGVAR_MAX).all()
    assert clamped[2] == -3.0 and raw.grad[2] == 1.0  # the identity at the range's middle


def test_every_backend_gives_the_same_mean_and_log_variance():
    model = _wide_variance_model()
    x = torch.randn(1, 60, 7)  # beyond the receptive field: the caches wrap
    with torch.no_grad():
        full = model(x)[0].numpy()
    assert full.shape == (60, 6) and np.isfinite(full).all()
    assert full[:, 3:].min() < LOGVAR_MIN + 1 and full[:, 3:].max() > LOGVAR_MAX - 1  # clamped
    assert np.abs(model.predict_sequence(x[0].numpy()) - full).max() < 1e-5
    onnx = OnnxStepper(step_onnx_bytes(model), state_spec(model))
    for stepper in (TorchStepper(model), NumpyStepper(model), onnx):
        steps = np.stack([stepper.step(row.numpy()).copy() for row in x[0]])
        assert np.abs(steps - full).max() < 1e-5, stepper.backend


def test_a_variance_model_is_trained_on_the_beta_nll():
    model = CausalTransformer(4, **SMALL, uncertainty=True).eval()  # no dropout: same output
    x, y = torch.randn(2, 30, 4), torch.randn(2, 30, 3)
    pred = model(x)[:, model.window:]
    expected = beta_nll(pred[..., :3], pred[..., 3:], y[:, model.window:])
    assert torch.equal(_loss(model, x, y, None), expected)
    var = torch.exp(pred[..., 3:])
    manual = torch.mean(var.detach() ** 0.5 * 0.5 * (pred[..., 3:]
                                                      + (y[:, model.window:] - pred[..., :3]) ** 2 / var))
    assert torch.allclose(expected, manual)


def _noisy_trial(seed: int, n: int = 2000) -> Trial:
    """A smooth signal and a slowly varying ``noise_level`` in [0.2, 1]; the target is linear in
    the signal plus Gaussian noise of std ``noise_level * NOISE_GAIN`` (kept as ``noise_std_*``)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    signal = sum(rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * rng.uniform(0.05, 0.5) * t
                                                 + rng.uniform(0, 2 * np.pi)) for _ in range(3))
    level = 0.6 + 0.4 * np.sin(2 * np.pi * rng.uniform(0.02, 0.1) * t + rng.uniform(0, 6))
    noise_std = level[:, None] * NOISE_GAIN
    target = signal[:, None] * [1.0, -1.0, 0.5] + noise_std * rng.standard_normal((n, 3))
    frame = pd.DataFrame({"signal": signal, "noise_level": level,
                          **{f"ati_f{a}": target[:, i] for i, a in enumerate("xyz")},
                          **{f"noise_std_{a}": noise_std[:, i] for i, a in enumerate("xyz")}})
    return Trial(f"noisy{seed}", "Traction", "train", frame)


@pytest.mark.slow
def test_the_learned_std_tracks_heteroscedastic_noise():
    trials = [_noisy_trial(k) for k in range(9)]
    fit_on, val, test = trials[:6], trials[6:8], trials[8]
    setup = make_setup("hybrid", fit_on, inputs=Inputs(("signal", "noise_level")),
                       config={**SMALL, "attention_window": 4, "n_layers": 1, "dropout": 0.0,
                               "uncertainty": True})
    cfg = TrainConfig(lr=1e-2, max_epochs=60, chunk=200, chunk_batch_size=4, progress=False)
    train_model(setup, fit_on, val, cfg)
    mean, std = predict_trial(setup, test, with_std=True)
    true_std = test.matrix([f"noise_std_{a}" for a in "xyz"], np.float64)
    error = test.matrix([f"ati_f{a}" for a in "xyz"], np.float64) - mean
    scored = slice(setup.model.window, None)  # past the warm-up, as training saw it
    for axis in range(3):
        correlation = np.corrcoef(std[scored, axis], true_std[scored, axis])[0, 1]
        within_1std = np.mean(np.abs(error[scored, axis]) <= std[scored, axis])
        print(f"axis {'xyz'[axis]}: correlation {correlation:.3f}, within 1 std "
              f"{within_1std:.3f}")
        assert correlation > 0.8 and 0.55 <= within_1std <= 0.8

    trainable = finetune_model(setup, fit_on, val, TrainConfig(**{**cfg.to_dict(),
                                                                    "max_epochs": 2}))
    assert trainable["trainable_parameters"] == sum(
        p.numel() for p in setup.model.decoder.parameters())
    assert np.isfinite(predict_trial(setup, test, with_std=True)[1]).all()


def _variance_estimator(**options) -> StreamingEstimator:
    features, base = hybrid_columns(True)
    model, xs, ys = model_and_scalers(len(features), uncertainty=True)
    return StreamingEstimator(model, features, xs, ys, base, StandInPrior(), **options)


def test_streaming_gives_the_std_of_the_raw_estimate_and_holds_it():
    frame = recording(150)
    rows = frame.to_dict("records")
    reference = _variance_estimator(post_filter="lowpass", backend="torch")
    force, std = reference.predict_recording(frame, with_std=True)
    for backend in ("torch", "numpy", "onnx"):
        est = _variance_estimator(post_filter="lowpass", backend=backend)
        out = [est.step(row) for row in rows]
        streamed = np.stack([o.std_hex10 for o in out])
        np.testing.assert_allclose(streamed, std, rtol=1e-4, err_msg=backend)
        np.testing.assert_allclose(np.stack([o.force_hex10 for o in out]), force, atol=1e-4)
    assert (std > 0).all() and not np.allclose(std, std[0])

    est = _variance_estimator()
    first = est.step({**rows[0], "fx": np.nan})
    assert first.flags & Flags.HELD and np.isnan(first.std_hex10).all()
    good = est.step(rows[0])
    held = est.step({**rows[1], "fx": np.nan})
    assert held.flags & Flags.INVALID_INPUT and held.flags & Flags.HELD
    np.testing.assert_array_equal(held.std_hex10, good.std_hex10)
    np.testing.assert_array_equal(held.force_hex10, good.force_hex10)

    features, base = hybrid_columns(True)
    plain, xs, ys = model_and_scalers(len(features))
    without = StreamingEstimator(plain, features, xs, ys, base, StandInPrior())
    assert without.step(rows[0]).std_hex10 is None
    with pytest.raises(StreamingError, match="predicts no variance"):
        without.predict_recording(frame, with_std=True)


def test_the_export_carries_the_log_variance_and_says_how_to_read_it(tmp_path):
    features, base = hybrid_columns(False)
    model, xs, ys = model_and_scalers(len(features), uncertainty=True)
    path = ck.TrainedModel("hybrid", {**SMALL, "uncertainty": True}, features, xs, ys, base,
                           model=model).save(tmp_path / "h.pt")
    summary = export(path, tmp_path / "out")
    assert summary["onnx_vs_torch_max_abs_diff"] < 1e-5
    spec = json.loads((tmp_path / "out" / "hybrid.json").read_text())
    assert spec["graph"]["y"]["shape"] == [1, 6]
    assert spec["uncertainty"]["logvar_columns"] == [3, 4, 5]
    assert any(step.startswith("std_hex10_N = exp(0.5 * y[3:6])") for step in spec["pipeline"])
    frame = recording(120)
    force, std = run_export(tmp_path / "out", frame, with_std=True)
    est = StreamingEstimator.from_checkpoint(path)
    out = [est.step(row) for row in frame.to_dict("records")]
    np.testing.assert_allclose(force, np.stack([o.force_hex10 for o in out]), atol=1e-5)
    np.testing.assert_allclose(std, np.stack([o.std_hex10 for o in out]), rtol=1e-5)

    plain, _, _ = model_and_scalers(len(features))
    plain_path = ck.TrainedModel("hybrid", SMALL, features, xs, ys, base, model=plain).save(
        tmp_path / "plain.pt")
    export(plain_path, tmp_path / "plain")
    assert json.loads((tmp_path / "plain" / "hybrid.json").read_text())["uncertainty"] is None
    with pytest.raises(ExportError, match="predicts no variance"):
        run_export(tmp_path / "plain", frame, with_std=True)


def test_the_cli_trains_a_hybrid_with_uncertainty_and_evaluate_scores_it(data, tmp_path):
    config = tmp_path / "config.json"
    config.write_text(json.dumps({**SMALL, "uncertainty": True}))
    assert main(["train", "--data", str(data), "--model", "hybrid", "--epochs", "1", "--config",
                 str(config), "--out", str(tmp_path / "h.pt")]) == 0
    assert ck.load_checkpoint(tmp_path / "h.pt").config["uncertainty"] is True
    result = evaluate(tmp_path / "h.pt", data, tmp_path / "eval", plots=False)
    block = result["uncertainty"]
    assert set(block["by_condition"]) == {"Free", "Traction"}
    for axis in block["overall"].values():
        assert axis["mean_std_n"] > 0 and 0 <= axis["within_1std"] <= axis["within_2std"] <= 1
        assert np.isfinite(axis["nll"])
    assert "**Predicted uncertainty**" in (tmp_path / "eval" / "metrics.md").read_text()


@pytest.mark.parametrize("config, reason", [
    ('{"uncertainty": "yes"}', "uncertainty must be true or false"),
    ('{"no_such_argument": 1}', "does not build a 'hybrid' model"),
    ("[1, 2]", "--config: expected a JSON object, got list"),
    ("{not json", "--config: the inline JSON is not valid"),
    ("missing.json", "--config: missing.json: cannot read the --config file")])
def test_a_bad_config_is_refused_before_training(data, tmp_path, cli_error, no_training,
                                                 config, reason):
    assert main(["train", "--data", str(data), "--model", "hybrid", "--config", config,
                 "--out", str(tmp_path / "h.pt")]) == 2
    assert reason in cli_error("train") and not (tmp_path / "h.pt").exists()


def test_only_a_model_that_predicts_variance_gives_a_std(data, tmp_path):
    with pytest.raises(TrainingError, match="does not build a 'fcn' model"):
        train(data, "fcn", tmp_path / "f.pt", config={"uncertainty": True})
    features, base = hybrid_columns(False)
    plain, xs, ys = model_and_scalers(len(features))
    record = ck.TrainedModel("hybrid", SMALL, features, xs, ys, base, model=plain)
    trial = Trial("t", "Free", "test", recording(120))
    with pytest.raises(ValueError, match="predicts no variance"):
        predict_trial(record, trial, with_std=True)
