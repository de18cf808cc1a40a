"""A window network run one sample at a time: the step protocol over its last ``window`` inputs.

A window model (:mod:`psmforce.estimators.networks.contract`, ``kind = "window"``: the paper's
transformer, the FCN, or a registered network of that kind) estimates the last sample of a window
of scaled inputs. :class:`StreamedWindow` gives it the step protocol of
:mod:`psmforce.estimators.runtime.steppers`, so that it streams
(:class:`psmforce.estimators.runtime.streaming.StreamingEstimator`, ``psmforce serve``) and exports
to a step graph like the hybrid's network:

* the state is the last ``window`` scaled input samples, oldest first, ``(B, window, F)``;
* a step shifts the new sample in and runs the network on the whole window, so the estimate of
  sample ``t`` is the network on samples ``t - window + 1 .. t``: what the offline evaluation
  computes for every sample from ``window - 1`` on
  (:func:`psmforce.estimators.evaluation.evaluate.predict_trial`), before the metrics'
  post-processing;
* before that, the window is padded with zeros (in scaled units: the training mean), the step
  protocol's zero start; the streaming estimator flags those ``window - 1`` answers
  ``WARMING_UP``, and the offline evaluation gives none there.

Only window networks with scaled outputs stream: the streaming pipeline un-scales every answer
with the target scaler.

Each step recomputes the whole window (the hybrid's network caches keys and values and adds one
token per layer), so a step of the paper's transformer costs its full batch-1 forward; its cost
beside the hybrid's is in ``benchmarks/streaming.py``. A closed-form window model (the
MultiRocket-Hydra baseline) is numpy, not torch, and does not stream.
"""

from __future__ import annotations

import numpy as np
import torch

from psmforce.estimators.data.dataset import sliding_windows
from psmforce.estimators.networks.contract import is_window_network
from psmforce.estimators.networks.uncertainty import predicts_variance
from psmforce.estimators.runtime.steppers import StreamingError

PREDICT_BATCH = 1024
"""Windows per call of :meth:`StreamedWindow.predict_sequence` (memory: ``PREDICT_BATCH x window x
F`` floats)."""


class StreamedWindow(torch.nn.Module):
    """``network`` (a window network, :func:`~psmforce.estimators.networks.contract.is_window_network`,
    of ``n_features`` inputs) under the step protocol; see the module docstring. Its weights are
    the network's own, not a copy; its state lives on the network's device. A network that does
    not take ``n_features`` inputs is refused (:class:`StreamingError`, one line)."""

    kind = "chunk"
    state_names = ("window_inputs",)

    def __init__(self, network: torch.nn.Module, n_features: int):
        super().__init__()
        self.network = network
        self.window = int(network.window)
        self.n_features = int(n_features)
        self.output_space = network.output_space
        self.predicts_variance = predicts_variance(network)
        training = network.training
        try:   # a window of zeros: what the first step will run
            with torch.inference_mode():
                network.eval()(*self.stream_state(1))
        except RuntimeError as err:
            raise StreamingError(f"the {type(network).__name__} window network does not take "
                                 f"{self.n_features} input features: {str(err).splitlines()[0]}"
                                 ) from None
        finally:
            network.train(training)

    def _device(self) -> torch.device:
        return next(self.network.parameters()).device

    def stream_state(self, batch: int = 1) -> tuple[torch.Tensor]:
        return (torch.zeros(batch, self.window, self.n_features, device=self._device()),)

    def stream_step(self, x: torch.Tensor, window_inputs: torch.Tensor
                    ) -> tuple[torch.Tensor, torch.Tensor]:
        window_inputs = torch.cat((window_inputs[:, 1:], x[:, None]), dim=1)
        return self.network(window_inputs), window_inputs

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, F) -> (B, T, C): each sample's estimate from the zero-padded window ending at
        it, the same function as stepping from :meth:`stream_state`."""
        b, t, f = x.shape
        padded = torch.cat((x.new_zeros(b, self.window - 1, f), x), dim=1)
        windows = padded.unfold(1, self.window, 1).transpose(2, 3)   # (B, T, window, F)
        return self.network(windows.reshape(b * t, self.window, f)).reshape(b, t, -1)

    def predict_sequence(self, x: np.ndarray) -> np.ndarray:
        """Offline: (N, F) -> (N, C) for one long sequence, equal to stepping from
        :meth:`stream_state` (up to float rounding), in batches of :data:`PREDICT_BATCH`."""
        x = np.ascontiguousarray(x, dtype=np.float32)
        padded = np.concatenate([np.zeros((self.window - 1, x.shape[1]), np.float32), x])
        views = sliding_windows(padded, self.window, 1)
        device = self._device()
        self.eval()
        with torch.inference_mode():
            out = [self.network(torch.from_numpy(np.array(views[i:i + PREDICT_BATCH])).to(device))
                   .cpu() for i in range(0, len(views), PREDICT_BATCH)]
        return torch.cat(out).numpy() if out else np.zeros((0, 6 if self.predicts_variance
                                                            else 3), np.float32)


def as_streamable(model, n_features: int):
    """``model`` ready for the step protocol: a :class:`StreamedWindow` around a window network
    (:func:`~psmforce.estimators.networks.contract.is_window_network`), else ``model`` itself (a
    streamable chunk model; for any other,
    :func:`psmforce.estimators.runtime.steppers.not_streamable` then names what it lacks)."""
    return StreamedWindow(model, n_features) if is_window_network(model) else model
