"""The hybrid's optional input ``prior_fz`` (the prior's internal axial force): derived the same
way for whole recordings and for one streamed sample, and consistent with the compensated HEX10."""

from __future__ import annotations

import numpy as np
import pytest

from hybrid.hybrid import (BASE_COLUMNS, HYBRID_FEATURES, HYBRID_FEATURES_PRIOR_FZ, PRIOR_FZ,
                           HybridInputError, HybridInputs, compensated_hex10)
from hybrid.streaming import StreamingEstimator
from test_streaming import StandInPrior, model_and_scalers, one_thread, recording  # noqa: F401


def test_prior_fz_is_the_priors_internal_fz_and_completes_comp_fz():
    frame, prior = recording(60), StandInPrior()
    cols = compensated_hex10(frame, prior)
    np.testing.assert_array_equal(cols[PRIOR_FZ], prior.predict(frame)[:, 2])
    np.testing.assert_allclose(cols["comp_fz"] + cols[PRIOR_FZ], frame["fz"], atol=1e-12)
    assert HYBRID_FEATURES_PRIOR_FZ == HYBRID_FEATURES + (PRIOR_FZ,)


def test_prior_fz_input_per_sample_equals_whole_recording():
    frame, prior = recording(80), StandInPrior(seed=3)
    _, xs, _ = model_and_scalers(len(HYBRID_FEATURES_PRIOR_FZ))
    inputs = HybridInputs(HYBRID_FEATURES_PRIOR_FZ, BASE_COLUMNS, xs, prior)
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
    est = StreamingEstimator(model, HYBRID_FEATURES_PRIOR_FZ, xs, ys, BASE_COLUMNS,
                             StandInPrior())
    offline = est.predict_recording(frame)
    online = np.stack([est.step(row).force_hex10 for row in frame.to_dict("records")])
    assert np.abs(online - offline).max() < 1e-4
