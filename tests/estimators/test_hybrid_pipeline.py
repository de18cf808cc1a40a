"""Data pipeline, metrics, training loop and checkpoints of hybrid/ on tiny synthetic recordings."""

from __future__ import annotations

import copy
import dataclasses
import json

import numpy as np
import pandas as pd
import pytest
import torch
from torch import nn

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.data.bounds import physical_bounds
from psmforce.estimators.data.dataset import (
    FEATURE_SETS,
    FREE_STRIDE_FACTOR,
    DatasetError,
    Scaler,
    Trial,
    WindowSet,
    fit_scalers,
    index_recordings,
    load_dataset,
    resolve_features,
    sliding_windows,
    split_validation,
    subsample_trials,
)
from psmforce.core.integrity import seal
from psmforce.estimators.evaluation.metrics import (MetricError, axis_metrics, nrmse, postprocess,
                                                    r2, rmse)
from psmforce.estimators.networks.baselines import (FCN, PaperTransformer, count_parameters,
                                                    freeze_for_finetuning)
from psmforce.estimators.networks.recipes import build_model
from psmforce.estimators.training.train import TrainConfig, TrainingError, fit, make_setup
from psmforce.io.recording import PAPER_FEATURES, REQUIRED, TARGETS, write_recording

torch.set_num_threads(1)


BOUNDS = physical_bounds()


def _frame(n: int, seed: int) -> pd.DataFrame:
    """A recording whose ATI force is a lagged, smooth function of its HEX10 and effort columns."""
    rng = np.random.default_rng(seed)
    data = {"time": np.arange(n) / 100.0}
    for c in REQUIRED[1:]:
        # a random walk squashed into the middle half of the column's physical range, which
        # load_dataset enforces (an unbounded walk leaves it: insertion below 0 m)
        low, high = BOUNDS[c]
        data[c] = (low + high) / 2 + (high - low) / 4 * np.tanh(np.cumsum(rng.normal(0, 0.05, n)))
    hx = np.convolve(data["fx"], np.ones(5) / 5, mode="same")
    data["ati_fx"] = 0.5 * hx + 0.1 * data["insertion_effort"]
    data["ati_fy"] = -0.3 * data["fy"] + 0.2 * data["roll_position"]
    data["ati_fz"] = 0.4 * data["fz"] - 0.2 * data["wrist_pitch_effort"]
    return pd.DataFrame(data)


def _trial(n=300, seed=0, condition="Traction", split="train") -> Trial:
    return Trial(f"{split}/{condition}/t{seed}.csv", condition, split, _frame(n, seed))


# ------------------------------------------------------------------------------ data

def test_feature_sets_are_the_papers():
    assert len(FEATURE_SETS["paper"]) == 21
    assert len(FEATURE_SETS["no_hex10"]) == 15
    assert len(FEATURE_SETS["no_efforts"]) == 14
    assert len(FEATURE_SETS["no_positions"]) == 17
    assert len(FEATURE_SETS["no_velocities"]) == 17
    assert len(FEATURE_SETS["no_positions_velocities"]) == 13
    assert resolve_features(["fx", "fy"]) == ("fx", "fy")
    with pytest.raises(DatasetError, match="unknown feature set"):
        resolve_features("no_such_set")


def test_sliding_windows_match_naive_reference_without_copying():
    x = np.random.default_rng(1).normal(size=(53, 4)).astype(np.float32)
    for window, stride in ((1, 1), (7, 3), (10, 5), (53, 2)):
        view = sliding_windows(x, window, stride)
        naive = np.stack([x[s:s + window] for s in range(0, len(x) - window + 1, stride)])
        np.testing.assert_array_equal(view, naive)
        assert np.shares_memory(view, x)
    assert sliding_windows(x, 60, 1).shape == (0, 60, 4)


def test_window_set_matches_naive_windows_per_trial_and_downsamples_free():
    trials = [_trial(40, 0), _trial(33, 1, "Free"), _trial(9, 2)]
    feats = ("fx", "fy", "tz")
    xs, ys = fit_scalers(trials, feats)
    ws = WindowSet(trials, feats, xs, ys, window=10, stride=3, downsample_free=True)
    naive_x, naive_y = [], []
    for t in trials:
        x, y = xs.transform(t.matrix(feats)), ys.transform(t.matrix(TARGETS))
        step = 3 * (FREE_STRIDE_FACTOR if t.condition == "Free" else 1)
        for s in range(0, len(t) - 10 + 1, step):
            naive_x.append(x[s:s + 10])
            naive_y.append(y[s + 9])
    bx, by = ws.batch(torch.arange(len(ws)))
    np.testing.assert_array_equal(bx.numpy(), np.stack(naive_x))
    np.testing.assert_array_equal(by.numpy(), np.stack(naive_y))
    chunks = WindowSet(trials, feats, xs, ys, window=10, stride=3, targets="all")
    cx, cy = chunks.batch(torch.tensor([0, 1]))
    assert cy.shape == (2, 10, 3)
    np.testing.assert_array_equal(cy[1].numpy(), ys.transform(trials[0].matrix(TARGETS))[3:13])


def test_validation_split_is_seeded_and_per_condition():
    trials = ([_trial(20, i, "Traction") for i in range(10)]
              + [_trial(20, 10 + i, "Palpation") for i in range(5)]
              + [_trial(20, 20, "Free")])
    train, val = split_validation(trials, 0.1, seed=3)
    again_train, again_val = split_validation(trials, 0.1, seed=3)
    assert [t.path for t in val] == [t.path for t in again_val]
    assert sorted(t.condition for t in val) == ["Palpation", "Traction"]
    assert len(train) + len(val) == len(trials)
    assert {t.condition for t in subsample_trials(trials, 0.1)} == {"Traction", "Palpation", "Free"}


def test_validation_split_keeps_trajectory_families_together():
    """On the automated bench a free-space trial replays traction / palpation trajectories: a
    family (metadata ``group``) goes to validation whole, never half in training."""
    trials = []
    for cell in range(6):
        for k, cond in enumerate(("Traction", "Traction", "Palpation", "Free")):
            t = _trial(20, len(trials), cond)
            t.path = f"train/{cond}/c{cell}_{len(trials)}.csv"
            t.params = {"group": f"c{cell}_" + ("replayed" if k in (0, 3) else str(k))}
            trials.append(t)
    for seed in range(8):
        train, val = split_validation(trials, 0.1, seed=seed)
        val_groups = {t.params["group"] for t in val}
        assert not val_groups & {t.params["group"] for t in train}
        assert {t.condition for t in val} >= {"Traction", "Palpation"}
        assert len(train) + len(val) == len(trials)
    seen = {t.path for seed in range(8) for t in split_validation(trials, 0.1, seed)[1]}
    assert any("Free" in p for p in seen)   # free space reaches validation with its family


def test_scalers_use_training_data_only_and_pass_raw_columns():
    t = _trial(100, 0)
    xs, ys = fit_scalers([t], ("fx", "fy"), raw_columns=("fy",))
    x = t.matrix(("fx", "fy"))
    np.testing.assert_allclose(xs.mean[0], x[:, 0].mean(), rtol=1e-5)
    assert xs.mean[1] == 0 and xs.std[1] == 1
    np.testing.assert_allclose(ys.transform(t.matrix(TARGETS)).mean(axis=0), 0, atol=1e-5)
    assert Scaler.from_dict(json.loads(json.dumps(xs.to_dict()))).std.tolist() == xs.std.tolist()


def test_load_dataset_from_folders_and_metadata(tmp_path):
    for split, cond, k in (("train", "Traction", 0), ("train", "Free", 1),
                           ("test", "Palpation", 2)):
        (tmp_path / split / cond).mkdir(parents=True)
        write_recording(_frame(50, k), tmp_path / split / cond / f"t{k}.csv")
    with pytest.raises(DatasetError, match="no metadata.json.*psmforce index"):
        load_dataset(tmp_path)  # loose recordings become a dataset only explicitly
    index_recordings(tmp_path)
    ds = load_dataset(tmp_path)
    assert sorted((t.split, t.condition) for t in ds.trials) == [
        ("test", "Palpation"), ("train", "Free"), ("train", "Traction")]
    (tmp_path / "metadata.json").write_text(json.dumps({"trials": [
        {"path": "train/Traction/t0.csv", "condition": "Traction", "split": "train", "phi": 1.0}]}))
    ds = load_dataset(tmp_path)
    assert len(ds.trials) == 1 and ds.trials[0].params == {"phi": 1.0}
    with pytest.raises(DatasetError, match="does not exist"):
        load_dataset(tmp_path / "nope")


# ------------------------------------------------------------------------------ metrics

def test_metrics_against_hand_computed_values():
    truth = np.array([[0.0, 1.0, 2.0], [1.0, 3.0, 2.0], [2.0, 5.0, 6.0], [3.0, 7.0, 6.0]])
    pred = truth + np.array([[1.0, 0, 0], [-1.0, 0, 0], [1.0, 2.0, 0], [-1.0, 0, 0]])
    np.testing.assert_allclose(rmse(pred, truth), [1.0, 1.0, 0.0])
    np.testing.assert_allclose(nrmse(pred, truth), [100 / 3, 100 / 6, 0.0])
    # Fx: SS_res 4, SS_tot 5 -> 0.2; Fy: SS_res 4, SS_tot 20 -> 0.8; Fz exact -> 1
    np.testing.assert_allclose(r2(pred, truth), [0.2, 0.8, 1.0])
    m = axis_metrics(pred, truth)
    assert m["Fy"]["range_n"] == 6.0 and m["Fx"]["r2_pct"] == pytest.approx(20.0)
    with pytest.raises(MetricError, match="shape"):
        rmse(pred[:2], truth)
    with pytest.raises(MetricError, match="constant"):
        nrmse(np.zeros((3, 3)), np.ones((3, 3)))


def test_postprocess_bias_then_centred_median():
    pred = np.zeros((200, 3))
    pred[:, 0] = 2.0                     # constant offset: removed by the bias step
    pred[100, 1] = 50.0                  # one-sample spike: removed by the median
    pred[120:, 2] = 1.0                  # a step survives, centred (no lag)
    out = postprocess(pred, 100.0, kernel=71)
    np.testing.assert_allclose(out[:, 0], 0.0)
    np.testing.assert_allclose(out[:, 1], 0.0)
    assert out[119, 2] == 0.0 and out[120, 2] == 1.0
    raw = postprocess(pred, 100.0, bias=False, kernel=1)
    np.testing.assert_allclose(raw, pred)
    with pytest.raises(MetricError, match="odd"):
        postprocess(pred, kernel=70)


# ------------------------------------------------------------------------------ models, training

def test_causal_postprocessing_never_looks_ahead_and_the_floor():
    """Causal modes: changing a future sample never changes an earlier output; the paper's
    centred median does. A step in the truth leaves the paper metric a floor the raw causal
    metric does not have; the low-pass lags a ramp by its stated delay."""
    from psmforce.estimators.evaluation.evaluate import floor_metrics
    from psmforce.estimators.evaluation.metrics import lowpass_lag_samples
    rng = np.random.default_rng(0)
    pred = rng.normal(size=(400, 3))
    later = pred.copy()
    later[300:] += 5.0
    for mode in ("causal", "causal_lowpass"):
        a = postprocess(pred, bias=False, mode=mode)
        b = postprocess(later, bias=False, mode=mode)
        np.testing.assert_array_equal(a[:300], b[:300])
    assert not np.array_equal(postprocess(pred, bias=False)[:300],
                              postprocess(later, bias=False)[:300])
    ramp = np.repeat(np.arange(2000.0)[:, None], 3, axis=1) * 0.01
    lagged = postprocess(ramp, bias=False, mode="causal_lowpass")
    np.testing.assert_allclose(ramp[1000:] - lagged[1000:], lowpass_lag_samples() * 0.01,
                               rtol=1e-3)
    with pytest.raises(MetricError, match="post-processing"):
        postprocess(pred, mode="centred")
    t = _trial(400, 0)
    t.frame[["ati_fx", "ati_fy", "ati_fz"]] = 0.0
    t.frame.loc[250:, ["ati_fx", "ati_fy", "ati_fz"]] = 1.0
    t.frame.loc[260:, ["ati_fx", "ati_fy", "ati_fz"]] = 0.0   # a 0.1 s tap
    floor = floor_metrics([t])
    assert floor["causal"]["Fx"]["nrmse_pct"] == 0.0
    assert floor["paper"]["Fx"]["nrmse_pct"] > 10.0


def test_paper_model_sizes():
    assert count_parameters(PaperTransformer(21)) == 155_715
    assert count_parameters(FCN(21)) == 5_763
    assert count_parameters(build_model("lstm", 36)) == 486_150
    trainable, total = freeze_for_finetuning(PaperTransformer(21))
    assert (trainable, total) == (4_355, 155_715)
    assert freeze_for_finetuning(FCN(21))[0] == 195
    assert freeze_for_finetuning(build_model("lstm", 36))[0] == 49_926


class _ChunkStandIn(nn.Module):
    """A causal chunk model (B, T, F) -> (B, T, 3) standing in for psmforce.estimators.networks.causal in loop tests."""

    kind, output_space = "chunk", "scaled"

    def __init__(self, n_features, window=4):
        super().__init__()
        self.window = window
        self.conv = nn.Conv1d(n_features, 32, window)
        self.head = nn.Linear(32, 3)

    def forward(self, x):
        h = nn.functional.pad(x.transpose(1, 2), (self.window - 1, 0))
        return self.head(torch.relu(self.conv(h)).transpose(1, 2))


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["fcn", "transformer", "chunk"])
def test_models_overfit_a_tiny_set(kind):
    trials = [_trial(120, 0), _trial(120, 1)]
    setup = make_setup("fcn" if kind == "chunk" else kind, trials, features="paper")
    if kind == "fcn":
        model = FCN(21)
    elif kind == "transformer":
        model = PaperTransformer(21, window=8, dropout=0.0)
    else:
        model = _ChunkStandIn(21)
    cfg = TrainConfig(lr=3e-3, weight_decay=0.0, batch_size=64, chunk_batch_size=8, chunk=40,
                      max_epochs=60, patience=60, stride=2, progress=False)
    report = fit(model, trials, trials, setup, cfg)
    losses = [h["val_loss"] for h in report["history"]]
    assert report["best_val_loss"] < 0.1 * losses[0] and report["best_val_loss"] < 0.1


def test_chunk_supervised_follows_the_warm_up_window():
    """``chunk_supervised`` sets the supervised samples per chunk whatever the receptive field:
    the chunk is the warm-up plus that many, consecutive chunks step by it (no sample
    supervised twice), and ``chunk`` is not read."""
    trials = [_trial(120, 0), _trial(120, 1)]
    setup = make_setup("fcn", trials, features="paper")
    cfg = TrainConfig(chunk=5, chunk_supervised=10, chunk_batch_size=4, max_epochs=1,
                      progress=False)
    for window in (4, 9):
        report = fit(_ChunkStandIn(21, window=window), trials, trials, setup, cfg)
        assert report["chunk"] == window + 10
        # a chunk starts every 10 samples while a whole one fits in a 120-sample trial; two trials
        assert report["train_windows"] == 2 * ((120 - (window + 10)) // 10 + 1)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(TrainingError, match="chunk_supervised must be a positive integer"):
            fit(_ChunkStandIn(21), trials, trials, setup, dataclasses.replace(
                cfg, chunk_supervised=bad))


def test_paper_transformer_equals_the_stock_encoder():
    """The fast forward (last layer for the last sample only, SDPA) computes the stock layers'
    function: same output and same gradients as nn.TransformerEncoder's last row."""
    torch.manual_seed(0)
    model = PaperTransformer(21, window=12, dropout=0.0)
    x = torch.randn(5, 12, 21)

    def stock(m):
        return m.decoder(m.encoder(m.positions(m.embed(x)))[:, -1])
    for mode in ("eval", "train"):
        getattr(model, mode)()
        fast, ref = model(x), stock(model)
        torch.testing.assert_close(fast, ref, rtol=1e-5, atol=1e-6)
    g_fast = torch.autograd.grad(model(x).square().sum(), list(model.parameters()),
                                 allow_unused=True)
    g_ref = torch.autograd.grad(stock(model).square().sum(), list(model.parameters()))
    for a, b in zip(g_fast, g_ref):
        torch.testing.assert_close(a if a is not None else torch.zeros_like(b), b,
                                   rtol=1e-4, atol=1e-6)


def test_finetuning_on_cached_features_equals_the_frozen_model():
    """Training the decoder on features computed once gives the same decoder as training it
    under the frozen trunk batch by batch (same order, same steps)."""
    trials, val = [_trial(150, 0), _trial(150, 1)], [_trial(150, 2)]
    setup = make_setup("transformer", trials, features="paper")
    cfg = TrainConfig(max_epochs=3, patience=5, batch_size=32, stride=3, progress=False)
    torch.manual_seed(0)
    base = PaperTransformer(21, window=10)
    cached, direct = copy.deepcopy(base), copy.deepcopy(base)
    freeze_for_finetuning(cached)
    report = fit(cached, trials, val, setup, cfg, frozen_in_eval=True)
    freeze_for_finetuning(direct)
    report_direct = fit(_Uncached(direct), trials, val, setup, cfg, frozen_in_eval=True)
    assert report["epochs_run"] == report_direct["epochs_run"] == 3
    assert report["train_windows"] == report_direct["train_windows"]
    for a, b in zip(cached.decoder.parameters(), direct.decoder.parameters()):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6)
    assert report["stopped_by"] == "epoch_limit" and not report["converged"]


class _Uncached(nn.Module):
    """The same model without ``features``: the loop must run the trunk every batch."""

    kind, output_space = "window", "scaled"

    def __init__(self, model):
        super().__init__()
        self.model, self.window = model, model.window

    def forward(self, x):
        return self.model(x)

    def finetune_modules(self):
        return self.model.finetune_modules()


def test_early_stopping_and_lr_decay():
    trials = [_trial(60, 0)]
    val = [_trial(60, 9)]     # unrelated noise: validation cannot improve for long
    setup = make_setup("fcn", trials, features=["fx"])
    cfg = TrainConfig(max_epochs=100, patience=4, lr_patience=1, batch_size=16, progress=False)
    report = fit(FCN(1), trials, val, setup, cfg)
    assert report["epochs_run"] < 100
    assert report["stopped_by"] == "patience" and report["converged"]
    assert min(h["lr"] for h in report["history"]) < cfg.lr
    steps = [h["steps"] for h in report["history"]]
    assert steps == sorted(steps) and steps[-1] == report["epochs_run"] * report[
        "batches_per_epoch"]
    capped = fit(FCN(1), trials, val, setup, TrainConfig(**{**cfg.to_dict(),
                                                            "max_batches_per_epoch": 1,
                                                            "batch_size": 2}))
    assert capped["capped"] and not capped["converged"]


# ------------------------------------------------------------------------------ checkpoints

def _trained_fcn(tmp_path):
    trials = [_trial(80, 0)]
    setup = make_setup("fcn", trials, features="no_hex10")
    model = build_model("fcn", len(setup.features))
    path = ck.TrainedModel("fcn", {}, setup.features, setup.input_scaler, setup.target_scaler,
                           model=model, provenance={"seed": 0}).save(tmp_path / "m.pt")
    return path, model, setup, trials


def test_checkpoint_round_trip(tmp_path):
    from psmforce.estimators.evaluation.evaluate import predict_trial
    path, model, setup, trials = _trained_fcn(tmp_path)
    loaded = ck.load_checkpoint(path)
    assert loaded.features == setup.features and loaded.provenance == {"seed": 0}
    assert loaded.versions["torch"] == torch.__version__
    setup.model = model
    a = predict_trial(setup, trials[0])
    b = predict_trial(loaded, trials[0])
    np.testing.assert_array_equal(a, b)
    assert not list(tmp_path.glob("*.part"))


def test_mismatched_or_corrupt_checkpoint_refused(tmp_path):
    path, _, _, _ = _trained_fcn(tmp_path)
    loaded = ck.load_checkpoint(path)
    with pytest.raises(ck.CheckpointError, match="missing from setup"):
        loaded.check_compatible(features=PAPER_FEATURES[:10])
    with pytest.raises(ck.CheckpointError, match="holds a 'fcn' model"):
        loaded.check_compatible(model_name="transformer")
    with pytest.raises(ck.CheckpointError, match="lacks the checkpoint's input columns"):
        loaded.check_compatible(available_columns=["fx"])
    bad = tmp_path / "bad.pt"
    bad.write_bytes(path.read_bytes()[:200])
    with pytest.raises(ck.CheckpointError, match="corrupt"):
        ck.load_checkpoint(bad)
    payload = torch.load(path, weights_only=True)
    meta = json.loads(payload["meta"])
    payload["meta"] = json.dumps({**meta, "features": meta["features"][:5]})
    torch.save(payload, tmp_path / "edited.pt")
    with pytest.raises(ck.CheckpointError, match=r"does not match its SHA-256 envelope \(changed: features\)"):
        ck.load_checkpoint(tmp_path / "edited.pt")
    scaler = {k: v[:5] if isinstance(v, list) else v for k, v in meta["input_scaler"].items()}
    payload["meta"] = json.dumps(seal({**meta, "features": meta["features"][:5],
                                       "input_scaler": scaler}))
    torch.save(payload, tmp_path / "shrunk.pt")  # resealed, as a careless tool would
    with pytest.raises(ck.CheckpointError, match="weights do not fit"):
        ck.load_checkpoint(tmp_path / "shrunk.pt")
    payload["meta"] = json.dumps({**meta, "format_version": 99})
    torch.save(payload, tmp_path / "future.pt")
    with pytest.raises(ck.CheckpointError, match="format version 99"):
        ck.load_checkpoint(tmp_path / "future.pt")


def _write_dataset(folder, trials, ati_gain: float = 1.0):
    """A dataset folder of 260-sample :func:`_frame` recordings, one per (split, condition, seed),
    the ATI force scaled by ``ati_gain``; indexed (metadata.json)."""
    for split, cond, k in trials:
        (folder / split / cond).mkdir(parents=True, exist_ok=True)
        frame = _frame(260, k)
        frame[["ati_fx", "ati_fy", "ati_fz"]] *= ati_gain
        write_recording(frame, folder / split / cond / f"t{k}.csv")
    index_recordings(folder)
    return folder


def test_train_and_evaluate_files_end_to_end(tmp_path):
    from psmforce.estimators.evaluation.evaluate import evaluate
    from psmforce.estimators.training.train import train
    data = _write_dataset(tmp_path / "data", ((split, cond, k) for k, (split, cond) in enumerate(
        [("train", "Traction")] * 2 + [("train", "Free")] * 2 + [("test", "Traction"),
                                                                ("test", "Free")])))
    summary = train(data, "fcn", tmp_path / "fcn.pt", epochs=2, seed=0,
                    train_config=TrainConfig(progress=False))
    assert summary["epochs_run"] == 2 and (tmp_path / "fcn.pt").exists()
    result = evaluate(tmp_path / "fcn.pt", data, tmp_path / "eval", plots=False)
    assert set(result["by_condition"]) == {"Free", "Traction"}
    assert (tmp_path / "eval" / "metrics.md").read_text().startswith("**test trials**")
    assert json.loads((tmp_path / "eval" / "metrics.json").read_text())["model"] == "fcn"


@pytest.mark.slow
def test_rocket_trains_evaluates_and_finetunes_through_checkpoints(tmp_path):
    pytest.importorskip("aeon")
    from psmforce.estimators.evaluation.evaluate import evaluate, predict_trial
    from psmforce.estimators.training.train import finetune, train
    data = _write_dataset(tmp_path / "data", ((split, cond, k) for k, (split, cond) in enumerate(
        [("train", "Traction")] * 2 + [("train", "Free")] * 2 + [("test", "Traction"),
                                                                ("test", "Free")])))
    small = {"n_kernels_multirocket": 168, "n_kernels_hydra": 32}
    summary = train(data, "rocket", tmp_path / "rocket.pt", seed=3, config=small)
    assert summary["stopped_by"] == "closed form" and summary["converged"]
    ckpt = ck.load_checkpoint(tmp_path / "rocket.pt")
    assert ckpt.config == {**ckpt.model.config(), **small} and ckpt.config["seed"] == 3
    payload = torch.load(tmp_path / "rocket.pt", weights_only=True)  # nothing but tensors
    assert all(isinstance(v, torch.Tensor) for v in payload["state_dict"].values())
    result = evaluate(tmp_path / "rocket.pt", data, tmp_path / "eval", plots=False)
    assert set(result["by_condition"]) == {"Free", "Traction"}
    tool = _write_dataset(tmp_path / "new_tool", (("train", c, k) for k, c in enumerate(
        ["Traction", "Traction", "Free", "Free"], start=6)), ati_gain=-1.5)  # another mapping
    tuned = finetune(tmp_path / "rocket.pt", tool, tmp_path / "tuned.pt", seed=3)
    assert tuned["stopped_by"] == "closed form"
    before, after = (ck.load_checkpoint(tmp_path / f) for f in ("rocket.pt", "tuned.pt"))
    trial = load_dataset(data).select(split="test")[0]
    pred = [predict_trial(c, trial) for c in (before, after)]
    assert np.isfinite(pred[0][99:]).all() and np.isnan(pred[0][:99]).all()
    assert not np.allclose(pred[0][99:], pred[1][99:])  # the head was refitted
    np.testing.assert_array_equal(before.model._fitted.scale, after.model._fitted.scale)


def test_chunked_offline_prediction_equals_one_causal_pass():
    """Chunks overlapping by the model's window reproduce a single pass over the whole trial
    exactly for a causal model whose receptive field is within that window."""
    from psmforce.estimators.evaluation import evaluate as ev
    trial = _trial(2600, 4)
    setup = make_setup("fcn", [trial], features="paper")
    torch.manual_seed(0)
    model = _ChunkStandIn(21, window=6).eval()
    setup.model = model
    pred = ev.predict_trial(setup, trial, batch=3 * ev.PREDICT_CHUNK)
    with torch.no_grad():
        x = torch.from_numpy(setup.input_scaler.transform(trial.matrix(setup.features)))
        full = setup.target_scaler.inverse(model(x[None])[0].numpy())
    np.testing.assert_allclose(pred, full, rtol=1e-5, atol=1e-5)
    window_model = PaperTransformer(21, window=5).eval()
    setup.model = window_model
    wpred = ev.predict_trial(setup, trial)
    assert np.isnan(wpred[:4]).all() and not np.isnan(wpred[4:]).any()
    with torch.no_grad():
        last = window_model(x[None, -5:])[0].numpy()
    np.testing.assert_allclose(wpred[-1], setup.target_scaler.inverse(last), rtol=1e-5, atol=1e-5)
