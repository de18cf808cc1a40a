"""Streaming estimator: equals the offline path, backends agree, bad samples flagged, recovery."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from hybrid import checkpoint as ck
from hybrid.causal import CausalTransformer
from hybrid.data import Scaler
from hybrid.hybrid import (BASE_COLUMNS, COMPENSATED_HEX10, HYBRID_FEATURES, HexRotation,
                           HybridInputs, SamplePrior, compensated_hex10, hybrid_columns,
                           sample_prior)
from hybrid.models import build_model
from hybrid.streaming import (CHAIN_POSITIONS, CausalFilter, Flags, StreamingError,
                              StreamingEstimator)
from psm_model.identification.insertion import InsertionEffortModel
from psm_model.recording import HEX10, PAPER_FEATURES, REQUIRED

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


def recording(n: int = 400, seed: int = 0) -> pd.DataFrame:
    """Smooth random signals in the recording layout (joint positions inside the PSM's range)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE_HZ
    cols = {"time": t}
    for k, c in enumerate(REQUIRED[1:]):
        f = rng.uniform(0.1, 1.0)
        cols[c] = 0.5 * np.sin(2 * np.pi * f * t + k) + 0.05 * rng.standard_normal(n)
    cols["insertion_position"] = 0.12 + 0.02 * np.sin(t)
    return pd.DataFrame(cols)


def model_and_scalers(n_features: int = 21, seed: int = 0):
    torch.manual_seed(seed)
    model = CausalTransformer(n_features, d_model=16, n_heads=2, d_ff=32, attention_window=8)
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
    far[est.columns.index("pitch_effort")] = 1e3
    assert est.step(far, time=row["time"] + 0.02, overload=True).flags & (
        Flags.EXTRAPOLATION | Flags.OVERLOAD) == Flags.EXTRAPOLATION | Flags.OVERLOAD
    with pytest.raises(StreamingError, match="array sample must have shape"):
        est.step(values[3][:-1], time=1.0)
    with pytest.raises(StreamingError, match="no timestamp"):
        est.step(values[3])


def test_base_frame_output_is_the_psm_rotation_of_the_hex10_force():
    from psm_model import PSM
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
    path = ck.save_checkpoint(tmp_path / "h.pt", model, model_name="hybrid",
                              config={"d_model": 16, "n_heads": 2, "d_ff": 32,
                                      "attention_window": 8},
                              features=features, input_scaler=xs, target_scaler=ys,
                              base_columns=base)
    frame = recording(100)
    loaded = StreamingEstimator.from_checkpoint(path)
    direct = StreamingEstimator(model, features, xs, ys, base)
    np.testing.assert_allclose(stream(loaded, frame)[0], stream(direct, frame)[0], atol=1e-6)
    fcn = ck.save_checkpoint(tmp_path / "f.pt", build_model("fcn", 1), model_name="fcn",
                             config={}, features=["fx"], input_scaler=xs, target_scaler=ys)
    with pytest.raises(StreamingError, match="needs a hybrid.causal.CausalTransformer"):
        StreamingEstimator.from_checkpoint(fcn)
    assert set(HEX10) <= set(loaded.columns)


def test_sample_prior_matches_the_identification_prior_on_whole_recordings():
    from psm_model.identification.prior import InternalForcePrior, gravity_in_hex10
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
