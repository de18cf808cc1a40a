"""Checkpoints built without training, for the tests that check what happens before a model
predicts (whether it streams, exports, reads the data's columns)."""

from pathlib import Path

import numpy as np


def untrained_checkpoint(name: str, path: Path) -> Path:
    """An untrained ``name`` model on its recipe's default inputs, unit scalers: enough for what
    is checked before predicting (whether it streams, exports, fits the data's columns)."""
    from psmforce.estimators.data.dataset import Scaler
    from psmforce.estimators.networks.recipes import build_model, recipe
    from psmforce.estimators.training.checkpoint import TrainedModel
    features = recipe(name).inputs().features
    unit = [Scaler(np.zeros(n, np.float32), np.ones(n, np.float32)) for n in (len(features), 3)]
    return TrainedModel(name, {}, features, *unit,
                        model=build_model(name, len(features))).save(path)
