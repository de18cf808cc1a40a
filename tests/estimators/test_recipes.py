"""The recipe table is the one place a model is added: a toy model registered there (and nowhere
else) trains, evaluates, finetunes, streams and exports end to end, from Python and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from psmforce.estimators.training.checkpoint import CheckpointError, load_checkpoint
from psmforce.estimators.evaluation.evaluate import evaluate
from psmforce.estimators.runtime.export import export, run_export
from psmforce.estimators.networks.recipes import (RECIPES, Recipe, RecipeError, recipe, register,
                                                  unregister)
from psmforce.estimators.runtime.streaming import StreamingEstimator
from psmforce.estimators.training.train import TrainConfig, finetune, train
from psmforce.io.recording import PAPER_FEATURES, read_recording
from psmforce.cli.main import main
from tests.estimators.test_hybrid_pipeline import _write_dataset
from tests.estimators.test_streaming import TwoTapToy

torch.set_num_threads(1)


class Toy(TwoTapToy):
    """The streaming tests' two-tap causal model, made trainable: scaled outputs, and its
    "last decoder block" (the current-sample tap) left trainable when finetuning."""

    output_space = "scaled"

    def finetune_modules(self):
        return [self.now]


@pytest.fixture
def toy():
    register(Recipe("toy", lambda n_features, config: Toy(n_features, **config)))
    yield recipe("toy")
    unregister("toy")


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("bench")
    return _write_dataset(root / "data", ((split, cond, k) for k, (split, cond) in enumerate(
        [("train", "Traction")] * 2 + [("train", "Free")] * 2
        + [("test", "Traction"), ("test", "Free")])))


def test_a_registered_model_runs_the_whole_path(toy, data, tmp_path):
    assert toy.streams and not toy.closed_form and not toy.uses_prior  # what Toy says itself
    summary = train(data, "toy", tmp_path / "toy.pt", epochs=3, seed=0,
                    train_config=TrainConfig(progress=False, lr=1e-2))
    assert summary["epochs_run"] == 3 and summary["parameters"] == 2 * 3 * len(PAPER_FEATURES) + 3
    record = load_checkpoint(tmp_path / "toy.pt")
    assert record.model_name == "toy" and isinstance(record.model, Toy)
    assert record.features == PAPER_FEATURES and record.base_columns == ()

    from psmforce.core.files import OutputError, locked_folder
    with locked_folder(tmp_path / "eval"):  # issue 46, class 6: one writer per output folder
        with pytest.raises(OutputError, match="another command is writing this folder"):
            evaluate(tmp_path / "toy.pt", data, tmp_path / "eval", plots=False)
    result = evaluate(tmp_path / "toy.pt", data, tmp_path / "eval", plots=False)
    assert result["model"] == "toy" and result["bias_correction"] is toy.bias_correction
    assert set(result["by_condition"]) == {"Free", "Traction"}

    tuned = finetune(tmp_path / "toy.pt", data, tmp_path / "tuned.pt", epochs=2, seed=0,
                     train_config=TrainConfig(progress=False))
    assert tuned["trainable_parameters"] == 3 * len(PAPER_FEATURES) + 3
    after = load_checkpoint(tmp_path / "tuned.pt")
    assert torch.equal(after.model.before.weight, record.model.before.weight)  # frozen tap
    assert not torch.equal(after.model.now.weight, record.model.now.weight)

    trial = sorted((data / "test" / "Traction").glob("*.csv"))[0]
    frame = read_recording(trial)
    estimator = StreamingEstimator.from_checkpoint(tmp_path / "toy.pt", backend="torch")
    streamed = np.array([estimator.step(row).force_hex10 for row in frame.to_dict("records")])
    np.testing.assert_allclose(streamed, estimator.predict_recording(frame), atol=1e-5)

    written = export(tmp_path / "toy.pt", tmp_path / "export")
    spec = json.loads((tmp_path / "export" / "hybrid.json").read_text())
    assert spec["model"] == "toy" and written["onnx_vs_torch_max_abs_diff"] < 1e-5
    np.testing.assert_allclose(run_export(tmp_path / "export", frame), streamed, atol=1e-4)


def test_the_cli_serves_a_registered_model(toy, data, tmp_path):
    assert main(["train", "--data", str(data), "--model", "toy", "--epochs", "1",
                 "--out", str(tmp_path / "toy.pt")]) == 0
    assert main(["export", str(tmp_path / "toy.pt"), "--out", str(tmp_path / "export")]) == 0
    assert (tmp_path / "export" / "hybrid.json").exists()


def test_an_unregistered_model_is_refused_by_name(data, tmp_path):
    assert "toy" not in RECIPES
    with pytest.raises(RecipeError, match="unknown model 'toy'; known: .*'hybrid'"):
        train(data, "toy", tmp_path / "toy.pt", epochs=1)
    assert not (tmp_path / "toy.pt").exists()
    with pytest.raises(RecipeError, match="already registered"):
        register(Recipe("fcn", RECIPES["fcn"].build))


def test_a_checkpoint_of_an_unregistered_model_is_refused(toy, data, tmp_path):
    train(data, "toy", tmp_path / "toy.pt", epochs=1, train_config=TrainConfig(progress=False))
    unregister("toy")
    with pytest.raises(CheckpointError, match="cannot build model 'toy'.*unknown model"):
        load_checkpoint(tmp_path / "toy.pt")
    register(toy)  # the fixture removes it again


def test_the_table_states_what_each_shipped_model_is(data):
    assert list(RECIPES)[:6] == ["transformer", "fcn", "lstm", "hybrid", "rocket",
                                 "hybrid_transformer"]
    assert [m for m, r in RECIPES.items() if r.streams] == ["transformer", "fcn", "hybrid",
                                                            "hybrid_transformer"]
    assert [m for m, r in RECIPES.items() if not r.bias_correction] == ["lstm"]
    assert recipe("lstm").inputs().derivation == "lstm"
    with pytest.raises(RecipeError, match="fixed inputs"):
        recipe("lstm").inputs("no_hex10")
    hybrid = recipe("hybrid").inputs()
    assert hybrid.derivation == "prior" and len(hybrid.base) == 3
    assert recipe("hybrid").inputs(use_prior=False).derivation == "none"
    # what the confirmation study trained as "hybrid_transformer": the hybrid's inputs, the paper's
    # transformer and its training settings (studies/hybrid_wide_confirm.py's Variant)
    candidate = recipe("hybrid_transformer")
    assert candidate.inputs() == recipe("hybrid").inputs()
    assert candidate.optimiser == recipe("transformer").optimiser
    assert candidate.config_ranges == recipe("transformer").config_ranges
    assert type(candidate.make(4, {})) is type(recipe("transformer").make(4, {}))
