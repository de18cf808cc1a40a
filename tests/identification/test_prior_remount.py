"""Recalibrating the internal-force prior after a re-mount
(psmforce/identification/prior_remount.py): a known per-mount change on data the law generates
is recovered, the shared parameters stay, and bad input is refused with a message."""

import numpy as np
import pandas as pd
import pytest

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior import InternalForcePrior, arrays_from_frame
from psmforce.identification.prior_law import CROSSTALK_LATERAL, NAMES
from psmforce.identification.prior_remount import (MOUNT_ANGLES, PER_MOUNT, MountedPrior,
                                                   _mounted_law, drift_basis, mount_rotation,
                                                   recalibrate)
from psmforce.io.recording import HEX10, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES, TIME

TRUE = dict(pretension_total=6.0, pulley_radius_pitch=2e-3, pulley_radius_blade=1.5e-3,
            twist_gain=0.03, direction_tension=0.0, asymmetry_pitch=0.3, asymmetry_blade=0.27,
            pitch_path_tension=0.9, distal_mass=5.5e-3, distal_com_distance=0.026,
            cable_radius=1.2e-3, bias_fx=0.05, bias_fy=-0.08, bias_fz=0.1, bias_tx=0.0,
            bias_ty=0.0, bias_tz=0.0, capstan_mu=0.0, crosstalk_fx=0.0, crosstalk_fy=0.0,
            crosstalk_tx=0.0, crosstalk_ty=0.0, crosstalk_tz=0.0, capstan_pitch_gain=0.0,
            capstan_roll_gain=0.0, pin_friction=0.0, pitch_path_pretension=0.0,
            **dict.fromkeys(CROSSTALK_LATERAL, 0.0))


def _prior(values=TRUE):
    return InternalForcePrior(params=np.array([values[n] for n in NAMES]), converged=True)


def _frame(n=3000, seed=0):
    """Free-space wrist motion (no HEX10 yet): roll over +-2.5 rad, pitch, yaw, small efforts."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    cols = {TIME: t}
    q = np.zeros((n, 7))
    q[:, 2] = 0.15
    q[:, 3] = 2.5 * np.sin(0.37 * t + 0.3)
    q[:, 4] = 0.9 * np.sin(1.1 * t)
    q[:, 5] = 0.8 * np.sin(0.7 * t + 1.0)
    q[:, 6] = 0.4
    qd = np.gradient(q, 0.01, axis=0)
    e = np.zeros((n, 7))
    e[:, 4:] = 0.004 * rng.standard_normal((n, 3))
    for j in range(7):
        cols[JOINT_POSITIONS[j]], cols[JOINT_VELOCITIES[j]], cols[JOINT_EFFORTS[j]] = q[:, j], qd[:, j], e[:, j]
    for c in HEX10:
        cols[c] = np.zeros(n)
    return pd.DataFrame(cols)


def _with_reading(frame, values, angles, noise=0.0, seed=1):
    a = arrays_from_frame(frame)
    w = _mounted_law(np.array([values[n] for n in NAMES]), angles, a["positions"], a["efforts"],
                     a["velocities"], a["g_hex"], a["direction"])
    w = w + noise * np.random.default_rng(seed).standard_normal(w.shape) * [1, 1, 1, 0.01, 0.01, 0.01]
    out = frame.copy()
    for k, c in enumerate(HEX10):
        out[c] = w[:, k]
    return out


def test_the_mounted_law_with_no_angle_is_the_prior_exactly():
    frame = _with_reading(_frame(), TRUE, (0.0, 0.0, 0.0))
    prior = _prior()
    np.testing.assert_array_equal(MountedPrior(prior).predict(frame), prior.predict(frame))


def test_recovers_a_known_per_mount_change_and_keeps_the_shared_parameters():
    new = {**TRUE, "pretension_total": 7.0, "bias_fx": -0.03, "bias_fy": 0.02, "bias_fz": 0.18,
           "bias_tx": 0.002, "bias_ty": -0.001, "bias_tz": 0.0005}
    tilt = (0.004, -0.003, 0.0)
    frame = _with_reading(_frame(), new, tilt, noise=0.005)
    mounted = recalibrate(_prior(), [frame])
    got = mounted.per_mount()
    assert got["pretension_total"] == pytest.approx(7.0, abs=0.1)
    for n in ("bias_fx", "bias_fy", "bias_fz"):
        assert got[n] == pytest.approx(new[n], abs=0.01), n
    for n in ("bias_tx", "bias_ty", "bias_tz"):
        assert got[n] == pytest.approx(new[n], abs=2e-4), n
    assert got["mount_about_x"] == pytest.approx(tilt[0], abs=5e-4)
    assert got["mount_about_y"] == pytest.approx(tilt[1], abs=5e-4)
    assert got["mount_about_z"] == 0.0                      # held by default
    shared = [k for k, n in enumerate(NAMES) if n not in PER_MOUNT]
    np.testing.assert_array_equal(mounted.prior.params[shared], _prior().params[shared])
    assert mounted.info["converged"]
    err = mounted.predict(frame) - frame[list(HEX10)].to_numpy()
    assert np.sqrt(np.mean(err[:, :3] ** 2)) < 0.01


def test_a_recalibration_without_a_change_changes_nothing_much():
    frame = _with_reading(_frame(), TRUE, (0.0, 0.0, 0.0))
    got = recalibrate(_prior(), [frame], drift_knot_s=None).per_mount()
    for n in PER_MOUNT:
        assert got[n] == pytest.approx(TRUE[n], abs=1e-6), n


def test_drift_basis_starts_at_zero_per_recording():
    b = drift_basis([np.arange(0, 45, 0.5), np.arange(0, 10, 0.5)], 20.0)
    assert b.shape == (90 + 20, 3 + 1)
    assert not b[0].any() and not b[90].any()
    assert b[:90, 3].max() == 0.0 and b[90:, :3].max() == 0.0
    with pytest.raises(IdentificationInputError, match="drift_knot_s"):
        drift_basis([np.arange(10.0)], 0.0)


def test_rotation_convention():
    r = mount_rotation((0.0, 0.0, np.pi / 2))
    np.testing.assert_allclose(np.array([1.0, 0.0, 0.0]) @ r, [0.0, -1.0, 0.0], atol=1e-15)


def test_refuses_bad_input():
    prior = _prior()
    frame = _with_reading(_frame(), TRUE, (0.0, 0.0, 0.0))
    with pytest.raises(IdentificationInputError, match="no recordings"):
        recalibrate(prior, [])
    with pytest.raises(IdentificationInputError, match="too short"):
        recalibrate(prior, [frame.iloc[:100]])
    still = frame.copy()
    still[JOINT_POSITIONS[3]] = 0.2
    with pytest.raises(IdentificationInputError, match="roll"):
        recalibrate(prior, [still])
    loaded = frame.copy()
    loaded["ati_fx"], loaded["ati_fy"], loaded["ati_fz"] = 1.0, 0.0, 0.0
    with pytest.raises(IdentificationInputError, match="free-space"):
        recalibrate(prior, [loaded])
    with pytest.raises(IdentificationInputError, match="per_mount"):
        recalibrate(prior, [frame], per_mount=("pulley_radius_pitch",))
    with pytest.raises(IdentificationInputError, match="InternalForcePrior"):
        recalibrate("prior.json", [frame])
    bad = frame.copy()
    bad.loc[5, "fx"] = np.nan
    with pytest.raises(IdentificationInputError, match="non-finite"):
        recalibrate(prior, [bad])
    assert set(MOUNT_ANGLES) >= {"mount_about_z"}
