"""Commanded joint motion for the bench: minimum-jerk moves and the arm's inverse kinematics.

Base = RCM frame (``docs/conventions.md``). The protocols (:mod:`.protocols`) place the jaw tip
with these and hold the wrist configurations they draw; trajectories are sampled at :data:`DT`.
"""

from __future__ import annotations

import numpy as np

from psmforce.robot.kinematics import default_psm

DT = 0.01
"""100 Hz, the paper's recording rate."""
WRIST_PITCH_OFFSET_M = 0.0156
"""The wrist-pitch axis meets the shaft axis this far short of the insertion: it lies at
(insertion - 0.0156) m from the RCM (DH frame 4, the URDF)."""
WRIST_TO_TIP_M = 0.0246
"""Wrist-pitch axis to jaw tip at a straight wrist (9.1 mm + 15.5 mm): where a protocol puts the
wrist so that the tip is where it wants it with the wrist straight."""


def min_jerk(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return s ** 3 * (10.0 - 15.0 * s + 6.0 * s ** 2)


def piecewise(waypoints: np.ndarray, move: np.ndarray, hold: np.ndarray, dt: float = DT) -> np.ndarray:
    """Minimum-jerk moves between consecutive waypoints (K+1, D), each followed by a hold."""
    pieces = []
    for k in range(len(waypoints) - 1):
        steps = max(1, int(round((move[k] + hold[k]) / dt)))
        t = np.arange(steps) * dt
        s = min_jerk(t / move[k]) if move[k] > 0 else np.ones(steps)
        pieces.append(waypoints[k] + (waypoints[k + 1] - waypoints[k]) * s[:, None])
    return np.concatenate(pieces, axis=0)


def shaft_direction(yaw, pitch):
    """Unit shaft direction (towards the tip) in the base frame from the first two joints
    (modified DH of the PSM: (cos p sin y, -sin p, -cos p cos y))."""
    return np.stack([np.cos(pitch) * np.sin(yaw), -np.sin(pitch), -np.cos(pitch) * np.cos(yaw)], axis=-1)


def arm_ik_for_wrist(p_wrist: np.ndarray) -> np.ndarray:
    """(N, 3) yaw, pitch, insertion placing the wrist-pitch axis point at ``p_wrist`` (N, 3)
    (:data:`WRIST_PITCH_OFFSET_M`)."""
    dist = np.linalg.norm(p_wrist, axis=-1)
    d = p_wrist / dist[..., None]
    return np.stack([np.arctan2(d[..., 0], -d[..., 2]), np.arcsin(-d[..., 1]),
                     dist + WRIST_PITCH_OFFSET_M], axis=-1)


def arm_ik_for_tip(p_tip: np.ndarray, wrist: np.ndarray, iterations: int = 8) -> np.ndarray:
    """(N, 7) joints putting the jaw tip at ``p_tip`` (N, 3) with instrument joints ``wrist``
    (N, 4). The tip offset in the roll frame depends on the wrist angles only, so a fixed point
    over the shaft rotation converges fast (offset ~25 mm vs ~200 mm lever)."""
    psm = default_psm()
    q = np.zeros((len(p_tip), 7))
    q[:, 2] = 0.15
    q[:, 3:] = wrist
    t_roll = psm.forward_kinematics(q[:, :6], frame="roll")
    t_tip = psm.forward_kinematics(q[:, :6], frame="jaw_tip")
    offset = np.einsum("nji,nj->ni", t_roll[:, :3, :3], t_tip[:, :3, 3] - t_roll[:, :3, 3])
    q[:, :3] = arm_ik_for_wrist(p_tip + np.array([0.0, 0.0, WRIST_TO_TIP_M]))  # guess: shaft straight down
    for _ in range(iterations):
        r_roll = psm.rotation(q[:, :6], "roll")
        q[:, :3] = arm_ik_for_wrist(p_tip - np.einsum("nij,nj->ni", r_roll, offset))
    return q
