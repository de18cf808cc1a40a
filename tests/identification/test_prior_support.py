"""The prior's per-component weights (psmforce.identification.prior_support): recovered on held-out
data whose internal wrench is a known multiple of the law, applied alike on every prediction path,
persisted strictly, and what they do to the hybrid's inputs."""
import json

import numpy as np
import pandas as pd
import pytest

from psmforce.estimators.data.hybrid_inputs import compensated_hex10
from psmforce.core.integrity import seal
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import InternalForcePrior, arrays_from_frame
from psmforce.identification.prior_support import MIN_EXPLAINED, supported_weights, weigh_prior
from psmforce.io.recording import HEX10, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES

SHARES = np.array([1.0, 0.5, 2.0, -1.0, 0.0, 0.7])
"""The held-out internal wrench is SHARES * law (+ noise): the weights must come back as
clip(SHARES, 0, 1), except on tz, which the law predicts as a constant (its bias: no cable
moment about the shaft) and so explains nothing of, whatever the share: weight 0."""


def _recording(prior: InternalForcePrior, n: int, seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 100.0
    frame = pd.DataFrame({"time": t})
    for k, c in enumerate(JOINT_POSITIONS):  # inside the joint limits (insertion 0 - 0.24 m)
        frame[c] = (0.12 + 0.1 * np.sin(0.3 * t) if c.startswith("insertion")
                    else 0.3 + 0.3 * np.sin(0.3 * (k + 1) * t + k))
    for k, c in enumerate(JOINT_VELOCITIES):
        frame[c] = 0.5 * np.cos(0.2 * (k + 1) * t)
    for k, c in enumerate(JOINT_EFFORTS):
        frame[c] = 0.01 * np.sin(0.7 * (k + 1) * t) + 0.002 * rng.normal(size=n)
    a = arrays_from_frame(frame)
    law = prior.law_arrays(a["positions"], a["efforts"], a["velocities"], a["g_hex"])
    noise = 0.05 * law.std(axis=0) * rng.normal(size=law.shape)
    for k, c in enumerate(HEX10):
        frame[c] = SHARES[k] * law[:, k] + noise[:, k] + 3.0  # an offset the weights ignore
    return frame


def test_weights_recover_the_share_of_the_law_the_data_carry():
    prior = InternalForcePrior(converged=True)
    weights, report = supported_weights(prior, [_recording(prior, 3000, 0),
                                                _recording(prior, 2000, 1)])
    expected = np.clip(SHARES, 0, 1) * [1, 1, 1, 1, 1, 0]
    assert np.allclose(weights, expected, atol=0.02), weights
    comps = report["components"]
    assert abs(comps["fz"]["slope"] - 2.0) < 0.05   # the unclipped slope is reported
    assert comps["tx"]["explained_as_fitted"] < 0     # subtracting it as fitted made things worse
    assert comps["tx"]["explained"] == 0.0 and comps["ty"]["weight"] == 0.0
    assert comps["fy"]["explained"] > MIN_EXPLAINED
    assert comps["tz"]["slope"] == 0.0 and comps["tz"]["explained"] == 0.0


def test_weights_apply_on_every_prediction_path_and_round_trip(tmp_path):
    prior = InternalForcePrior(converged=True)
    weighted = weigh_prior(prior, [_recording(prior, 2000, 2)])
    assert weighted is not prior and np.all(prior.axis_weights == 1.0)
    frame = _recording(prior, 300, 3)
    a = arrays_from_frame(frame)
    law = prior.predict(frame)
    assert np.allclose(weighted.predict(frame), law * weighted.axis_weights)
    one = np.array([weighted.predict_one(a["positions"][i].tolist(), a["efforts"][i].tolist(),
                                         a["velocities"][i].tolist(), a["g_hex"][i].tolist())
                    for i in range(5)])
    assert np.allclose(one, law[:5] * weighted.axis_weights, atol=1e-12)
    weighted.save(tmp_path / "p.json")
    back = InternalForcePrior.load(tmp_path / "p.json")
    assert np.array_equal(back.axis_weights, weighted.axis_weights)
    assert back.info["axis_weights"]["components"]["fx"]["weight"] == weighted.axis_weights[0]
    # the hybrid's compensated reading: the raw HEX10 where the weight is 0
    comp = compensated_hex10(frame, back)
    assert np.array_equal(comp["comp_tx"], frame["tx"].to_numpy())
    assert not np.allclose(comp["comp_fx"], frame["fx"].to_numpy())


@pytest.mark.parametrize("weights, match", [
    ([1, 1, 1, 1, 1], "6 numbers"), ([1, 1, 1, 1, 1, 1.5], r"\[0, 1\]"),
    ([1, 1, 1, 1, 1, float("nan")], r"\[0, 1\]"), ("ones", "6 numbers"),
    ([1, 1, 1, 1, 1, True], "6 numbers")])
def test_bad_weights_in_a_prior_file_are_refused(tmp_path, weights, match):
    InternalForcePrior(converged=True).save(tmp_path / "p.json")
    d = json.loads((tmp_path / "p.json").read_text())
    d["axis_weights"] = weights
    (tmp_path / "p.json").write_text(json.dumps(seal(d)))  # resealed: the range check refuses
    with pytest.raises(IdentificationInputError, match=match):
        InternalForcePrior.load(tmp_path / "p.json")
    # a prior written before the weights (and before the envelope): the law as fitted
    for key in ("axis_weights", "sha256", "format_version"):
        del d[key]
    (tmp_path / "p.json").write_text(json.dumps(d))
    assert np.all(InternalForcePrior.load(tmp_path / "p.json").axis_weights == 1.0)
    with pytest.raises(IdentificationInputError, match="held-out"):
        supported_weights(InternalForcePrior(), [])
