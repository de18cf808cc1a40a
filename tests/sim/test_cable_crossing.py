"""Cables crossing the HEX10 section at an angle (``InstrumentParams.cable_crossing_angle_rad``):
an internal lateral force the prior does not model. Default 0 leaves the bench unchanged."""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from psmforce.sim import Contact, Effects, InstrumentParams, run_trajectory, simulate
from psmforce.sim.cables import CABLE_ANGLES_RAD, section_wrench


def _tensions(seed=0, n=50):
    return np.random.default_rng(seed).uniform(0.0, 20.0, size=(n, 3, 2))  # (+, -) per pair, N


def test_default_angle_gives_the_straight_cable_wrench_bit_for_bit():
    t = _tensions()
    rho = InstrumentParams().cable_radius_in_section_m
    assert InstrumentParams().cable_crossing_angle_rad == 0.0
    w = section_wrench(t, InstrumentParams())
    expected = np.zeros_like(w)  # the section wrench before the field existed, as it was coded
    cx, cy = rho * np.cos(CABLE_ANGLES_RAD), rho * np.sin(CABLE_ANGLES_RAD)
    expected[:, 2] = -t.sum(axis=(1, 2))
    expected[:, 3] = -(t * cy).sum(axis=(1, 2))
    expected[:, 4] = (t * cx).sum(axis=(1, 2))
    assert np.array_equal(w, expected)


def test_an_angle_adds_the_closed_form_lateral_force():
    b = 0.03
    params = InstrumentParams(cable_crossing_angle_rad=b)
    rho = params.cable_radius_in_section_m
    t = _tensions(1)
    w = section_wrench(t, params)
    d = t[:, :, 0] - t[:, :, 1]                     # pair differentials T+ - T-
    phi = CABLE_ANGLES_RAD[:, 0]                    # the "+" cables' angles
    # each pair pulls sin b (T+ - T-) along the tangent (-sin phi, cos phi) of its "+" cable
    assert np.allclose(w[:, 0], np.sin(b) * d @ -np.sin(phi), rtol=1e-12, atol=1e-12)
    assert np.allclose(w[:, 1], np.sin(b) * d @ np.cos(phi), rtol=1e-12, atol=1e-12)
    assert np.allclose(w[:, 5], rho * np.sin(b) * t.sum(axis=(1, 2)), rtol=1e-12)
    assert np.allclose(w[:, 2], -np.cos(b) * t.sum(axis=(1, 2)), rtol=1e-12)
    straight = section_wrench(t, InstrumentParams())
    assert np.allclose(w[:, 3:5], np.cos(b) * straight[:, 3:5], rtol=1e-12)
    # equal tensions in a pair: no lateral force (the pair's tilts cancel)
    assert np.allclose(section_wrench(np.full((2, 3, 2), 3.0), params)[:, :2], 0.0, atol=1e-15)


def test_the_field_is_serialised_sampled_and_simulated():
    params = InstrumentParams(cable_crossing_angle_rad=0.02)
    assert InstrumentParams.from_dict(params.to_dict()) == params
    old = {k: v for k, v in InstrumentParams().to_dict().items() if k != "cable_crossing_angle_rad"}
    assert InstrumentParams.from_dict(old).cable_crossing_angle_rad == 0.0  # older metadata
    assert params.sample(3).cable_crossing_angle_rad == 0.02
    # on the bench, pretension only: every cable at T_tot / 6, no lateral force,
    # tz = rho sin b T_tot
    effects = dataclasses.replace(Effects.none(), pretension=True)
    q = np.zeros((20, 7))
    q[:, 2] = 0.12
    runs = [run_trajectory(q, 0.01, Contact(), p, effects, np.random.default_rng(0))
            for p in (InstrumentParams(), params)]
    t_tot, rho = params.pretension_total_n, params.cable_radius_in_section_m
    assert np.allclose(runs[1]["tz"] - runs[0]["tz"], rho * np.sin(0.02) * t_tot, rtol=1e-9)
    assert np.allclose(runs[1]["fz"] - runs[0]["fz"], (1 - np.cos(0.02)) * t_tot, rtol=1e-6)
    assert np.allclose(runs[1][["fx", "fy"]], 0.0, atol=1e-12)


def test_a_bench_is_simulated_with_it(tmp_path):
    params = InstrumentParams(cable_crossing_angle_rad=0.03)
    simulate("automated", scale=0.005, seed=0, out=tmp_path / "d", instrument=params)
    meta = json.loads((tmp_path / "d" / "metadata.json").read_text())
    assert meta["instrument"]["cable_crossing_angle_rad"] == 0.03
    assert InstrumentParams.from_dict(meta["instrument"]) == params
