"""One recipe per model: how to build it and feed it, the table ``psmforce/estimators/`` reads to build models.

A :class:`Recipe` says, for one model name, how to build the model, which columns it reads and how
they are derived from a recording (:class:`Inputs`, :data:`DERIVATIONS`), which columns are added
back to its output (the base of a residual model), whether the paper's first-0.5 s bias correction
applies, its optimiser settings, and the valid values of its constructor's arguments
(:attr:`Recipe.config_ranges`, :attr:`Recipe.config_rules`: positive sizes, heads dividing the
width, bounded windows and streaming memory), which :func:`build_model` checks before anything is
allocated, for a config typed on the command line or read from a checkpoint alike
(:func:`check_config`: one line naming the key). What the model is (a trainable network, a
closed-form model, one that streams) the model says itself through the protocols of
:mod:`psmforce.estimators.networks.contract`, checked on every model :func:`build_model` makes; the
recipe's :attr:`Recipe.closed_form`, :attr:`Recipe.streams` and :attr:`Recipe.uses_prior` are
derived from the model and its inputs, never stated twice. What ``psmforce reproduce`` runs of a
model (its label, ablations, data efficiency, published figures) is the experiment plan,
:data:`psmforce.experiments.plan.PLAN`, not the model's recipe.

Training, evaluation, finetuning, calibration, reproduce, streaming, export and the CLI read
:data:`RECIPES`; no other module compares model names. A new model is one :func:`register` call
(``tests/estimators/test_recipes.py`` registers a toy model and trains, evaluates, streams and
exports it). :func:`register` notes the module that called it; a checkpoint of a model registered
outside this module records it as ``"module:attribute"`` (:func:`origin`). Loading never imports
it: a file does not choose which code runs. The user imports the module (``psmforce --plugin
mymodels evaluate ...``, :func:`load_plugins`; ``import mymodels`` in Python), and a checkpoint of
an unregistered model is refused naming the module it recorded (:func:`require_recipe`).

Size: one table with its row type, the checks of a row's arguments and the shipped rows; split,
a recipe would be read in one file and checked in another.
"""

from __future__ import annotations

import importlib
import re
import sys
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Callable, Sequence

import torch

from psmforce.estimators.networks.causal import CausalTransformer
from psmforce.estimators.networks.contract import ClosedFormModel, can_stream, check_model
from psmforce.estimators.data.dataset import Dataset, resolve_features
from psmforce.estimators.data.lstm_inputs import LSTM_FEATURES, LSTM_RAW_COLUMNS, lstm_columns
from psmforce.estimators.data.hybrid_inputs import (add_prior_columns, hybrid_feature_set,
                                                    prior_from_json)
from psmforce.estimators.networks.baselines import FCN, JointLSTMForce, PaperTransformer
from psmforce.estimators.networks.rocket import RocketRegressor

Features = str | Sequence[str] | None
"""A feature-set name of :data:`psmforce.estimators.data.dataset.FEATURE_SETS`, an explicit column list, or None (the
model's default inputs)."""


class RecipeError(ValueError):
    """A model name or an input request that no recipe serves; the message says why."""


MAX_FEATURES = 4096
"""Most input columns a model is built for (the paper's models read 21 to 36)."""
MAX_STATE_FLOATS = 2 ** 24
"""Most floats in one streaming state (the hybrid's cache, ``n_layers * attention_window *
d_model``; a window network's ``window * features``): 64 MB in float32, so a config, typed or
read from a checkpoint, cannot ask for gigabytes."""


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
                          f"more than {MAX_STATE_FLOATS} (psmforce.estimators.networks.recipes.MAX_STATE_FLOATS)")


@dataclass(frozen=True)
class Inputs:
    """What a model reads: network inputs in order, the base (0 or 3 columns added to its output;
    :data:`psmforce.estimators.data.dataset.NO_BASE` on an axis without one), the input columns left
    unscaled, and the derivation (a key of :data:`DERIVATIONS`) that adds the derived ones to a
    recording."""

    features: tuple[str, ...]
    base: tuple[str, ...] = ()
    raw: tuple[str, ...] = ()
    derivation: str = "none"

    @property
    def uses_prior(self) -> bool:
        """Derived with the internal-force prior (derivation ``"prior"``): training needs one."""
        return self.derivation == "prior"


def recorded_inputs(features: Features = None, use_prior: bool = True) -> Inputs:
    """Recorded columns only: a named set or a list (default: the paper's 21 inputs)."""
    return Inputs(resolve_features(features or "paper"))


def _lstm_inputs(features: Features = None, use_prior: bool = True) -> Inputs:
    if features not in (None, "lstm") and resolve_features(features) != LSTM_FEATURES:
        raise RecipeError("the LSTM baseline takes its fixed inputs "
                          "(psmforce.estimators.data.lstm_inputs.LSTM_FEATURES); feature sets do not apply to it")
    return Inputs(LSTM_FEATURES, raw=LSTM_RAW_COLUMNS, derivation="lstm")


def _hybrid_inputs(features: Features = None, use_prior: bool = True) -> Inputs:
    columns, base = hybrid_feature_set(features, use_prior)
    return Inputs(columns, base, derivation="prior" if use_prior else "none")


def _derive_lstm(dataset: Dataset, prior_json: str | None) -> None:
    from psmforce.robot import PSM
    dataset.add_columns(lstm_columns(PSM()))


def _derive_prior(dataset: Dataset, prior_json: str | None) -> None:
    add_prior_columns(dataset, prior_from_json(prior_json))


DERIVATIONS: dict[str, Callable[[Dataset, str | None], None]] = {
    "none": lambda dataset, prior_json: None,
    "lstm": _derive_lstm,
    "prior": _derive_prior,
}
"""How the derived input columns are added to every trial of a dataset: ``"lstm"``, the
Jacobian map A(q) of the LSTM baseline (:func:`psmforce.estimators.data.lstm_inputs.lstm_columns`);
``"prior"``, the prior-compensated columns
(:func:`psmforce.estimators.data.hybrid_inputs.add_prior_columns`, the prior from its JSON)."""


@dataclass(frozen=True)
class Recipe:
    """How to build and feed one model; see the module docstring."""

    name: str
    build: Callable[[int, dict], object]
    """(number of input columns, constructor keyword arguments) -> an untrained model, one of
    the protocols of :mod:`psmforce.estimators.networks.contract`; it must build from an empty config."""
    inputs: Callable[..., Inputs] = recorded_inputs
    """(features, use_prior) -> :class:`Inputs`."""
    bias_correction: bool = True
    """The paper's first-0.5 s bias correction in the offline metric (off for the LSTM, as in
    the paper)."""
    optimiser: dict = field(default_factory=dict)
    """:class:`psmforce.estimators.training.train.TrainConfig` overrides for pretraining (the paper's Table S1)."""
    config_ranges: dict = field(default_factory=dict)
    """Constructor argument -> :class:`Param`, its valid values; empty: the constructor alone
    checks (a test's toy model). With ranges, an unknown argument is refused by name."""
    config_rules: Callable[[str, dict, dict], None] | None = None
    """(model name, config, ranges) -> None or :class:`RecipeError`: rules across arguments
    (heads divide the width, bounded streaming memory)."""
    home: str | None = None
    """The module that registered the recipe (:func:`register` fills it in); see
    :func:`origin`."""

    def make(self, n_features: int, config: dict) -> object:
        """The model ``build`` gives, checked against :mod:`psmforce.estimators.networks.contract`
        (:class:`psmforce.estimators.networks.contract.ContractError` naming what it lacks)."""
        model = self.build(n_features, dict(config))
        check_model(model, self.name)
        return model

    @cached_property
    def _probe(self) -> object:
        """The model of the default inputs and config, what the derived flags read; built once,
        the global torch generator left as it was (a seeded training must not see it)."""
        with torch.random.fork_rng(devices=[]):
            return self.make(len(self.inputs().features), {})

    @property
    def closed_form(self) -> bool:
        """Fitted in closed form (a :class:`~.contract.ClosedFormModel`), not by the loop."""
        return isinstance(self._probe, ClosedFormModel)

    @property
    def kind(self) -> str:  # "window" or "chunk" (psmforce.estimators.networks.contract)
        return self._probe.kind

    @property
    def streams(self) -> bool:
        """Streams and exports to a step graph (:func:`~.contract.can_stream`)."""
        return can_stream(self._probe)

    @property
    def uses_prior(self) -> bool:
        """Its default inputs are derived with the internal-force prior (fitted when none is
        given); ``use_prior=False`` trains it without."""
        return self.inputs().uses_prior


def _transformer(n_features: int, config: dict):
    return PaperTransformer(n_features, **config)


def _fcn(n_features: int, config: dict):
    return FCN(n_features, **config)


def _lstm(n_features: int, config: dict):
    if n_features != len(LSTM_FEATURES):
        raise ValueError(f"the LSTM baseline takes the {len(LSTM_FEATURES)} columns of "
                         f"psmforce.estimators.data.lstm_inputs.LSTM_FEATURES, got {n_features}")
    return JointLSTMForce(**config)


def _hybrid(n_features: int, config: dict):
    return CausalTransformer(n_features, **config)


def _rocket(n_features: int, config: dict):
    return RocketRegressor(**config)  # reads its input count when fitted


RECIPES: dict[str, Recipe] = {}
"""Model name -> recipe, in the order tables list them."""

_IMPORT_PATH = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*(:[A-Za-z_]\w*)?")


def register(recipe: Recipe) -> Recipe:
    """Add a model to the table (a name already taken is refused); returns the recipe as
    registered, its :attr:`Recipe.home` the calling module unless given."""
    if recipe.name in RECIPES:
        raise RecipeError(f"a model named '{recipe.name}' is already registered")
    if recipe.home is None:
        # the module whose import performs the registration is what a new process must import
        recipe = replace(recipe, home=sys._getframe(1).f_globals.get("__name__"))
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


def origin(name: str) -> str | None:
    """Where a new process finds the recipe of model ``name``: ``"module:attribute"`` (the
    module-level name bound to a recipe of that name in the module that registered it), or
    ``"module"`` when none is bound (importing the module registers it); None for the models
    shipped here."""
    home = recipe(name).home
    if home is None or home == __name__:
        return None
    bound = sorted(k for k, v in vars(sys.modules.get(home, object())).items()
                   if isinstance(v, Recipe) and v.name == name)
    return f"{home}:{bound[0]}" if bound else home


def require_recipe(name: str, path: str | None) -> Recipe:
    """The recipe of model ``name``, which must be registered in this process; ``path`` (where a
    checkpoint says it was registered, :func:`origin`) only words the refusal. Nothing read from
    a file decides which module is imported: a model of one's own is registered by importing
    its module first, by the caller's choice (``import mymodels`` in Python, ``psmforce --plugin
    mymodels`` on the command line, :func:`load_plugins`)."""
    if name in RECIPES:
        return RECIPES[name]
    hint = ""
    if isinstance(path, str) and _IMPORT_PATH.fullmatch(path):
        module = path.partition(":")[0]
        hint = (f"; the file says module '{module}' registers it: if you trust that module, "
                f"import it first (psmforce --plugin {module} ..., or import {module} in Python)")
    raise RecipeError(f"unknown model '{name}'; known: {list(RECIPES)}{hint}")


def load_plugins(modules: Sequence[str]) -> None:
    """Import ``modules``, the user's own models (each registers its recipes when imported):
    the one place a module is imported by name. Refused with :class:`RecipeError` naming the
    module: not a dotted module name, a script (``__main__``), or not importable."""
    for module in modules:
        if not isinstance(module, str) or not _IMPORT_PATH.fullmatch(module) or ":" in module:
            raise RecipeError(f"plugin {module!r:.80}: not a module name (such as 'mymodels' "
                              f"or 'lab.models')")
        if module == "__main__":
            raise RecipeError("plugin '__main__': a script cannot be imported by another "
                              "process; register the model in an importable module")
        try:
            importlib.import_module(module)
        except ImportError as err:
            raise RecipeError(f"plugin '{module}' cannot be imported ({err}): put it on the "
                              f"Python path") from None


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
    checkpoints), checked first (:func:`check_config`); the model is checked against
    :mod:`psmforce.estimators.networks.contract` (:meth:`Recipe.make`)."""
    check_config(name, n_features, config)
    return recipe(name).make(n_features, config or {})


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


register(Recipe("transformer", _transformer, config_ranges=TRANSFORMER_RANGES,
                config_rules=_heads_divide_width))
register(Recipe("fcn", _fcn, config_ranges=FCN_RANGES))
register(Recipe("lstm", _lstm, _lstm_inputs, bias_correction=False,
                # Table S1 (automated data); the 1000-sample sequences are Yang et al.'s
                optimiser={"lr": 5e-3, "weight_decay": 1e-6, "chunk": 1000},
                config_ranges=LSTM_RANGES))
register(Recipe("hybrid", _hybrid, _hybrid_inputs,
                # batches of many short chunks from across the training set: 16 long ones (the
                # defaults) left the lateral error flat as the data grew (docs/results.md, "Why
                # the hybrid's lateral error stops improving"); early stopping ends every run,
                # the epoch limit must not bind
                optimiser={"max_epochs": 300, "chunk_supervised": 25, "chunk_batch_size": 64},
                config_ranges=HYBRID_RANGES,
                config_rules=_hybrid_rules))
register(Recipe("rocket", _rocket, config_ranges=ROCKET_RANGES))
register(Recipe("hybrid_transformer", _transformer, _hybrid_inputs,
                # the hybrid's physics (prior-compensated inputs, insertion state, base) read by
                # the paper's transformer as the paper trains it: chosen over the hybrid's causal
                # network by studies/hybrid_wide_confirm.py's rule, on seeds of its own
                config_ranges=TRANSFORMER_RANGES, config_rules=_heads_divide_width))
