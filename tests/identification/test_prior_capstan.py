"""The prior law's capstan (prior_law.py): the friction direction's Dahl recursion, batch and
streamed, against its closed form; the law's slack and taut branches against the capstan's
closed forms; numpy, CasADi and the per-sample path agree; files written before the capstan load
as the law they were fitted with; the efforts reading holds it; a capstan prior without the
friction state is refused."""
import math

import numpy as np
import pytest

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import HELD_BY_READING, InternalForcePrior
from psmforce.identification.cable_pair import tension_sum
from psmforce.identification.prior_law import (NAMES, PRESLIDING_RAD, SMOOTH_MAX_N,
                                               FrictionDirection, _CasadiOps, _model,
                                               friction_direction)

def _params(**values):
    """A law with everything off but what is given (SI)."""
    base = dict.fromkeys(NAMES, 0.0)
    base.update(pulley_radius_pitch=2e-3, pulley_radius_blade=1.5e-3, cable_radius=1.2e-3)
    base.update(values)
    return np.array([base[n] for n in NAMES])


def _law(params, efforts, z):
    """(6,) the law's wrench at the straight wrist, no roll, no motion, no gravity."""
    return np.array(_model(params, (0.0, 0.0), efforts, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), z,
                           math))


def test_friction_direction_follows_its_closed_form_and_remembers_at_rest():
    x_c = PRESLIDING_RAD
    # wrist pitch rises 3 x_c in 30 steps, rests, then falls 1 x_c: yaw and jaw still
    pitch = np.concatenate([np.linspace(0.0, 3 * x_c, 31), np.full(20, 3 * x_c),
                            np.linspace(3 * x_c, 2 * x_c, 11)[1:]])
    q = np.column_stack([pitch, np.zeros_like(pitch), np.zeros_like(pitch)])
    z = friction_direction(q)
    rise = 1.0 - math.exp(-3.0)  # exact for piecewise-linear motion, whatever the steps
    assert z[30, 0] == pytest.approx(rise, abs=1e-12)
    assert np.all(z[30:51, 0] == z[30, 0])  # at rest the state is remembered
    assert z[-1, 0] == pytest.approx(-1.0 + (rise + 1.0) * math.exp(-1.0), abs=1e-12)
    # the blade pairs take the pitch through the coupling kappa = 0.8306 / 1.0186
    assert z[30, 1] == z[30, 2] == pytest.approx(1.0 - math.exp(-3.0 * 0.8306 / 1.0186),
                                                 abs=1e-12)
    # the stream gives the same states, sample by sample
    rng = np.random.default_rng(3)
    walk = np.cumsum(rng.normal(0.0, 0.01, (400, 3)), axis=0)
    stream = FrictionDirection()
    streamed = np.array([list(stream.step(*row)) for row in walk.tolist()])
    assert np.allclose(streamed, friction_direction(walk), atol=1e-12, rtol=0)


@pytest.mark.parametrize("z", [1.0, -1.0])
def test_a_slack_pair_passes_its_load_times_exp_mu_z(z):
    """One pair loaded far past its pretension (D = 10 N on the pitch pair, 2 T0 = 0.2 N): the
    section sees ``|D| exp(mu z sgn D)`` in compression and ``D exp(...)`` in its moment."""
    mu, d = 0.3, 10.0
    p = _params(pretension_total=0.6, capstan_mu=mu)
    w = _law(p, (d * 2e-3, 0.0, 0.0), (z, 0.0, 0.0))
    w0 = _law(p, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # the blade pairs' share, unchanged
    pitch_pair = d * math.exp(mu * z)
    at_rest = tension_sum(0.2, 0.0, SMOOTH_MAX_N, math)  # the pitch pair's own share in w0
    assert -(w[2] - w0[2]) == pytest.approx(pitch_pair - at_rest, rel=1e-4)
    assert w[4] == pytest.approx(1.2e-3 * pitch_pair, rel=1e-4)  # ty = rho cos(0) D_section
    assert w[3] == pytest.approx(0.0, abs=1e-15)  # the pitch pair's "+" cable lies on x


def test_a_taut_pair_closes_its_loop_at_the_section():
    """Taut (D = 0.5 N under 2 T0 = 2 N), asymmetry a: the section's sum and differential keep
    ``S - a D = 2 T0`` (the loop's closure), and without friction (mu = 0) the law is the one
    before the capstan, ``S = 2 T0 + a D``."""
    a, d = 0.3, 0.5
    for mu in (0.0, 0.4):
        p = _params(pretension_total=6.0, asymmetry_pitch=a, capstan_mu=mu)
        w = _law(p, (d * 2e-3, 0.0, 0.0), (1.0, 0.0, 0.0))
        w0 = _law(p, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        s_pair = -(w[2] - w0[2]) + 2.0  # w0 holds three pairs at 2 T0 each (up to the smooth max)
        d_section = w[4] / 1.2e-3
        assert s_pair - a * d_section == pytest.approx(2.0, abs=2e-3), mu
        if mu == 0.0:
            assert d_section == pytest.approx(d, rel=1e-12) and s_pair == pytest.approx(
                2.0 + a * d, abs=2e-3)
        else:
            assert d_section > d  # the friction adds to the differential towards the section


def test_numpy_casadi_and_the_per_sample_path_agree():
    import casadi as ca

    rng = np.random.default_rng(0)
    n = 50
    q = np.cumsum(rng.normal(0.0, 0.02, (n, 3)), axis=0)
    pos = np.column_stack([rng.uniform(-1, 1, n), q[:, 0]])
    e, v = 0.02 * rng.standard_normal((n, 3)), rng.standard_normal((n, 3))
    g = rng.standard_normal((n, 3))
    z = friction_direction(q)
    prior = InternalForcePrior(params=_params(pretension_total=6.0, asymmetry_pitch=0.3,
                                              asymmetry_blade=0.2, capstan_mu=0.35,
                                              twist_gain=0.03, direction_tension=0.1,
                                              distal_mass=5e-3, distal_com_distance=0.02))
    batch = prior.predict_arrays(pos, e, v, g, z)
    one = np.array([prior.predict_one(pos[i].tolist(), e[i].tolist(), v[i].tolist(),
                                      g[i].tolist(), z[i].tolist()) for i in range(n)])
    assert np.allclose(batch, one, atol=1e-12, rtol=0)
    sym = _model(prior.params.tolist(), [ca.DM(pos[:, 0]), ca.DM(pos[:, 1])],
                 *[[ca.DM(c) for c in a.T.tolist()] for a in (e, v, g, z)], _CasadiOps())
    cas = np.column_stack([np.broadcast_to(np.array(ca.evalf(c)).ravel(), (n,)) for c in sym])
    assert np.allclose(batch, cas, atol=1e-10, rtol=0)


def test_a_capstan_prior_needs_the_friction_state_and_streams_it():
    from psmforce.estimators.data.hybrid_inputs import SamplePrior
    from psmforce.io.recording import JOINT_POSITIONS

    prior = InternalForcePrior(params=_params(pretension_total=6.0, capstan_mu=0.3))
    zeros = np.zeros((4, 3))
    with pytest.raises(IdentificationInputError, match="capstan"):
        prior.predict_arrays(np.zeros((4, 2)), zeros, zeros, zeros)
    with pytest.raises(IdentificationInputError, match="capstan"):
        prior.predict_one((0.0, 0.0), (0.0,) * 3, (0.0,) * 3, (0.0,) * 3)
    assert InternalForcePrior().friction_state() is None  # no capstan, no state to carry

    # a stream carries the state: sample by sample it gives the batch prediction of the frame
    import pandas as pd
    rng = np.random.default_rng(1)
    n = 200
    sp = SamplePrior(prior)
    cols = {c: np.zeros(n) for c in sp.input_columns}
    walk = np.cumsum(rng.normal(0.0, 0.01, (n, 3)), axis=0) + [0.0, 0.0, 0.6]  # jaw open
    for k, c in enumerate(JOINT_POSITIONS[4:]):
        cols[c] = walk[:, k]
    cols[JOINT_POSITIONS[2]] = np.full(n, 0.12)
    for c in sp.input_columns[len(JOINT_POSITIONS):len(JOINT_POSITIONS) + 3]:
        cols[c] = 0.02 * rng.standard_normal(n)
    frame = pd.DataFrame(cols)
    batch = prior.predict(frame)
    values = frame[list(sp.input_columns)].to_numpy(dtype=float)
    streamed = np.array([sp.predict_sample(row)[:6].copy() for row in values])
    assert np.allclose(streamed, batch, atol=1e-9, rtol=0)
    assert np.ptp(friction_direction(walk), axis=0).min() > 1.0  # the state did move


def test_files_before_the_capstan_load_without_it_and_new_ones_need_it():
    from psmforce.core.integrity import seal

    # a file of format version 2 (its 17 parameters, sealed as that version wrote them)
    v2 = InternalForcePrior(converged=True, params=_params(pretension_total=5.0)).to_dict()
    del v2["parameters"]["capstan_mu"]
    old = InternalForcePrior.from_dict(seal({**v2, "format_version": 2}), "old.json")
    assert old.params[NAMES.index("capstan_mu")] == 0.0 and len(old.params) == len(NAMES)
    assert old.params[NAMES.index("pretension_total")] == 5.0 and old.friction_state() is None
    d = InternalForcePrior(converged=True, params=_params(capstan_mu=0.2)).to_dict()
    assert InternalForcePrior.from_dict(d, "p.json").params[NAMES.index("capstan_mu")] == 0.2
    del d["parameters"]["capstan_mu"]
    with pytest.raises(IdentificationInputError, match="missing parameters.*capstan_mu"):
        InternalForcePrior.from_dict(seal({**d, "format_version": 3}), "p.json")


def test_the_efforts_reading_holds_the_capstan_and_the_load_path_frees_it():
    assert HELD_BY_READING["efforts"]["capstan_mu"] == 0.0
    assert "capstan_mu" not in HELD_BY_READING["load_path"]



def _law_at(params, roll, pitch, efforts, z):
    """(6,) the law's wrench at (roll, wrist pitch) (rad), no motion, no gravity."""
    return np.array(_model(params, (roll, pitch), efforts, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), z,
                           math))


@pytest.mark.parametrize("pitch", [0.7, -0.7])
def test_the_blade_pairs_capstan_grows_with_the_wrist_pitch_magnitude(pitch):
    """``capstan_pitch_gain`` raises the blade pairs' exponent to ``mu (1 + g |pitch|)`` and
    leaves the pitch pair's at ``mu``: with the pitch pair's friction state at 0 (its exponent
    then acts on nothing) the law equals the constant capstan ``mu (1 + g |pitch|)``, whichever
    way the wrist is pitched; the pitch pair's own share is the constant ``mu``'s."""
    mu, g = 0.2, 0.5
    efforts, z_blades = (0.01, 0.004, -0.003), (0.0, 0.8, -0.5)
    base = dict(pretension_total=6.0, asymmetry_pitch=0.3, asymmetry_blade=0.2)
    grown = _params(**base, capstan_mu=mu, capstan_pitch_gain=g)
    grown_blades = _law_at(grown, 0.0, pitch, efforts, z_blades)
    constant = _law_at(_params(**base, capstan_mu=mu * (1 + g * abs(pitch))), 0.0, pitch,
                       efforts, z_blades)
    assert np.allclose(grown_blades, constant, atol=1e-12, rtol=0)
    # pairs add: the pitch pair's share, its state moved, is the constant mu's
    z_all = (0.6, *z_blades[1:])
    share = _law_at(grown, 0.0, pitch, efforts, z_all) - grown_blades
    plain = _params(**base, capstan_mu=mu)
    as_mu = _law_at(plain, 0.0, pitch, efforts, (0.6, 0.0, 0.0)) \
        - _law_at(plain, 0.0, pitch, efforts, (0.0, 0.0, 0.0))
    assert np.allclose(share, as_mu, atol=1e-12, rtol=0) and np.abs(share).max() > 1e-3
    # at the straight wrist the term is nothing
    straight = [_law_at(_params(**base, capstan_mu=mu, capstan_pitch_gain=x), 0.0, 0.0, efforts,
                        z_all) for x in (0.0, g)]
    assert np.array_equal(straight[0], straight[1])


@pytest.mark.parametrize("roll", [1.2, -1.2])
def test_roll_twist_raises_every_pairs_capstan_by_its_relative_gain(roll):
    """``capstan_roll_gain`` multiplies every pair's exponent by ``1 + g |roll|``: the law equals
    the constant capstan ``mu (1 + g |roll|)`` at that roll, and nothing changes at roll 0."""
    mu, g = 0.25, 0.4
    efforts, z = (0.01, 0.004, -0.003), (0.6, 0.8, -0.5)
    twisted = _law_at(_params(pretension_total=6.0, twist_gain=0.03, capstan_mu=mu,
                              capstan_roll_gain=g), roll, 0.0, efforts, z)
    constant = _law_at(_params(pretension_total=6.0, twist_gain=0.03,
                               capstan_mu=mu * (1 + g * abs(roll))), roll, 0.0, efforts, z)
    assert np.allclose(twisted, constant, atol=1e-12, rtol=0)
    at_rest = [_law_at(_params(pretension_total=6.0, capstan_mu=mu, capstan_roll_gain=x),
                       0.0, 0.0, efforts, z) for x in (0.0, g)]
    assert np.array_equal(at_rest[0], at_rest[1])


def test_the_configuration_terms_scale_the_capstan_and_every_path_agrees():
    """The gains scale ``capstan_mu``: with it 0 the law has no capstan whatever they are (no
    friction state read). With it not 0, numpy, CasADi and the per-sample path agree."""
    args = (np.array([[0.8, -0.6]]), np.array([[0.01, 0.004, -0.003]]), np.zeros((1, 3)),
            np.zeros((1, 3)))
    z = np.array([[0.6, 0.8, -0.5]])
    gains = dict(pretension_total=6.0, capstan_pitch_gain=0.5, capstan_roll_gain=0.3)
    none = InternalForcePrior(params=_params(**gains))
    assert not none.has_friction and none.friction_state() is None
    assert np.array_equal(none.predict_arrays(*args),
                          InternalForcePrior(params=_params(pretension_total=6.0))
                          .predict_arrays(*args))
    p = _params(**gains, capstan_mu=0.3)
    prior = InternalForcePrior(params=p)
    with pytest.raises(IdentificationInputError, match="capstan_mu 0.3"):
        prior.predict_arrays(*args)
    batch = prior.predict_arrays(*args, z)[0]
    pos, e, v, g = (a[0] for a in args)
    one = prior.predict_one(tuple(pos), tuple(e), tuple(v), tuple(g), tuple(z[0]))
    assert np.allclose(batch, one, atol=1e-12, rtol=0)
    import casadi as ca
    sym = _model(list(p), [ca.DM(args[0][:, 0]), ca.DM(args[0][:, 1])],
                 *([ca.DM(x) for x in a.T] for a in (args[1], args[2], args[3], z)),
                 _CasadiOps())
    assert np.allclose([float(c) for c in sym], batch, atol=1e-12, rtol=0)
    constant = InternalForcePrior(params=_params(pretension_total=6.0, capstan_mu=0.3))
    assert np.abs(batch - constant.predict_arrays(*args, z)[0]).max() > 1e-3


def test_files_before_the_configuration_terms_load_with_the_constant_capstan():
    from psmforce.core.integrity import seal

    d = InternalForcePrior(converged=True, params=_params(capstan_mu=0.2)).to_dict()
    for name in ("capstan_pitch_gain", "capstan_roll_gain"):
        del d["parameters"][name]
    old = InternalForcePrior.from_dict(seal({**d, "format_version": 5}), "v5.json")
    assert old.params[NAMES.index("capstan_mu")] == 0.2
    assert old.params[NAMES.index("capstan_pitch_gain")] == 0.0
    assert old.params[NAMES.index("capstan_roll_gain")] == 0.0
    with pytest.raises(IdentificationInputError, match="missing parameters.*capstan_roll_gain"):
        InternalForcePrior.from_dict(seal({**d, "format_version": 6}), "v6.json")
    for name in ("capstan_pitch_gain", "capstan_roll_gain"):
        assert HELD_BY_READING["efforts"][name] == 0.0 and name not in HELD_BY_READING["load_path"]
