"""Force frame changes base <-> roll <-> HEX10 and the ATI ground truth into HEX10 (paper eq. 4)."""

import numpy as np
import pytest

from psmforce.robot import PSM
from psmforce.robot.frames import (ati_force_in_hex10, base_to_hex10, base_to_roll, hex10_to_base,
                              hex10_to_roll, roll_to_base, roll_to_hex10)
from psmforce.robot.kinematics import KinematicsInputError

_LOWER = np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
_UPPER = np.array([1.588, 0.925025, 0.240, 4.53786, 1.39626, 1.39626])


@pytest.fixture(scope="module")
def psm():
    return PSM(hex10_clocking=0.3)  # a non-zero clocking so roll and HEX10 axes differ


@pytest.fixture(scope="module")
def batch():
    rng = np.random.default_rng(10)
    return rng.uniform(_LOWER, _UPPER, size=(64, 6)), rng.normal(size=(64, 3))


def test_round_trips(psm, batch):
    q, f = batch
    np.testing.assert_allclose(roll_to_base(base_to_roll(f, q, psm), q, psm), f, atol=1e-12)
    np.testing.assert_allclose(hex10_to_roll(roll_to_hex10(f, psm), psm), f, atol=1e-12)
    np.testing.assert_allclose(hex10_to_base(base_to_hex10(f, q, psm), q, psm), f, atol=1e-12)
    np.testing.assert_allclose(base_to_hex10(f, q, psm),
                               roll_to_hex10(base_to_roll(f, q, psm), psm), atol=1e-12)


def test_known_values_at_zero():
    """q = 0 by hand from the DH table: R_PSM_Roll = R01 R12 R23 = [[0,-1,0],[-1,0,0],[0,0,-1]]."""
    psm = PSM()
    np.testing.assert_allclose(psm.rotation(np.zeros(6), "roll"), [[0, -1, 0], [-1, 0, 0], [0, 0, -1]],
                               atol=1e-12)
    # A push up the shaft (base +z at q = 0) is shaft compression: negative z in roll and HEX10.
    np.testing.assert_allclose(base_to_roll([0, 0, 2.0], np.zeros(6), psm), [0, 0, -2.0], atol=1e-12)
    np.testing.assert_allclose(base_to_hex10([1.0, 0, 2.0], np.zeros(6), psm), [0, -1.0, -2.0],
                               atol=1e-12)


def test_clocking_rotates_about_shaft(batch):
    q, f = batch
    quarter = PSM(hex10_clocking=np.pi / 2)
    f_roll = base_to_roll(f, q, quarter)
    f_hex = roll_to_hex10(f_roll, quarter)
    # HEX10 x = roll y, HEX10 y = -roll x, z shared
    np.testing.assert_allclose(f_hex, np.stack([f_roll[:, 1], -f_roll[:, 0], f_roll[:, 2]], 1),
                               atol=1e-12)


def test_roll_frame_follows_roll_joint(psm):
    q = np.array([0.2, -0.3, 0.12, 0.0, 0.4, -0.2])
    f = np.array([1.0, 0.0, 0.0])
    q_rolled = q.copy()
    q_rolled[3] = np.pi / 2
    a, b = base_to_roll(f, q, psm), base_to_roll(f, q_rolled, psm)
    np.testing.assert_allclose(b, [a[1], -a[0], a[2]], atol=1e-12)  # turning +90 deg about z


def test_ati_eq4(psm, batch):
    q, f = batch
    np.testing.assert_allclose(ati_force_in_hex10(f, q, np.eye(3), psm), base_to_hex10(f, q, psm),
                               atol=1e-12)
    c, s = np.cos(0.7), np.sin(0.7)
    R_ati_psm = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[1.0, 0, 0], [0, -1.0, 0], [0, 0, -1.0]])
    expected = np.einsum("nji,nj->ni", R_ati_psm @ psm.rotation(q, "roll") @ psm.R_roll_hex10, f)
    np.testing.assert_allclose(ati_force_in_hex10(f, q, R_ati_psm, psm), expected, atol=1e-12)
    np.testing.assert_allclose(ati_force_in_hex10(f, q, R_ati_psm, psm, sign=-1.0), -expected,
                               atol=1e-12)
    # F_ATI in ATI axes is R_ati_psm f_base: eq. 4 brings it back to base_to_hex10(f_base)
    f_ati = f @ R_ati_psm.T
    np.testing.assert_allclose(ati_force_in_hex10(f_ati, q, R_ati_psm, psm),
                               base_to_hex10(f, q, psm), atol=1e-12)


def test_single_q_many_forces(psm, batch):
    q, f = batch
    np.testing.assert_allclose(base_to_roll(f, q[0], psm), base_to_roll(f, np.tile(q[0], (64, 1)), psm),
                               atol=1e-12)
    assert base_to_roll(f[0], q[0], psm).shape == (3,)


def test_bad_input(psm, batch):
    q, f = batch
    with pytest.raises(KinematicsInputError, match=r"force_base must have shape \(3,\) or \(N,3\)"):
        base_to_roll(np.zeros(6), q[0], psm)
    with pytest.raises(KinematicsInputError, match="force_base has 3 samples but q has 64"):
        base_to_roll(f[:3], q, psm)
    with pytest.raises(KinematicsInputError, match="force_roll has a non-finite value at sample 0"):
        roll_to_hex10([np.nan, 0, 0], psm)
    with pytest.raises(KinematicsInputError, match="R_ati_psm is not a proper rotation"):
        ati_force_in_hex10(f, q, np.diag([1.0, 1.0, -1.0]), psm)
    with pytest.raises(KinematicsInputError, match=r"R_ati_psm must have shape \(3,3\)"):
        ati_force_in_hex10(f, q, np.eye(4), psm)
    with pytest.raises(KinematicsInputError, match="sign must be"):
        ati_force_in_hex10(f, q, np.eye(3), psm, sign=2.0)
    with pytest.raises(KinematicsInputError, match="unknown frame|non-finite"):
        base_to_hex10(f[0], np.full(6, np.nan), psm)
