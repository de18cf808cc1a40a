"""Design choices of the hybrid: the per-axis base (residual only where the prior-compensated
HEX10 makes the target easier) and the optional input ``prior_fz`` (the prior's internal axial
force), each derived the same way for whole recordings and for one streamed sample."""

from __future__ import annotations

import numpy as np
import pytest

from psmforce.estimators.data.dataset import NO_BASE, Trial, base_matrix, fit_scalers, target_matrix
from psmforce.estimators.evaluation.evaluate import predict_trial
from psmforce.estimators.data.hybrid_inputs import (COMPENSATED_HEX10, HYBRID_FEATURES,
                                                    HYBRID_FEATURES_PRIOR_FZ, PRIOR_FZ,
                                                    HybridInputError, HybridInputs,
                                                    add_prior_columns, compensated_hex10,
                                                    select_base)
from psmforce.estimators.training.checkpoint import TrainedModel
from psmforce.estimators.runtime.streaming import StreamingEstimator
from tests.estimators.test_streaming import (StandInPrior, model_and_scalers, one_thread, recording)  # noqa: F401


def test_prior_fz_is_the_priors_internal_fz_and_completes_comp_fz():
    frame, prior = recording(60), StandInPrior()
    cols = compensated_hex10(frame, prior)
    np.testing.assert_array_equal(cols[PRIOR_FZ], prior.predict(frame)[:, 2])
    np.testing.assert_allclose(cols["comp_fz"] + cols[PRIOR_FZ], frame["fz"], atol=1e-12)
    assert HYBRID_FEATURES_PRIOR_FZ == HYBRID_FEATURES + (PRIOR_FZ,)


def test_prior_fz_input_per_sample_equals_whole_recording():
    frame, prior = recording(80), StandInPrior(seed=3)
    _, xs, _ = model_and_scalers(len(HYBRID_FEATURES_PRIOR_FZ))
    inputs = HybridInputs(HYBRID_FEATURES_PRIOR_FZ, COMPENSATED_HEX10[:3], xs, prior)
    x, base = inputs.frame(frame)
    expected = (prior.predict(frame)[:, 2] - xs.mean[-1]) / xs.std[-1]
    np.testing.assert_allclose(x[:, -1], expected, rtol=1e-5, atol=1e-5)
    for i, row in enumerate(frame[list(inputs.raw_columns)].to_numpy()):
        inputs.sample(row)
        np.testing.assert_allclose(inputs.x, x[i], atol=1e-6)
        np.testing.assert_allclose(inputs.base, base[i], atol=1e-12)


def test_prior_fz_needs_a_prior():
    features = HYBRID_FEATURES[:-6] + (PRIOR_FZ,)  # joint states and prior_fz, no comp_*
    _, xs, _ = model_and_scalers(len(features))
    with pytest.raises(HybridInputError, match=r"\['prior_fz'\] need a prior"):
        HybridInputs(features, (), xs, None)


def test_streaming_with_prior_fz_equals_offline():
    frame = recording(200)
    model, xs, ys = model_and_scalers(len(HYBRID_FEATURES_PRIOR_FZ))
    est = StreamingEstimator(model, HYBRID_FEATURES_PRIOR_FZ, xs, ys, COMPENSATED_HEX10[:3],
                             StandInPrior())
    offline = est.predict_recording(frame)
    online = np.stack([est.step(row).force_hex10 for row in frame.to_dict("records")])
    assert np.abs(online - offline).max() < 1e-4


def _trial(fx_base_error: float, fz_base_error: float, n: int = 500, seed: int = 0) -> Trial:
    """ATI force plus a base that equals it up to noise of the given sizes on x and z; y's base
    is unrelated to the force."""
    rng = np.random.default_rng(seed)
    ati = rng.standard_normal((n, 3))
    frame = recording(n, seed)
    frame[["ati_fx", "ati_fy", "ati_fz"]] = ati
    frame["comp_fx"] = ati[:, 0] + fx_base_error * rng.standard_normal(n)
    frame["comp_fy"] = 3.0 * rng.standard_normal(n)
    frame["comp_fz"] = ati[:, 2] + fz_base_error * rng.standard_normal(n)
    return Trial("t.csv", "Traction", "train", frame)


def test_select_base_keeps_an_axis_only_where_the_residual_is_smaller():
    assert select_base([_trial(0.1, 2.0)], COMPENSATED_HEX10[:3]) == ("comp_fx", NO_BASE, NO_BASE)
    assert select_base([_trial(0.1, 0.5)], COMPENSATED_HEX10[:3]) == ("comp_fx", NO_BASE, "comp_fz")
    with pytest.raises(HybridInputError, match="3 columns"):
        select_base([_trial(0.1, 0.1)], COMPENSATED_HEX10[:2])


def test_no_base_axis_adds_nothing_and_its_target_is_the_force():
    trial = _trial(0.1, 2.0)
    base = ("comp_fx", NO_BASE, "comp_fz")
    b = base_matrix(trial, base)
    np.testing.assert_array_equal(b[:, 1], 0.0)
    np.testing.assert_array_equal(b[:, 0], trial.frame["comp_fx"])
    y = target_matrix(trial, base, np.float64)
    np.testing.assert_array_equal(y[:, 1], trial.frame["ati_fy"])
    np.testing.assert_allclose(y[:, 2], trial.frame["ati_fz"] - trial.frame["comp_fz"])


def test_streaming_with_a_no_base_axis_equals_offline_evaluation():
    """One base axis empty: the streamed estimate, the estimator's batch path and the evaluation's
    predict_trial (which training and scoring use) agree."""
    frame, prior = recording(300), StandInPrior(seed=2)
    frame[["ati_fx", "ati_fy", "ati_fz"]] = 0.0
    base = (COMPENSATED_HEX10[0], COMPENSATED_HEX10[1], NO_BASE)
    model, xs, ys = model_and_scalers(len(HYBRID_FEATURES))
    est = StreamingEstimator(model, HYBRID_FEATURES, xs, ys, base, prior)
    online = np.stack([est.step(row).force_hex10 for row in frame.to_dict("records")])
    offline = est.predict_recording(frame)
    assert np.abs(online - offline).max() < 1e-4

    class _Dataset:  # add_prior_columns needs only add_columns
        def __init__(self, trial):
            self.trial = trial

        def add_columns(self, fn):
            for k, v in fn(self.trial).items():
                self.trial.frame[k] = v

    trial = Trial("t.csv", "Free", "test", frame.copy())
    add_prior_columns(_Dataset(trial), prior)
    evaluated = predict_trial(TrainedModel("hybrid", {}, HYBRID_FEATURES, xs, ys, base,
                                           model=model), trial)
    warm = model.window
    np.testing.assert_allclose(evaluated[warm:], offline[warm:], atol=1e-4)
    # the same network without any base: the empty axis is exactly its output, the others differ
    # from it by their base column
    network_only = predict_trial(TrainedModel("hybrid", {}, HYBRID_FEATURES, xs, ys, model=model),
                                 trial)
    np.testing.assert_allclose(evaluated[:, 2], network_only[:, 2], atol=1e-12)
    np.testing.assert_allclose(evaluated[:, :2] - network_only[:, :2],
                               trial.frame[list(base[:2])].to_numpy(), atol=1e-9)


def test_fit_scalers_on_a_no_base_target():
    trial = _trial(0.1, 2.0)
    _, ys = fit_scalers([trial], ("comp_fx",), base_columns=("comp_fx", NO_BASE, NO_BASE))
    assert ys.std[2] == pytest.approx(trial.frame["ati_fz"].std(ddof=0), rel=1e-5)
