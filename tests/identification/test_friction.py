import numpy as np
import pytest

from psmforce.identification import friction as fr
from psmforce.identification.errors import IdentificationInputError


def test_numpy_casadi_torch_agree_and_signs():
    import casadi as ca
    import torch

    v = np.linspace(-0.5, 0.5, 41)
    p = np.array([0.1, 0.02, 0.03, -0.01])
    tau = fr.friction_torque(v, p)
    x = ca.SX.sym("v")
    f = ca.Function("f", [x], [fr.friction_torque_casadi(x, p)])
    assert np.allclose([float(f(vi)) for vi in v], tau, atol=1e-12)
    tt = fr.friction_torque_torch(torch.tensor(v), torch.tensor(p)).numpy()
    assert np.allclose(tt, tau, atol=1e-12)
    # dissipative part has the sign of the velocity away from zero
    assert (np.sign(tau[v > 0.1] - p[3]) > 0).all() and (np.sign(tau[v < -0.1] - p[3]) < 0).all()
    # at high speed the Coulomb level + viscous slope remain, Stribeck decays
    assert fr.friction_torque(np.array([5.0]), p)[0] == pytest.approx(0.1 + 0.02 * 5 - 0.01, 1e-6)


def test_regressor_columns_linear_in_parameters():
    v = np.random.default_rng(0).normal(size=(50, 3))
    P = np.random.default_rng(1).normal(size=(3, 4))
    R = fr.friction_regressor(v)
    assert R.shape == (50, 3, 4)
    assert np.allclose(np.einsum("nkt,kt->nk", R, P), fr.friction_torque(v, P))


def test_bad_shape_constants():
    with pytest.raises(IdentificationInputError):
        fr.FrictionShape(smooth_sign_velocity=0.0)


def test_maxwell_slip_states_closed_form():
    """Up by 3 delta then down by 5 delta: z = min(x / delta, 1) on the way up; after the
    reversal z = 1 - (x_max - x) / delta, clipped at -1 (elasto-plastic element)."""
    delta = np.array([0.1, 0.4])
    up = np.linspace(0.0, 0.3, 31)
    down = np.linspace(0.3, -0.2, 51)[1:]
    x = np.concatenate([up, down])
    z = fr.maxwell_slip_states(x, delta)
    expected_up = np.minimum(up[:, None] / delta, 1.0)
    expected_down = np.maximum(expected_up[-1] - (0.3 - down[:, None]) / delta, -1.0)
    assert np.allclose(z, np.concatenate([expected_up, expected_down]), atol=1e-12)
    # rate independent: the same path sampled twice as densely gives the same states there
    x2 = np.interp(np.arange(2 * len(x) - 1) / 2, np.arange(len(x)), x)
    assert np.allclose(fr.maxwell_slip_states(x2, delta)[::2], z, atol=1e-12)
    # dissipative with F >= 0: positive work of the friction torque around a closed cycle
    t = np.linspace(0, 4 * np.pi, 2001)
    xs = 0.3 * np.sin(t)
    tau_h = fr.maxwell_slip_states(xs, delta) @ np.array([0.02, 0.05])
    assert np.sum(tau_h[1:] * np.diff(xs)) > 0
    with pytest.raises(IdentificationInputError):
        fr.maxwell_slip_states(x, [0.1, 0.0])
