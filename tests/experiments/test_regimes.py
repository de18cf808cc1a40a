"""Training regimes (psmforce/estimators/training/regimes.py): the paper's regime gives a chunk
model the window models' targets, the dense one every sample; a regime changes only what it owns."""
import numpy as np
import pandas as pd
import pytest

from psmforce.estimators.data.dataset import Trial
from psmforce.estimators.networks.recipes import Inputs, build_model, recipe
from psmforce.experiments.regimes import RegimeError, regime_settings
from psmforce.estimators.training.train import TrainConfig, TrainingError, _window_set, make_setup

CONFIG = {"d_model": 8, "n_heads": 2, "n_layers": 1, "d_ff": 16, "attention_window": 8}


def _trial(seed: int, n: int = 400, condition: str = "Traction") -> Trial:
    t = np.arange(n) / 100.0
    frame = pd.DataFrame({"a": np.sin(t + seed), "b": np.cos(2 * t),
                          **{f"ati_f{x}": np.sin(t * (i + 1)) for i, x in enumerate("xyz")}})
    return Trial(f"t{seed}", condition, "train", frame)


TRIALS = [_trial(0), _trial(1, 300), _trial(2, 500, "Free")]


def _setup(name: str, config: dict):
    setup = make_setup(name, TRIALS, inputs=Inputs(("a", "b")), config=config)
    setup.model = build_model(name, len(setup.features), setup.config)
    return setup


def _targets(setup, cfg: TrainConfig) -> set[int]:
    """Row indices (into the concatenated trials) of every supervised target of an epoch."""
    data = _window_set(setup.model, TRIALS, setup, cfg)
    starts = data.starts.numpy()
    if data.mode == "last":
        return set((starts + data.window - 1).tolist())
    return {int(s) + k for s in starts for k in range(setup.model.window, data.window)}


def test_the_paper_regime_gives_a_chunk_model_the_window_models_targets():
    hybrid = _setup("hybrid", CONFIG)
    window = hybrid.model.window
    window_model = _setup("transformer", {"window": window, "d_model": 8, "n_heads": 2,
                                        "n_layers": 1, "d_ff": 16})
    paper_chunk = TrainConfig(**regime_settings("paper", recipe("hybrid")))
    paper_window = TrainConfig(**regime_settings("paper", recipe("transformer")))
    # the chunk model's target is the sample after its warm-up: one later than a window of the
    # same length ends
    shifted = {i - 1 for i in _targets(hybrid, paper_chunk)}
    assert shifted == _targets(window_model, paper_window)
    assert len(_targets(window_model, paper_window)) < len(_targets(window_model, TrainConfig(
        **regime_settings("dense", recipe("transformer")))))


def test_the_dense_regime_supervises_every_sample_of_a_chunk_model_once():
    hybrid = _setup("hybrid", CONFIG)
    data = _window_set(hybrid.model, TRIALS[:2], hybrid,
                       TrainConfig(**regime_settings("dense", recipe("hybrid"))))
    rows = [int(s) + k for s in data.starts.numpy()
            for k in range(hybrid.model.window, data.window)]
    assert len(rows) == len(set(rows))  # none twice


def test_a_regime_leaves_what_it_does_not_own():
    lstm = recipe("lstm")
    paper = regime_settings("paper", lstm)
    assert paper["lr"] == lstm.optimiser["lr"] and paper["weight_decay"] == lstm.optimiser[
        "weight_decay"]
    assert regime_settings("own", recipe("hybrid")) == recipe("hybrid").optimiser
    assert regime_settings("dense", recipe("rocket")) == recipe("rocket").optimiser  # closed form
    assert regime_settings("dense", recipe("hybrid")) == {**recipe("hybrid").optimiser}


def test_an_unknown_regime_or_a_bad_stride_is_refused():
    with pytest.raises(RegimeError, match="known: own, paper, dense"):
        regime_settings("fast", recipe("hybrid"))
    hybrid = _setup("hybrid", CONFIG)
    with pytest.raises(TrainingError, match="chunk_stride"):
        _window_set(hybrid.model, TRIALS, hybrid, TrainConfig(chunk_stride=0))
