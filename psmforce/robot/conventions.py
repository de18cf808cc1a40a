"""The library's conventions as code: joint order, gravity, and the names of reference frames.

``docs/conventions.md`` explains them; this module is the one place their values are written.
It imports nothing from the project, so that every module can take them from here.

**Where a wrench or a Jacobian is expressed** (``expressed_in``), for the body carrying ``frame``:

* ``"base"``: moment (or velocity) about the base origin, base axes. The base is the PSM base,
  the remote centre of motion (RCM), which is the Pinocchio model's world; Pinocchio WORLD. For
  the PSM this is the dual of ``PSM.spatial_jacobian``, the dVRK's spatial Jacobian.
* ``"base_at_frame"``: about the origin of ``frame``, base axes; Pinocchio LOCAL_WORLD_ALIGNED.
* ``"frame"``: about the origin of ``frame``, ``frame``'s own axes; Pinocchio LOCAL.

The earlier spellings (``"world"``, ``"world_at_frame"`` of :mod:`psmforce.robot.wrench`;
``"world"``, ``"local_world_aligned"``, ``"local"`` of ``PSM.jacobian(reference=...)``) are
accepted for one release with a :class:`DeprecationWarning` (:func:`canonical_expressed_in`).
"""

from __future__ import annotations

import warnings

JOINTS = ("yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw", "jaw")
"""dVRK joint order and names (dVRK >= 2024). The paper's q5 / q6 are wrist_yaw / wrist_pitch."""
CHAIN_JOINTS = JOINTS[:6]
"""The six joints of the serial chain; the jaw (7th) moves no chain frame."""
JAW_JOINT = JOINTS[6]
"""The opening angle between the two jaw blades (rad)."""
JAW_CLOSED_RAD = 0.0
"""Jaw angle (rad) at which the two blades touch: the dVRK's jaw zero, closed. Below it (the
motor side driven past closed) the blades press on each other: a clench, its grip internal to
the jaws."""
INSERTION_JOINT = JOINTS[2]
"""The one prismatic joint (m, m/s, N); the others are revolute (rad, rad/s, Nm)."""
WRIST_JOINTS = JOINTS[4:]
"""The instrument's cable-driven joints (wrist_pitch, wrist_yaw, jaw), coupled through its
wrist motors."""


def wrist_torques_to_distal(torque_pitch, torque_yaw, torque_jaw):
    """Torques on the wrist joints (wrist_pitch, wrist_yaw, jaw; Nm, dVRK efforts' signs) as
    torques on the distal coordinates the cables drive, (pitch, blade_1, blade_2) with blade_1,2
    = yaw -+ jaw / 2. By virtual work ``tau_yaw = tau_b1 + tau_b2`` and ``tau_jaw = (tau_b2 -
    tau_b1) / 2``, so ``tau_b1,2 = tau_yaw / 2 -+ tau_jaw``. Arrays, floats or CasADi
    expressions; ``psmforce.sim.cables.distal_torque_to_joints`` is its inverse."""
    return torque_pitch, 0.5 * torque_yaw - torque_jaw, 0.5 * torque_yaw + torque_jaw

NAMED_FRAMES = ("cp", "jaw_tip", "roll", "hex10")
"""The frames this library names (docs/conventions.md); ``PSM`` accepts any other frame of its
model on the chain too."""

GRAVITY_MPS2 = 9.81
"""Magnitude of gravity (m/s^2)."""
GRAVITY_UPRIGHT_MPS2 = (0.0, 0.0, -GRAVITY_MPS2)
"""Gravity (m/s^2) in the base frame of the upright benchtop PSM (z up, shaft pointing down at
q = 0)."""

EXPRESSED_IN = ("base", "base_at_frame", "frame")
"""Where a wrench or a Jacobian is expressed (module docstring)."""
DEPRECATED_EXPRESSED_IN = {"world": "base", "world_at_frame": "base_at_frame",
                           "local_world_aligned": "base_at_frame", "local": "frame"}
"""Earlier spellings and their names in :data:`EXPRESSED_IN`; accepted with a warning until the
next release."""


def canonical_expressed_in(value, *, stacklevel: int = 3):
    """``value`` in the vocabulary of :data:`EXPRESSED_IN`: a deprecated spelling is replaced by
    its name there, with a :class:`DeprecationWarning` pointing ``stacklevel`` frames up (3: the
    caller of the function that calls this); any other value is returned as it is, for the caller
    to check."""
    if isinstance(value, str) and value in DEPRECATED_EXPRESSED_IN:
        name = DEPRECATED_EXPRESSED_IN[value]
        warnings.warn(f"'{value}' is deprecated; say expressed_in='{name}' (same arrays)",
                      DeprecationWarning, stacklevel=stacklevel)
        return name
    return value
