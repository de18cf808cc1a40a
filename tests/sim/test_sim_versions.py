"""Simulator versions (psmforce/sim/versions.py): the default version's cable law is what it was
before simulator 2.2's cable-law terms existed; 2.2's load-independent friction acts as
documented (docs/simulator.md sections 6 and 12b)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from psmforce.sim import cables, versions
from psmforce.sim.dataset import SIM_VERSION
from psmforce.sim.params import OMITTED_WHEN_OFF, Effects, InstrumentParams

BEFORE_2_2 = Path(__file__).parents[1] / "data" / "cable_law_before_2_2.npz"
"""``cables.transmission`` of :func:`_trajectory` for the nominal instrument, computed with
psmforce/sim/cables.py as committed before simulator 2.2's terms were added (git 1a5f325).

Stored as arrays, not as a hash: numpy's exp and sinh take other SIMD paths on other CPUs
(AVX2, AVX-512), which move the last bits, so a hash of the bytes named the machine as much as
the law. On one machine the old and the new module give the same bytes (checked on AVX-512 when
this file was written); across machines they agree to rounding."""
ROUNDING = 1e-9
"""Relative tolerance against :data:`BEFORE_2_2`: far above a few ULPs carried through the
Dahl recursion, far below any change of the law (the 2.2 terms move these arrays by percent)."""


def _trajectory():
    t = np.arange(400) * 0.01
    q = np.zeros((400, 7))
    q[:, 3] = 1.2 * np.sin(0.7 * t)
    q[:, 4] = 0.8 * np.sin(1.3 * t + 0.4)
    q[:, 5] = 0.6 * np.sin(2.1 * t + 1.0)
    q[:, 6] = 0.5 + 0.4 * np.sin(3.0 * t)
    tau = np.stack([0.02 * np.sin(1.1 * t), 0.03 * np.cos(0.9 * t),
                    -0.025 * np.sin(1.7 * t)], axis=1)
    return q, tau


def _transmission(params) -> dict:
    q, tau = _trajectory()
    return cables.transmission(q, tau, params, Effects())


def _same_law(out: dict, reference: dict) -> bool:
    return sorted(out) == sorted(reference) and all(
        np.allclose(out[k], reference[k], rtol=ROUNDING, atol=ROUNDING * np.abs(reference[k]).max())
        for k in reference)


def test_the_default_version_is_the_datasets_and_the_nominal_instrument():
    assert versions.DEFAULT_VERSION == SIM_VERSION
    assert versions.instrument() == InstrumentParams()
    assert versions.CHANGES[versions.DEFAULT_VERSION] == {}
    with pytest.raises(ValueError, match="unknown simulator version"):
        versions.instrument("9.9")


def test_the_default_cable_law_is_unchanged():
    with np.load(BEFORE_2_2) as stored:
        before = {k: stored[k] for k in stored.files}
    default = _transmission(InstrumentParams())
    assert _same_law(default, before)
    # The new terms are inert while the friction is 0, whatever the share: bit for bit.
    off = _transmission(dataclasses.replace(InstrumentParams(), cable_coulomb_stretch_share=0.7))
    assert sorted(off) == sorted(default)
    for k in default:
        np.testing.assert_array_equal(off[k], default[k])


def test_the_default_metadata_keeps_its_fields():
    d = InstrumentParams().to_dict()
    assert not set(OMITTED_WHEN_OFF) & set(d)
    assert InstrumentParams.from_dict(d) == InstrumentParams()
    on = versions.instrument("2.2")
    assert on.cable_coulomb_n > 0 and InstrumentParams.from_dict(on.to_dict()) == on


def test_v22_changes_the_cable_law_and_only_through_its_listed_fields():
    v22 = versions.instrument("2.2")
    with np.load(BEFORE_2_2) as stored:
        assert not _same_law(_transmission(v22), {k: stored[k] for k in stored.files})
    changed = {f.name for f in dataclasses.fields(InstrumentParams)
               if getattr(v22, f.name) != getattr(InstrumentParams(), f.name)}
    assert changed <= set(versions.CHANGES["2.2"])


def test_coulomb_friction_is_paid_by_the_motor_not_seen_by_the_section():
    q, tau = _trajectory()
    base = InstrumentParams()
    f = 12.0
    on = dataclasses.replace(base, cable_coulomb_n=f, cable_coulomb_stretch_share=0.0)
    a = cables.transmission(q, tau, base, Effects())
    b = cables.transmission(q, tau, on, Effects())
    for k in ("s_shaft", "d_shaft", "tensions", "slack", "deflection"):
        np.testing.assert_array_equal(a[k], b[k])      # the HEX10 section sees none of it
    g = cables.coupling_matrix(base)
    extra = cables.distal_torque_to_joints((f * a["z"]) @ g)
    np.testing.assert_allclose(b["effort"] - a["effort"], extra, atol=1e-12)
    # With the capstan (the cable path's friction) off, the term is off too.
    quiet = dataclasses.replace(Effects(), capstan=False)
    np.testing.assert_array_equal(cables.transmission(q, tau, on, quiet)["effort"],
                                  cables.transmission(q, tau, base, quiet)["effort"])


def test_the_stretch_share_moves_the_deflection_only():
    q, tau = _trajectory()
    on = dataclasses.replace(InstrumentParams(), cable_coulomb_n=12.0)
    shared = dataclasses.replace(on, cable_coulomb_stretch_share=0.5)
    a = cables.transmission(q, tau, on, Effects())
    b = cables.transmission(q, tau, shared, Effects())
    np.testing.assert_array_equal(a["effort"], b["effort"])
    np.testing.assert_array_equal(a["s_shaft"], b["s_shaft"])
    assert np.abs(b["deflection"] - a["deflection"]).max() > 1e-4
