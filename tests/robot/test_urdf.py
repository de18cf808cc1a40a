"""The bundled URDF: Pinocchio and yourdfpy load it and agree; published limits; plausible inertials."""

import numpy as np
import pinocchio as pin
import pytest
import yourdfpy

from psmforce.robot.kinematics import BUNDLED_URDF

_JOINTS = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw", "jaw")
_LIMITS = {  # psm_facts.md
    "yaw": (-1.588, 1.588), "pitch": (-0.925025, 0.925025), "insertion": (0.0, 0.240),
    "roll": (-4.53786, 4.53786), "wrist_pitch": (-1.39626, 1.39626),
    "wrist_yaw": (-1.39626, 1.39626), "jaw": (-0.349066, 1.39626),
}
_EFFORTS = {"yaw": 3.316, "pitch": 3.316, "insertion": 9.878, "roll": 0.33, "wrist_pitch": 0.25,
            "wrist_yaw": 0.20, "jaw": 0.16}
_FRAMES = ("yaw_link", "pitch_link", "insertion_link", "roll_link", "roll", "hex10",
           "wrist_pitch_link", "wrist_yaw_link", "cp", "jaw_tip", "jaw_blade_1_link",
           "jaw_blade_2_link")


@pytest.fixture(scope="module")
def model():
    return pin.buildModelFromUrdf(str(BUNDLED_URDF), mimic=True)


@pytest.fixture(scope="module")
def urdf():
    return yourdfpy.URDF.load(str(BUNDLED_URDF), load_meshes=False)


def test_joints_in_dvrk_order_with_published_limits(model, urdf):
    assert model.nq == model.nv == 7
    assert tuple(model.names[1:8]) == _JOINTS
    assert tuple(urdf.actuated_joint_names) == _JOINTS
    np.testing.assert_allclose(model.lowerPositionLimit, [_LIMITS[j][0] for j in _JOINTS])
    np.testing.assert_allclose(model.upperPositionLimit, [_LIMITS[j][1] for j in _JOINTS])
    np.testing.assert_allclose(model.effortLimit, [_EFFORTS[j] for j in _JOINTS])
    assert urdf.joint_map["insertion"].type == "prismatic"


def test_pinocchio_and_yourdfpy_agree(model, urdf):
    data = model.createData()
    rng = np.random.default_rng(30)
    for _ in range(25):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        pin.framesForwardKinematics(model, data, q)
        urdf.update_cfg(q)
        for name in _FRAMES:
            T_pin = data.oMf[model.getFrameId(name, pin.FrameType.BODY)].homogeneous
            np.testing.assert_allclose(urdf.get_transform(name, "rcm"), T_pin, atol=1e-12,
                                       err_msg=name)


def test_jaw_blades_at_half_the_opening(model, urdf):
    data = model.createData()
    q = np.array([0.1, -0.2, 0.1, 0.3, 0.4, -0.5, 0.8])
    pin.framesForwardKinematics(model, data, q)
    hub = data.oMf[model.getFrameId("wrist_yaw_link")]
    for blade, sign in (("jaw_blade_1_link", 1.0), ("jaw_blade_2_link", -1.0)):
        rel = hub.actInv(data.oMf[model.getFrameId(blade)])
        assert np.arctan2(rel.rotation[1, 0], rel.rotation[0, 0]) == pytest.approx(sign * 0.4)
    urdf.update_cfg(q)
    assert urdf.cfg[-1] == pytest.approx(0.8)


def test_inertials_plausible(urdf):
    moving = [link for link in urdf.link_map.values()
              if link.inertial is not None and link.name != "rcm"]
    names = {link.name for link in moving}
    assert {"yaw_link", "pitch_link", "insertion_link", "roll_link", "wrist_pitch_link",
            "wrist_yaw_link", "jaw_blade_1_link", "jaw_blade_2_link", "hex10"} <= names
    for link in moving:
        I = link.inertial.inertia
        assert link.inertial.mass > 0, link.name
        eig = np.linalg.eigvalsh(I)
        assert eig.min() > 0, link.name
        assert eig.max() <= eig.sum() - eig.max() + 1e-15, link.name  # triangle inequality
    tool = sum(urdf.link_map[n].inertial.mass for n in
               ("roll_link", "wrist_pitch_link", "wrist_yaw_link", "jaw_blade_1_link",
                "jaw_blade_2_link"))
    assert tool == pytest.approx(0.03667, abs=1e-5)  # shaft + wrist, seed paper
    assert urdf.link_map["hex10"].inertial.mass == pytest.approx(0.00305)


def test_closed_form_at_zero(model):
    data = model.createData()
    pin.framesForwardKinematics(model, data, np.zeros(7))
    cp = data.oMf[model.getFrameId("cp")]
    np.testing.assert_allclose(cp.rotation, [[0, 1, 0], [1, 0, 0], [0, 0, -1]], atol=1e-12)


def test_gravity_torques_finite(model):
    """The inertials make a usable dynamic model: regular mass matrix over the joint range."""
    data = model.createData()
    rng = np.random.default_rng(31)
    for _ in range(10):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        assert np.linalg.eigvalsh(M).min() > 0
        assert np.isfinite(pin.computeGeneralizedGravity(model, data, q)).all()
