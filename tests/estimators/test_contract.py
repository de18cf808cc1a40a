"""The model contract has one home (psmforce/estimators/networks/contract.py): every built model is checked against it,
the recipe's flags are derived from it, evaluation dispatches on it, and a model registered at
run time in an importable module is loaded and evaluated by a new process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import torch
from tests.estimators.test_recipes import data  # noqa: F401  (the small bench, a module fixture)

from psmforce.estimators.training.checkpoint import CheckpointError, TrainedModel, load_checkpoint
from psmforce.estimators.networks.contract import (
    ClosedFormModel,
    ContractError,
    StepModel,
    StreamableModel,
    TrainableNetwork,
    members,
)
from psmforce.estimators.data.dataset import fit_scalers, load_dataset
from psmforce.estimators.evaluation.evaluate import EVAL_START, evaluate, predict_trial
from psmforce.estimators.networks.recipes import (
    RECIPES,
    Recipe,
    RecipeError,
    build_model,
    load_plugins,
    require_recipe,
    origin,
    recipe,
    register,
    unregister,
)
from psmforce.estimators.runtime.steppers import PROTOCOL
from psmforce.estimators.training.train import TrainConfig, train
from psmforce.io.recording import HEX10_FORCE, PAPER_FEATURES

torch.set_num_threads(1)


@pytest.fixture
def registered():
    names = []

    def add(recipe: Recipe) -> Recipe:
        names.append(recipe.name)
        return register(recipe)
    yield add
    for name in names:
        unregister(name)


class NoHead(torch.nn.Module):
    """A window network that forgot ``finetune_modules``."""

    kind, output_space = "window", "scaled"

    def __init__(self, n_features: int):
        super().__init__()
        self.window, self.linear = 1, torch.nn.Linear(n_features, 3)

    def forward(self, x):
        return self.linear(x[:, -1])


class Constant:
    """A closed-form window model that predicts 0 (scaled): the target mean once un-scaled."""

    kind, output_space, window = "window", "scaled", 3

    def fit(self, windows, targets, val_windows=None, val_targets=None):
        return {"criterion_rmse": 1.0}

    refit_head = fit

    def predict(self, windows):
        return np.zeros((len(windows), 3))

    def subsample_indices(self, n, stream):
        return np.arange(n)

    def config(self):
        return {}

    def n_parameters(self):
        return 0

    def state_dict(self):
        return {}

    def load_state_dict(self, state, strict=True):
        return None

    def to(self, device):
        return self

    def eval(self):
        return self


def test_a_built_model_is_checked_against_the_contract_naming_what_it_lacks(registered):
    registered(Recipe("no_head", lambda n, config: NoHead(n)))
    with pytest.raises(ContractError, match=r"model 'no_head' \(NoHead\) is neither a trainable "
                                            r"network nor a closed-form model.*"
                                            r"as a TrainableNetwork it lacks finetune_modules;"):
        build_model("no_head", 4)
    registered(Recipe("odd_kind", lambda n, config: type(
        "OddKind", (Constant,), {"kind": "rocket"})()))
    with pytest.raises(ContractError, match="kind must be one of .*got 'rocket'"):
        build_model("odd_kind", 4)
    # a recipe's flags come from the model, so a model that breaks the contract has none
    with pytest.raises(ContractError, match="finetune_modules"):
        recipe("no_head").streams


def test_the_flags_are_derived_from_the_models_themselves():
    shipped = ["transformer", "fcn", "lstm", "hybrid", "rocket"]
    assert [m for m in shipped if recipe(m).closed_form] == ["rocket"]
    assert [m for m in shipped if recipe(m).streams] == ["transformer", "fcn", "hybrid"]
    assert [m for m in shipped if recipe(m).uses_prior] == ["hybrid"]
    for name in shipped:
        model = build_model(name, len(recipe(name).inputs().features))
        assert isinstance(model, ClosedFormModel) == (name == "rocket")
        assert isinstance(model, TrainableNetwork) == (name != "rocket")
        assert isinstance(model, StreamableModel) == (name == "hybrid")
    assert PROTOCOL == members(StepModel)  # the step protocol is written once


def test_deriving_a_flag_leaves_the_torch_generator_alone(registered):
    registered(Recipe("fresh_fcn", RECIPES["fcn"].build))
    torch.manual_seed(7)
    before = torch.get_rng_state()
    assert recipe("fresh_fcn").streams  # builds its probe model now
    assert torch.equal(torch.get_rng_state(), before)


def test_evaluation_dispatches_on_the_protocol_and_adds_the_base_for_every_model(
        registered, data):
    registered(Recipe("constant", lambda n, config: Constant()))
    trials = load_dataset(data).select(split="test")
    x_scaler, y_scaler = fit_scalers(trials, PAPER_FEATURES, base_columns=HEX10_FORCE)
    setup = TrainedModel("constant", {}, PAPER_FEATURES, x_scaler, y_scaler,
                         base_columns=HEX10_FORCE, model=build_model("constant", 21))
    for trial in trials:
        pred = predict_trial(setup, trial)
        assert np.isnan(pred[:2]).all()
        np.testing.assert_allclose(pred[2:], y_scaler.mean + trial.matrix(HEX10_FORCE,
                                                                          np.float64)[2:])


def test_evaluate_writes_the_causal_table(data, tmp_path):
    train(data, "fcn", tmp_path / "fcn.pt", epochs=1, train_config=TrainConfig(progress=False))
    result = evaluate(tmp_path / "fcn.pt", data, tmp_path / "eval", plots=False)
    md = (tmp_path / "eval" / "metrics.md").read_text()
    assert "Causal metric, test trials" in md and "HEX10 frame" in md
    causal = result["postprocessing"]["overall"]["causal"]
    assert f"{causal['Fx']['nrmse_pct']:.2f}" in md
    assert result["eval_start_sample"] == EVAL_START
    assert result["physics_only_axes"] == []    # the result says which axes the physics answers
    assert result["physics_only_prior"] == "the network's"   # and with which prior


def test_a_plugin_that_cannot_serve_is_refused_by_name():
    assert origin("hybrid") is None  # shipped: always there
    with pytest.raises(RecipeError, match="'no_such_module_xyz' cannot be imported"):
        load_plugins(["no_such_module_xyz"])
    with pytest.raises(RecipeError, match="script"):
        load_plugins(["__main__"])
    for bad in ("os; rm -rf", "json:loads", ""):
        with pytest.raises(RecipeError, match="not a module name"):
            load_plugins([bad])


def test_loading_never_imports_the_module_a_checkpoint_names(tmp_path, monkeypatch):
    """The recipe path in a file only words the refusal: nothing in a file decides which
    module is imported (issue 46, class 3). A module that would record its import is named by
    a sealed checkpoint; loading is refused and the module stays unimported."""
    modules = tmp_path / "modules"
    modules.mkdir()
    (modules / "planted_models.py").write_text("import pathlib\n"
                                               f"pathlib.Path({str(tmp_path / 'ran')!r})"
                                               ".write_text('imported')\n")
    monkeypatch.syspath_prepend(str(modules))
    with pytest.raises(RecipeError, match="unknown model 'planted'.*module 'planted_models' "
                                          "registers it.*--plugin planted_models"):
        require_recipe("planted", "planted_models:PLANTED")
    assert not (tmp_path / "ran").exists() and "planted_models" not in sys.modules
    assert require_recipe("hybrid", "planted_models:PLANTED") is recipe("hybrid")
    assert not (tmp_path / "ran").exists()


MODULE = '''
"""A model of one's own, registered when this module is imported."""
from psmforce.estimators.networks.baselines import FCN
from psmforce.estimators.networks.recipes import Recipe, register

TINY = register(Recipe("tiny_fcn", lambda n_inputs, config: FCN(n_inputs, **{"hidden": 4,
                                                                             **config})))
'''


def _cli(args, pythonpath):
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join(pythonpath)}
    return subprocess.run([sys.executable, "-m", "psmforce.cli.main", *args], env=env,
                           capture_output=True, text=True, timeout=600, check=False)


@pytest.mark.slow
@pytest.mark.e2e
def test_a_model_registered_at_run_time_is_evaluated_by_a_new_process(data, tmp_path,
                                                                      monkeypatch):
    modules = tmp_path / "modules"
    modules.mkdir()
    (modules / "tiny_models.py").write_text(textwrap.dedent(MODULE))
    monkeypatch.syspath_prepend(str(modules))
    try:
        import tiny_models  # noqa: F401 - registers tiny_fcn
        train(data, "tiny_fcn", tmp_path / "tiny.pt", epochs=1,
              train_config=TrainConfig(progress=False))
        assert load_checkpoint(tmp_path / "tiny.pt").metadata()["recipe"] == "tiny_models:TINY"
    finally:
        unregister("tiny_fcn")
        sys.modules.pop("tiny_models", None)
    with pytest.raises(CheckpointError, match="cannot build model 'tiny_fcn'.*module "
                                              "'tiny_models' registers it"):
        load_checkpoint(tmp_path / "tiny.pt")  # importable, yet not imported by the file
    assert "tiny_models" not in sys.modules
    sys.path.remove(str(modules))  # monkeypatch restores sys.path afterwards

    source = str(Path(__file__).resolve().parents[2])  # the repository
    unasked = _cli(["evaluate", str(tmp_path / "tiny.pt"), "--data", str(data), "--out",
                    str(tmp_path / "eval")], [source, str(modules)])
    assert unasked.returncode == 2 and "--plugin tiny_models" in unasked.stderr
    ok = _cli(["--plugin", "tiny_models", "evaluate", str(tmp_path / "tiny.pt"), "--data",
               str(data), "--out", str(tmp_path / "eval")], [source, str(modules)])
    assert ok.returncode == 0, ok.stderr[-2000:]
    assert "Causal metric, test trials" in ok.stdout and "HEX10 frame" in ok.stdout
    result = json.loads((tmp_path / "eval" / "metrics.json").read_text())
    assert result["model"] == "tiny_fcn"
    assert f"{result['postprocessing']['overall']['causal']['Fz']['rmse_n']:.3f}" in ok.stdout

    lost = _cli(["--plugin", "tiny_models", "evaluate", str(tmp_path / "tiny.pt"), "--data",
                 str(data), "--out", str(tmp_path / "eval2")], [source])
    assert lost.returncode == 2
    assert "tiny_models" in lost.stderr and "cannot be imported" in lost.stderr
