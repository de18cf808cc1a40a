"""Training regimes: how densely a network's targets are supervised and how long it may train,
kept apart from the model so that a comparison can swap them (issue 45).

Each model's recipe carries its own settings (:attr:`psmforce.estimators.networks.recipes.Recipe.optimiser`):
the paper's models train as the paper trains them, the hybrid with its denser regime. A regime
named here replaces the part of those settings that says which samples are targets, how many
go in a batch and the epoch cap, the same way for every network of a kind, and leaves the rest
(learning rate, weight decay) as the recipe has it. A closed-form model (MultiRocket-Hydra) has
no epochs and keeps its settings under every regime:

- ``"paper"``: one target every fifth sample (free space 4x sparser), 256 targets per batch,
  at most 100 epochs. A window model sees windows 5 samples apart; a chunk model sees chunks of
  its warm-up plus one supervised sample, 5 samples apart: as many targets, from the same
  starts, as a window model whose window is that warm-up (each one sample later).
- ``"dense"``: every sample a target, at most 300 epochs. A chunk model trains on batches of 64
  chunks of its warm-up plus 25 supervised samples (the hybrid's own regime); a window model on
  windows 1 sample apart in batches of 256 (a window model has one target per window, so
  "every sample" means 5x the paper's windows per epoch).

Early stopping ends every run in both; the cap must not bind (the fit report says when it did).
"""

from __future__ import annotations

from psmforce.estimators.networks.recipes import Recipe

REGIMES = ("own", "paper", "dense")
"""``"own"``: each recipe's settings unchanged; the others as the module docstring says."""

_SETTINGS: dict[str, dict[str, dict]] = {
    "paper": {"window": {"stride": 5, "batch_size": 256, "max_epochs": 100},
              "chunk": {"chunk_supervised": 1, "chunk_stride": 5, "chunk_batch_size": 256,
                        "max_epochs": 100}},
    "dense": {"window": {"stride": 1, "batch_size": 256, "max_epochs": 300},
              "chunk": {"chunk_supervised": 25, "chunk_stride": None, "chunk_batch_size": 64,
                        "max_epochs": 300}},
}
_REPLACED = {"stride", "batch_size", "max_epochs", "chunk", "chunk_supervised", "chunk_stride",
             "chunk_batch_size"}
"""The settings a regime owns: a recipe's value of any of them is dropped under a regime."""


class RegimeError(ValueError):
    """An unknown regime; the message lists the known ones."""


def regime_settings(regime: str, spec: Recipe) -> dict:
    """The :class:`psmforce.estimators.training.train.TrainConfig` overrides of the model of recipe
    ``spec`` under ``regime``: its own settings for ``"own"`` and for a closed-form model."""
    if regime not in REGIMES:
        raise RegimeError(f"unknown training regime {regime!r}; known: {', '.join(REGIMES)}")
    if regime == "own" or spec.closed_form:
        return dict(spec.optimiser)
    kept = {k: v for k, v in spec.optimiser.items() if k not in _REPLACED}
    return kept | {k: v for k, v in _SETTINGS[regime][spec.kind].items() if v is not None}
