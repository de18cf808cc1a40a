"""Static equilibrium, sign and consistency checks of the simulated bench's physics."""

import dataclasses

import numpy as np
import pytest

from psmforce.robot import PSM
from psmforce.sim import Contact, Effects, InstrumentParams, run_trajectory
from psmforce.sim import cables, motion, protocols, sensors

DT = 0.01
NOMINAL = InstrumentParams()


def _hold(wrist=(0.0, 0.0, 0.0, 0.3), n=50, arm=None):
    q = np.zeros((n, 7))
    q[:, :3] = protocols._traction_arm(0.0, 45.0, 1) if arm is None else arm
    q[:, 3:] = wrist
    return q


def _only(**on):
    return dataclasses.replace(Effects.none(), **on)


def _run(q, contact=None, effects=None, params=NOMINAL, seed=0):
    return run_trajectory(q, DT, contact or Contact(), params, effects or Effects.none(),
                          np.random.default_rng(seed), r_base_ati=protocols.R_BASE_ATI)


def _pull(direction_hex, q, stretch=0.02):
    """Traction contact pulling the jaw tip along a HEX10-frame direction (stretch m beyond rest)."""
    psm = PSM()
    tip = psm.forward_kinematics(q[0, :6], "jaw_tip")[:3, 3]
    d = psm.rotation(q[0, :6], "hex10") @ np.asarray(direction_hex, float)
    rest = 0.05
    return Contact(kind="traction", anchor=tip + (rest + stretch) * d, rest_length=rest)


def _moving_wrist():
    way = np.array([[0.5, -0.4, 0.3, 0.2], [-1.0, 0.6, -0.5, 0.6], [1.5, 0.2, 0.8, 0.1]])
    wrist = motion.piecewise(way, np.array([1.0, 1.0]), np.array([0.3, 0.3]))
    q = np.zeros((len(wrist), 7))
    q[:, :3] = protocols._traction_arm(120.0, 45.0, 2)
    q[:, 3:] = wrist
    return q


@pytest.mark.parametrize("condition", ["traction", "palpation"])
def test_all_effects_off_hex10_force_is_external_force_in_hex10_frame(condition):
    q = _moving_wrist()
    if condition == "traction":
        contact = protocols.traction_contact()
    else:
        q = protocols.palpation_q(60.0, 45.0, np.array([[0.3, 0.2, -0.3, 0.4], [-0.5, -0.4, 0.3, 0.2]]),
                                  0.4, 1.1, 0.4)
        contact = protocols.palpation_contact("shore_22a", 60.0, 45.0)
    df = _run(q, contact)
    hex10 = df[["fx", "fy", "fz"]].to_numpy()
    target = df[["ati_fx", "ati_fy", "ati_fz"]].to_numpy()
    assert np.abs(target).max() > 1.0  # the trial is really loaded
    np.testing.assert_allclose(hex10, target, atol=1e-9)


def test_all_effects_off_with_noise_only_differs_by_sensor_noise():
    df = _run(_moving_wrist(), protocols.traction_contact(), _only(sensor_noise=True))
    diff = (df[["fx", "fy", "fz"]].to_numpy() - df[["ati_fx", "ati_fy", "ati_fz"]].to_numpy())
    expected = np.hypot(NOMINAL.hex10_force_noise_n, NOMINAL.ati_force_noise_n)
    assert np.all(np.abs(diff.mean(axis=0)) < 4 * expected / np.sqrt(len(diff)) + 1e-3)
    np.testing.assert_allclose(diff.std(axis=0), expected, rtol=0.2)


def test_pretension_compresses_the_section_by_its_total():
    df = _run(_hold(), effects=_only(pretension=True))
    np.testing.assert_allclose(df.fz, -NOMINAL.pretension_total_n, atol=1e-12)


def test_distal_gravity_pulls_on_the_sensor_of_a_hanging_tool():
    q = _hold(arm=(0.0, 0.0, 0.15))  # shaft straight down: distal mass hangs on the section
    df = _run(q, effects=_only(distal_gravity=True))
    weight = (NOMINAL.distal_body_mass_kg + NOMINAL.jaw_mass_kg) * 9.81
    np.testing.assert_allclose(df.fz, weight, rtol=1e-9)


def test_axial_pull_raises_fz_by_the_pull_and_lateral_pull_amplifies_compression():
    q = _hold(wrist=(0.0, 0.0, 0.0, 0.0))
    eff = _only(pretension=True, slack=True)
    rest = _run(q, effects=eff).fz.to_numpy()
    axial = _run(q, _pull([0, 0, 1], q), eff)
    np.testing.assert_allclose(axial.fz - rest, axial.ati_fz, atol=1e-9)
    assert axial.ati_fz.iloc[0] > 2.0
    lateral = _run(q, _pull([1, 0, 0], q), eff)
    f_lat = np.hypot(lateral.ati_fx, lateral.ati_fy).to_numpy()
    assert f_lat[0] > 2.0
    extra_compression = rest - lateral.fz.to_numpy()
    # jaw length (15.5 mm) / blade pulley radius (1.5 mm) ~ 10: compression grows many times faster
    assert np.all(extra_compression > 5.0 * f_lat)


def test_slack_cables_never_push_and_taut_pairs_keep_their_pretension():
    rng = np.random.default_rng(1)
    n = 400
    q = np.zeros((n, 7))
    q[:, 3:] = rng.uniform(-1, 1, (n, 4))
    load = rng.normal(0.0, 0.01, (n, 3))
    eff = _only(pretension=True, slack=True)
    out = cables.transmission(q, load, NOMINAL, eff)
    assert out["tensions"].min() >= -1e-12
    t0 = out["pretension"]
    d = out["d_shaft"]
    np.testing.assert_allclose(out["s_shaft"], np.maximum(2 * t0, np.abs(d)), atol=1e-12)
    assert out["slack"].any() and (~out["slack"]).any()
    # without the slack effect a cable may push: the sum stays at 2 T0
    free = cables.transmission(q, load, NOMINAL, _only(pretension=True))
    np.testing.assert_allclose(free["s_shaft"], 2 * free["pretension"], atol=1e-12)
    assert free["tensions"].min() < 0


def test_cable_coordinates_reproduce_the_dvrk_coupling_matrix():
    g = cables.coupling_matrix(NOMINAL)
    rng = np.random.default_rng(2)
    joints = rng.uniform(-1, 1, (20, 4))  # roll, wrist_pitch, wrist_yaw, jaw
    discs = joints @ np.linalg.inv(sensors.COUPLING).T
    radii = np.array([1.0186 * NOMINAL.pulley_radius_pitch_m, 1.2177 * NOMINAL.pulley_radius_blade_m,
                      1.2177 * NOMINAL.pulley_radius_blade_m])
    x_from_discs = discs[:, 1:] * radii
    x_from_joints = cables.joints_to_distal(joints[:, 1], joints[:, 2], joints[:, 3]) @ g.T
    # the published matrix is rounded to 4 decimals (0.6089 vs 1.2177 / 2)
    np.testing.assert_allclose(x_from_joints, x_from_discs, atol=2e-7)  # 0.2 um of cable


def test_ideal_transmission_efforts_are_the_torques_the_load_demands():
    rng = np.random.default_rng(3)
    q = np.zeros((50, 7))
    load = rng.normal(0.0, 0.02, (50, 3))
    out = cables.transmission(q, load, NOMINAL, Effects.none())
    np.testing.assert_allclose(out["effort"], -cables.distal_torque_to_joints(load), atol=1e-12)


def test_static_external_load_enters_arm_efforts_as_minus_jacobian_transpose():
    q = _hold(wrist=(0.3, 0.2, -0.1, 0.2))
    contact = _pull([0.3, -0.5, 0.8], q)
    df = _run(q, contact)
    psm = PSM()
    f_base = psm.rotation(q[0, :6], "hex10") @ df[["ati_fx", "ati_fy", "ati_fz"]].to_numpy()[0]
    j = psm.jacobian(q[0, :6], "jaw_tip", "base_at_frame")
    expected = -(j[:3].T @ f_base)
    efforts = df[["yaw_effort", "pitch_effort", "insertion_effort", "roll_effort",
                  "wrist_pitch_effort", "wrist_yaw_effort"]].to_numpy()[0]
    # wrist yaw: the dVRK joint torque is the sum over both blades, as the jacobian's column
    np.testing.assert_allclose(efforts, expected, atol=1e-9)


def test_friction_memory_makes_fz_depend_on_the_approach_direction():
    q0 = _hold(n=1)[0]
    way = np.tile(q0, (5, 1))
    way[1, 4], way[3, 4] = 0.5, -0.5
    q = motion.piecewise(way, np.full(4, 1.5), np.full(4, 1.0))
    n = len(q) // 4

    def gap(effects):
        fz = _run(q, effects=effects).fz.to_numpy()
        return fz[2 * n - 20] - fz[4 * n - 20]

    full = dataclasses.replace(Effects(), sensor_noise=False, hex10_drift=False)
    assert abs(gap(full)) > 0.5
    assert abs(gap(dataclasses.replace(full, hysteresis=False))) < 1e-6  # at rest: no memory
    assert abs(gap(dataclasses.replace(full, capstan=False, pin_friction=False))) < 1e-6


def test_roll_twist_raises_compression():
    eff = _only(pretension=True, roll_twist=True)
    fz0 = _run(_hold(wrist=(0.0, 0.0, 0.0, 0.3)), effects=eff).fz.iloc[0]
    fz2 = _run(_hold(wrist=(2.0, 0.0, 0.0, 0.3)), effects=eff).fz.iloc[0]
    expected = -NOMINAL.pretension_total_n * (1 + NOMINAL.twist_tension_gain_per_rad2 * 4.0)
    assert fz0 == pytest.approx(-NOMINAL.pretension_total_n)
    assert fz2 == pytest.approx(expected)


def test_elastic_wrist_deflects_along_the_external_torque():
    q = _hold(wrist=(0.0, 0.0, 0.0, 0.0))
    eff = _only(pretension=True, slack=True, elasticity=True)
    df = _run(q, _pull([1, 0, 0], q), eff)
    psm = PSM()
    f_base = psm.rotation(q[0, :6], "hex10") @ df[["ati_fx", "ati_fy", "ati_fz"]].to_numpy()[0]
    j = psm.jacobian(q[0, :6], "jaw_tip", "base_at_frame")
    tau_ext = j[:3].T @ f_base
    moved = df[["sim_wrist_pitch_true", "sim_wrist_yaw_true"]].to_numpy()[0] - q[0, 4:6]
    assert np.abs(moved).max() > 1e-3
    big = np.abs(tau_ext[4:6]) > 1e-3
    assert np.all(np.sign(moved[big]) == np.sign(tau_ext[4:6][big]))


def test_hex10_clips_at_overload_and_flags_it():
    w = np.zeros((3, 6))
    w[:, 2] = [-50.0, -120.0, 130.0]
    y, flag = sensors.hex10_reading(w, DT, NOMINAL, Effects.none(), np.random.default_rng(0))
    np.testing.assert_array_equal(y[:, 2], [-50.0, -100.0, 100.0])
    np.testing.assert_array_equal(flag, [False, True, True])
    y2, _ = sensors.hex10_reading(w[:1] * 0.6, DT, NOMINAL, _only(hex10_range_error=True),
                                  np.random.default_rng(0))
    assert y2[0, 2] == pytest.approx(-30.0 - NOMINAL.hex10_range_gain_error * 5.0)


def test_contacts_cannot_pull_or_push_the_wrong_way():
    from psmforce.sim import contacts

    p = np.array([[0.0, 0.0, 0.01], [0.0, 0.0, -0.004]])
    f = contacts.surface(p, np.zeros_like(p), np.zeros(3), np.array([0, 0, 1.0]),
                         contacts.MATERIALS["shore_8a"])
    assert f[0] == pytest.approx(np.zeros(3)) and f[1, 2] > 0
    t = contacts.traction(np.array([[0.0, 0.0, 0.03], [0.0, 0.0, 0.08]]), np.zeros(3), 0.05)
    assert t[0] == pytest.approx(np.zeros(3))
    assert t[1, 2] == pytest.approx(-0.154 * 30.0)


def test_sampled_instrument_is_seeded_and_differs_from_nominal():
    a, b, c = NOMINAL.sample(1), NOMINAL.sample(1), NOMINAL.sample(2)
    assert a == b and a != c and a != NOMINAL
    assert a.pulley_radius_blade_m > 0 and a.pretension_total_n > 0
    with pytest.raises(ValueError, match="spread"):
        NOMINAL.sample(0, spread=-1)


def test_instrument_params_survive_their_json_round_trip():
    import json
    tool = NOMINAL.sample(3, spread=2.0)
    back = type(NOMINAL).from_dict(json.loads(json.dumps(tool.to_dict())))
    assert back == tool and back != NOMINAL
    assert isinstance(back.hex10_crosstalk[0], tuple)   # nested tuples, not lists
    older = {k: v for k, v in tool.to_dict().items() if k != "effort_band_noise"}
    assert type(NOMINAL).from_dict(older).effort_band_noise == NOMINAL.effort_band_noise


def test_arm_ik_puts_the_jaw_tip_on_target():
    rng = np.random.default_rng(4)
    wrist = rng.uniform(-1, 1, (30, 4))
    target = np.array([0.02, -0.01, -0.17]) + rng.uniform(-0.02, 0.02, (30, 3))
    q = motion.arm_ik_for_tip(target, wrist)
    tip = PSM().forward_kinematics(q[:, :6], "jaw_tip")[:, :3, 3]
    np.testing.assert_allclose(tip, target, atol=1e-7)
    np.testing.assert_array_equal(q[:, 3:], wrist)


def test_protocol_wrist_configurations_respect_the_hex10_safety_screen():
    configs = protocols._safe_configs(np.random.default_rng(0), 10, protocols.TRACTION_WRIST_LIMITS,
                                      protocols._traction_static(0.0, 0.0, 2), protocols.traction_contact())
    q = protocols._traction_static(0.0, 0.0, 2)(configs)
    fz = _run(q, protocols.traction_contact(), _only(pretension=True, slack=True)).fz
    assert len(configs) == 10 and fz.min() > protocols.SAFE_COMPRESSION_N


@pytest.mark.parametrize("q, message", [(np.zeros((1, 7)), "N >= 2"), (np.zeros((5, 6)), "shape"),
                                        (np.full((5, 7), np.nan), "non-finite")])
def test_run_trajectory_rejects_bad_joint_arrays(q, message):
    with pytest.raises(ValueError, match=message):
        _run(q)


def test_pitch_path_mismatch_tensions_the_blade_cables_symmetrically_in_pitch():
    eff = _only(pretension=True, pitch_path_mismatch=True)
    fz = [_run(_hold(wrist=(0.0, p, 0.0, 0.3)), effects=eff).fz.iloc[0] for p in (-0.8, 0.0, 0.8)]
    extra = 4 * NOMINAL.cable_stiffness_n_per_m * NOMINAL.pitch_path_mismatch_m * (1 - np.cos(0.8))
    assert fz[1] == pytest.approx(-NOMINAL.pretension_total_n)
    assert fz[0] == pytest.approx(fz[2]) == pytest.approx(fz[1] - extra)


def test_crosstalk_mixes_channels_by_the_matrix():
    q = _hold(wrist=(0.0, 0.0, 0.0, 0.0))
    plain = _run(q, _pull([1, 0, 0], q), _only(pretension=True))
    mixed = _run(q, _pull([1, 0, 0], q), _only(pretension=True, hex10_crosstalk=True))
    x = np.asarray(NOMINAL.hex10_crosstalk)
    w = plain[["fx", "fy", "fz", "tx", "ty", "tz"]].to_numpy()
    np.testing.assert_allclose(mixed[["fx", "fy", "fz", "tx", "ty", "tz"]].to_numpy(), w @ x.T, atol=1e-12)


def _press(path_xyz, material="shore_22a"):
    from psmforce.sim import contacts

    p = np.asarray(path_xyz, dtype=float)
    return contacts.surface(p, np.zeros_like(p), np.zeros(3), np.array([0, 0, 1.0]), contacts.MATERIALS[material])


@pytest.mark.parametrize("material", ["shore_22a", "rigid"])
def test_oblique_press_sticks_with_mindlin_shear_ratio(material):
    """Quasi-static press at angle a from the normal: while stuck, the shear integrates
    k_t = 2/3 dFn/dd along du = tan(a) dd, so F_t / F_n = (2/3) tan(a) for any power law."""
    from psmforce.sim import contacts

    a = np.deg2rad(20.0)
    d = np.linspace(0.0, 0.006, 6001)
    f = _press(np.column_stack([d * np.tan(a), np.zeros_like(d), -d]), material)
    assert (2.0 / 3.0) * np.tan(a) < contacts.MATERIALS[material].friction  # the case sticks
    np.testing.assert_allclose(f[-1, 0] / f[-1, 2], -(2.0 / 3.0) * np.tan(a), rtol=2e-3)
    assert f[-1, 1] == 0.0


def test_shear_is_held_in_the_dwell_and_lost_out_of_contact():
    d = np.linspace(0.0, 0.006, 600)
    press = np.column_stack([0.5 * d, np.zeros_like(d), -d])
    dwell = np.repeat(press[-1:], 100, 0)
    # lifted out and pressed back faster than one sample, so no shrinking cap can hide a lost reset
    out = np.tile([0.003, 0.0, 0.001], (100, 1))
    straight = np.tile([0.003, 0.0, -0.004], (50, 1))
    f = _press(np.vstack([press, dwell, out, straight]))
    held = f[600:700]
    assert held[0, 0] < -0.1 and np.allclose(held, held[0])  # the press holds its shear at rest
    assert np.all(f[700:800][f[700:800, 2] == 0.0] == 0.0)  # nothing once out of contact
    np.testing.assert_array_equal(f[800:, :2], 0.0)  # a straight press after leaving starts unsheared


@pytest.mark.parametrize("theta", protocols.THETA_DEG)
def test_every_palpation_elevation_presses_the_block(theta):
    """The approach enters the block's top (45, 90 deg) or side wall (0 deg) and loads the ATI."""
    q = protocols.palpation_q(120.0, theta, np.array([[0.3, 0.2, -0.3, 0.4]]), 0.4, 1.1, 0.4)
    df = _run(q, protocols.palpation_contact("shore_22a", 120.0, theta))
    force = np.linalg.norm(df[["ati_fx", "ati_fy", "ati_fz"]].to_numpy(), axis=1)
    assert force[0] == 0.0 and force.max() > 2.0


def test_drag_slides_at_coulomb_limit_opposing_motion_then_sticks_on_reversal():
    from psmforce.sim import contacts

    mu = contacts.MATERIALS["shore_8a"].friction
    down = np.column_stack([np.zeros(200), np.zeros(200), -np.linspace(0.0, 0.006, 200)])
    drag = np.column_stack([np.linspace(0.0, 0.02, 400), np.zeros(400), np.full(400, -0.006)])
    back = np.column_stack([np.linspace(0.02, 0.0199, 11)[1:], np.zeros(10), np.full(10, -0.006)])
    f = _press(np.vstack([down, drag, back]), "shore_8a")
    sliding = f[400:600]
    np.testing.assert_allclose(sliding[:, 0], -mu * sliding[:, 2], rtol=1e-12)
    reversed_ = f[600:]
    assert np.all(np.diff(reversed_[:, 0]) > 0)  # backing off unloads the shear elastically...
    assert np.all(np.abs(reversed_[:, 0]) < mu * reversed_[:, 2])  # ...without sliding
    assert np.all(reversed_[:, 0] < 0)


def test_encoder_quantisation_snaps_to_encoder_steps():
    rng = np.random.default_rng(5)
    q = rng.uniform(-1, 1, (20, 7))
    qq = sensors.quantise_joints(q, Effects())
    steps = qq[:, :3] / np.asarray(sensors.ENCODER_QUANTUM)
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    discs = qq[:, 3:] @ np.linalg.inv(sensors.COUPLING).T / sensors.DISC_QUANTUM
    np.testing.assert_allclose(discs, np.round(discs), atol=1e-6)
    assert np.abs(qq - q).max() < 1e-3
