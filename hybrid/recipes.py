"""One recipe per model: the table every part of ``hybrid/`` reads to treat models differently.

A :class:`Recipe` says, for one model name, how to build the model, which columns it reads and how
they are derived from a recording (:class:`Inputs`, :data:`DERIVATIONS`), which columns are added
back to its output (the base of a residual model), whether the paper's first-0.5 s bias
correction applies, its optimiser settings, whether it is fitted by :mod:`hybrid.train`'s loop or
in closed form, whether it streams (the step protocol of :mod:`hybrid.steppers`), and which
variants ``psmforce reproduce`` runs of it. Training, evaluation, finetuning, calibration,
reproduce, streaming, export and the CLI read :data:`RECIPES`; no other module compares model
names. A new model is one :func:`register` call (``tests/test_recipes.py`` registers a toy model
and trains, evaluates, streams and exports it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

from hybrid.causal import CausalTransformer
from hybrid.data import Dataset, resolve_features
from hybrid.lstm_inputs import LSTM_FEATURES, LSTM_RAW_COLUMNS, lstm_columns
from hybrid.inputs import add_prior_columns, hybrid_feature_set, prior_from_json
from hybrid.models import FCN, JointLSTMForce, PaperTransformer
from hybrid.rocket import RocketRegressor

Features = str | Sequence[str] | None
"""A feature-set name of :data:`hybrid.data.FEATURE_SETS`, an explicit column list, or None (the
model's default inputs)."""


class RecipeError(ValueError):
    """A model name or an input request that no recipe serves; the message says why."""


@dataclass(frozen=True)
class Inputs:
    """What a model reads: network inputs in order, the base (0 or 3 columns added to its output;
    :data:`hybrid.data.NO_BASE` on an axis without one), the input columns left unscaled, and the
    derivation (a key of :data:`DERIVATIONS`) that adds the derived ones to a recording."""

    features: tuple[str, ...]
    base: tuple[str, ...] = ()
    raw: tuple[str, ...] = ()
    derivation: str = "none"


def recorded_inputs(features: Features = None, use_prior: bool = True) -> Inputs:
    """Recorded columns only: a named set or a list (default: the paper's 21 inputs)."""
    return Inputs(resolve_features(features or "paper"))


def _lstm_inputs(features: Features = None, use_prior: bool = True) -> Inputs:
    if features not in (None, "lstm") and resolve_features(features) != LSTM_FEATURES:
        raise RecipeError("the LSTM baseline takes its fixed inputs "
                          "(hybrid.lstm_inputs.LSTM_FEATURES); feature sets do not apply to it")
    return Inputs(LSTM_FEATURES, raw=LSTM_RAW_COLUMNS, derivation="lstm")


def _hybrid_inputs(features: Features = None, use_prior: bool = True) -> Inputs:
    columns, base = hybrid_feature_set(features, use_prior)
    return Inputs(columns, base, derivation="prior" if use_prior else "none")


def _derive_lstm(dataset: Dataset, prior_json: str | None) -> None:
    from psm_model import PSM
    dataset.add_columns(lstm_columns(PSM()))


def _derive_prior(dataset: Dataset, prior_json: str | None) -> None:
    add_prior_columns(dataset, prior_from_json(prior_json))


DERIVATIONS: dict[str, Callable[[Dataset, str | None], None]] = {
    "none": lambda dataset, prior_json: None,
    "lstm": _derive_lstm,
    "prior": _derive_prior,
}
"""How the derived input columns are added to every trial of a dataset: ``"lstm"``, the
Jacobian map A(q) of the LSTM baseline (:func:`hybrid.lstm_inputs.lstm_columns`); ``"prior"``, the
prior-compensated columns (:func:`hybrid.inputs.add_prior_columns`, the prior from its JSON)."""


@dataclass(frozen=True)
class Recipe:
    """Everything that differs between models; see the module docstring."""

    name: str
    label: str
    """The name in tables and figures."""
    build: Callable[[int, dict], object]
    """(number of input columns, constructor keyword arguments) -> an untrained model."""
    inputs: Callable[..., Inputs] = recorded_inputs
    """(features, use_prior) -> :class:`Inputs`."""
    bias_correction: bool = True
    """The paper's first-0.5 s bias correction in the offline metric (off for the LSTM, as in
    the paper)."""
    optimiser: dict = field(default_factory=dict)
    """:class:`hybrid.train.TrainConfig` overrides for pretraining (the paper's Table S1)."""
    closed_form: bool = False
    """Fitted in closed form (its ``fit`` / ``refit_head``), not by the training loop."""
    uses_prior: bool = False
    """Trained with the internal-force prior (fitted when none is given)."""
    streams: bool = False
    """Runs in :class:`hybrid.streaming.StreamingEstimator` and exports to a step graph."""
    ablations: tuple[str, ...] = ()
    """``psmforce reproduce``'s extra variants of this model: ``"no_prior"`` or input groups of
    :data:`hybrid.data.FEATURE_SETS`."""
    data_efficiency: bool = False
    """``psmforce reproduce`` trains it on fractions of the training trials too."""
    published_nrmse_pct: dict | None = None
    """The seed paper's NRMSE (%) per axis on its automated test set, where it reports one."""


def _transformer(n_features: int, config: dict):
    return PaperTransformer(n_features, **config)


def _fcn(n_features: int, config: dict):
    return FCN(n_features, **config)


def _lstm(n_features: int, config: dict):
    if n_features != len(LSTM_FEATURES):
        raise ValueError(f"the LSTM baseline takes the {len(LSTM_FEATURES)} columns of "
                         f"hybrid.lstm_inputs.LSTM_FEATURES, got {n_features}")
    return JointLSTMForce(**config)


def _hybrid(n_features: int, config: dict):
    return CausalTransformer(n_features, **config)


def _rocket(n_features: int, config: dict):
    return RocketRegressor(**config)  # reads its input count when fitted


ABLATION_GROUPS = ("no_hex10", "no_efforts", "no_positions", "no_velocities",
                   "no_positions_velocities")

RECIPES: dict[str, Recipe] = {}
"""Model name -> recipe, in the order tables list them."""


def register(recipe: Recipe) -> Recipe:
    """Add a model to the table (a name already taken is refused)."""
    if recipe.name in RECIPES:
        raise RecipeError(f"a model named '{recipe.name}' is already registered")
    RECIPES[recipe.name] = recipe
    return recipe


def unregister(name: str) -> None:
    """Remove a model from the table (a test's toy model, after the test)."""
    RECIPES.pop(name, None)


def recipe(name: str) -> Recipe:
    """The recipe of a model name; an unknown name is refused with the known ones."""
    try:
        return RECIPES[name]
    except KeyError:
        raise RecipeError(f"unknown model '{name}'; known: {list(RECIPES)}") from None


def build_model(name: str, n_features: int, config: dict | None = None):
    """A fresh model by name; ``config`` holds its constructor's keyword arguments (saved in
    checkpoints)."""
    return recipe(name).build(n_features, dict(config or {}))


register(Recipe("transformer", "Transformer (paper)", _transformer, data_efficiency=True,
                published_nrmse_pct={"Fx": 1.45, "Fy": 1.31, "Fz": 2.26}))  # its Table III
register(Recipe("fcn", "FCN", _fcn))
register(Recipe("lstm", "LSTM (Yang et al.)", _lstm, _lstm_inputs, bias_correction=False,
                # Table S1 (automated data); the 1000-sample sequences are Yang et al.'s
                optimiser={"lr": 5e-3, "weight_decay": 1e-6, "chunk": 1000}))
register(Recipe("hybrid", "Hybrid (ours)", _hybrid, _hybrid_inputs, uses_prior=True,
                streams=True, ablations=("no_prior",) + ABLATION_GROUPS, data_efficiency=True,
                # an epoch is ~7 batches of 16 chunks, so 100 epochs (the paper's limit for
                # window models) stopped runs still improving; the limit must not bind
                optimiser={"max_epochs": 300}))
register(Recipe("rocket", "MultiRocket-Hydra", _rocket, closed_form=True))
