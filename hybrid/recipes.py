"""One recipe per model: the table every part of ``hybrid/`` reads to treat models differently.

A :class:`Recipe` says, for one model name, how to build the model, which columns it reads and how
they are derived from a recording (:class:`Inputs`, :data:`DERIVATIONS`), which columns are added
back to its output (the base of a residual model), whether the paper's first-0.5 s bias
correction applies, its optimiser settings, whether it is fitted by :mod:`hybrid.train`'s loop or
in closed form, whether it streams (the step protocol of :mod:`hybrid.steppers`), and which
variants ``psmforce reproduce`` runs of it, and the valid values of its constructor's arguments
(:attr:`Recipe.config_ranges`, :attr:`Recipe.config_rules`: positive sizes, heads dividing the
width, bounded windows and streaming memory), which :func:`build_model` checks before anything
is allocated, for a config typed on the command line or read from a checkpoint alike
(:func:`check_config`: one line naming the key). Training, evaluation, finetuning, calibration,
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


MAX_FEATURES = 4096
"""Most input columns a model is built for (the paper's models read 21 to 36)."""
MAX_STATE_FLOATS = 2 ** 24
"""Most floats in one streaming cache of the hybrid (``n_layers * attention_window * d_model``:
64 MB in float32), so a config, typed or read from a checkpoint, cannot ask for gigabytes."""


@dataclass(frozen=True)
class Param:
    """A constructor argument's valid values: ``kind`` int (not bool) in [lo, hi], float in
    [lo, hi) (finite), bool, or ``"torques"`` (6 finite numbers > 0)."""

    kind: object
    lo: float | None = None
    hi: float | None = None
    default: object = None

    def check(self, model: str, key: str, value) -> None:
        def bad(expected: str) -> RecipeError:
            return RecipeError(f"config of model '{model}': {key} must be {expected}, "
                               f"got {value!r:.80}")
        if self.kind is bool:
            if not isinstance(value, bool):
                raise bad("true or false")
        elif self.kind is int:
            if isinstance(value, bool) or not isinstance(value, int) \
                    or not self.lo <= value <= self.hi:
                raise bad(f"an integer in [{self.lo:g}, {self.hi:g}]")
        elif self.kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not self.lo <= value < self.hi:  # also refuses NaN
                raise bad(f"a number in [{self.lo:g}, {self.hi:g})")
        elif self.kind == "torques":
            if not isinstance(value, (list, tuple)) or len(value) != 6 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and 0 < v < 1e6
                    for v in value):
                raise bad("6 numbers in (0, 1e6)")


def _heads_divide_width(model: str, config: dict, ranges: dict) -> None:
    width = config.get("d_model", ranges["d_model"].default)
    heads = config.get("n_heads", ranges["n_heads"].default)
    if width % heads:
        raise RecipeError(f"config of model '{model}': n_heads must divide d_model "
                          f"({width}), got {heads}")


def _hybrid_rules(model: str, config: dict, ranges: dict) -> None:
    _heads_divide_width(model, config, ranges)
    floats = 1
    for key in ("n_layers", "attention_window", "d_model"):
        floats *= config.get(key, ranges[key].default)
    if floats > MAX_STATE_FLOATS:
        raise RecipeError(f"config of model '{model}': attention_window too large: n_layers "
                          f"x attention_window x d_model = {floats} floats per streaming cache, "
                          f"more than {MAX_STATE_FLOATS} (hybrid.recipes.MAX_STATE_FLOATS)")


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
    config_ranges: dict = field(default_factory=dict)
    """Constructor argument -> :class:`Param`, its valid values; empty: the constructor alone
    checks (a test's toy model). With ranges, an unknown argument is refused by name."""
    config_rules: Callable[[str, dict, dict], None] | None = None
    """(model name, config, ranges) -> None or :class:`RecipeError`: rules across arguments
    (heads divide the width, bounded streaming memory)."""


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


def check_config(name: str, n_features: int, config: dict | None = None) -> None:
    """Refuse, in one line naming the key and before anything is allocated, a ``config`` (the
    constructor's keyword arguments) outside the recipe's :attr:`Recipe.config_ranges` and
    rules, or an input count outside [1, :data:`MAX_FEATURES`]."""
    found = recipe(name)
    if isinstance(n_features, bool) or not isinstance(n_features, int) \
            or not 1 <= n_features <= MAX_FEATURES:
        raise RecipeError(f"model '{name}' needs 1 to {MAX_FEATURES} input columns, got "
                          f"{n_features!r}")
    if config is None:
        return
    if not isinstance(config, dict):
        raise RecipeError(f"config of model '{name}' must be an object of its constructor's "
                          f"arguments, got {type(config).__name__}")
    ranges = found.config_ranges
    if not ranges:
        return
    unknown = sorted(k for k in config if k not in ranges)
    if unknown:
        raise RecipeError(f"config '{unknown[0]}' is not an argument of model '{name}'; it "
                          f"takes {sorted(ranges)}")
    for key, value in config.items():
        ranges[key].check(name, key, value)
    if found.config_rules is not None:
        found.config_rules(name, config, ranges)


def build_model(name: str, n_features: int, config: dict | None = None):
    """A fresh model by name; ``config`` holds its constructor's keyword arguments (saved in
    checkpoints), checked first (:func:`check_config`)."""
    check_config(name, n_features, config)
    return recipe(name).build(n_features, dict(config or {}))


_WIDTH = {"d_model": Param(int, 1, 1024, 64), "n_heads": Param(int, 1, 64, 8),
          "n_layers": Param(int, 1, 16, 3), "d_ff": Param(int, 1, 8192, 256),
          "dropout": Param(float, 0.0, 1.0, 0.1)}
TRANSFORMER_RANGES = {"window": Param(int, 1, 4096, 100), **_WIDTH}
FCN_RANGES = {"hidden": Param(int, 1, 8192, 64)}
LSTM_RANGES = {"window": Param(int, 1, 100_000, 100), "hidden": Param(int, 1, 2048, 128),
               "head": Param(int, 1, 2048, 64), "max_torque": Param("torques")}
HYBRID_RANGES = {**_WIDTH, "d_model": Param(int, 1, 1024, 32), "n_heads": Param(int, 1, 64, 4),
                 "n_layers": Param(int, 1, 16, 2), "d_ff": Param(int, 1, 8192, 64),
                 "attention_window": Param(int, 1, 4096, 50), "uncertainty": Param(bool)}
ROCKET_RANGES = {"window": Param(int, 9, 4096, 100),
                 "n_kernels_multirocket": Param(int, 84, 100_000, 504),
                 "n_kernels_hydra": Param(int, 16, 100_000, 128),
                 "max_train_windows": Param(int, 2, 10_000_000, 20_000),
                 "seed": Param(int, 0, 2 ** 32 - 1, 0), "threads": Param(int, 1, 1024, 1)}
"""The constructors' valid arguments (their defaults as in the constructors)."""


register(Recipe("transformer", "Transformer (paper)", _transformer, data_efficiency=True,
                published_nrmse_pct={"Fx": 1.45, "Fy": 1.31, "Fz": 2.26},  # its Table III
                config_ranges=TRANSFORMER_RANGES, config_rules=_heads_divide_width))
register(Recipe("fcn", "FCN", _fcn, config_ranges=FCN_RANGES))
register(Recipe("lstm", "LSTM (Yang et al.)", _lstm, _lstm_inputs, bias_correction=False,
                # Table S1 (automated data); the 1000-sample sequences are Yang et al.'s
                optimiser={"lr": 5e-3, "weight_decay": 1e-6, "chunk": 1000},
                config_ranges=LSTM_RANGES))
register(Recipe("hybrid", "Hybrid (ours)", _hybrid, _hybrid_inputs, uses_prior=True,
                streams=True, ablations=("no_prior",) + ABLATION_GROUPS, data_efficiency=True,
                # an epoch is ~7 batches of 16 chunks, so 100 epochs (the paper's limit for
                # window models) stopped runs still improving; the limit must not bind
                optimiser={"max_epochs": 300}, config_ranges=HYBRID_RANGES,
                config_rules=_hybrid_rules))
register(Recipe("rocket", "MultiRocket-Hydra", _rocket, closed_form=True,
                config_ranges=ROCKET_RANGES))
