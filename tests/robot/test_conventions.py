"""One vocabulary for where wrenches and Jacobians are expressed, its deprecated spellings, and
the constants every module takes from ``psmforce.robot.conventions``."""

import argparse
import warnings

import numpy as np
import pytest

from psmforce.robot import PSM
from psmforce.robot import conventions as cv
from psmforce.robot.kinematics import KinematicsInputError
from psmforce.io.recording import JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES, joint_column
from psmforce.robot.wrench import WrenchInputError, wrench_from_torques


@pytest.fixture(scope="module")
def psm():
    return PSM()


@pytest.fixture(scope="module")
def q():
    rng = np.random.default_rng(7)
    return np.column_stack([rng.uniform(-0.5, 0.5, (20, 2)), rng.uniform(0.08, 0.2, 20),
                            rng.uniform(-1, 1, (20, 3))])


def _quiet(call):
    """The result of ``call()``, failing on any warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return call()


@pytest.mark.parametrize("old, new", [("world", "base"), ("local_world_aligned", "base_at_frame"),
                                      ("local", "frame")])
@pytest.mark.parametrize("frame", ["cp", "jaw_tip", "hex10"])
def test_jacobian_old_spellings_warn_and_give_the_same_arrays(psm, q, old, new, frame):
    expected = _quiet(lambda: psm.jacobian(q, frame, new))
    assert np.array_equal(_quiet(lambda: psm.jacobian(q, frame, expressed_in=new)), expected)
    with pytest.warns(DeprecationWarning, match=f"'{old}' is deprecated; say expressed_in='{new}'"):
        assert np.array_equal(psm.jacobian(q, frame, old), expected)
    with pytest.warns(DeprecationWarning, match=f"reference='{old}'\\) is deprecated; say "
                                                f"expressed_in='{new}'"):
        assert np.array_equal(psm.jacobian(q, frame, reference=old), expected)


def test_jacobian_refuses_both_names_and_unknown_values(psm, q):
    with pytest.raises(KinematicsInputError, match="not both"):
        psm.jacobian(q, "cp", "frame", reference="local")
    with pytest.raises(KinematicsInputError, match=r"expressed_in must be one of \('base', "):
        psm.jacobian(q, "cp", "body")


@pytest.mark.parametrize("old, new", [("world", "base"), ("world_at_frame", "base_at_frame")])
def test_generic_wrench_old_spellings_warn_and_give_the_same_arrays(psm, q, old, new):
    q7 = np.column_stack([q, np.zeros(len(q))])
    tau = np.random.default_rng(8).normal(size=(len(q), 7))
    expected = _quiet(lambda: wrench_from_torques(psm.model, q7, tau, "jaw_tip", expressed_in=new))
    with pytest.warns(DeprecationWarning, match=f"'{old}' is deprecated"):
        assert np.array_equal(
            wrench_from_torques(psm.model, q7, tau, "jaw_tip", expressed_in=old), expected)
    with pytest.raises(WrenchInputError, match="expressed_in must be one of"):
        wrench_from_torques(psm.model, q7, tau, "jaw_tip", expressed_in="body")


def test_psm_and_generic_wrench_agree_on_every_name(psm, q):
    q7 = np.column_stack([q, np.zeros(len(q))])
    tau = np.random.default_rng(9).normal(size=(len(q), 7))
    for name in cv.EXPRESSED_IN:
        np.testing.assert_allclose(
            _quiet(lambda: wrench_from_torques(psm.model, q7, tau, "jaw_tip", expressed_in=name)),
            _quiet(lambda: psm.wrench_from_torques(q, tau, frame="jaw_tip", expressed_in=name)),
            atol=1e-9)


def test_cli_offers_the_vocabulary():
    """The CLI writes its choices out (its parser loads no Pinocchio); they must stay these."""
    from psmforce.cli.main import _parser

    commands = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    options = {o: a for a in commands.choices["wrench"]._actions for o in a.option_strings}
    assert set(options["--expressed-in"].choices) == set(cv.EXPRESSED_IN)
    assert set(options["--frame"].choices) == set(cv.NAMED_FRAMES)


def test_joint_names_have_one_source(psm):
    assert psm.joint_names == cv.CHAIN_JOINTS == cv.JOINTS[:6]
    assert cv.WRIST_JOINTS == ("wrist_pitch", "wrist_yaw", "jaw")
    for columns, quantity in ((JOINT_POSITIONS, "position"), (JOINT_VELOCITIES, "velocity"),
                              (JOINT_EFFORTS, "effort")):
        assert columns == tuple(f"{j}_{quantity}" for j in cv.JOINTS)
    with pytest.raises(ValueError, match="no joint column"):
        joint_column("elbow", "position")


def test_gravity_vector_is_the_magnitude_downwards():
    assert cv.GRAVITY_UPRIGHT_MPS2 == (0.0, 0.0, -cv.GRAVITY_MPS2)


def test_wrist_torques_to_distal_is_the_simulators_inverse_and_keeps_virtual_work():
    """Joint torques to the distal coordinates' (pitch, blade_1, blade_2 = yaw -+ jaw / 2) and
    back through the bench's map; the power at any joint velocity is the same on both sides."""
    import numpy as np

    from psmforce.robot.conventions import wrist_torques_to_distal
    from psmforce.sim.cables import distal_torque_to_joints
    rng = np.random.default_rng(3)
    tau = rng.standard_normal((6, 3))
    distal = np.stack(wrist_torques_to_distal(tau[:, 0], tau[:, 1], tau[:, 2]), axis=1)
    np.testing.assert_allclose(distal_torque_to_joints(distal), tau, atol=1e-15)
    qd = rng.standard_normal((6, 3))   # wrist_pitch, wrist_yaw, jaw rates
    qd_distal = np.stack([qd[:, 0], qd[:, 1] - qd[:, 2] / 2, qd[:, 1] + qd[:, 2] / 2], axis=1)
    np.testing.assert_allclose((distal * qd_distal).sum(1), (tau * qd).sum(1), atol=1e-14)
