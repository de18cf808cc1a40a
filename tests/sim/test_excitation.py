"""The excitation's trajectory (psmforce/sim/excitation.py) and the bench's jaw-on-jaw grip
(psmforce/sim/cables.py, jaw_grip_torque; psmforce/sim/bench.py): limits, determinism, a
closed-form clench, grip-dependent internal force."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from psmforce.identification import prior_design
from psmforce.robot.kinematics import default_psm
from psmforce.sim import Effects, InstrumentParams, excitation as ex
from psmforce.sim.cables import jaw_command_for_grip, jaw_grip_torque

PARAMS = InstrumentParams()
NOISE = [0.02] * 3 + [2e-4] * 3


def _fisher(frame):
    return prior_design.fisher_information(frame, NOISE, psm=default_psm())


@pytest.fixture(scope="module")
def designed():
    return ex.design(5, 0.4, _fisher, prior_design.log_det)


def _static(jaw, n=50, wrist=(0.3, 0.2, -0.1)):
    q = np.zeros((n, 7))
    q[:, :3] = (0.1, -0.1, 0.15)
    q[:, 3:6] = wrist
    q[:, 6] = jaw
    return q


def test_a_jaw_commanded_past_closed_grips_by_the_cables_closed_form():
    """Ideal bench with pretension and slack only: the blade pairs carry D = min(2 k e, k e + T0)
    with e = r_b |jaw| / 2; the jaw effort is -r_b D, the HEX10 fz the cables' -sum S, with S =
    2 T0 for the unloaded pitch pair and max(2 T0, D) for each blade pair (slack beyond)."""
    effects = dataclasses.replace(Effects.none(), pretension=True, slack=True)
    t0 = PARAMS.pretension_total_n / 6.0
    k, r_b = PARAMS.cable_stiffness_n_per_m, PARAMS.pulley_radius_blade_m
    for jaw in (-0.002, -0.005, -0.05, -0.2):
        frame = ex.simulate_excitation(_static(jaw), params=PARAMS, effects=effects)
        e = r_b * abs(jaw) / 2.0
        d = min(2 * k * e, k * e + t0)
        assert frame["jaw_effort"].to_numpy() == pytest.approx(-r_b * d, rel=1e-9)
        assert frame["fz"].to_numpy() == pytest.approx(-(2 * t0 + 2 * max(2 * t0, d)), rel=1e-9)
        assert frame["wrist_yaw_effort"].to_numpy() == pytest.approx(0.0, abs=1e-12)
    # open or just closed: no grip, the rest level
    for jaw in (0.0, 0.3):
        frame = ex.simulate_excitation(_static(jaw), params=PARAMS, effects=effects)
        assert frame["jaw_effort"].to_numpy() == pytest.approx(0.0, abs=1e-12)
        assert frame["fz"].to_numpy() == pytest.approx(-6 * t0)


def test_the_jaw_command_for_a_grip_inverts_the_grip_law():
    grips = np.array([0.0, 0.001, 0.003, 0.01, 0.05])
    jaw = jaw_command_for_grip(grips, 1.0, PARAMS)
    assert np.all(jaw <= 0.0)
    assert jaw_grip_torque(jaw, 1.0, PARAMS) == pytest.approx(grips, abs=1e-12)


def test_a_clench_gives_grip_dependent_internal_force_on_the_full_bench():
    """Every effect on (noise too): the harder grip compresses the HEX10 more and the jaw
    effort closes harder; on fz by at least the frictionless 2 x grip difference / r_b and at
    most twice it (the capstan over the wrist idlers and the pin friction raise the shaft-side
    tensions)."""
    pose = np.array([0.1, -0.1, 0.15, 0.5, 0.3, -0.2, 0.0])
    hold = {}
    for grip in (0.005, 0.02):
        q, spec = ex.clench_segment(pose, grip, PARAMS, ex.excitation_limits())
        frame = ex.simulate_excitation(q, params=PARAMS, seed=1)
        mid = slice(int(ex.CLOSE_S / ex.DT) + 50, int((ex.CLOSE_S + ex.HOLD_S) / ex.DT) - 10)
        hold[grip] = (frame["fz"].to_numpy()[mid].mean(), frame["jaw_effort"].to_numpy()[mid].mean(),
                      frame["sim_slack_pairs"].to_numpy()[mid].max())
        assert spec["jaw_command_rad"] < 0.0
    (fz1, e1, _), (fz2, e2, slack2) = hold[0.005], hold[0.02]
    expected = 2 * 0.015 / PARAMS.pulley_radius_blade_m      # 20 N more compression
    assert expected <= fz1 - fz2 <= 2 * expected
    assert e2 < e1 < 0.0
    assert slack2 >= 2                                       # both blade pairs slack


def test_the_excitation_keeps_to_its_limits(designed):
    q, lim = designed.q, designed.limits
    assert np.all(q >= lim.lower - 1e-12) and np.all(q <= lim.upper + 1e-12)
    vel = np.gradient(q, ex.DT, axis=0)
    acc = np.gradient(vel, ex.DT, axis=0)
    assert np.all(np.abs(vel).max(axis=0) <= lim.velocity)
    assert np.all(np.abs(acc).max(axis=0) <= lim.acceleration)
    # and within the URDF's, which the limits are taken inside
    psm = default_psm()
    assert np.all(lim.lower >= psm.lower_limits) and np.all(lim.upper <= psm.upper_limits)


def test_the_excitation_holds_clenches_and_motions_in_its_duration(designed):
    kinds = [s.kind for s in designed.segments]
    assert "clench" in kinds and set(kinds) <= {"settle", "fourier", "clench", "transition"}
    assert len(designed.q) * ex.DT <= 0.4 * 60.0 + 1e-9
    ends = [s.start_s + s.duration_s for s in designed.segments]
    assert [s.start_s for s in designed.segments[1:]] == pytest.approx(ends[:-1])
    assert ends[-1] == pytest.approx(len(designed.q) * ex.DT)
    assert min(s.spec["jaw_command_rad"] for s in designed.segments if s.kind == "clench") < 0.0


def test_the_design_is_deterministic_in_its_seed(designed):
    again = ex.design(5, 0.4, _fisher, prior_design.log_det)
    assert np.array_equal(again.q, designed.q)
    other = ex.design(6, 0.4, _fisher, prior_design.log_det)
    assert not np.array_equal(other.q[: len(designed.q)], designed.q[: len(other.q)])


def test_random_motion_keeps_to_the_same_limits():
    lim = ex.excitation_limits()
    q = ex.random_motion(0, 30.0, lim)
    assert len(q) == 3000
    vel = np.gradient(q, ex.DT, axis=0)
    assert np.all(q >= lim.lower - 1e-12) and np.all(q <= lim.upper + 1e-12)
    assert np.all(np.abs(vel).max(axis=0) <= lim.velocity)
    assert np.all(np.abs(np.gradient(vel, ex.DT, axis=0)).max(axis=0) <= lim.acceleration)


def test_setpoints_read_back_and_bad_files_are_refused(tmp_path):
    q = ex.random_motion(1, 2.0, ex.excitation_limits())
    path = tmp_path / "s.csv"
    path.write_text(ex.setpoints_frame(q).to_csv(index=False, float_format="%.9g"))
    back, dt = ex.read_setpoints(path)
    assert dt == pytest.approx(ex.DT) and back == pytest.approx(q, abs=1e-8)
    path.write_text("time_s,a\n0,1\n0.01,2\n")
    with pytest.raises(ValueError, match="columns must be"):
        ex.read_setpoints(path)


def test_a_hold_hung_from_rest_never_moves_and_an_approached_one_moves_in_from_its_side():
    """A weight hung from rest gives the cables' friction no direction; an approached hold
    starts ``approach_rad`` beyond the pose on the wrist's pitch and yaw, on the side asked, and
    ends on the pose for the whole hold, moving within the excitation's limits."""
    pose = np.array([0.3, 0.2, 0.15, 0.0, 0.7, -0.7, 0.0])
    still = ex.weight_hold(pose, 10.0)
    assert still.shape == (int(round(10.0 / ex.DT)), 7) and (still == pose).all()
    hold = int(round(10.0 / ex.DT))
    for side in (1, -1):
        q = ex.weight_hold(pose, 10.0, ex.APPROACH_RAD, side)
        wrist = [4, 5]
        assert np.allclose(q[0, wrist] - pose[wrist], side * ex.APPROACH_RAD)
        assert np.allclose(np.delete(q, wrist, axis=1), np.delete(pose, wrist)[None])
        assert (q[-hold:] == pose).all() and len(q) > hold
        step = np.diff(q[:, wrist], axis=0)
        assert (np.sign(step[np.abs(step) > 0]) == -side).all()   # one way, into the pose
        assert np.abs(step / ex.DT).max() < ex.excitation_limits().velocity[4]
    with pytest.raises(ValueError, match="side"):
        ex.weight_hold(pose, 10.0, ex.APPROACH_RAD, 0)
