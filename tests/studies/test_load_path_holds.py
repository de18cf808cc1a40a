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

from studies.load_path_holds import READINGS, _law, bench_sag, hold_residuals  # noqa: E402
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


def test_the_bench_sag_is_the_load_paths_where_their_laws_agree_and_not_where_friction_acts():
    """Without friction, on the design compliance's tool, the bench's sag is the load path's
    (one law, two codes); with the capstan turned one way it is not, which the diagnostic
    measures."""
    from psmforce.cli.excitation import WEIGHT_ARM_POSE
    from psmforce.identification.load_path import sagged_positions
    q = np.repeat(np.r_[WEIGHT_ARM_POSE, 0.0, -0.7, 0.7, 0.0][None], 3, 0)
    q[:, 5] = (0.7, 0.0, -0.7)
    force = np.tile([0.0, 0.0, -1.96], (3, 1))   # 0.2 kg along the HEX10's -z, a bent wrist
    tool = dataclasses.replace(InstrumentParams(), capstan_mu_wrap_distal=0.0,
                               pin_friction_coefficient=0.0, pitch_path_mismatch_m=0.0,
                               twist_tension_gain_per_rad2=0.0)
    ours = sagged_positions(q, force)
    bench = bench_sag(tool)(q, force)
    assert np.abs(ours[:, 4:6] - q[:, 4:6]).max() > 5e-3  # rad: the load sags the wrist
    np.testing.assert_allclose(bench[:, 4:6], ours[:, 4:6], atol=2e-4)
    friction = bench_sag(dataclasses.replace(tool, capstan_mu_wrap_distal=0.3))(q, force)
    assert np.abs(friction[:, 4:6] - ours[:, 4:6]).max() > 1e-3


def test_the_load_paths_sag_with_the_tools_friction_is_the_benchs():
    """A wrist that moves into its pose and holds a 0.2 kg weight there (the friction turned
    one way): with the tool's capstan, its growth and its pins the load path's sag is the
    bench's; without them it is not."""
    from psmforce.cli.excitation import WEIGHT_ARM_POSE
    from psmforce.identification.load_path import WristCompliance, sagged_positions
    tool = dataclasses.replace(InstrumentParams(), pitch_path_mismatch_m=0.0,
                               twist_tension_gain_per_rad2=0.0)
    q = np.repeat(np.r_[WEIGHT_ARM_POSE, 1.0, -0.7, 0.7, 0.0][None], 400, 0)
    q[:200, 5] = np.linspace(0.9, 0.7, 200)        # yaw moves into the pose, then holds
    q[:200, 4] = np.linspace(-0.5, -0.7, 200)
    force = np.tile([0.0, 0.0, -1.96], (400, 1))
    bench = bench_sag(tool)(q, force)[-1, 4:6]
    friction = WristCompliance(
        tool.cable_stiffness_n_per_m, tool.pretension_total_n, tool.pulley_radius_pitch_m,
        tool.pulley_radius_blade_m, tool.cable_asymmetry[0], tool.cable_asymmetry[1],
        capstan_mu=tool.capstan_mu_wrap_distal, capstan_pitch_gain=tool.capstan_wrap_pitch_gain,
        capstan_roll_gain=tool.twist_friction_gain_per_rad,
        pin_friction=tool.pin_friction_coefficient)
    without = dataclasses.replace(friction, capstan_mu=0.0, pin_friction=0.0)
    ours = sagged_positions(q, force, friction)[-1, 4:6]
    plain = sagged_positions(q, force, without)[-1, 4:6]
    assert np.abs(plain - bench).max() > 1e-3          # rad: the friction moves the sag
    np.testing.assert_allclose(ours, bench, atol=2e-4)
