"""Wrench from joint torques: PSM round trips, frame consistency, damping, UR5 and Panda, bad input."""

import numpy as np
import pinocchio as pin
import pytest

from psmforce.robot import PSM
from psmforce.robot.conventions import EXPRESSED_IN
from psmforce.robot.example_robots import load_example_robot
from psmforce.robot.frames import base_to_hex10
from psmforce.robot.kinematics import KinematicsInputError
from psmforce.robot.wrench import WrenchInputError, solve_wrench, wrench_from_torques

# Away from the singularity where cp passes through the RCM (insertion about 6.5-15.6 mm).
_LOWER = np.array([-1.588, -0.925025, 0.05, -4.53786, -1.39626, -1.39626])
_UPPER = np.array([1.588, 0.925025, 0.240, 4.53786, 1.39626, 1.39626])


@pytest.fixture(scope="module")
def psm():
    return PSM(hex10_clocking=0.4)


@pytest.fixture(scope="module")
def loads():
    rng = np.random.default_rng(20)
    q = rng.uniform(_LOWER, _UPPER, size=(500, 6))
    w = np.hstack([rng.normal(0, 2.0, (500, 3)), rng.normal(0, 0.02, (500, 3))])  # N, Nm
    return q, w


def _torques(J, w):
    return np.einsum("nij,ni->nj", J, w)


def test_psm_round_trip_spatial(psm, loads):
    """The issue's round trip: wrench_from_torques(q, J_s(q)^T w) == w, J_s = spatial_jacobian."""
    q, w = loads
    tau = _torques(psm.spatial_jacobian(q), w)
    w_hat, info = psm.wrench_from_torques(q, tau, return_info=True)
    assert not info.damped.any()
    np.testing.assert_allclose(w_hat, w, atol=1e-9)
    assert info.residual.max() < 1e-9
    # the frame only matters for the other two conventions
    np.testing.assert_allclose(psm.wrench_from_torques(q, tau, frame="hex10"), w_hat, atol=1e-12)


@pytest.mark.parametrize("frame", ["cp", "jaw_tip", "hex10", "roll"])
@pytest.mark.parametrize("expressed_in", ["base_at_frame", "frame"])
def test_psm_round_trip_at_frame(psm, loads, frame, expressed_in):
    q, w = loads
    # the wrench acts on the distal body: its Jacobian at the frame's origin p, in base or frame axes
    T = psm.forward_kinematics(q, frame)
    J = psm.spatial_jacobian(q, "cp").copy()
    J[:, :3] -= np.cross(T[:, :3, 3][:, :, None], J[:, 3:], axis=1)  # v_p = v_0 + w x p
    if expressed_in == "frame":
        Rt = np.swapaxes(T[:, :3, :3], 1, 2)
        J = np.concatenate([Rt @ J[:, :3], Rt @ J[:, 3:]], axis=1)
    tau = _torques(J, w)
    w_hat, info = psm.wrench_from_torques(q, tau, frame=frame, expressed_in=expressed_in,
                                          return_info=True)
    assert not info.damped.any()
    np.testing.assert_allclose(w_hat, w, atol=1e-9)
    assert info.residual.max() < 1e-9


def test_round_trip_with_internal_torques(psm, loads):
    """The paper's F = J_s^-T (tau - tau_hat), J_s the spatial Jacobian the dVRK publishes."""
    q, w = loads
    tau_internal = np.random.default_rng(21).normal(size=(500, 7))
    tau = _torques(psm.spatial_jacobian(q), w) + tau_internal[:, :6]
    np.testing.assert_allclose(psm.wrench_from_torques(q, tau, tau_internal), w, atol=1e-9)
    one = psm.wrench_from_torques(q[0], tau[0], tau_internal[0])
    assert one.shape == (6,)
    np.testing.assert_allclose(one, w[0], atol=1e-9)


def test_frames_agree_on_the_same_load(psm, loads):
    """One load, reduced at the RCM / cp / hex10: same force (rotated), moments differ by the lever."""
    q, w = loads
    tau = _torques(psm.jacobian(q, "cp", "base_at_frame"), w)
    at_rcm = psm.wrench_from_torques(q, tau)
    at_cp = psm.wrench_from_torques(q, tau, frame="cp", expressed_in="base_at_frame")
    at_hex = psm.wrench_from_torques(q, tau, frame="hex10", expressed_in="base_at_frame")
    at_hex_local = psm.wrench_from_torques(q, tau, frame="hex10", expressed_in="frame")
    np.testing.assert_allclose(at_cp, w, atol=1e-9)
    for other in (at_rcm, at_hex):
        np.testing.assert_allclose(other[:, :3], at_cp[:, :3], atol=1e-9)
    p_cp = psm.forward_kinematics(q, "cp")[:, :3, 3]
    lever = p_cp - psm.forward_kinematics(q, "hex10")[:, :3, 3]
    np.testing.assert_allclose(at_hex[:, 3:], at_cp[:, 3:] + np.cross(lever, at_cp[:, :3]),
                               atol=1e-9)
    np.testing.assert_allclose(at_rcm[:, 3:], at_cp[:, 3:] + np.cross(p_cp, at_cp[:, :3]),
                               atol=1e-9)
    np.testing.assert_allclose(at_hex_local[:, :3], base_to_hex10(at_cp[:, :3], q, psm), atol=1e-9)


def test_static_balance_sign(psm):
    """tau = J^T w: the torques the environment's wrench w exerts; motors hold it with -J^T w.

    At q = 0 with insertion 0.1 m the shaft points down (-z0); pushing the tip up (+z0) pushes the
    insertion back: -1 N on the insertion joint, which the insertion motor holds with +1 N.
    """
    q = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    w = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    tau = psm.spatial_jacobian(q).T @ w
    np.testing.assert_allclose(tau[2], -1.0, atol=1e-12)
    np.testing.assert_allclose(psm.wrench_from_torques(q, tau), w, atol=1e-12)


def test_sign_against_pinocchio_dynamics(psm, loads):
    """Pinocchio's inverse dynamics with an external wrench on the jaws and no gravity gives the
    motor torques that hold it; the wrench on the tool is wrench_from_torques of their negative."""
    q, w = loads
    model = psm.model.copy()
    model.gravity.setZero()
    data = model.createData()
    jaw_body = model.getJointId("wrist_yaw")
    for qk, wk in zip(q[:20], w[:20]):
        full = np.zeros(model.nq)
        full[:6] = qk
        pin.forwardKinematics(model, data, full)
        p_cp = psm.forward_kinematics(qk, "cp")[:3, 3]
        at_origin = pin.Force(wk[:3], wk[3:] + np.cross(p_cp, wk[:3]))  # world axes, about 0
        fext = [pin.Force.Zero() for _ in range(model.njoints)]
        fext[jaw_body] = data.oMi[jaw_body].actInv(at_origin)  # Pinocchio wants joint-local
        tau_motor = pin.rnea(model, data, full, np.zeros(model.nv), np.zeros(model.nv), fext)
        np.testing.assert_allclose(
            psm.wrench_from_torques(qk, -tau_motor[:6], expressed_in="base_at_frame"), wk, atol=1e-9)
        np.testing.assert_allclose(psm.wrench_from_torques(qk, -tau_motor[:6]),
                                   np.r_[at_origin.linear, at_origin.angular], atol=1e-9)


def test_damping_near_the_rcm_singularity(psm):
    q = np.array([[0.2, 0.1, 0.0075, 0.3, 0.2, 0.1],   # cp 2 mm from the RCM: sigma_min ~ 8e-4
                  [0.2, 0.1, 0.0156, 0.3, 0.2, 0.1],   # wrist-pitch axis through the RCM: singular
                  [0.2, 0.1, 0.1200, 0.3, 0.2, 0.1]])  # regular
    tau = np.array([[0.01, -0.02, 0.5, 0.001, 0.002, -0.001]] * 3)
    w, info = psm.wrench_from_torques(q, tau, return_info=True)
    assert np.isfinite(w).all()
    assert info.damped.tolist() == [True, True, False]
    assert info.sigma_min[1] < 1e-12 and info.damping[1] == pytest.approx(1e-3)
    assert info.sigma_min[2] > info.sigma_threshold and info.damping[2] == 0.0
    assert info.condition_number[1] > 1e12
    assert np.abs(w[1]).max() < 1e4  # bounded by the damping, not 1/sigma_min
    assert info.residual[2] < 1e-10
    single = psm.wrench_from_torques(q[1], tau[1], return_info=True)[1]
    assert bool(single.damped) and single.sigma_min.shape == ()


def test_damping_is_continuous_at_the_threshold():
    rng = np.random.default_rng(22)
    U, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    V, _ = np.linalg.qr(rng.normal(size=(6, 6)))
    tau = rng.normal(size=6)
    outs = []
    for s_min in (1e-3 * (1 + 1e-9), 1e-3 * (1 - 1e-9)):
        J = U @ np.diag([1.0, 0.8, 0.5, 0.1, 0.01, s_min]) @ V.T
        outs.append(solve_wrench(J[None], tau[None])[0][0])
    np.testing.assert_allclose(outs[0], outs[1], rtol=1e-6)


@pytest.mark.parametrize("robot", ["ur5", "panda"])
@pytest.mark.parametrize("expressed_in, reference", [("base", pin.WORLD),
                                                     ("base_at_frame", pin.LOCAL_WORLD_ALIGNED),
                                                     ("frame", pin.LOCAL)])
def test_generic_round_trip_example_robots(robot, expressed_in, reference):
    model, tool = load_example_robot(robot)
    data = model.createData()
    rng = np.random.default_rng(23)
    q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit, size=(60, model.nq))
    w = np.hstack([rng.normal(0, 5.0, (60, 3)), rng.normal(0, 0.5, (60, 3))])
    J = np.array([pin.computeFrameJacobian(model, data, qk, model.getFrameId(tool), reference)
                  for qk in q])
    tau = _torques(J, w)
    w_hat, info = wrench_from_torques(model, q, tau, tool, expressed_in=expressed_in,
                                      return_info=True)
    regular = ~info.damped
    assert regular.mean() > 0.9
    np.testing.assert_allclose(w_hat[regular], w[regular], atol=1e-8)
    assert info.residual[regular].max() < 1e-8


def test_generic_matches_psm_class(psm, loads):
    q, w = loads
    q7 = np.hstack([q[:50], np.zeros((50, 1))])
    tau = np.hstack([_torques(psm.jacobian(q[:50], "jaw_tip", "base_at_frame"), w[:50]),
                     np.zeros((50, 1))])
    for expressed_in in EXPRESSED_IN:  # one vocabulary for both
        generic = wrench_from_torques(psm.model, q7, tau, "jaw_tip", expressed_in=expressed_in)
        np.testing.assert_allclose(
            generic, psm.wrench_from_torques(q[:50], tau, frame="jaw_tip",
                                             expressed_in=expressed_in), atol=1e-9)
    np.testing.assert_allclose(
        wrench_from_torques(psm.model, q7, tau, "jaw_tip", expressed_in="base_at_frame"), w[:50],
        atol=1e-9)


def test_fewer_than_six_joints_not_identifiable():
    J = np.random.default_rng(24).normal(size=(4, 6, 4))
    w, info = solve_wrench(J, np.ones((4, 4)))
    assert info.damped.all() and (info.sigma_min == 0).all() and np.isfinite(w).all()


def test_undamped_solve_is_the_pseudo_inverse():
    rng = np.random.default_rng(25)
    J = rng.normal(size=(8, 6, 7))
    tau = rng.normal(size=(8, 7))
    w, info = solve_wrench(J, tau, sigma_threshold=0.0)
    expected = np.einsum("nij,nj->ni", np.linalg.pinv(np.swapaxes(J, 1, 2)), tau)
    np.testing.assert_allclose(w, expected, atol=1e-10)
    assert not info.damped.any() and (info.damping == 0).all()


def test_bad_input(psm):
    q = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    with pytest.raises(KinematicsInputError, match=r"tau must have shape.*got \(5,\)"):
        psm.wrench_from_torques(q, np.zeros(5))
    with pytest.raises(KinematicsInputError, match=r"tau has 2 sample\(s\) but q has 1"):
        psm.wrench_from_torques(q, np.zeros((2, 6)))
    with pytest.raises(KinematicsInputError,
                       match=r"tau_internal has a non-finite value for joint 'roll'"):
        psm.wrench_from_torques(q, np.zeros(6), np.array([0, 0, 0, np.nan, 0, 0]))
    with pytest.raises(KinematicsInputError, match=r"expressed_in must be one of \('base', "):
        psm.wrench_from_torques(q, np.zeros(6), expressed_in="world")
    with pytest.raises(KinematicsInputError, match="unknown frame 'tip'"):
        psm.wrench_from_torques(q, np.zeros(6), frame="tip")
    model, tool = load_example_robot("ur5")
    with pytest.raises(WrenchInputError, match="unknown frame 'flange'"):
        wrench_from_torques(model, np.zeros(6), np.zeros(6), "flange")
    with pytest.raises(WrenchInputError, match=r"q must have shape \(6,\) or \(N,6\); got \(7,\)"):
        wrench_from_torques(model, np.zeros(7), np.zeros(6), tool)
    with pytest.raises(WrenchInputError, match="tau has a non-finite value at sample 0, index 2"):
        wrench_from_torques(model, np.zeros(6), [0, 0, np.inf, 0, 0, 0], tool)
    with pytest.raises(WrenchInputError, match="jacobian must have shape"):
        solve_wrench(np.zeros((6, 6)), np.zeros(6))
    with pytest.raises(WrenchInputError, match="sigma_threshold and max_damping must be finite"):
        solve_wrench(np.zeros((1, 6, 6)), np.zeros((1, 6)), sigma_threshold=np.nan)
    with pytest.raises(ValueError, match="unknown example robot 'kuka'"):
        load_example_robot("kuka")
