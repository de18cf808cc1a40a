"""Roles and identifiability of the cable transmission: the bootstrap over files measures what
the data pin down, identify() fixes and names what they do not, one rule names what sits at a
bound."""

from __future__ import annotations

import numpy as np
import pytest

from psmforce.identification.transmission import roles
from psmforce.identification.transmission.model import (PER_SESSION, TORQUE_NAMES,
                                                        CableTransmission, at_bound)
from tests.identification.test_transmission import TRUTH, _in_family_bench

WIDTHS = CableTransmission(presliding_rad=0.04, hold_rad=0.005, backlash_rad=0.01)


def test_the_bound_rule_is_one_rule():
    assert at_bound(0.0, 0.0, 1.0) and at_bound(0.9995, 0.0, 1.0)
    assert not at_bound(0.01, 0.0, 1.0)


@pytest.mark.slow
def test_the_bootstrap_pins_the_gain_and_spreads_over_files():
    recs = _in_family_bench(5)
    model = CableTransmission.fit(recs, initial=WIDTHS)
    boot = roles.bootstrap(model, recs, resamples=4, seed=1)
    p = boot["parameters"]
    assert set(p) >= {"current_gain", "capstan_mu", "pretension_torque[synthetic]"}
    assert p["current_gain"]["relative_sd"] < 0.05
    assert p["current_gain"]["interval_5_95"][0] <= model.torque[0] <= \
        p["current_gain"]["interval_5_95"][1]
    assert all(v["sd"] > 0 for k, v in p.items() if k in ("current_gain", "capstan_mu"))


def test_identify_fixes_and_names_what_the_bootstrap_cannot_pin(monkeypatch):
    recs = _in_family_bench(6)
    calls = []

    def fake_bootstrap(model, recordings, **kw):
        calls.append(model.fixed)
        loose = "viscous" not in model.fixed
        return {"resamples": 2, "parameters": {
            "viscous": {"value": 0.01, "sd": 0.02 if loose else 0.0,
                        "relative_sd": 2.0 if loose else 0.0},
            "current_gain": {"value": 0.65, "sd": 0.001, "relative_sd": 0.002}}}

    monkeypatch.setattr(roles, "bootstrap", fake_bootstrap)
    model, report = roles.identify(recs, initial=WIDTHS, declared_fixed={"inertia": 0.0})
    assert report["not_identifiable"] == ["viscous"]
    assert model.info["not_identifiable"] == ["viscous"]
    assert "viscous" in model.fixed and model.torque[TORQUE_NAMES.index("viscous")] == \
        roles.FALLBACK["viscous"]
    by = {r["name"]: r for r in report["roles"]}
    assert by["viscous"]["role"] == "fixed: not identifiable"
    assert by["inertia"]["role"] == "fixed: declared"
    assert by["current_gain"]["role"] == "shared"
    assert by["pretension_torque"]["role"] == "per_session"
    assert {r["role"] for r in report["roles"]} >= {"design", "shared", "per_session"}
    assert len(calls) == 2                                  # refitted, then bootstrapped again


@pytest.mark.slow
def test_what_sits_at_a_bound_is_named_in_the_fit_and_the_roles_alike():
    recs = _in_family_bench(7)
    # the truth has no motor Coulomb friction: the fit puts it on its lower bound (0)
    model = CableTransmission.fit(recs, initial=WIDTHS, fixed={"motor_coulomb": 0.0})
    model.torque[TORQUE_NAMES.index("viscous")] = 0.0       # a parameter on its bound
    rows = {r["name"]: r for r in roles.roles_table(model)}
    assert rows["viscous"]["at_bound"] is True
    assert rows["current_gain"]["at_bound"] is False
    assert rows["backlash_rad"]["at_bound"] is False          # initial widths: no grid edge
    grids = {"presliding_rad": (0.01, 0.16), "hold_rad": (0.005, 0.8), "backlash_rad": (0.0, 0.02)}
    for width, edges in grids.items():           # the widths' grid edges by the same rule
        flagged = width in model.info["identifiability"]["at_bound"]
        assert flagged == (getattr(model, width) in edges), width


def test_per_session_parameters_are_declared_once():
    assert set(PER_SESSION) == {"pretension_torque", "pair_asymmetry", "torque_bias",
                                "angle_offset"}
    assert TRUTH.keys() == set(TORQUE_NAMES)
