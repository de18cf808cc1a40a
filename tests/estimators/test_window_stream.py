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
from psmforce.estimators.runtime.streaming import Flags, StreamingError, StreamingEstimator
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


def test_only_window_networks_with_scaled_outputs_are_wrapped_and_share_their_weights():
    chunk = build_model("hybrid", 4)
    assert as_streamable(chunk, 4) is chunk
    lstm = build_model("lstm", len(recipe("lstm").inputs().features))
    assert as_streamable(lstm, 4) is lstm and not can_stream(lstm)
    assert "JointLSTMForce lacks" in not_streamable(lstm)   # a chunk model without the step
    rocket = build_model("rocket", 4)   # a window model, but numpy, fitted in closed form
    assert as_streamable(rocket, 4) is rocket and not can_stream(rocket)
    newton = FCN(4)
    newton.output_space = "newton"   # the pipeline un-scales every answer: it would be wrong
    assert as_streamable(newton, 4) is newton and not can_stream(newton)
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
    xs, ys = _scalers(n)
    config = {"window": WINDOW, "d_model": 16, "n_heads": 2, "n_layers": 2, "d_ff": 32}
    model = build_model("transformer", n, config).eval()
    return ck.TrainedModel("transformer", config, PAPER_FEATURES, xs, ys, model=model).save(path)


def test_a_window_network_of_other_inputs_is_refused_in_one_line():
    with pytest.raises(StreamingError, match="FCN window network does not take 7 input features"):
        StreamedWindow(FCN(5), 7)
    xs, ys = _scalers(7)
    with pytest.raises(StreamingError, match="does not take 7 input features") as err:
        StreamingEstimator(FCN(5), PAPER_FEATURES[:7], xs, ys)
    assert "\n" not in str(err.value)


def _scalers(n: int) -> tuple[Scaler, Scaler]:
    """Input scalers of the first ``n`` paper inputs from a recording, and target scalers."""
    x = recording(300, seed=5)[list(PAPER_FEATURES[:n])].to_numpy(np.float32)
    return (Scaler(x.mean(0), x.std(0) + 1e-3),
            Scaler(np.array([0.1, -0.2, 0.3], np.float32), np.array([0.5, 0.7, 1.5], np.float32)))


def test_the_fcn_streams_at_a_faster_input_rate_and_exports(tmp_path):
    """Decimated (a 300 Hz stream, a 100 Hz model), stepping equals the offline path; a window
    of one sample has no warm-up; the export runs back the stream's answers."""
    torch.manual_seed(4)
    xs, ys = _scalers(len(PAPER_FEATURES))
    fcn = build_model("fcn", len(PAPER_FEATURES)).eval()
    frame = recording(300, seed=6)
    fast = frame.assign(time=np.arange(len(frame)) / 300.0)
    est = StreamingEstimator(fcn, PAPER_FEATURES, xs, ys, input_rate_hz=300.0)
    forces, flags = stream(est, fast)
    assert est.decimation == 3 and not any(f & Flags.WARMING_UP for f in flags)
    np.testing.assert_allclose(est.predict_recording(fast), forces, atol=1e-5)
    path = ck.TrainedModel("fcn", {}, PAPER_FEATURES, xs, ys, model=fcn).save(tmp_path / "f.pt")
    export(path, tmp_path / "out")
    at_rate, _ = stream(StreamingEstimator.from_checkpoint(path), frame)
    np.testing.assert_allclose(run_export(tmp_path / "out", frame), at_rate, atol=1e-5)


def test_the_paper_transformer_streams_the_estimates_the_evaluation_scores(tmp_path):
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


def test_the_hybrids_physics_read_by_the_paper_transformer_streams_and_exports(tmp_path):
    """The model ``hybrid_transformer``: the hybrid's inputs (prior-compensated, the prior in
    the checkpoint) and base, the paper's window network; the stream adds the base back as the
    offline path does, on every sample past the warm-up, and its export runs the same."""
    from psmforce.estimators.data.dataset import Dataset
    from psmforce.estimators.data.hybrid_inputs import prior_to_json
    from psmforce.estimators.networks.recipes import DERIVATIONS
    from psmforce.identification.prior import InternalForcePrior
    from tests.estimators.test_streaming import INSERTION

    spec = recipe("hybrid_transformer")
    inputs = spec.inputs()
    assert inputs.uses_prior and len(inputs.base) == 3 and spec.streams
    assert spec.optimiser == recipe("transformer").optimiser   # trained as the paper trains it
    torch.manual_seed(5)
    n = len(inputs.features)
    config = {"window": WINDOW, "d_model": 16, "n_heads": 2, "n_layers": 2, "d_ff": 32}
    model = build_model("hybrid_transformer", n, config).eval()
    prior_json = prior_to_json(InternalForcePrior(converged=True, insertion=INSERTION))
    frame = recording(120, seed=7)
    trial = Trial("t", "Free", "test", frame)
    DERIVATIONS["prior"](Dataset(tmp_path, [trial], {}), prior_json)   # as training adds them
    x = trial.frame[list(inputs.features)].to_numpy(np.float32)
    xs = Scaler(x.mean(0), x.std(0) + 1e-3)
    _, ys = _scalers(3)
    path = ck.TrainedModel("hybrid_transformer", config, inputs.features, xs, ys, inputs.base,
                           derivation="prior", prior_json=prior_json, model=model
                           ).save(tmp_path / "ht.pt")
    est = StreamingEstimator.from_checkpoint(path)
    forces, _ = stream(est, frame)
    offline = predict_trial(ck.load_checkpoint(path), trial)   # the derived columns
    np.testing.assert_allclose(forces[WINDOW - 1:], offline[WINDOW - 1:], atol=1e-4)
    assert np.abs(trial.frame[list(inputs.base)].to_numpy()[WINDOW - 1:]).max() > 0.1   # a base
    export(path, tmp_path / "out")
    np.testing.assert_allclose(run_export(tmp_path / "out", frame), forces, atol=1e-4)
