"""The load path's readings on hung weights (studies/load_path_holds.py, docs/ati_free.md section
4.1): each reading's law at the bench's truth, and on a bench hold the closed jaw kept and the
wrist's sag taken out of the law's error."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from studies.load_path_holds import READINGS, _law, hold_residuals  # noqa: E402
from psmforce.experiments.prior_recovery import default_bench_truth  # noqa: E402
from psmforce.identification.prior_law import NAMES  # noqa: E402
from psmforce.sim.params import Effects, InstrumentParams  # noqa: E402


def test_before_the_pin_term_the_capstan_carries_both_frictions():
    tool = InstrumentParams()
    truth = default_bench_truth(tool)
    wrist = tool.capstan_mu_wrap_distal + tool.pin_friction_coefficient
    for reading in READINGS:
        p = dict(zip(NAMES, _law(truth, reading).params))
        own = reading in ("pins", "path as pretension")
        assert p["pin_friction"] == (tool.pin_friction_coefficient if own else 0.0)
        assert np.isclose(p["capstan_mu"], tool.capstan_mu_wrap_distal if own else wrist)
        inside = reading == "path as pretension"  # one form of the path tension at a time
        assert (p["pitch_path_pretension"] > 0, p["pitch_path_tension"] > 0) == (inside,
                                                                                 not inside)


def test_a_hold_at_closed_is_kept_and_the_sag_taken_out_of_the_laws_error():
    """A 0.2 kg weight on the bench's elastic wrist (pretension, slack, elasticity, the distal
    masses and the sensor's offset: what the law at the truth models), the jaw reading -3e-17 rad
    (a bench's round-off): the strict reading drops the hold, the others keep it, and the sag
    removes most of the law's fz error."""
    from psmforce.cli.excitation import WEIGHT_ARM_POSE
    from psmforce.sim.bench import Contact, run_trajectory
    tool = dataclasses.replace(InstrumentParams(), cable_asymmetry=(0.0, 0.0, 0.0),
                               pitch_path_mismatch_m=0.0)
    effects = dataclasses.replace(Effects.none(), pretension=True, slack=True, elasticity=True,
                                  distal_gravity=True, hex10_bias=True)
    q = np.repeat(np.r_[WEIGHT_ARM_POSE, 0.0, -0.7, 0.7, -3e-17][None], 400, 0)
    frame = run_trajectory(q, 1e-3, Contact(kind="weight", mass_kg=0.2), tool, effects,
                           np.random.default_rng(0))
    truth = default_bench_truth(tool)
    got = {r: hold_residuals(frame, _law(truth, r), r) for r in READINGS}
    assert got["before"] is None
    assert abs(got["closed jaw kept"]["fz"]) > 0.3  # N: the encoders' pose misses the load
    assert abs(got["wrist sag"]["fz"]) < 0.25 * abs(got["closed jaw kept"]["fz"])
