"""PSM kinematics: an independent modified-DH model, finite differences, Pinocchio, bad input."""

import warnings

import numpy as np
import pinocchio as pin
import pytest

from psmforce.robot import PSM
from psmforce.robot.kinematics import JointLimitError, JointLimitWarning, KinematicsInputError

# The published modified-DH table (psm_facts.md), typed in again on purpose: the test must not
# read the URDF it checks.  (alpha, a, d, theta offset, prismatic)
_DH = [
    (np.pi / 2, 0.0, 0.0, np.pi / 2, False),
    (-np.pi / 2, 0.0, 0.0, -np.pi / 2, False),
    (np.pi / 2, 0.0, -0.4318, 0.0, True),
    (0.0, 0.0, 0.4162, 0.0, False),
    (-np.pi / 2, 0.0, 0.0, -np.pi / 2, False),
    (-np.pi / 2, 0.0091, 0.0, -np.pi / 2, False),
]
_R_TIP = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
_LOWER = np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
_UPPER = -_LOWER
_UPPER[2] = 0.240


def _dh_link(alpha, a, theta, d):
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    # RotX(alpha) TransX(a) RotZ(theta) TransZ(d), Craig's form
    return np.array([[ct, -st, 0.0, a],
                     [st * ca, ct * ca, -sa, -sa * d],
                     [st * sa, ct * sa, ca, ca * d],
                     [0.0, 0.0, 0.0, 1.0]])


def _dh_cp(q):
    T = np.eye(4)
    for (alpha, a, d, offset, prismatic), qi in zip(_DH, q):
        T = T @ (_dh_link(alpha, a, offset, d + qi) if prismatic
                 else _dh_link(alpha, a, offset + qi, d))
    tip = np.eye(4)
    tip[:3, :3] = _R_TIP
    return T @ tip


def _random_q(rng, n):
    return rng.uniform(_LOWER, _UPPER, size=(n, 6))


@pytest.fixture(scope="module")
def psm():
    return PSM()


def test_cp_matches_independent_modified_dh(psm):
    q = _random_q(np.random.default_rng(1), 1000)
    T = psm.forward_kinematics(q, "cp")
    T_ref = np.array([_dh_cp(qi) for qi in q])
    assert np.abs(T[:, :3, 3] - T_ref[:, :3, 3]).max() < 1e-5
    R_err = np.einsum("nji,njk->nik", T_ref[:, :3, :3], T[:, :3, :3])
    angle = np.arccos(np.clip((np.trace(R_err, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert angle.max() < 1e-4


def test_closed_form_at_zero(psm):
    T = psm.forward_kinematics(np.zeros(6))
    np.testing.assert_allclose(T[:3, :3], [[0, 1, 0], [1, 0, 0], [0, 0, -1]], atol=1e-12)
    # retracted: wrist-pitch axis 15.6 mm and cp 15.6 - 9.1 mm above the RCM, shaft along -z0
    np.testing.assert_allclose(T[:3, 3], [0, 0, 0.0156 - 0.0091], atol=1e-12)
    T = psm.forward_kinematics([0, 0, 0.1, 0, 0, 0])
    np.testing.assert_allclose(T[:3, 3], [0, 0, -(0.1 - 0.0156 + 0.0091)], atol=1e-12)


def test_roll_frame_on_shaft(psm):
    """DH frame 4: origin on the shaft axis, q3 - 0.0156 from the RCM, z along the shaft to the tip."""
    q = _random_q(np.random.default_rng(2), 200)
    T = psm.forward_kinematics(q, "roll")
    np.testing.assert_allclose(T[:, :3, 3], (q[:, 2] - 0.0156)[:, None] * T[:, :3, 2], atol=1e-12)
    cp = psm.forward_kinematics(q * [1, 1, 1, 1, 0, 0], "cp")  # wrist straight
    np.testing.assert_allclose(cp[:, :3, 2], T[:, :3, 2], atol=1e-12)
    np.testing.assert_allclose(psm.rotation(q, "roll"), T[:, :3, :3])


def test_hex10_and_jaw_tip_geometry(psm):
    q = _random_q(np.random.default_rng(3), 50)
    roll, hex10 = psm.forward_kinematics(q, "roll"), psm.forward_kinematics(q, "hex10")
    np.testing.assert_allclose(hex10[:, :3, 3],
                               roll[:, :3, 3] - psm.hex10_distance * roll[:, :3, 2], atol=1e-12)
    cp, tip = psm.forward_kinematics(q, "cp"), psm.forward_kinematics(q, "jaw_tip")
    np.testing.assert_allclose(tip[:, :3, 3], cp[:, :3, 3] + psm.jaw_length * cp[:, :3, 2],
                               atol=1e-12)
    other = PSM(jaw_length=0.02, hex10_distance=0.03, hex10_clocking=np.pi / 2)
    assert (other.jaw_length, other.hex10_distance) == pytest.approx((0.02, 0.03))
    assert other.hex10_clocking == pytest.approx(np.pi / 2)
    R = other.rotation(q, "hex10")
    # clocking by +90 deg about the shaft: HEX10 x = roll y, HEX10 z = roll z
    np.testing.assert_allclose(R[:, :, 0], roll[:, :3, 1], atol=1e-12)
    np.testing.assert_allclose(R[:, :, 2], roll[:, :3, 2], atol=1e-12)
    assert psm.jaw_length == pytest.approx(0.0155)  # the shared model is untouched


def _pin_q(psm, qi):
    full = np.zeros(psm.model.nq)
    full[:6] = qi
    return full


@pytest.mark.parametrize("frame", ["cp", "jaw_tip", "roll", "hex10"])
def test_matches_pinocchio(psm, frame):
    q = _random_q(np.random.default_rng(4), 100)
    T, J = psm.forward_kinematics_and_jacobian(q, frame)
    model, data = psm.model, psm.model.createData()
    fid = model.getFrameId(frame, pin.FrameType.BODY)
    for k, qi in enumerate(q):
        pin.forwardKinematics(model, data, _pin_q(psm, qi))
        pin.updateFramePlacements(model, data)
        pin.computeJointJacobians(model, data, _pin_q(psm, qi))
        np.testing.assert_allclose(T[k], data.oMf[fid].homogeneous, atol=1e-12)
        np.testing.assert_allclose(J[k], pin.getFrameJacobian(model, data, fid, pin.WORLD)[:, :6],
                                   atol=1e-12)
        for ref, name in [(pin.LOCAL_WORLD_ALIGNED, "base_at_frame"), (pin.LOCAL, "frame")]:
            np.testing.assert_allclose(psm.jacobian(qi, frame, name),
                                       pin.getFrameJacobian(model, data, fid, ref)[:, :6],
                                       atol=1e-12)


def _fd_twists(psm, q, frame, h=1e-6):
    """Central differences: (N,6,6) WORLD twists [v0; w] and origin velocities per joint."""
    n = q.shape[0]
    J_world = np.zeros((n, 6, 6))
    v_origin = np.zeros((n, 3, 6))
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = h
        Tp, Tm = psm.forward_kinematics(q + dq, frame), psm.forward_kinematics(q - dq, frame)
        R = psm.rotation(q, frame)
        dR = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * h)
        W = dR @ np.swapaxes(R, 1, 2)  # skew(w)
        w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], axis=1)
        v = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h)
        p = psm.forward_kinematics(q, frame)[:, :3, 3]
        J_world[:, :3, i] = v - np.cross(w, p)  # velocity of the body point at the base origin
        J_world[:, 3:, i] = w
        v_origin[:, :, i] = v
    return J_world, v_origin


@pytest.mark.parametrize("frame", ["cp", "jaw_tip", "hex10"])
def test_jacobian_matches_finite_differences(psm, frame):
    rng = np.random.default_rng(5)
    q = rng.uniform(_LOWER + 1e-3, _UPPER - 1e-3, size=(200, 6))
    J_fd, v_fd = _fd_twists(psm, q, frame)
    assert np.abs(psm.spatial_jacobian(q, frame) - J_fd).max() < 1e-6
    assert np.abs(psm.jacobian(q, frame, "base_at_frame")[:, :3] - v_fd).max() < 1e-6


def test_dvrk_jacobian_conversion_formula(psm):
    """Docstring formulas: WORLD (dVRK spatial) -> LOCAL_WORLD_ALIGNED at cp -> LOCAL (dVRK body)."""
    q = _random_q(np.random.default_rng(6), 100)
    J_world = psm.spatial_jacobian(q)
    p = psm.forward_kinematics(q)[:, :3, 3]
    R = psm.rotation(q)
    skew = np.zeros((100, 3, 3))
    skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -p[:, 2], p[:, 1], -p[:, 0]
    skew -= np.swapaxes(skew, 1, 2)
    shift = np.tile(np.eye(6), (100, 1, 1))
    shift[:, :3, 3:] = -skew
    J_lwa = shift @ J_world
    Rt6 = np.zeros((100, 6, 6))
    Rt6[:, :3, :3] = Rt6[:, 3:, 3:] = np.swapaxes(R, 1, 2)
    np.testing.assert_allclose(J_lwa, psm.jacobian(q, "cp", "base_at_frame"), atol=1e-12)
    body = Rt6 @ J_lwa
    np.testing.assert_allclose(body, psm.jacobian(q, "cp", "frame"), atol=1e-12)
    # and back: the dVRK's spatial Jacobian is Ad(T_base_cp) @ body Jacobian (cisst robManipulator)
    Ad = np.zeros((100, 6, 6))
    Ad[:, :3, :3] = Ad[:, 3:, 3:] = R
    Ad[:, :3, 3:] = skew @ R
    np.testing.assert_allclose(Ad @ body, J_world, atol=1e-12)


def test_shapes_and_jaw_ignored(psm):
    q = _random_q(np.random.default_rng(7), 5)
    q7 = np.hstack([q, np.full((5, 1), 0.5)])
    assert psm.forward_kinematics(q[0]).shape == (4, 4)
    assert psm.forward_kinematics(q).shape == (5, 4, 4)
    assert psm.rotation(q[0], "roll").shape == (3, 3)
    assert psm.rotation(q, "hex10").shape == (5, 3, 3)
    assert psm.spatial_jacobian(q[0]).shape == (6, 6)
    assert psm.spatial_jacobian(q7).shape == (5, 6, 6)
    np.testing.assert_array_equal(psm.forward_kinematics(q7, "jaw_tip"),
                                  psm.forward_kinematics(q, "jaw_tip"))
    np.testing.assert_array_equal(psm.forward_kinematics(q7[2]), psm.forward_kinematics(q)[2])
    assert psm.joint_names == ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw")
    assert np.all(psm.jacobian(q, "roll")[:, :, 4:] == 0.0)  # wrist joints do not move the shaft


@pytest.mark.parametrize("bad, message", [
    (np.zeros(5), r"shape \(6,\), \(7,\), \(N,6\) or \(N,7\).*\(5,\)"),
    (np.zeros((3, 8)), r"got \(3, 8\)"),
    (np.zeros((2, 3, 6)), r"got \(2, 3, 6\)"),
    (np.zeros((0, 6)), r"N >= 1"),
    (np.array([0, 0, 0.1, np.nan, 0, 0]), r"non-finite.*'roll' at sample 0"),
    (np.array([[0, 0, 0.1, 0, 0, 0], [0, np.inf, 0.1, 0, 0, 0]]), r"non-finite.*'pitch' at sample 1"),
    (np.array(["a"] * 6), r"numeric"),
    (["0"] * 6, r"numeric"),
    ([0, 0, None, 0, 0, 0], r"numeric"),
])
def test_bad_q(psm, bad, message):
    with pytest.raises(KinematicsInputError, match=message):
        psm.forward_kinematics(bad)


def test_unknown_frame_and_reference(psm):
    with pytest.raises(KinematicsInputError, match=r"unknown frame 'tool_tip'"):
        psm.forward_kinematics(np.zeros(6), "tool_tip")
    with pytest.raises(KinematicsInputError, match=r"not one of the six chain joints"):
        psm.rotation(np.zeros(6), "jaw_blade_1_link")
    with pytest.raises(KinematicsInputError, match=r"unknown Jacobian reference 'body'"):
        psm.jacobian(np.zeros(6), "cp", "body")
    with pytest.raises(FileNotFoundError):
        PSM("/nonexistent/psm.urdf")
    with pytest.raises(KinematicsInputError, match="jaw_length must be > 0"):
        PSM(jaw_length=-0.01)


def test_joint_limits_warn_or_raise(psm):
    q = np.array([[0, 0, 0.1, 0, 0, 0], [0, 0, 0.3, 0, 0, 0], [0, 1.0, 0.1, 0, 0, 0]])
    with pytest.warns(JointLimitWarning, match=r"'pitch' = 1 at sample 2.*'insertion' = 0.3 at sample 1"):
        T = psm.forward_kinematics(q)
    assert np.isfinite(T).all()  # computed anyway, not clipped
    np.testing.assert_allclose(T[1, 2, 3], -(0.3 - 0.0156 + 0.0091))
    with pytest.raises(JointLimitError,
                       match=r"'pitch' = 1 at sample 2 \(limits \[-0.925025, 0.925025\]"):
        psm.forward_kinematics(q, strict=True)
    with pytest.warns(JointLimitWarning, match=r"'jaw' = 2"):
        psm.forward_kinematics([0, 0, 0.1, 0, 0, 0, 2.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        psm.forward_kinematics(np.vstack([_LOWER, _UPPER]))  # the limits themselves are inside
