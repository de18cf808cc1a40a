"""Poses and Jacobians of a serial chain of one-axis joints, composed in numpy over a batch.

A chain is a list of constant joint placements (R, p) (each joint's frame in its parent's, at
joint value 0) and of joint axes (revolute or prismatic, about / along x, y or z of the joint's
own frame), as Pinocchio's ``jointPlacements`` and joint models hold them. Arrays are in
structure-of-arrays layout while composing (R as (3,3,N), p as (3,N)), so that every step is a
contiguous vector operation over the batch; the constant placements are mostly signed
permutations, and their zero entries are skipped. ``psmforce.robot.kinematics`` builds the PSM's
chain from its URDF and checks it against Pinocchio (tests/robot/test_kinematics.py).
"""

from __future__ import annotations

import numpy as np

JOINT_AXES = {
    "JointModelRX": (True, 0), "JointModelRY": (True, 1), "JointModelRZ": (True, 2),
    "JointModelPX": (False, 0), "JointModelPY": (False, 1), "JointModelPZ": (False, 2),
}
"""(revolute, axis index) of each Pinocchio joint model a chain may hold."""


def chain_pose(placements, axes, q: np.ndarray, depth: int, R_f: np.ndarray, p_f: np.ndarray,
               with_jacobian: bool):
    """Pose (R (N,3,3), p (N,3)) in the base frame of the frame at (R_f, p_f) on joint ``depth``
    (the number of chain joints that move it), and its WORLD Jacobian (N,6,6) or None.

    ``placements``: (R, p) of each joint; ``axes``: (revolute, axis index) of each joint
    (:data:`JOINT_AXES`); ``q`` (N, >= depth) joint values (rad or m). Jacobian rows [v; w]: v
    the velocity of the body point at the base origin, w the angular velocity, base axes.
    """
    n = q.shape[0]
    R = np.broadcast_to(np.eye(3)[:, :, None], (3, 3, n))
    p = np.zeros((3, n))
    J = np.zeros((6, 6, n)) if with_jacobian else None
    for i in range(depth):
        R_fixed, p_fixed = placements[i]
        p = p + _times_constant_vector(R, p_fixed)
        R = _times_constant_matrix(R, R_fixed)
        revolute, k = axes[i]
        axis = R[:, k]
        if revolute:
            R = _rotate_about_own_axis(R, k, q[:, i])
            if with_jacobian:
                J[:3, i] = _cross(p, axis)
                J[3:, i] = axis
        else:
            p = p + axis * q[:, i]
            if with_jacobian:
                J[:3, i] = axis
    p = p + _times_constant_vector(R, p_f)
    R = _times_constant_matrix(R, R_f)
    J_out = np.ascontiguousarray(J.transpose(2, 0, 1)) if with_jacobian else None
    return np.ascontiguousarray(R.transpose(2, 0, 1)), np.ascontiguousarray(p.T), J_out


def express_jacobian(J_world: np.ndarray, R: np.ndarray, p: np.ndarray,
                     expressed_in: str) -> np.ndarray:
    """WORLD Jacobian (N,6,n) -> ``expressed_in`` (:data:`psmforce.robot.conventions.EXPRESSED_IN`):
    ``"base"`` unchanged, ``"base_at_frame"`` the velocity of the point p (N,3), ``"frame"`` the
    same in the axes R (N,3,3)."""
    if expressed_in == "base":
        return J_world
    v = J_world[:, :3] - np.cross(p[:, :, None], J_world[:, 3:], axis=1)  # v_p = v_0 + w x p
    J = np.concatenate([v, J_world[:, 3:]], axis=1)
    if expressed_in == "frame":
        Rt = np.swapaxes(R, 1, 2)
        J = np.concatenate([Rt @ J[:, :3], Rt @ J[:, 3:]], axis=1)
    return J


def homogeneous(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """4x4 transforms (..., 4, 4) from rotations (..., 3, 3) and translations (..., 3)."""
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def rot_z(angle: float) -> np.ndarray:
    """Rotation (3,3) by ``angle`` (rad) about z."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _times_constant_matrix(R: np.ndarray, M: np.ndarray) -> np.ndarray:
    """R @ M for R (3,3,N) and a constant (3,3) M, skipping M's zero entries."""
    out = np.zeros((3, 3, R.shape[2]))
    for k in range(3):
        for j in np.flatnonzero(M[:, k]):
            out[:, k] += R[:, j] * M[j, k]
    return out


def _times_constant_vector(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R @ v for R (3,3,N) and a constant (3,) v -> (3,N), skipping v's zero entries."""
    out = np.zeros((3, R.shape[2]))
    for j in np.flatnonzero(v):
        out += R[:, j] * v[j]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of (3,N) arrays."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _rotate_about_own_axis(R: np.ndarray, k: int, angle: np.ndarray) -> np.ndarray:
    """R @ Rot_k(angle) for R (3,3,N): only the two columns other than k change."""
    i, j = [(1, 2), (2, 0), (0, 1)][k]
    c = np.cos(angle)
    s = np.sin(angle)
    out = np.empty_like(R)
    out[:, k] = R[:, k]
    out[:, i] = c * R[:, i] + s * R[:, j]
    out[:, j] = c * R[:, j] - s * R[:, i]
    return out
