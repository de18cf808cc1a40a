"""Streaming estimator: equals the offline path, backends agree, bad samples flagged, recovery."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.data.bounds import MAX_FORCE_N, physical_bounds
from psmforce.estimators.networks.causal import CausalTransformer
from psmforce.estimators.data.dataset import Scaler
from psmforce.estimators.data.hybrid_inputs import (BASE_COLUMNS, COMPENSATED_HEX10,
                                                    HYBRID_FEATURES, HexRotation, HybridInputs,
                                                    SamplePrior, compensated_hex10, hybrid_columns,
                                                    sample_prior)
from psmforce.estimators.runtime.postfilter import CausalFilter
from psmforce.estimators.runtime.steppers import step_onnx_bytes
from psmforce.estimators.runtime.streaming import (CHAIN_POSITIONS, Flags, StreamingError,
                                                   StreamingEstimator)
from psmforce.identification.insertion import InsertionEffortModel
from psmforce.io.recording import HEX10, PAPER_FEATURES, REQUIRED
from tests.checkpoints import untrained_checkpoint

RATE_HZ = 100.0


@pytest.fixture(autouse=True)
def one_thread():
    """Tiny tensors: more torch threads only add contention on the shared CI cores."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


INSERTION = InsertionEffortModel((0.3, -0.2, 8.8, 0.35, 2.0, 0.05), 0.005, {})
"""An insertion model with physical parameters (g_b N, Coulomb N, viscous N s/m, offset N)."""


class StandInPrior:
    """A linear internal-wrench model with the prior's interface (the real
    InternalForcePrior is tested by its owner): internal = A @ wrist efforts + b."""

    input_columns = ("roll_effort", "wrist_pitch_effort", "wrist_yaw_effort", "jaw_effort",
                     "insertion_effort")
    insertion = "stand-in: insertion_fz = 0.5 - insertion_effort"

    def __init__(self, seed: int = 0):
        rng = np.random.default_rng(seed)
        self.A = rng.standard_normal((6, 4))
        self.b = rng.standard_normal(6)

    def predict(self, frame: pd.DataFrame) -> np.ndarray:
        return frame[list(self.input_columns[:4])].to_numpy(float) @ self.A.T + self.b

    def insertion_axial_force(self, frame: pd.DataFrame) -> np.ndarray:
        return 0.5 - frame["insertion_effort"].to_numpy(float)

    def predict_sample(self, values: np.ndarray) -> np.ndarray:
        return np.r_[self.A @ values[:4] + self.b, 0.5 - values[4]]


BOUNDS = physical_bounds()


def recording(n: int = 400, seed: int = 0) -> pd.DataFrame:
    """Smooth random signals in the recording layout, well inside each column's physical bounds
    (amplitude 0.5 or a quarter of the bound, whichever is smaller)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE_HZ
    cols = {"time": t}
    for k, c in enumerate(REQUIRED[1:]):
        f = rng.uniform(0.1, 1.0)
        lo, hi = BOUNDS[c]
        amplitude = min(0.5, (hi - lo) / 8)
        cols[c] = ((lo + hi) / 2 + amplitude * np.sin(2 * np.pi * f * t + k)
                   + 0.1 * amplitude * rng.standard_normal(n))
    cols["insertion_position"] = 0.12 + 0.02 * np.sin(t)
    return pd.DataFrame(cols)


def model_and_scalers(n_features: int = 21, seed: int = 0, **config):
    """A small causal transformer (``config``: more constructor arguments) with non-zero lag
    biases, and input / target scalers."""
    torch.manual_seed(seed)
    model = CausalTransformer(n_features, d_model=16, n_heads=2, d_ff=32, attention_window=8,
                              **config)
    with torch.no_grad():
        for block in model.blocks:
            block.lag_bias.normal_()
    model.eval()
    rng = np.random.default_rng(seed)
    x_scaler = Scaler(rng.normal(0, 0.1, n_features).astype(np.float32),
                      rng.uniform(0.3, 1.0, n_features).astype(np.float32))
    y_scaler = Scaler(np.array([0.1, -0.2, 0.3], np.float32), np.array([0.5, 0.7, 1.5], np.float32))
    return model, x_scaler, y_scaler


def estimator(use_prior: bool = True, **options) -> StreamingEstimator:
    features, base = hybrid_columns(use_prior)
    model, xs, ys = model_and_scalers(len(features))
    return StreamingEstimator(model, features, xs, ys, base,
                              StandInPrior() if use_prior else None, **options)


def stream(est: StreamingEstimator, frame: pd.DataFrame):
    outs = [est.step(row) for row in frame.to_dict("records")]
    return np.stack([o.force_hex10 for o in outs]), np.array([o.flags for o in outs])


def test_hybrid_inputs_subtract_the_prior_and_keep_the_papers_order():
    frame, prior = recording(50), StandInPrior()
    assert HYBRID_FEATURES[-6:] == tuple(f"comp_{c}" for c in PAPER_FEATURES[-6:])
    assert BASE_COLUMNS == COMPENSATED_HEX10[:2] + ("insertion_fz",)
    comp = compensated_hex10(frame, prior)
    np.testing.assert_allclose(comp["comp_fz"], frame["fz"] - prior.predict(frame)[:, 2])
    _, xs, _ = model_and_scalers()
    inputs = HybridInputs(HYBRID_FEATURES, COMPENSATED_HEX10[:3], xs, prior)
    x, base = inputs.frame(frame)
    np.testing.assert_allclose(base[:, 0], comp["comp_fx"])
    for i, row in enumerate(frame[list(inputs.raw_columns)].to_numpy()):
        inputs.sample(row)
        np.testing.assert_allclose(inputs.x, x[i], atol=1e-6)
        np.testing.assert_allclose(inputs.base, base[i], atol=1e-12)


@pytest.mark.parametrize("post_filter", ["none", "median", "lowpass"])
def test_streaming_equals_offline_path(post_filter):
    frame = recording(300)
    est = estimator(post_filter=post_filter, median_kernel=9, lowpass_hz=4.0)
    offline = est.predict_recording(frame)
    online, flags = stream(est, frame)
    assert np.abs(online - offline).max() < 1e-4
    assert (flags[:est.window - 1] & Flags.WARMING_UP).all()
    assert not (flags[est.window - 1:] & Flags.WARMING_UP).any()


def test_backends_agree_and_no_prior_variant_streams():
    frame = recording(120)
    ref, _ = stream(estimator(backend="torch"), frame)
    for backend in ("numpy", "onnx", "auto"):
        out, _ = stream(estimator(backend=backend), frame)
        assert np.abs(out - ref).max() < 1e-5, backend
    est = estimator(use_prior=False)
    assert "fx" in est.columns and not any(c.startswith("comp_") for c in est.columns)
    online, _ = stream(est, frame)
    assert np.abs(online - est.predict_recording(frame)).max() < 1e-4
    with pytest.raises(StreamingError, match="unknown backend"):
        estimator(backend="tensorrt")


class TwoTapToy(torch.nn.Module):
    """A streamable model that is not the hybrid: follows the step protocol of psmforce.estimators.runtime.steppers
    and nothing else. y_t = (A x_t + B x_{t-1} + c) * min(t + 1, window) / window (x_{-1} = 0):
    its state is the previous sample (float) and a sample counter (int64) the step advances."""

    kind = "chunk"
    window = 2
    state_names = ("previous", "seen")

    def __init__(self, n_features: int):
        super().__init__()
        self.n_features = n_features
        self.now = torch.nn.Linear(n_features, 3)
        self.before = torch.nn.Linear(n_features, 3, bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        previous = torch.nn.functional.pad(x, (0, 0, 1, 0))[:, :-1]
        ramp = torch.arange(1, x.shape[1] + 1).clamp(max=self.window) / self.window
        return (self.now(x) + self.before(previous)) * ramp[:, None]

    def stream_state(self, batch: int = 1) -> tuple[torch.Tensor, torch.Tensor]:
        return torch.zeros(batch, self.n_features), torch.zeros(1, dtype=torch.int64)

    def stream_step(self, x, previous, seen):
        seen = torch.clamp(seen + 1, max=self.window)
        return (self.now(x) + self.before(previous)) * (seen / self.window), x, seen

    def predict_sequence(self, x: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            return self(torch.from_numpy(np.asarray(x, np.float32))[None])[0].numpy()


def test_any_model_that_follows_the_step_protocol_streams_on_torch_and_onnx():
    torch.manual_seed(1)
    toy = TwoTapToy(len(PAPER_FEATURES)).eval()
    _, xs, ys = model_and_scalers(len(PAPER_FEATURES))
    frame = recording(60)
    outs = {}
    for backend in ("torch", "onnx", "auto"):
        est = StreamingEstimator(toy, PAPER_FEATURES, xs, ys, backend=backend)
        outs[backend], flags = stream(est, frame)
        assert est.window == 2 and (flags[:1] & Flags.WARMING_UP).all()
        assert not (flags[1:] & Flags.WARMING_UP).any()
    assert est.backend_name == "onnx"  # auto: onnxruntime is installed, the toy has no numpy path
    offline = est.predict_recording(frame)
    for backend, out in outs.items():
        assert np.abs(out - offline).max() < 1e-5, backend
    with pytest.raises(StreamingError, match="backend 'numpy' runs .*not TwoTapToy"):
        StreamingEstimator(toy, PAPER_FEATURES, xs, ys, backend="numpy")
    with pytest.raises(StreamingError, match="takes 21 features, 3 given"):
        StreamingEstimator(toy, PAPER_FEATURES[:3], xs, ys)
    with pytest.raises(StreamingError, match="Linear lacks kind, window, n_features"):
        StreamingEstimator(torch.nn.Linear(21, 3), PAPER_FEATURES, xs, ys)


def test_building_the_step_graph_leaves_the_model_in_eval_mode():
    # the ONNX exporter restores its wrapper's mode on the whole tree: it once switched dropout
    # on in the model a torch stepper built before the export was running
    model, _, _ = model_and_scalers()
    step_onnx_bytes(model)
    assert not model.training


def test_bad_samples_flagged_state_untouched_and_recovery():
    frame = recording(200)
    rows = frame.to_dict("records")
    clean, _ = stream(estimator(), frame)
    est = estimator()
    for row in rows[:100]:
        est.step(row)
    nan_row = dict(rows[100], fz=float("nan"))
    missing = {k: v for k, v in rows[100].items() if k != "roll_effort"}
    backwards = dict(rows[99])
    for bad, flag in ((nan_row, Flags.INVALID_INPUT), (missing, Flags.INVALID_INPUT),
                      (backwards, Flags.TIME_BACKWARDS), ({**rows[100], "time": np.inf},
                                                          Flags.INVALID_INPUT)):
        out = est.step(bad)
        assert out.flags & flag and out.flags & Flags.HELD
        np.testing.assert_array_equal(out.force_hex10, clean[99])  # last estimate, held
    # rejected samples never touched the state: the stream goes on exactly as the clean one
    tail = np.stack([est.step(r).force_hex10 for r in rows[100:150]])
    assert np.abs(tail - clean[100:150]).max() < 1e-6

    # a gap of 6 missing samples (> 5) resets; the estimator then equals a fresh one
    out = est.step(rows[156])
    assert out.flags & Flags.GAP and out.flags & Flags.WARMING_UP
    resumed = [out] + [est.step(r) for r in rows[157:]]
    fresh, _ = stream(estimator(), frame.iloc[156:])
    assert np.abs(np.stack([o.force_hex10 for o in resumed]) - fresh).max() < 1e-6
    assert not resumed[-1].flags & Flags.WARMING_UP and np.isfinite(resumed[-1].force_hex10).all()


def test_short_gap_is_bridged_and_first_bad_sample_gives_nan():
    frame = recording(60)
    rows = frame.to_dict("records")
    est = estimator()
    first = est.step(dict(rows[0], fx=None))
    assert np.isnan(first.force_hex10).all() and first.flags & Flags.INVALID_INPUT
    est.step(rows[0])
    out = est.step(rows[6])  # 5 samples missing: bridged, no reset
    assert not out.flags & Flags.GAP and np.isfinite(out.force_hex10).all()


def test_overload_extrapolation_and_array_input():
    frame = recording(30)
    est = estimator(extrapolation_z=5.0)
    row = frame.iloc[0]
    assert est.step(dict(row, hex10_overload=1)).flags & Flags.OVERLOAD
    values = frame[list(est.columns)].to_numpy()
    out = est.step(values[1], time=row["time"] + 0.01)
    assert out.flags == Flags.WARMING_UP
    far = values[2].copy()
    far[est.columns.index("pitch_effort")] = 5.0  # Nm: physical, far outside the training range
    assert est.step(far, time=row["time"] + 0.02, overload=True).flags & (
        Flags.EXTRAPOLATION | Flags.OVERLOAD) == Flags.EXTRAPOLATION | Flags.OVERLOAD
    # a bad array sample is flagged like a bad mapping, never raised
    text = np.full(values[3].shape, "abc")
    for bad, when in ((values[3][:-1], 1.0), (values[3], None), (text, 1.0)):
        out = est.step(bad, time=when)
        assert out.flags & Flags.INVALID_INPUT and out.flags & Flags.HELD


def test_base_frame_output_is_the_psm_rotation_of_the_hex10_force():
    from psmforce.robot import PSM
    psm = PSM()
    frame = recording(20)
    est = estimator(psm=psm)
    assert set(CHAIN_POSITIONS) <= set(est.columns)
    for row in frame.to_dict("records"):
        out = est.step(row, base_frame=True)
    q = frame.iloc[-1][list(CHAIN_POSITIONS)].to_numpy(float)
    np.testing.assert_allclose(out.force_base, psm.rotation(q, "hex10") @ out.force_hex10,
                               atol=1e-12)
    rotation, rng = HexRotation(psm), np.random.default_rng(1)
    for q in rng.uniform(psm.lower_limits, psm.upper_limits, size=(50, 7)):
        np.testing.assert_allclose(rotation(q), psm.rotation(q, "hex10"), atol=1e-12)


def test_causal_filters_lag_and_step_response():
    step_input = np.zeros((200, 3))
    step_input[50:] = 1.0
    median = CausalFilter("median", median_kernel=11)
    assert median.lag_samples() == 5
    out = median.offline(step_input)
    assert out[54, 0] == 0.0 and out[55, 0] == 1.0       # the median lags a step by (k-1)/2
    lowpass = CausalFilter("lowpass", rate_hz=100.0, lowpass_hz=5.0, lowpass_order=2)
    assert 3.0 < lowpass.lag_samples() < 6.0              # 2nd-order Butterworth at 5 Hz: ~4.5
    out = lowpass.offline(step_input)
    assert np.all(out[:50] == 0.0) and abs(out[-1, 0] - 1.0) < 1e-6
    with pytest.raises(StreamingError, match="lowpass_hz"):
        CausalFilter("lowpass", rate_hz=100.0, lowpass_hz=60.0)


def test_from_checkpoint_uses_the_training_checkpoint(tmp_path):
    model, xs, ys = model_and_scalers(len(PAPER_FEATURES))
    features, base = hybrid_columns(use_prior=False)
    config = {"d_model": 16, "n_heads": 2, "d_ff": 32, "attention_window": 8}
    path = ck.TrainedModel("hybrid", config, features, xs, ys, base, model=model).save(
        tmp_path / "h.pt")
    frame = recording(100)
    loaded = StreamingEstimator.from_checkpoint(path)
    direct = StreamingEstimator(model, features, xs, ys, base)
    np.testing.assert_allclose(stream(loaded, frame)[0], stream(direct, frame)[0], atol=1e-6)
    lstm = untrained_checkpoint("lstm", tmp_path / "l.pt")
    with pytest.raises(StreamingError, match="'lstm' model, which does not stream"):
        StreamingEstimator.from_checkpoint(lstm)
    assert set(HEX10) <= set(loaded.columns)


def test_sample_prior_matches_the_identification_prior_on_whole_recordings():
    from psmforce.identification.prior import InternalForcePrior, gravity_in_hex10
    frame = recording(40)
    # default parameters: a valid physical model
    prior = sample_prior(InternalForcePrior(insertion=INSERTION))
    assert isinstance(prior, SamplePrior)
    whole = prior.predict(frame)
    values = frame[list(prior.input_columns)].to_numpy()
    per_sample = np.stack([prior.predict_sample(v).copy() for v in values])
    np.testing.assert_allclose(per_sample[:, :6], whole, rtol=1e-9, atol=1e-9)
    axial = prior.insertion_axial_force(frame)
    assert np.ptp(axial) > 0.1  # the shaft direction and the effort vary in this recording
    np.testing.assert_allclose(per_sample[:, 6], axial, rtol=1e-9, atol=1e-9)
    q = frame[list(CHAIN_POSITIONS)].to_numpy()
    g_hex = gravity_in_hex10(q, prior.psm)
    assert np.abs(g_hex).max() > 1.0  # gravity enters the prediction for these poses
    assert sample_prior(StandInPrior()).__class__ is StandInPrior


# ------------------------------------------------------------------ samples that cannot poison

def _skipping(frame: pd.DataFrame, skip: int, **options) -> np.ndarray:
    """The clean stream's estimates with sample ``skip`` left out (a bridged one-sample gap)."""
    est = estimator(**options)
    rows = frame.to_dict("records")
    out = [est.step(r).force_hex10 for k, r in enumerate(rows) if k != skip]
    return np.stack(out[:skip] + [out[skip - 1]] + out[skip:])


@pytest.mark.parametrize("column, value", [("roll_position", 1e30), ("fz", 1e39),
                                           ("jaw_velocity", 1e39), ("insertion_effort", 1e4),
                                           ("insertion_effort", 1e20), ("tx", -1e5)])
def test_one_finite_extreme_sample_is_refused_and_leaves_no_trace(column, value):
    """Issue 14 item 1: with the low-pass, one such sample gave NaN for good (flags 0)."""
    frame = recording(200)
    clean = _skipping(frame, 100, post_filter="lowpass")
    est = estimator(post_filter="lowpass")
    rows = frame.to_dict("records")
    outs = [est.step(dict(r, **{column: value}) if k == 100 else r) for k, r in enumerate(rows)]
    assert outs[100].flags & Flags.INVALID_INPUT and outs[100].flags & Flags.HELD
    assert not any(o.flags & (Flags.INVALID_INPUT | Flags.EXTRAPOLATION) for o in outs[101:])
    np.testing.assert_allclose(np.stack([o.force_hex10 for o in outs]), clean, atol=1e-9)


def test_physical_spike_is_flagged_until_the_estimate_has_forgotten_it():
    frame = recording(300)
    clean = _skipping(frame, 100, post_filter="lowpass")
    est = estimator(post_filter="lowpass")
    memory = est.window + est.filter.memory_samples() - 1
    assert est.filter.memory_samples() > 10  # the low-pass remembers for tens of samples
    rows = frame.to_dict("records")
    spike = 25.0  # N: inside the insertion drive's physical bound, far outside the training range
    outs = [est.step(dict(r, insertion_effort=spike) if k == 100 else r)
            for k, r in enumerate(rows)]
    flags = np.array([o.flags for o in outs])
    assert (flags[100:100 + memory] & Flags.EXTRAPOLATION).all()
    assert not (flags[100 + memory:] & Flags.EXTRAPOLATION).any()
    forces = np.stack([o.force_hex10 for o in outs])
    assert np.abs(forces[100:100 + memory] - clean[100:100 + memory]).max() > 1.0  # it did move
    np.testing.assert_allclose(forces[100 + memory:], clean[100 + memory:], atol=1e-3)


def test_non_finite_state_resets_itself_and_says_so(monkeypatch):
    frame = recording(120)
    rows = frame.to_dict("records")
    est = estimator(post_filter="lowpass")
    last = [est.step(r) for r in rows[:50]][-1]
    est.filter._z[:] = np.nan  # a corrupted filter state
    out = est.step(rows[50])
    assert out.flags & Flags.RESET and out.flags & Flags.HELD and out.flags & Flags.WARMING_UP
    np.testing.assert_array_equal(out.force_hex10, last.force_hex10)
    monkeypatch.setattr(est._net, "step", lambda x: np.full(3, np.inf, np.float32))
    out = est.step(rows[51])
    assert out.flags & Flags.RESET and np.isfinite(out.force_hex10).all()
    monkeypatch.undo()
    after = [est.step(r) for r in rows[52:]]
    assert all(np.isfinite(o.force_hex10).all() for o in after)
    assert after[0].flags & Flags.WARMING_UP and not after[-1].flags & Flags.WARMING_UP


@pytest.mark.parametrize("rate_hz", [float("nan"), float("inf"), 0.0, -100.0, "100"])
def test_constructor_refuses_a_rate_that_is_not_a_positive_number(rate_hz):
    with pytest.raises(StreamingError, match="rate_hz"):
        estimator(rate_hz=rate_hz)


def test_missing_time_is_flagged_and_a_future_timestamp_cannot_lock_the_stream_out():
    frame = recording(80)
    rows = frame.to_dict("records")
    est = estimator()
    for r in rows[:20]:
        est.step(r)
    out = est.step({k: v for k, v in rows[20].items() if k != "time"})
    assert out.flags & Flags.INVALID_INPUT and out.flags & Flags.HELD
    assert not est.step(rows[20], time=None).flags & Flags.HELD  # the mapping's time is used
    values = frame[list(est.columns)].to_numpy()
    assert est.step(values[21], time=None).flags & Flags.INVALID_INPUT  # an array has none
    out = est.step(dict(rows[21], time=1e9))  # one corrupt clock reading, far ahead
    assert out.flags & Flags.GAP
    outs = [est.step(r) for r in rows[22:]]
    held = est.max_gap_samples
    assert all(o.flags & Flags.TIME_BACKWARDS and o.flags & Flags.HELD for o in outs[:held])
    assert outs[held].flags & Flags.GAP and not outs[held].flags & Flags.HELD  # clock restarted
    assert not any(o.flags & (Flags.HELD | Flags.TIME_BACKWARDS) for o in outs[held + 1:])


def test_an_estimate_beyond_what_the_sensor_can_carry_is_flagged():
    features, base = hybrid_columns(True)
    model, xs, _ = model_and_scalers(len(features))
    huge = Scaler(np.full(3, 2 * MAX_FORCE_N, np.float32), np.ones(3, np.float32))
    est = StreamingEstimator(model, features, xs, huge, base, StandInPrior())
    out = est.step(recording(1).to_dict("records")[0])
    assert out.flags & Flags.IMPLAUSIBLE and np.isfinite(out.force_hex10).all()


@pytest.mark.slow
def test_adversarial_stream_property():
    """2 x 10^4 samples, 10 % corrupted (psmforce/experiments/stream_fuzzer.py; 10^6 in
    tests/robustness/adversarial_stream.py): no exception, every estimate finite, every malformed
    sample refused, every estimate far from the clean stream's flagged."""
    from psmforce.experiments.stream_fuzzer import KINDS, fuzz_stream
    report = fuzz_stream(lambda: estimator(post_filter="lowpass", backend="numpy"),
                         recording(2000, seed=3), 20_000, seed=1)
    assert set(report["kinds"]) == set(KINDS)
    assert report["flags"]["INVALID_INPUT"] > 1000 and report["flags"]["EXTRAPOLATION"] > 100
    for violation in ("exceptions", "non_finite", "not_refused", "unflagged_far"):
        assert report[violation] == 0, (violation, report["examples"][violation])
