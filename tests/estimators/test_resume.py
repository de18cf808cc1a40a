"""Resumable training (psmforce/estimators/training/resume.py): killed after an epoch and resumed, a training ends with
the weights and metrics of an uninterrupted one; a state file is read back strictly."""
import numpy as np
import pandas as pd
import pytest
import torch

import psmforce.estimators.training.train as train_module
from psmforce.estimators.data.dataset import Trial
from psmforce.estimators.networks.recipes import Inputs
from psmforce.estimators.training.resume import FORMAT_VERSION, ResumeError
from psmforce.estimators.training.train import TrainConfig, make_setup, train_model

CONFIG = {"d_model": 16, "n_heads": 2, "n_layers": 1, "d_ff": 32, "attention_window": 8,
          "dropout": 0.2}  # dropout on: the global random stream must be restored too


def _trial(seed: int, n: int = 600) -> Trial:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    a, b = np.sin(2 * np.pi * 0.3 * t + seed), np.cos(2 * np.pi * 0.7 * t)
    target = np.stack([a + 0.5 * b, a - b, 0.3 * a * b], axis=1) + 0.05 * rng.normal(size=(n, 3))
    frame = pd.DataFrame({"a": a, "b": b, **{f"ati_f{x}": target[:, i]
                                             for i, x in enumerate("xyz")}})
    return Trial(f"t{seed}", "Traction", "train", frame)


TRIALS = [_trial(k) for k in range(5)]
CFG = TrainConfig(lr=5e-3, max_epochs=6, patience=3, lr_patience=1, chunk=120,
                  chunk_batch_size=4, progress=False, seed=3)


def _train(resume=None):
    setup = make_setup("hybrid", TRIALS[:4], inputs=Inputs(("a", "b")), config=CONFIG)
    report = train_model(setup, TRIALS[:4], TRIALS[4:], CFG, resume=resume)
    return setup, report


def _killed_in_epoch(monkeypatch, epoch: int) -> None:
    """The validation pass of ``epoch`` raises, as a Ctrl-C would: that epoch is lost."""
    calls = {"n": 0}
    evaluate = train_module._evaluate_loss

    def interrupted(*args, **kwargs):
        calls["n"] += 1
        if calls["n"] == epoch:
            raise KeyboardInterrupt
        return evaluate(*args, **kwargs)
    monkeypatch.setattr(train_module, "_evaluate_loss", interrupted)


def _killed_training(monkeypatch, state, epoch: int = 3) -> None:
    """A training with its state at ``state``, killed in ``epoch``."""
    with monkeypatch.context() as m:
        _killed_in_epoch(m, epoch)
        with pytest.raises(KeyboardInterrupt):
            _train(state)
    assert state.exists()


def test_a_killed_training_resumes_to_the_uninterrupted_result(monkeypatch, tmp_path):
    whole, whole_report = _train()
    state = tmp_path / "hybrid.state"
    _killed_training(monkeypatch, state)
    resumed, report = _train(state)
    for key, value in whole.model.state_dict().items():
        assert torch.equal(value, resumed.model.state_dict()[key]), key
    assert [h["val_loss"] for h in report["history"]] == \
        [h["val_loss"] for h in whole_report["history"]]
    assert [h["train_loss"] for h in report["history"]] == \
        [h["train_loss"] for h in whole_report["history"]]
    for key in ("best_val_loss", "epochs_run", "stopped_by", "converged"):
        assert report[key] == whole_report[key], key
    # the reported wall-clock counts the killed process's epochs too, not only the last process's
    clock = [h["elapsed_s"] for h in report["history"]]
    assert report["seconds"] >= clock[-1] > clock[1]
    # a finished state resumes to the same result without training again
    again, again_report = _train(state)
    assert again_report["epochs_run"] == whole_report["epochs_run"]
    assert torch.equal(next(iter(again.model.state_dict().values())),
                       next(iter(whole.model.state_dict().values())))


def _record(path):
    return torch.load(path, weights_only=True)


def test_a_state_file_is_read_back_strictly(monkeypatch, tmp_path):
    state = tmp_path / "s.state"
    _killed_training(monkeypatch, state, epoch=2)
    good = _record(state)

    def refused(record, match):
        torch.save(record, state)
        with pytest.raises(ResumeError, match=match):
            _train(state)

    payload = bytearray(good["payload"])
    payload[len(payload) // 2] ^= 0xFF
    refused({**good, "payload": bytes(payload)}, "SHA-256")
    refused({**good, "format_version": str(FORMAT_VERSION)}, "format version")
    refused({**good, "format_version": FORMAT_VERSION + 1}, "format version")
    refused({**good, "format": "other"}, "not a psmforce-training-state")
    refused({**good, "fingerprint": "0" * 64}, "another training")
    state.write_text("not a state")
    with pytest.raises(ResumeError, match="not a readable training state"):
        _train(state)


def test_a_training_resumes_on_another_device_and_names_each_epochs(monkeypatch, tmp_path):
    """A GPU training whose machine is gone goes on on the CPU: the state is accepted on another
    device (here "cpu:0", another device string on the same hardware, so the numbers must still
    equal the uninterrupted run's) and the history says where each epoch ran."""
    whole, whole_report = _train()
    state = tmp_path / "moved.state"
    _killed_training(monkeypatch, state)
    moved_cfg = TrainConfig(**{**CFG.to_dict(), "device": "cpu:0"})
    setup = make_setup("hybrid", TRIALS[:4], inputs=Inputs(("a", "b")), config=CONFIG)
    report = train_model(setup, TRIALS[:4], TRIALS[4:], moved_cfg, resume=state)
    assert [h["device"] for h in report["history"]] == ["cpu"] * 2 + ["cpu:0"] * (
        whole_report["epochs_run"] - 2)
    assert report["devices"] == ["cpu", "cpu:0"] and whole_report["devices"] == ["cpu"]
    assert [h["val_loss"] for h in report["history"]] == \
        [h["val_loss"] for h in whole_report["history"]]
    for key, value in whole.model.state_dict().items():
        assert torch.equal(value, setup.model.state_dict()[key]), key
