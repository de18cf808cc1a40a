"""The LSTM baseline's inputs (Yang et al., as the seed paper trains it): joint states, measured
efforts and the per-sample map A(q) from joint torques to the force on the tool.

:data:`LSTM_FEATURES` is the column order
:class:`psmforce.estimators.networks.baselines.JointLSTMForce` reads; :func:`lstm_columns` derives
the map's 18 columns from the joint positions of a recording (the ``"lstm"`` derivation of
:data:`psmforce.estimators.networks.recipes.DERIVATIONS`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from psmforce.estimators.data.dataset import Trial
from psmforce.robot.conventions import CHAIN_JOINTS
from psmforce.io.recording import joint_column

LSTM_JACOBIAN_COLUMNS = tuple(f"lstm_map_{r}{c}" for r in range(3) for c in range(6))
CHAIN_POSITIONS = tuple(joint_column(j, "position") for j in CHAIN_JOINTS)
LSTM_FEATURES = (CHAIN_POSITIONS + tuple(joint_column(j, "velocity") for j in CHAIN_JOINTS)
                 + tuple(joint_column(j, "effort") for j in CHAIN_JOINTS) + LSTM_JACOBIAN_COLUMNS)
"""Inputs of :class:`psmforce.estimators.networks.baselines.JointLSTMForce`: (q, dq) of joints 1-6 (standardised), their
measured efforts and the 3x6 map A(q) = R_base_hex10^T J_s^-T[:3] (both left raw)."""
LSTM_RAW_COLUMNS = LSTM_FEATURES[12:]


def lstm_columns(psm) -> Callable[[Trial], dict[str, np.ndarray]]:
    """Deriver for :meth:`Dataset.add_columns`: the per-sample 3x6 map A(q) of the LSTM baseline,
    F_tool_hex10 = A(q) (tau - tau_hat).

    Sign and frames: dVRK efforts are the torques the motors apply, so a static external force F
    on the tool shows up as tau = -J^T [F; m] (the simulator's ``effort_convention``), while
    ``psm.wrench_from_torques`` returns the wrench w with J^T w = tau. Hence A(q) is minus the
    force rows of that map: the seed paper's F = J_s^-T (tau - tau_hat) with the sign that makes F
    the force ON the tool, expressed in the HEX10 frame (eq. 2; the force of a wrench does not
    depend on the reduction point, so reducing at the HEX10 origin is the same force as at cp).
    The map is linear in tau (damping near singularities depends on J only), so six unit-torque
    calls give it for a whole recording at once.
    """
    def derive(trial: Trial) -> dict[str, np.ndarray]:
        q = trial.matrix(CHAIN_POSITIONS, np.float64)
        n = len(q)
        cols = []
        for j in range(6):
            unit = np.zeros((n, 6))
            unit[:, j] = 1.0
            wrench = np.asarray(psm.wrench_from_torques(q, unit, frame="hex10",
                                                        expressed_in="frame"))
            cols.append(-wrench[:, :3])
        amap = np.stack(cols, axis=-1)  # (N, 3, 6): rows force axes, columns joints
        return {name: amap.reshape(n, 18)[:, k] for k, name in enumerate(LSTM_JACOBIAN_COLUMNS)}
    return derive
