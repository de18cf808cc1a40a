"""The insertion joint's internal-effort model (psmforce.identification.insertion)."""

import numpy as np
import pytest

from psmforce.identification import IdentificationInputError
from psmforce.identification.insertion import InsertionEffortModel
from psmforce.identification.prior import InternalForcePrior

TRUE = (0.4, -0.3, 8.8, 0.35, 2.0, 0.06)  # g_b (N), Coulomb (N), viscous (N s/m), offset (N)


def _recording(rng, n=600, smooth_sign=0.005):
    """A shaft swept over a cone, insertion moving back and forth, a known axial press."""
    t = np.arange(n) * 0.01
    yaw, pitch = 0.6 * np.sin(0.7 * t + rng.uniform(0, 6)), 0.5 * np.sin(0.4 * t + rng.uniform(0, 6))
    d = np.column_stack([np.cos(pitch) * np.sin(yaw), -np.sin(pitch), -np.cos(pitch) * np.cos(yaw)])
    v = 0.03 * np.sin(1.3 * t + rng.uniform(0, 6))
    f_axial = -np.clip(2.0 * np.sin(0.9 * t), 0.0, None)  # presses only
    g, fc, b, c = np.array(TRUE[:3]), *TRUE[3:]
    effort = -f_axial + d @ g + fc * np.tanh(v / smooth_sign) + b * v + c
    return d, v, effort, f_axial


def _fit(recs):
    return InsertionEffortModel.fit(*map(list, zip(*recs)))


def test_recovers_parameters_and_transition_and_returns_the_axial_force():
    rng = np.random.default_rng(0)
    recs = [_recording(rng) for _ in range(6)]
    model = _fit(recs)
    np.testing.assert_allclose(model.params, TRUE, atol=1e-8)
    assert model.smooth_sign_mps == 0.005  # chosen by cross-validation among the candidates
    d, v, effort, f_axial = _recording(np.random.default_rng(1))
    np.testing.assert_allclose(model.axial_force(d, v, effort), f_axial, atol=1e-8)
    one = [model.axial_force_one(d[k].tolist(), float(v[k]), float(effort[k])) for k in range(len(v))]
    np.testing.assert_allclose(one, f_axial, atol=1e-8)


def test_gravity_along_the_shaft_follows_an_unseen_arm_direction():
    """Fitted on a narrow cone of shaft directions, the physics extrapolates to a shaft tilted far
    outside it (where a function of the joint angles learned on the cone would not)."""
    rng = np.random.default_rng(2)
    recs = []
    for _ in range(5):
        d, v, effort, f = _recording(rng)
        narrow = d * [0.3, 0.3, 1.0]
        narrow /= np.linalg.norm(narrow, axis=1, keepdims=True)
        effort = effort - d @ np.array(TRUE[:3]) + narrow @ np.array(TRUE[:3])
        recs.append((narrow, v, effort, f))
    model = _fit(recs)
    tilted = np.tile([np.sin(1.0), 0.0, -np.cos(1.0)], (50, 1))
    v = np.zeros(50)
    effort = tilted @ np.array(TRUE[:3]) + TRUE[5] + 1.5  # a 1.5 N pull along the shaft
    np.testing.assert_allclose(model.axial_force(tilted, v, effort), -1.5, atol=1e-6)


def test_bad_input_is_named():
    rng = np.random.default_rng(3)
    d, v, effort, f = _recording(rng)
    with pytest.raises(IdentificationInputError, match="insertion effort"):
        _fit([(d, v, effort[:-1], f)])
    bad = v.copy()
    bad[5] = np.nan
    with pytest.raises(IdentificationInputError, match="insertion velocity"):
        _fit([(d, bad, effort, f)])
    still = np.tile(d[:1], (len(d), 1))
    with pytest.raises(IdentificationInputError, match="do not excite"):
        _fit([(still, v, effort, f), (still, v, effort, f)])
    model = _fit([_recording(rng) for _ in range(3)])
    with pytest.raises(IdentificationInputError, match="finite"):
        model.axial_force(d, v, np.full(len(v), np.inf))
    with pytest.raises(IdentificationInputError, match="missing or bad"):
        InsertionEffortModel.from_dict({"parameters": {}, "smooth_sign_mps": 0.005})


def test_round_trips_inside_the_prior_json(tmp_path):
    rng = np.random.default_rng(4)
    model = _fit([_recording(rng) for _ in range(3)])
    prior = InternalForcePrior(converged=True, insertion=model)
    prior.save(tmp_path / "p.json")
    back = InternalForcePrior.load(tmp_path / "p.json")
    assert back.insertion.params == model.params
    assert back.insertion.smooth_sign_mps == model.smooth_sign_mps
    InternalForcePrior(converged=True).save(tmp_path / "q.json")
    assert InternalForcePrior.load(tmp_path / "q.json").insertion is None
