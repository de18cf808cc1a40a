"""The LSTM baseline's Jacobian map: frames, sign and differentiability."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from psmforce.estimators.data.dataset import Trial
from psmforce.estimators.data.lstm_inputs import LSTM_FEATURES, LSTM_JACOBIAN_COLUMNS, lstm_columns
from psmforce.robot import PSM
from psmforce.robot.conventions import CHAIN_JOINTS
from psmforce.estimators.networks.baselines import JointLSTMForce


def test_map_recovers_a_static_tool_force_in_the_hex10_frame():
    """A force F (HEX10 frame) on the tool, no internal torques: the motors apply
    tau = -J^T [F_base; m] and A(q) tau must give F back."""
    psm = PSM()
    rng = np.random.default_rng(0)
    n = 5
    q = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.4, 0.4, n),
                         rng.uniform(0.08, 0.2, n), rng.uniform(-1, 1, n),
                         rng.uniform(-0.8, 0.8, n), rng.uniform(-0.8, 0.8, n)])
    f_hex = rng.normal(size=(n, 3))
    R = psm.rotation(q, "hex10")                                  # HEX10 axes in base
    J = psm.jacobian(q, "cp", "base_at_frame")              # [v_cp; w] in base axes
    f_base = np.einsum("nij,nj->ni", R, f_hex)
    tau = -np.einsum("nji,nj->ni", J[:, :3, :], f_base)           # force at cp, no moment
    frame = pd.DataFrame({f"{j}_position": q[:, k] for k, j in enumerate(CHAIN_JOINTS)})
    cols = lstm_columns(psm)(Trial("t.csv", "Traction", "train", frame))
    A = np.column_stack([cols[c] for c in LSTM_JACOBIAN_COLUMNS]).reshape(n, 3, 6)
    np.testing.assert_allclose(np.einsum("nij,nj->ni", A, tau), f_hex, atol=1e-6)


def test_lstm_force_is_the_map_applied_to_torque_residual_and_differentiable():
    torch.manual_seed(0)
    model = JointLSTMForce(window=2)
    x = torch.randn(2, 7, len(LSTM_FEATURES))
    out = model(x)
    tau_hat = model.internal_torques(x)
    A = x[..., 18:].reshape(2, 7, 3, 6)
    expected = torch.einsum("btij,btj->bti", A, x[..., 12:18] - tau_hat)
    torch.testing.assert_close(out, expected)
    assert (tau_hat.abs() <= model.max_torque).all()
    out.sum().backward()
    assert model.lstms[0].weight_ih_l0.grad is not None


def test_lstm_streaming_step_matches_sequence_forward():
    torch.manual_seed(1)
    model = JointLSTMForce(window=2).eval()
    x = torch.randn(3, 6, len(LSTM_FEATURES))
    with torch.no_grad():
        full = model(x)
        state, steps = None, []
        for t in range(6):
            out, state = model.step(x[:, t], state)
            steps.append(out)
    torch.testing.assert_close(torch.stack(steps, dim=1), full, atol=1e-5, rtol=1e-5)
