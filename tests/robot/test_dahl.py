"""The Dahl friction state: the exact step against the ODE, memory at rest, stream == batch."""
import numpy as np
import pytest

from psmforce.robot.dahl import DahlState, dahl_states


def _integrated(x, x_c, substeps=2000):
    """The ODE dz/dx = (1 - z sgn dx) / x_c integrated with small explicit Euler steps."""
    z, out = 0.0, [0.0]
    for x0, x1 in zip(x[:-1], x[1:]):
        h = (x1 - x0) / substeps
        for _ in range(substeps):
            z += abs(h) * (np.sign(h) - z) / x_c
        out.append(z)
    return np.array(out)


def test_the_exact_step_solves_the_ode_whatever_the_sampling():
    x_c = 0.02
    x = np.array([0.0, 0.01, 0.05, 0.05, 0.03, 0.031, -0.02, 0.0])  # coarse, reversing
    z = dahl_states(x[:, None], x_c)[:, 0]
    assert np.allclose(z, _integrated(x, x_c), atol=2e-3, rtol=0)
    assert np.all(np.abs(z) < 1.0)
    assert z[3] == z[2]  # at rest the state keeps the last direction


def test_a_reversal_passes_through_zero_within_a_few_presliding_lengths():
    x_c = 0.5
    x = np.concatenate([np.linspace(0.0, 10.0, 101), np.linspace(10.0, 7.0, 31)[1:]])
    z = dahl_states(x[:, None], x_c)[:, 0]
    assert z[100] == pytest.approx(1.0, abs=1e-8)
    after = z[101:]
    crossing = np.argmax(after < 0.0)  # 0.1 of travel a sample
    assert after[crossing - 1] >= 0.0 and 0.1 * crossing < 2 * x_c * np.log(2) + 0.1
    assert after[-1] == pytest.approx(-1.0 + 2.0 * np.exp(-3.0 / x_c), abs=1e-9)


def test_the_stream_gives_the_batch_values_per_channel():
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.normal(0.0, 0.01, (300, 4)), axis=0)
    state = DahlState(4, 0.02)
    streamed = np.array([list(state.step(row)) for row in x.tolist()])
    assert np.allclose(streamed, dahl_states(x, 0.02), atol=1e-12, rtol=0)


def test_the_simulator_and_the_prior_read_the_same_state():
    from psmforce.identification.prior_law import PRESLIDING_RAD, friction_direction
    from psmforce.sim.cables import dahl_direction
    rng = np.random.default_rng(6)
    x = np.cumsum(rng.normal(0.0, 0.01, (200, 3)), axis=0)
    assert np.array_equal(dahl_direction(x, 0.02, hysteresis=True), dahl_states(x, 0.02))
    pitch_only = np.column_stack([x[:, 0], np.zeros(200), np.zeros(200)])
    assert np.array_equal(friction_direction(pitch_only)[:, 0],
                          dahl_states(x[:, :1], PRESLIDING_RAD)[:, 0])
