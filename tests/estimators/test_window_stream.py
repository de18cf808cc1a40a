"""A window network streams (psmforce.estimators.runtime.window_stream): stepping it gives the
estimate the offline evaluation scores, on every backend, through the streaming estimator and
through an export."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from psmforce.estimators.data.dataset import Scaler, Trial, sliding_windows
from psmforce.estimators.evaluation.evaluate import predict_trial
from psmforce.estimators.networks.baselines import FCN, PaperTransformer
from psmforce.estimators.networks.contract import can_stream
from psmforce.estimators.networks.recipes import build_model, recipe
from psmforce.estimators.runtime.export import export, run_export
from psmforce.estimators.runtime.steppers import make_backend, not_streamable
from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator
from psmforce.estimators.runtime.window_stream import StreamedWindow, as_streamable
from psmforce.estimators.training import checkpoint as ck
from psmforce.io.recording import PAPER_FEATURES
from tests.estimators.test_streaming import one_thread, recording, stream  # noqa: F401

WINDOW = 12


def _networks():
    torch.manual_seed(0)
    return [PaperTransformer(5, window=WINDOW, d_model=16, n_heads=2, n_layers=2, d_ff=32).eval(),
            FCN(5, hidden=8).eval()]


@pytest.mark.parametrize("network", _networks(), ids=["transformer", "fcn"])
def test_each_step_is_the_network_on_the_window_ending_there(network):
    x = np.random.default_rng(1).normal(size=(40, 5)).astype(np.float32)
    streamed = as_streamable(network, 5)
    assert isinstance(streamed, StreamedWindow) and not_streamable(streamed) is None
    with torch.no_grad():   # the definition: the network on each full window
        offline = network(torch.from_numpy(np.array(sliding_windows(x, network.window, 1))))
        chunk = streamed(torch.from_numpy(x)[None])[0]
    sequence = streamed.predict_sequence(x)
    np.testing.assert_array_equal(sequence, chunk.numpy())
    np.testing.assert_allclose(sequence[network.window - 1:], offline.numpy(), atol=1e-6)
    for backend in ("torch", "onnx"):
        stepper = make_backend(streamed, backend)
        steps = np.stack([stepper.step(row).copy() for row in x])
        np.testing.assert_allclose(steps, sequence, atol=1e-5, err_msg=backend)
        stepper.reset()   # a reset starts from the zero window again
        np.testing.assert_allclose(stepper.step(x[0]), sequence[0], atol=1e-5)


def test_only_trainable_window_networks_are_wrapped_and_the_weights_are_shared():
    chunk = build_model("hybrid", 4)
    assert as_streamable(chunk, 4) is chunk
    lstm = build_model("lstm", len(recipe("lstm").inputs().features))
    assert as_streamable(lstm, 4) is lstm and not can_stream(lstm)
    assert "JointLSTMForce lacks" in not_streamable(lstm)   # a chunk model without the step
    network = _networks()[0]
    streamed = as_streamable(network, 5)
    with torch.no_grad():
        network.decoder[-1].bias.add_(1.0)
    x = np.ones((WINDOW, 5), np.float32)
    with torch.no_grad():
        want = network(torch.from_numpy(x)[None])[0].numpy()
    np.testing.assert_allclose(streamed.predict_sequence(x)[-1], want, atol=1e-6)


def _transformer_checkpoint(path):
    """A paper transformer on the paper's 21 inputs (no prior, no base), scalers from a
    recording, saved as training would."""
    torch.manual_seed(3)
    n = len(PAPER_FEATURES)
    frame = recording(300, seed=5)
    x = frame[list(PAPER_FEATURES)].to_numpy(np.float32)
    xs = Scaler(x.mean(0), x.std(0) + 1e-3)
    ys = Scaler(np.array([0.1, -0.2, 0.3], np.float32), np.array([0.5, 0.7, 1.5], np.float32))
    model = build_model("transformer", n, {"window": WINDOW, "d_model": 16, "n_heads": 2,
                                            "n_layers": 2, "d_ff": 32}).eval()
    return ck.TrainedModel("transformer", {"window": WINDOW, "d_model": 16, "n_heads": 2,
                                           "n_layers": 2, "d_ff": 32}, PAPER_FEATURES, xs, ys,
                           model=model).save(path)


def test_the_paper_transformer_streams_what_the_causal_metric_scores(tmp_path):
    path = _transformer_checkpoint(tmp_path / "t.pt")
    frame = recording(200, seed=2)
    est = StreamingEstimator.from_checkpoint(path)
    forces, flags = stream(est, frame)
    assert [bool(f & Flags.WARMING_UP) for f in flags] == [i < WINDOW - 1 for i in range(200)]
    offline = predict_trial(ck.load_checkpoint(path), Trial("t", "Free", "test", frame))
    assert np.isnan(offline[:WINDOW - 1]).all()
    np.testing.assert_allclose(forces[WINDOW - 1:], offline[WINDOW - 1:], atol=1e-4)
    np.testing.assert_allclose(est.predict_recording(frame), forces, atol=1e-4)
    export(path, tmp_path / "out")   # the step graph, run back from the files alone
    np.testing.assert_allclose(run_export(tmp_path / "out", frame), forces, atol=1e-4)
