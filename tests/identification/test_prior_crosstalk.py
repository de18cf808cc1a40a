"""The prior law's HEX10 cross-talk of the forces it reads into its other channels
(prior_law.py): the axial column and the lateral ones, their closed form in numpy, CasADi and
the per-sample path, refused without the readings; the axial column held by the efforts reading
and freed by the load path, the lateral ones held by both unless asked; files written before
each load as the law they were fitted with."""
import math

import numpy as np
import pytest

from psmforce.core.integrity import seal
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import (HELD_BY_READING, HELD_BY_READING_REASON,
                                           InternalForcePrior)
from psmforce.identification.prior_law import (ADDED_TERMS, CROSSTALK, CROSSTALK_LATERAL,
                                                FRICTION, NAMES, _CasadiOps, _model)


def _params(**values):
    base = dict.fromkeys(NAMES, 0.0)
    base.update(pretension_total=6.0, pulley_radius_pitch=2e-3, pulley_radius_blade=1.5e-3,
                cable_radius=1.2e-3, distal_mass=5.5e-3, bias_fx=0.05, bias_fy=-0.03,
                bias_fz=0.1)
    base.update(values)
    return np.array([base[n] for n in NAMES])


def _inputs(n=50, seed=0):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-1.0, 1.0, (2, n))
    e = rng.normal(0.0, 0.02, (3, n))
    v = rng.normal(0.0, 0.5, (3, n))
    g = rng.normal(0.0, 5.0, (3, n))
    return pos, e, v, g, np.zeros((3, n))


LEAK = {"crosstalk_fx": 0.006, "crosstalk_fy": -0.009, "crosstalk_tx": 4e-4,
        "crosstalk_ty": -3e-4, "crosstalk_tz": 2e-4}
LATERAL = {"crosstalk_fy_from_fx": -0.008, "crosstalk_fz_from_fx": 0.015,
           "crosstalk_tx_from_fx": 1e-4, "crosstalk_ty_from_fx": -3e-4,
           "crosstalk_tz_from_fx": 2.5e-4, "crosstalk_fx_from_fy": 0.012,
           "crosstalk_fz_from_fy": -0.010, "crosstalk_tx_from_fy": 4e-4,
           "crosstalk_ty_from_fy": -1e-4, "crosstalk_tz_from_fy": -2e-4}
_IDX = {"fx": 0, "fy": 1, "fz": 2, "tx": 3, "ty": 4, "tz": 5}
# each term: (the wrench's (fx, fy, fz, tx, ty, tz) index it adds to, the reading it leaks from)
CHANNEL = {**{n: (_IDX[n.split("_")[1]], 2) for n in LEAK},
           **{n: (_IDX[n.split("_")[1]], _IDX[n.split("_")[3]]) for n in LATERAL}}
BIAS = (0.05, -0.03, 0.1)  # _params' force offsets: a leak reads the reading less its offset


def _readings(n, seed):
    """(3, n) HEX10 (fx, fy, fz) readings: internal and external forces alike."""
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(-4.0, 4.0, n), rng.uniform(-4.0, 4.0, n),
                     rng.uniform(-40.0, 5.0, n)])


def test_each_channel_gains_the_read_force_times_its_cross_talk():
    args = _inputs()
    force = _readings(50, 7)
    plain = np.array(_model(_params(), *args, np))
    assert tuple(LEAK) == CROSSTALK and set(LATERAL) == set(CROSSTALK_LATERAL)
    for name, x in {**LEAK, **LATERAL}.items():  # one term at a time: it moves its channel only
        leaky = np.array(_model(_params(**{name: x}), *args, np, force))
        k, src = CHANNEL[name]
        assert np.allclose(leaky[k] - plain[k], x * (force[src] - BIAS[src]), atol=1e-12,
                           rtol=0), name
        others = [c for c in range(6) if c != k]
        assert np.array_equal(leaky[others], plain[others]), name
    every = np.array(_model(_params(**LEAK), *args, np, force))
    assert np.array_equal(every[2], plain[2])  # the axial channel itself never leaks into itself
    with pytest.raises(ValueError, match="hex10_force"):  # a term cannot run without its reading
        _model(_params(crosstalk_fx=0.006), *args, np)
    for name in ("crosstalk_fy", "crosstalk_tz_from_fy"):
        with pytest.raises(IdentificationInputError, match="HEX10's force readings"):
            InternalForcePrior(params=_params(**{name: 0.001})).predict_arrays(
                *(x.T for x in args[:4]))


def test_numpy_casadi_and_the_per_sample_path_agree():
    import casadi as ca
    p = _params(**LEAK, **LATERAL)
    pos, e, v, g, z = _inputs(5, seed=1)
    force = _readings(5, 4)
    numpy_out = np.array(_model(p, pos, e, v, g, z, np, force))
    sym = ca.MX.sym("p", len(NAMES))
    f = ca.Function("law", [sym], [ca.vertcat(*[ca.vec(c) for c in _model(
        [sym[i] for i in range(len(NAMES))], [ca.DM(r) for r in pos], [ca.DM(r) for r in e],
        [ca.DM(r) for r in v], [ca.DM(r) for r in g], [ca.DM(r) for r in z], _CasadiOps(),
        [ca.DM(r) for r in force])])])
    assert np.allclose(np.array(f(p)).reshape(6, 5), numpy_out, atol=1e-12, rtol=0)
    prior = InternalForcePrior(params=p)
    one = prior.predict_one(pos[:, 0], e[:, 0], v[:, 0], g[:, 0],
                            hex10_force=[float(x) for x in force[:, 0]])
    assert np.allclose(one, numpy_out[:, 0], atol=1e-12, rtol=0)
    plain = InternalForcePrior(params=_params()).predict_one(pos[:, 0], e[:, 0], v[:, 0], g[:, 0])
    expected = np.array(plain)
    for name, x in {**LEAK, **LATERAL}.items():
        k, src = CHANNEL[name]
        expected[k] += x * (force[src, 0] - BIAS[src])
    assert np.allclose(one, expected, atol=1e-12, rtol=0)
    for name, x in {**LEAK, **LATERAL}.items():  # any one term needs the readings; named
        with pytest.raises(IdentificationInputError, match=f"{name}.*HEX10's force readings"):
            InternalForcePrior(params=_params(**{name: x})).predict_one(
                pos[:, 0], e[:, 0], v[:, 0], g[:, 0])


def test_the_efforts_reading_holds_it_and_says_why():
    for name in CROSSTALK:
        assert name in ADDED_TERMS and HELD_BY_READING["efforts"][name] == 0.0
        assert name not in HELD_BY_READING["load_path"]
        assert "load path fits it" in HELD_BY_READING_REASON[name]
    for name in CROSSTALK_LATERAL:  # both readings hold the lateral columns unless asked
        assert name in ADDED_TERMS
        assert HELD_BY_READING["efforts"][name] == HELD_BY_READING["load_path"][name] == 0.0
        assert "crosstalk='full'" in HELD_BY_READING_REASON[name]


def test_files_before_it_load_without_it_and_new_ones_need_it():
    v3 = InternalForcePrior(converged=True, params=_params(capstan_mu=0.2)).to_dict()
    for name in CROSSTALK:
        del v3["parameters"][name]
    old = InternalForcePrior.from_dict(seal({**v3, "format_version": 3}), "v3.json")
    assert old.params[NAMES.index("capstan_mu")] == 0.2
    assert all(old.params[NAMES.index(n)] == 0 for n in CROSSTALK)
    with pytest.raises(IdentificationInputError, match="missing parameters.*crosstalk_fx"):
        InternalForcePrior.from_dict(seal({**v3, "format_version": 4}), "v4.json")
    v4 = InternalForcePrior(converged=True, params=_params(crosstalk_fx=0.01)).to_dict()
    for name in ("crosstalk_tx", "crosstalk_ty", "crosstalk_tz"):
        del v4["parameters"][name]
    old = InternalForcePrior.from_dict(seal({**v4, "format_version": 4}), "v4.json")
    assert old.params[NAMES.index("crosstalk_fx")] == 0.01 and not old.params[-3:].any()
    with pytest.raises(IdentificationInputError, match="missing parameters.*crosstalk_tx"):
        InternalForcePrior.from_dict(seal({**v4, "format_version": 5}), "v5.json")
    d = InternalForcePrior(converged=True, params=_params(crosstalk_tz=2e-4)).to_dict()
    assert InternalForcePrior.from_dict(d, "p.json").params[NAMES.index("crosstalk_tz")] == 2e-4
    d["parameters"]["crosstalk_fx"]["value"] = 0.2  # beyond its +-5 % bounds
    with pytest.raises(IdentificationInputError, match="crosstalk_fx"):
        InternalForcePrior.from_dict(seal({**d, "format_version": 5}), "p.json")
    d["parameters"]["crosstalk_fx"]["value"] = 0.0
    d["parameters"]["crosstalk_ty"]["value"] = 0.01  # a 10 mm lever: beyond its +-2 mm bounds
    with pytest.raises(IdentificationInputError, match="crosstalk_ty"):
        InternalForcePrior.from_dict(seal({**d, "format_version": 5}), "p.json")
    v8 = InternalForcePrior(converged=True, params=_params(**LEAK)).to_dict()
    for name in CROSSTALK_LATERAL:
        del v8["parameters"][name]
    old = InternalForcePrior.from_dict(seal({**v8, "format_version": 8}), "v8.json")
    assert old.crosstalk is True and np.array_equal(old.params, _params(**LEAK))
    with pytest.raises(IdentificationInputError, match="missing parameters.*crosstalk_fy_from"):
        InternalForcePrior.from_dict(seal({**v8, "format_version": 9}), "v9.json")
    d = InternalForcePrior(converged=True, params=_params(crosstalk_fz_from_fy=0.01)).to_dict()
    back = InternalForcePrior.from_dict(d, "p.json")
    assert back.crosstalk == "full" and back.params[NAMES.index("crosstalk_fz_from_fy")] == 0.01
    d["parameters"]["crosstalk_tz_from_fx"]["value"] = -0.003  # a 3 mm lever: beyond +-2 mm
    with pytest.raises(IdentificationInputError, match="crosstalk_tz_from_fx"):
        InternalForcePrior.from_dict(seal({**d, "format_version": 9}), "p.json")


def test_a_mounted_law_turns_the_cables_not_the_sensors_cross_talk():
    """The mount turns the law's wrench into a tilted sensor's frame; the cross-talk is the
    sensor's own (its reading, its channels): added after the turn, unturned, and refused
    without the reading."""
    from psmforce.identification.prior_remount import MountedPrior, mount_rotation
    prior = InternalForcePrior(converged=True, params=_params(**LEAK, **LATERAL))
    pos, e, v, g, _ = _inputs(40)
    force = _readings(40, 3).T
    args = (pos.T, e.T, v.T, g.T)
    straight = MountedPrior(prior).predict_arrays(*args, hex10_force=force)
    assert np.allclose(straight, prior.predict_arrays(*args, hex10_force=force), atol=1e-12)
    angles = (0.02, -0.03, 0.01)
    tilted = MountedPrior(prior, angles).predict_arrays(*args, hex10_force=force)
    plain = InternalForcePrior(converged=True, params=_params()).predict_arrays(*args)
    bias = np.array([*BIAS, 0.0, 0.0, 0.0])
    r = mount_rotation(angles)
    turned = np.concatenate([(plain - bias)[:, :3] @ r, (plain - bias)[:, 3:] @ r], axis=1) + bias
    leak = np.zeros((40, 6))
    for name, x in {**LEAK, **LATERAL}.items():
        k, src = CHANNEL[name]
        leak[:, k] += x * (force[:, src] - BIAS[src])
    assert np.allclose(tilted, turned + leak, atol=1e-12)
    with pytest.raises(IdentificationInputError, match="HEX10's force readings"):
        MountedPrior(prior).predict_arrays(*args)


def test_the_efforts_reading_fits_the_cross_talk_when_asked():
    """``crosstalk`` overrides the reading's hold both ways and names nothing else."""
    from psmforce.identification.prior import held_by_reading
    assert held_by_reading("efforts") == HELD_BY_READING["efforts"]
    lateral = dict.fromkeys(CROSSTALK_LATERAL, 0.0)
    assert held_by_reading("efforts", crosstalk=True) == {**dict.fromkeys(FRICTION, 0.0),
                                                          "pitch_path_pretension": 0.0,
                                                          **lateral}
    assert held_by_reading("efforts", crosstalk="full") == {**dict.fromkeys(FRICTION, 0.0),
                                                            "pitch_path_pretension": 0.0}
    path = {"pitch_path_tension": 0.0}  # the load path reads it as the pretension form
    assert held_by_reading("load_path", crosstalk=False) == {
        **path, **dict.fromkeys(CROSSTALK, 0.0), **lateral}
    assert held_by_reading("load_path") == held_by_reading("load_path", True) == {**path,
                                                                                   **lateral}
    assert held_by_reading("load_path", crosstalk="full") == path
    for wrong in ("yes", 1, "Full"):
        with pytest.raises(IdentificationInputError, match="crosstalk must be"):
            held_by_reading("efforts", crosstalk=wrong)
    with pytest.raises(IdentificationInputError, match="unknown prior inputs"):
        held_by_reading("currents")


def test_a_cross_talk_prior_streams_its_reading_sample_by_sample():
    """The streaming path (SamplePrior) reads the HEX10's forces for a law with cross-talk and
    gives the batch prediction of the frame; without the term it reads the columns it always
    did."""
    import pandas as pd

    from psmforce.estimators.data.hybrid_inputs import SamplePrior
    from psmforce.io.recording import HEX10, JOINT_POSITIONS

    assert not set(HEX10) & set(SamplePrior(InternalForcePrior()).input_columns)
    prior = InternalForcePrior(converged=True, params=_params(**LEAK, **LATERAL))
    sp = SamplePrior(prior)
    assert sp.input_columns[-3:] == HEX10[:3]
    rng = np.random.default_rng(2)
    n = 120
    cols = {c: 0.02 * rng.standard_normal(n) for c in sp.input_columns}
    cols[JOINT_POSITIONS[2]] = np.full(n, 0.12)
    cols[JOINT_POSITIONS[3]] = rng.uniform(-1.0, 1.0, n)
    cols[HEX10[2]] = rng.uniform(-30.0, 5.0, n)
    cols[HEX10[0]], cols[HEX10[1]] = rng.uniform(-3.0, 3.0, (2, n))
    frame = pd.DataFrame(cols)
    batch = prior.predict(frame)
    values = frame[list(sp.input_columns)].to_numpy(dtype=float)
    streamed = np.array([sp.predict_sample(row)[:6].copy() for row in values])
    assert np.allclose(streamed, batch, atol=1e-9, rtol=0)
    plain = InternalForcePrior(converged=True, params=_params()).predict(frame)
    assert not np.allclose(batch[:, 1], plain[:, 1])  # the reading moved fy
