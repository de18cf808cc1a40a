"""The second pair law (``InstrumentParams.pair_law = "quadratic"``, psmforce/sim/cable_laws.py):
strain-stiffening cables, a bench variant outside the prior's family. The default law leaves the
bench unchanged."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from psmforce.sim import Effects, InstrumentParams
from psmforce.sim.cable_laws import quadratic_pair
from psmforce.sim.cables import _capstan_pair, transmission


def test_without_capstan_the_law_is_its_closed_form_and_slackens_smoothly():
    t0 = np.full((9, 3), 1.0)                       # N per cable
    d = np.linspace(-8.0, 8.0, 9)[:, None] * np.ones((1, 3))
    s, d_sh, slack = quadratic_pair(d, np.zeros_like(d), np.full(3, 0.3), t0, True)
    taut = np.abs(d) <= 4.0
    assert np.allclose(d_sh, d)
    assert np.allclose(s[taut], 2.0 + d[taut] ** 2 / 8.0)
    assert np.allclose(s[~taut], np.abs(d[~taut]))
    assert np.array_equal(slack, ~taut)
    # continuous with equal slope at |D| = 4 T0, where the linear law (alpha 0) is already slack
    eps = 1e-6
    one, zero = np.ones((1, 1)), np.zeros((1, 1))
    s_in, _, _ = quadratic_pair(np.array([[4 - eps]]), zero, 0.0, one, True)
    s_out, _, _ = quadratic_pair(np.array([[4 + eps]]), zero, 0.0, one, True)
    assert abs(s_out[0, 0] - s_in[0, 0]) < 3e-6
    s_lin, _, slack_lin = _capstan_pair(np.array([[3.0]]), np.zeros((1, 1)), 0.0,
                                        np.ones((1, 1)), True)
    assert slack_lin[0, 0] and s_lin[0, 0] == 3.0


def test_with_capstan_the_shaft_side_meets_the_closure_and_the_capstan():
    rng = np.random.default_rng(0)
    d_in = rng.uniform(-6.0, 6.0, (200, 3))
    mu_z = rng.uniform(-0.4, 0.4, (200, 3))
    t0 = rng.uniform(0.8, 1.5, (200, 3))
    s_sh, d_sh, slack = quadratic_pair(d_in, mu_z, 0.0, t0, True)
    c, s = np.cosh(mu_z), np.sinh(mu_z)
    s_dist = (s_sh - d_in * s) / c                  # the distal sum the shaft side implies
    taut = ~slack
    assert taut.sum() > 100 and slack.sum() > 10
    assert np.allclose(d_sh[taut], s_dist[taut] * s[taut] + d_in[taut] * c[taut])
    assert np.allclose(s_sh[taut], 2 * t0[taut] + d_sh[taut] ** 2 / (8 * t0[taut]))
    assert np.all(np.abs(d_sh[taut]) <= 4 * t0[taut] + 1e-9)
    assert np.allclose(s_sh[slack], np.abs(d_sh[slack]))


def test_the_default_law_is_linear_and_the_option_changes_the_tensions():
    assert InstrumentParams().pair_law == "linear"
    with pytest.raises(ValueError, match="pair_law"):
        InstrumentParams(pair_law="cubic")
    rng = np.random.default_rng(1)
    q = np.zeros((100, 7))
    q[:, 3:6] = rng.uniform(-0.5, 0.5, (100, 3))
    tau = rng.uniform(-0.01, 0.01, (100, 3))
    base = InstrumentParams()
    lin = transmission(q, tau, base, Effects())
    again = transmission(q, tau, dataclasses.replace(base, pair_law="linear"), Effects())
    quad = transmission(q, tau, dataclasses.replace(base, pair_law="quadratic"), Effects())
    for key in ("s_shaft", "d_shaft", "effort"):
        assert np.array_equal(lin[key], again[key])
    assert np.abs(quad["s_shaft"] - lin["s_shaft"]).max() > 0.1
    restored = InstrumentParams.from_dict(dataclasses.replace(base, pair_law="quadratic").to_dict())
    assert restored.pair_law == "quadratic"
    assert "pair_law" not in base.to_dict()  # the default bench's metadata.json is unchanged
    assert InstrumentParams.from_dict(base.to_dict()).pair_law == "linear"
