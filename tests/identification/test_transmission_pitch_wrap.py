"""The wrist pitch's capstan wrap (model docstring): antagonistic (``capstan_mu_pitch``: one cable
+q, its partner -q) and symmetric (``capstan_mu_abs_pitch``: both +|q|). The exact two-cable
capstan in closed form, derivatives by finite differences, units (radians), no effect at pitch 0,
where the pitch comes from (the folder's ReadME.txt), how the fit holds the terms when no
recording is pitched, and that a pitched bench gives the coefficient back."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from psmforce.identification.cable_pair import tension_sum
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.transmission import roles
from psmforce.identification.transmission.model import (ABS_PITCH_TERM, ANGLE_NAMES, PITCH_TERM,
                                                        PITCH_TERMS, SMOOTH_MAX_NM,
                                                        TORQUE_NAMES, CableTransmission,
                                                        _signals, _torque_law)
from psmforce.identification.transmission.recording import read_configuration
from tests.identification.test_transmission import (ANGLE_TRUTH, MRDLAB, TRUTH,
                                                    _in_family_bench, _synthetic)

MU, MU_Q = 0.5, 0.3


def _params(mu_q=MU_Q, pretension=0.05, bias=0.0, mu_a=0.0):
    p = dict(TRUTH, viscous=0.0, inertia=0.0, position_stiffness=0.0, motor_coulomb=0.0,
             capstan_mu=MU, capstan_mu_per_rad=0.0, capstan_mu_pitch=mu_q,
             capstan_mu_abs_pitch=mu_a,
             pretension_torque=pretension, pair_asymmetry=0.0, torque_bias=bias, current_gain=1.0)
    return np.array([p[k] for k in TORQUE_NAMES])


def _pitched(pitch_rad, current=0.02):
    theta = np.concatenate([np.linspace(0, 1, 300), np.linspace(1, 0.2, 300)])
    rec = replace(_synthetic(theta, np.full(len(theta), current), "wrap"), pitch_rad=pitch_rad)
    return _signals(rec, 0.01)


@pytest.mark.parametrize("pitch", [np.radians(60.0), np.radians(-30.0)])
def test_the_two_cables_wrap_antagonistically_in_closed_form(pitch):
    # taut pair: tension sum S = P (smooth max), differential D = tau_s; the closing cable
    # T1 = (S + D) / 2 wraps (mu + mu_q q) z, the opening one T2 = (S - D) / 2 (mu - mu_q q) z:
    # jaw torque = -(T1 exp(-m1) - T2 exp(m2)), the capstan law of each cable on its own
    s = _pitched(pitch)
    law = _torque_law(_params(), s, np)
    d = s.current
    big_s = tension_sum(0.05 + 0 * d, d, SMOOTH_MAX_NM, np)
    m1, m2 = (MU + MU_Q * pitch) * s.z, (MU - MU_Q * pitch) * s.z
    exact = -(0.5 * (big_s + d) * np.exp(-m1) - 0.5 * (big_s - d) * np.exp(m2))
    assert np.allclose(law, exact, rtol=1e-12, atol=1e-15)
    # switched off (mu_q = 0) or with the sign flipped, the law misses the closed form
    for wrong in (0.0, -MU_Q):
        assert np.max(np.abs(_torque_law(_params(wrong), s, np) - exact)) > 1e-3 * np.max(
            np.abs(exact))


def test_slack_closing_cable_follows_the_belt_friction_law():
    # slack (P ~ 0): only the closing cable carries the load: T_out = T_in exp(-mu wrap z) with
    # the wrap grown by the pitch in radians (60 degrees = pi / 3 rad, not 60)
    q = np.radians(60.0)
    s = _pitched(q, current=0.2)
    law = _torque_law(_params(pretension=1e-6), s, np)
    z = s.z[299]
    assert z > 0.99
    assert law[299] == pytest.approx(-0.2 * np.exp(-(MU + MU_Q * q) * z), rel=1e-4)
    assert law[299] != pytest.approx(-0.2 * np.exp(-(MU + MU_Q * 60.0) * z), rel=1e-2)


def test_derivative_in_pitch_matches_finite_differences():
    # d law / d q = mu_q z (c_0 - law): the wrap scales the cable torque by exp(-mu_q q z)
    q, h, bias = 0.4, 1e-6, 0.01
    up, down, mid = (_torque_law(_params(bias=bias), _pitched(x), np)
                     for x in (q + h, q - h, q))
    z = _pitched(q).z
    fd = (up - down) / (2 * h)
    assert np.allclose(fd, MU_Q * z * (bias - mid), rtol=1e-5, atol=1e-9)
    # and with the load driven closed (cable torque above the friction), the torque reaching
    # the jaw shrinks as a positive pitch wraps the closing cable more (positive mu_q)
    heavy = [_torque_law(_params(), _pitched(x, current=0.2), np) for x in (0.0, q)]
    closing = _pitched(q, current=0.2).z > 0.99
    assert np.all(np.abs(heavy[1][closing]) < np.abs(heavy[0][closing]))


@pytest.mark.parametrize("pitch", [np.radians(60.0), np.radians(-30.0)])
def test_symmetric_wrap_grows_both_cables_exponents_by_abs_pitch(pitch):
    # both cables wrap |q| more: T1 exp(-(mu + mu_a |q|) z) - T2 exp((mu + mu_a |q|) z)
    mu_a = 0.2
    s = _pitched(pitch)
    law = _torque_law(_params(0.0, mu_a=mu_a), s, np)
    d = s.current
    big_s = tension_sum(0.05 + 0 * d, d, SMOOTH_MAX_NM, np)
    m = (MU + mu_a * abs(pitch)) * s.z
    exact = -(0.5 * (big_s + d) * np.exp(-m) - 0.5 * (big_s - d) * np.exp(m))
    assert np.allclose(law, exact, rtol=1e-12, atol=1e-15)
    # even in the pitch: +q and -q give one law; switched off it misses the closed form
    assert np.allclose(_torque_law(_params(0.0, mu_a=mu_a), _pitched(-pitch), np), law)
    off = _torque_law(_params(0.0), s, np)
    assert np.max(np.abs(off - exact)) > 1e-3 * np.max(np.abs(exact))


def test_symmetric_derivative_matches_finite_differences():
    # d law / d mu_a = |q| d law / d mu: the wrap adds to the friction exponent, 1:1 in rad
    q, h, mu_a = np.radians(-30.0), 1e-6, 0.2
    s = _pitched(q, current=0.2)
    fd_a = (_torque_law(_params(0.0, mu_a=mu_a + h), s, np)
            - _torque_law(_params(0.0, mu_a=mu_a - h), s, np)) / (2 * h)
    p_up, p_down = _params(0.0, mu_a=mu_a), _params(0.0, mu_a=mu_a)
    k = TORQUE_NAMES.index("capstan_mu")
    p_up[k] += h
    p_down[k] -= h
    fd_mu = (_torque_law(p_up, s, np) - _torque_law(p_down, s, np)) / (2 * h)
    assert np.allclose(fd_a, abs(q) * fd_mu, rtol=1e-5, atol=1e-10)
    closing = s.z > 0.99                      # more wrap, more friction: less torque reaches
    assert np.all(fd_a[closing] > 0)          # the jaw (its torque is negative while closing)


def test_no_effect_at_pitch_zero():
    s = _pitched(0.0)
    assert np.array_equal(_torque_law(_params(0.0), s, np),
                          _torque_law(_params(0.9, mu_a=0.7), s, np))


def test_configuration_comes_from_the_folder_readme(tmp_path):
    (tmp_path / "ReadME.txt").write_text(
        "This is a roll of 0 degrees (i.e. 90 degrees on the outer ring of the protractor)\n"
        "This is a pitch of +60 degrees (i.e. 120 on the top of the shaft)")
    assert read_configuration(tmp_path) == pytest.approx(
        {"roll_rad": 0.0, "pitch_rad": np.pi / 3})
    (tmp_path / "ReadME.txt").write_text("This is a roll of -45 degrees (i.e. 45 degrees ...)")
    assert read_configuration(tmp_path) == pytest.approx(
        {"roll_rad": -np.pi / 4, "pitch_rad": 0.0})
    assert read_configuration(tmp_path / "absent") == {"roll_rad": 0.0, "pitch_rad": 0.0}


@pytest.mark.skipif(not MRDLAB.is_dir(), reason="needs ../shared/data/mrdlab")
def test_the_real_folders_pitch():
    assert read_configuration(MRDLAB / "Tool_4_Maryland_L_Pitch_1")["pitch_rad"] == \
        pytest.approx(np.radians(60.0))
    assert read_configuration(MRDLAB / "Tool_4_Maryland_L_Pitch_4")["pitch_rad"] == \
        pytest.approx(np.radians(-30.0))
    assert read_configuration(MRDLAB / "Tool_4_Maryland_L_4")["pitch_rad"] == 0.0


def test_an_unpitched_fit_holds_the_term_and_says_so():
    model = CableTransmission(presliding_rad=0.04, hold_rad=0.005, backlash_rad=0.01)
    model.info.update(unexcited=list(PITCH_TERMS))
    model.fixed = PITCH_TERMS
    for name in PITCH_TERMS:
        row = next(r for r in roles.roles_table(model) if r["name"] == name)
        assert row["role"] == "fixed: not excited" and row["unit"] == "1/rad"
    model.info.update(declared_fixed=[ABS_PITCH_TERM])     # a declaration names itself
    row = next(r for r in roles.roles_table(model) if r["name"] == ABS_PITCH_TERM)
    assert row["role"] == "fixed: declared"
    model.info.update(unexcited=[], declared_fixed=[], pitch_wrap=[PITCH_TERM])
    roles_now = {r["name"]: r["role"] for r in roles.roles_table(model)}
    assert roles_now[ABS_PITCH_TERM] == "fixed: switched off"      # pitched, not switched on
    assert roles.DESIGN["pitch_wrap_per_rad"][0] == 1.0   # 1:1 wrap change: design, not fitted


@pytest.mark.slow
def test_a_pitched_bench_gives_the_coefficient_back():
    # the in-family bench at three wrist pitches (one session each): the shared coefficient
    # comes back, with its sign; a fit on pitch 0 alone holds it at 0 (not excited)
    truth_p = dict(TRUTH, capstan_mu_pitch=0.25)
    truth = CableTransmission(np.array([truth_p[k] for k in TORQUE_NAMES]),
                              np.array([ANGLE_TRUTH[k] for k in ANGLE_NAMES]),
                              presliding_rad=0.04, hold_rad=0.005, backlash_rad=0.01)
    rng = np.random.default_rng(3)
    recs = []
    for q, session in ((0.0, "flat"), (np.radians(60), "up"), (np.radians(-30), "down")):
        for r in _in_family_bench(4)[:3]:
            r = replace(r, pitch_rad=q, session=session, name=f"{session}/{r.name}")
            recs.append(replace(r, jaw_torque_nm=truth.predict(r).jaw_torque_nm
                                + 1e-3 * rng.standard_normal(len(r))))
    start = CableTransmission(presliding_rad=0.04, hold_rad=0.005, backlash_rad=0.01)
    fit = CableTransmission.fit(recs, initial=start, pitch_wrap=(PITCH_TERM,))
    assert fit.info["unexcited"] == [] and ABS_PITCH_TERM in fit.fixed
    assert fit.torque[TORQUE_NAMES.index(PITCH_TERM)] == pytest.approx(0.25, abs=0.03)
    flat = CableTransmission.fit([r for r in recs if r.session == "flat"], initial=start,
                                 pitch_wrap=PITCH_TERMS)
    assert set(PITCH_TERMS) <= set(flat.fixed)
    assert flat.info["unexcited"] == list(PITCH_TERMS)
    assert flat.torque[TORQUE_NAMES.index(PITCH_TERM)] == 0.0
    # the default model (switch off) holds both terms at 0 on the pitched bench: as it was
    default = CableTransmission.fit(recs, initial=start)
    assert set(PITCH_TERMS) <= set(default.fixed) and default.info["pitch_wrap"] == []
    assert all(default.torque[TORQUE_NAMES.index(n)] == 0.0 for n in PITCH_TERMS)
    assert {r["name"]: r["role"] for r in roles.roles_table(default)}[PITCH_TERM] == \
        "fixed: switched off"
    with pytest.raises(IdentificationInputError, match="pitch_wrap"):
        CableTransmission.fit(recs, initial=start, pitch_wrap=("capstan_mu",))
