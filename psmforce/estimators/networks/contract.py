"""What a model provides, written once: the protocols every part of ``psmforce/estimators/`` reads a model by.

A model the recipe table builds (:func:`psmforce.estimators.networks.recipes.build_model`) is one of
two things, and :func:`check_model` refuses one that is neither, naming the members it lacks:

* a :class:`TrainableNetwork`: a ``torch.nn.Module`` fitted by
  :mod:`psmforce.estimators.training.train`'s loop (the paper's transformer, the FCN, the LSTM, the
  hybrid);
* a :class:`ClosedFormModel`: fitted in one call on the training windows, no loop (the
  MultiRocket-Hydra baseline, :mod:`psmforce.estimators.networks.rocket`).

Both are an :class:`Estimator`: ``kind`` is ``"window"`` (standard-scaled (B, L, F) windows -> one
estimate of the last sample each, (B, C); L = ``window``) or ``"chunk"`` (causal, (B, T, F) -> (B,
T, C), an estimate per sample, the first ``window`` a warm-up); ``output_space`` is ``"scaled"``
(standard-scaled targets, un-scaled with the training target statistics) or ``"newton"`` (force in
N, HEX10 frame); C = 3, or 6 where an optional ``predicts_variance`` is true
(:mod:`psmforce.estimators.networks.uncertainty`). A window network may also split into
``features(x)`` and ``decode(features)``: finetuning then computes the frozen features once.

A :class:`StreamableModel` is a chunk network that also runs one sample at a time (the step protocol
of :mod:`psmforce.estimators.runtime.steppers`): it streams
(:class:`psmforce.estimators.runtime.streaming.StreamingEstimator`) and exports to a step graph
(:mod:`psmforce.estimators.runtime.export`). :class:`StepModel` is that step protocol alone, what
the step backends read. A trainable window network streams too, its last ``window`` samples
carried as the state (:mod:`psmforce.estimators.runtime.window_stream`); :func:`can_stream` says
which models do.

The protocols are ``runtime_checkable``: ``isinstance(model, ClosedFormModel)`` is how code
dispatches (never a model's name); :func:`missing` lists what an object lacks of one.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

KINDS = ("window", "chunk")
OUTPUT_SPACES = ("scaled", "newton")


class ContractError(ValueError):
    """A model that does not provide what its protocol says; the message names the members."""


@runtime_checkable
class Estimator(Protocol):
    """What every model provides (see the module docstring for ``kind`` and ``output_space``)."""

    kind: str
    window: int
    """Samples per window (window models) or the warm-up / receptive field (chunk models)."""
    output_space: str

    def state_dict(self) -> dict:
        """Plain tensors only: a checkpoint holds no pickled code."""

    def load_state_dict(self, state: dict, strict: bool = True) -> Any: ...

    def to(self, device) -> Any: ...

    def eval(self) -> Any: ...


@runtime_checkable
class TrainableNetwork(Estimator, Protocol):
    """A ``torch.nn.Module`` the training loop fits: called on a batch, its parameters
    optimised; ``finetune_modules()`` are the modules left trainable when finetuning (the
    paper's "last decoder block")."""

    def __call__(self, x) -> Any: ...

    def parameters(self) -> Any: ...

    def finetune_modules(self) -> list: ...


@runtime_checkable
class ClosedFormModel(Estimator, Protocol):
    """A window model fitted in closed form on numpy windows ((N, L, F) -> (N, 3), scaled)."""

    def fit(self, windows: np.ndarray, targets: np.ndarray, val_windows=None,
            val_targets=None) -> dict:
        """Fit on the training windows, a penalty or the like chosen on the validation ones;
        returns the fit report (``criterion_rmse``: the validation RMSE, scaled units)."""

    def refit_head(self, windows: np.ndarray, targets: np.ndarray, val_windows=None,
                   val_targets=None) -> dict:
        """Finetuning: the features kept, the last map refitted; the fit report."""

    def predict(self, windows: np.ndarray) -> np.ndarray: ...

    def subsample_indices(self, n: int, stream: int) -> np.ndarray:
        """Which of ``n`` windows it keeps (seeded; ``stream`` 0 training, 1 validation)."""

    def config(self) -> dict:
        """Every constructor argument, as the checkpoint records them."""

    def n_parameters(self) -> int: ...


@runtime_checkable
class StepModel(Protocol):
    """The step protocol of :mod:`psmforce.estimators.runtime.steppers` (its module docstring says what each does)."""

    kind: str
    window: int
    n_features: int
    state_names: tuple

    def stream_state(self, batch: int = 1) -> tuple: ...

    def stream_step(self, x, *state) -> tuple: ...

    def predict_sequence(self, x: np.ndarray) -> np.ndarray: ...


@runtime_checkable
class StreamableModel(TrainableNetwork, StepModel, Protocol):
    """A chunk network that also streams (see the module docstring)."""


def members(protocol: type) -> tuple[str, ...]:
    """The members ``protocol`` requires, its bases' first, each in the order it declares them
    (attributes, then methods)."""
    names: dict[str, None] = {}
    for base in reversed(protocol.__mro__):
        if base in (Protocol, object) or not getattr(base, "_is_protocol", False):
            continue
        names.update(dict.fromkeys(vars(base).get("__annotations__", {})))
        names.update(dict.fromkeys(n for n, v in vars(base).items() if callable(v)
                                   and (not n.startswith("_") or n == "__call__")))
    return tuple(names)


def missing(obj, protocol: type) -> list[str]:
    """The members of ``protocol`` that ``obj`` lacks (empty: it provides them all)."""
    return [m for m in members(protocol) if not hasattr(obj, m)]


def is_chunk(model) -> bool:
    """Whether ``model`` estimates every sample of a chunk (``kind`` ``"chunk"``), not the last
    sample of each window (``"window"``)."""
    return model.kind == "chunk"


def is_streamable(model) -> bool:
    """Whether ``model`` provides :class:`StreamableModel` and is a causal chunk model."""
    return isinstance(model, StreamableModel) and is_chunk(model)


def is_window_network(model) -> bool:
    """Whether ``model`` is a trainable window network with scaled outputs, which streams with
    its last ``window`` samples as its state
    (:class:`psmforce.estimators.runtime.window_stream.StreamedWindow`; the streaming pipeline
    un-scales every answer, so a window network in newtons does not stream)."""
    return (isinstance(model, TrainableNetwork) and not is_chunk(model)
            and model.output_space == "scaled")


def can_stream(model) -> bool:
    """Whether ``model`` runs one sample at a time: a :class:`StreamableModel` itself, or a
    window network (:func:`is_window_network`)."""
    return is_streamable(model) or is_window_network(model)


def check_model(model, name: str) -> None:
    """Refuse a model built for the recipe ``name`` that is neither a :class:`TrainableNetwork`
    nor a :class:`ClosedFormModel`, or whose ``kind`` / ``output_space`` is not one of
    :data:`KINDS` / :data:`OUTPUT_SPACES`: one line naming the members it lacks."""
    what = f"model '{name}' ({type(model).__name__})"
    if not isinstance(model, (TrainableNetwork, ClosedFormModel)):
        lacks = {p.__name__: missing(model, p) for p in (TrainableNetwork, ClosedFormModel)}
        raise ContractError(f"{what} is neither a trainable network nor a closed-form model "
                            f"(psmforce.estimators.networks.contract): " + "; ".join(
                                f"as a {p} it lacks {', '.join(m)}" for p, m in lacks.items()))
    if model.kind not in KINDS:
        raise ContractError(f"{what}: kind must be one of {KINDS}, got {model.kind!r}")
    if model.output_space not in OUTPUT_SPACES:
        raise ContractError(f"{what}: output_space must be one of {OUTPUT_SPACES}, got "
                            f"{model.output_space!r}")
