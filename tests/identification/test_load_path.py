"""The load path (identification/load_path.py): the wrist efforts a tip force demands and its
moment at the HEX10, against finite differences and closed forms; the prior fitted through it on
the default bench; an estimator refuses such a prior."""
import numpy as np
import pytest

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.load_path import (CONTACT_FRAME, tip_force_moment,
                                               wrist_efforts_for_tip_force)
from psmforce.identification.prior import NAMES, InternalForcePrior
from psmforce.identification.prior_law import CAPSTAN
from psmforce.robot import PSM


def _configurations(n=5, seed=0):
    rng = np.random.default_rng(seed)
    q = np.zeros((n, 7))
    q[:, 0:2] = rng.uniform(-0.5, 0.5, (n, 2))
    q[:, 2] = rng.uniform(0.08, 0.2, n)
    q[:, 3:6] = rng.uniform(-0.8, 0.8, (n, 3))
    return q


def test_wrist_efforts_are_minus_the_virtual_work_of_the_tip_force():
    # the effort holding F balances it: tau_i = -F . dp_tip/dq_i (finite differences, base frame)
    psm, q = PSM(), _configurations()
    f_hex = np.random.default_rng(1).normal(0.0, 1.0, (len(q), 3))
    got = wrist_efforts_for_tip_force(q, f_hex, psm)
    f_base = np.einsum("nij,nj->ni", psm.rotation(q[:, :6], "hex10"), f_hex)
    h = 1e-6
    for col, joint in ((0, 4), (1, 5)):
        up, down = q.copy(), q.copy()
        up[:, joint] += h
        down[:, joint] -= h
        dp = (psm.forward_kinematics(up[:, :6], CONTACT_FRAME)[:, :3, 3]
              - psm.forward_kinematics(down[:, :6], CONTACT_FRAME)[:, :3, 3]) / (2 * h)
        np.testing.assert_allclose(got[:, col], -np.einsum("ni,ni->n", f_base, dp), atol=1e-7)
    np.testing.assert_array_equal(got[:, 2], 0.0)  # a force at the closed tip opens nothing


def test_tip_force_moment_closed_form_on_the_straight_wrist():
    # wrist straight: the jaw tip lies on the HEX10 z axis, distal by hex10_distance + jaw length
    # (cp sits on the wrist's axis); F along x gives (0, L F, 0)
    psm = PSM()
    q = np.zeros((1, 7))
    q[0, 2] = 0.12
    tip = psm.forward_kinematics(q[:, :6], CONTACT_FRAME)[0, :3, 3]
    hex10 = psm.forward_kinematics(q[:, :6], "hex10")[0]
    lever = hex10[:3, :3].T @ (tip - hex10[:3, 3])
    np.testing.assert_allclose(lever[:2], 0.0, atol=1e-12)
    assert lever[2] > 0.01  # towards the tip
    m = tip_force_moment(q, np.array([[2.0, 0.0, 0.0]]), psm)
    np.testing.assert_allclose(m[0], [0.0, 2.0 * lever[2], 0.0], atol=1e-12)


def test_bad_inputs_are_refused():
    q = _configurations(2)
    with pytest.raises(IdentificationInputError, match="tip force"):
        wrist_efforts_for_tip_force(q, np.zeros((3, 3)))
    with pytest.raises(IdentificationInputError, match="joint positions"):
        tip_force_moment(np.full((2, 7), np.nan), np.zeros((2, 3)))


@pytest.fixture(scope="module")
def default_bench(tmp_path_factory):
    from psmforce.sim import simulate
    out = tmp_path_factory.mktemp("default") / "d"
    simulate(protocol="automated", scale=0.05, seed=5, out=str(out))
    return out


@pytest.fixture(scope="module")
def fits(default_bench, tmp_path_factory):
    """``fit-prior --use-loaded`` on the default bench, all free: reading the motor efforts,
    the load path, and the load path with the sensor's lateral cross-talk (``--crosstalk
    full``); name -> (the report, the prior's JSON)."""
    from psmforce.identification.prior_report import fit_prior_cli
    out = tmp_path_factory.mktemp("fits")
    runs = {"efforts": ("efforts", None), "load_path": ("load_path", None),
            "full": ("load_path", "full")}
    return {name: (fit_prior_cli(default_bench, out / f"{name}.json", use_loaded=True,
                                 inputs=inputs, crosstalk=xt), out / f"{name}.json")
            for name, (inputs, xt) in runs.items()}


@pytest.mark.slow
def test_the_load_path_recovers_what_the_efforts_cannot(default_bench, fits):
    """On the default bench (every effect on) the motor efforts carry the discs' friction and
    the arm's disturbance: read as cable torques, the all-free fit puts the pretension at several
    times the bench's 6 N and the cable radius near 0. Read from the known tip force, the cable
    radius and both pulley radii come back within 10 % and the pretension near the truth (pin
    friction, outside the law, keeps it from 10 % in this all-free fit at this scale:
    docs/identification.md section 2.3). Switching the load path off fails this test; so does
    holding the law's capstan at 0: the capstan's gain on the slack side is then read as a
    smaller blade pulley. The law's capstan grows with |wrist pitch| and |roll| as the bench's
    does, so its straight-wrist value is not the bench's average over the configurations. The
    HEX10's cross-talk of the axial force into the lateral forces comes back through the load
    path too."""
    from psmforce.experiments.prior_recovery import default_bench_truth
    from psmforce.sim.params import InstrumentParams

    truth = default_bench_truth(InstrumentParams())
    load, efforts = fits["load_path"][0]["parameters"], fits["efforts"][0]["parameters"]
    def error(fit, name):
        return abs(fit[name] / truth[name] - 1)

    for name in ("cable_radius", "pulley_radius_pitch", "pulley_radius_blade"):
        assert error(load, name) < 0.1, (name, load)
    assert error(load, "pretension_total") < 0.25, load
    assert error(efforts, "cable_radius") > 0.5 and error(efforts, "pretension_total") > 1.0
    # the sensor's cross-talk of the axial force: the load path frees it and it comes back; the
    # efforts reading holds it, and its lateral bias carries the leak's mean instead
    for name in ("crosstalk_fx", "crosstalk_fy"):
        assert error(load, name) < 0.1 and efforts[name] == 0.0, (name, load)
    assert error(load, "bias_fy") < 0.15 and error(efforts, "bias_fy") > 1.0
    from psmforce.io.recording import list_recordings, read_recording
    frames = [read_recording(r.path) for r in list_recordings(default_bench)
              if r.split == "train"]
    no_capstan = InternalForcePrior.fit(frames, inputs="load_path",
                                        fixed={n: 0.0 for n in CAPSTAN}, report=False)
    # the capstan's growth with the wrist's configuration is the law's too: its straight-wrist
    # value is nearer the bench's than the bench's average over these recordings, which is all
    # one constant could stand for
    from psmforce.experiments.prior_recovery import bench_capstan_over
    average = bench_capstan_over(frames, InstrumentParams())
    assert abs(load["capstan_mu"] - truth["capstan_mu"]) < abs(average - truth["capstan_mu"])
    assert error(dict(zip(NAMES, no_capstan.params)), "pulley_radius_blade") > 0.1
    prior = InternalForcePrior.load(fits["load_path"][1])
    assert prior.inputs == "load_path" and fits["load_path"][0]["inputs"] == "load_path"
    # an all-free fit (no selection) sags the wrist with the design's values, and says so
    from psmforce.identification.load_path import WristCompliance
    assert prior.wrist_compliance == WristCompliance.design() and "wrist_sag" not in fits[
        "load_path"][0]
    # the law read back over its training recordings gives the fit's own figure, capstan or not
    for law in (no_capstan, prior):
        again, stored = law.fit_metrics(frames), law.info["train_metrics"]
        assert law is no_capstan or law.has_friction
        for channel in ("fz", "tx", "ty"):
            assert again[channel]["rms"] == pytest.approx(stored[channel]["rms"], rel=1e-9)


@pytest.mark.slow
def test_the_load_path_reads_the_sensors_lateral_cross_talk_when_asked(fits):
    """``fit-prior --load-path --crosstalk full``: the law's lateral columns of the sensor's
    cross-talk are fitted on the tip forces the load path knows. The leaks of fx into fy and of
    fy into fx, and of fx into ty (the nominal tool's matrix), come back within 10 %; the capstan's
    pitch gain, which carried them with the axial column alone (docs/identification.md section
    2.3), comes nearer its truth. Holding the lateral columns (the load path's default) fails
    the first check."""
    from psmforce.experiments.prior_recovery import default_bench_truth
    from psmforce.sim.params import InstrumentParams

    truth = default_bench_truth(InstrumentParams())
    full, axial = fits["full"][0]["parameters"], fits["load_path"][0]["parameters"]
    for name in ("crosstalk_fy_from_fx", "crosstalk_fx_from_fy", "crosstalk_ty_from_fx"):
        assert truth[name] != 0 and abs(full[name] / truth[name] - 1) < 0.1, (name, full[name])
        assert axial[name] == 0.0  # held by the load path unless asked
    gain = "capstan_pitch_gain"
    assert abs(full[gain] - truth[gain]) < abs(axial[gain] - truth[gain]), (full[gain],
                                                                             axial[gain])
    assert InternalForcePrior.load(fits["full"][1]).crosstalk == "full"


def test_an_estimator_refuses_a_prior_that_reads_the_tip_force():
    from psmforce.estimators.data.hybrid_inputs import HybridInputError, SamplePrior
    prior = InternalForcePrior(info={"inputs": "load_path"})
    with pytest.raises(HybridInputError, match="known tip force"):
        SamplePrior(prior)
    SamplePrior(InternalForcePrior())  # the efforts' prior is taken


def test_the_inputs_survive_a_round_trip_and_a_bad_value_is_refused():
    prior = InternalForcePrior(converged=True, info={"inputs": "load_path"})
    assert InternalForcePrior.from_json(prior.to_json()).inputs == "load_path"
    assert InternalForcePrior.from_json(
        InternalForcePrior(converged=True).to_json()).inputs == "efforts"
    bad = InternalForcePrior(info={"inputs": "currents"}).to_dict()
    with pytest.raises(IdentificationInputError, match="info.inputs"):
        InternalForcePrior.from_dict(bad, "p.json")
    with pytest.raises(IdentificationInputError, match="unknown prior inputs"):
        InternalForcePrior.fit([object()], inputs="currents")


def test_a_recording_without_its_tip_force_is_refused_by_name():
    import pandas as pd

    from psmforce.identification.load_path import load_path_inputs
    from psmforce.io.recording import JOINT_POSITIONS
    frame = pd.DataFrame(np.zeros((3, len(JOINT_POSITIONS))), columns=list(JOINT_POSITIONS))
    with pytest.raises(IdentificationInputError, match="ati_fx, ati_fy, ati_fz"):
        load_path_inputs(frame)


def test_clenched_samples_are_left_out_of_a_load_path_fit():
    """A clench's grip (the jaw driven past closed) loads the blade pairs with no tip force to
    show it: the load path's fit masks those samples; the efforts reading keeps them."""
    import pandas as pd

    from psmforce.identification.load_path import clenched
    from psmforce.identification.prior import fit_arrays
    from psmforce.io.recording import HEX10, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES
    n = 6
    q = _configurations(n)
    q[:, 6] = [0.3, 0.0, -0.05, -0.2, 0.1, -1e-4]  # the jaw: open, closed, clenched ...
    cols = {c: q[:, k] for k, c in enumerate(JOINT_POSITIONS)}
    cols.update({c: np.zeros(n) for c in JOINT_VELOCITIES + JOINT_EFFORTS + HEX10})
    cols.update({c: np.zeros(n) for c in ("ati_fx", "ati_fy", "ati_fz")})
    frame = pd.DataFrame(cols)
    assert clenched(frame).tolist() == [False, False, True, True, False, True]
    _, _, mask = fit_arrays(frame, "load_path")
    assert (mask.sum(axis=1) == 0).tolist() == clenched(frame).tolist()
    _, _, kept = fit_arrays(frame, "efforts")
    assert kept[:, :3].all()
    # the jaws clenched on each other put no lateral force through the section: with
    # clenched_lateral their fx and fy count, the axial force and the moments still do not
    _, _, lateral = fit_arrays(frame, "load_path", clenched_lateral=True)
    grip = clenched(frame)
    assert (lateral[:, :2] == mask[:, :2] + grip[:, None]).all()
    assert (lateral[:, 2:] == mask[:, 2:]).all()
    assert lateral[grip, :2].all() and not lateral[grip, 2:].any()


def test_the_clenched_lateral_reading_is_the_load_paths_and_travels_with_the_prior():
    """``clenched_lateral`` is a load path option (refused with the efforts reading, or given as
    anything but a bool, by the fit and by the identification); a prior's info records it and
    reads back only as true."""
    from psmforce.identification.prior_selection import fit_identified
    for call in (lambda: InternalForcePrior.fit([object()], clenched_lateral=True),
                 lambda: InternalForcePrior.fit([object()], inputs="load_path",
                                                clenched_lateral="yes"),
                 lambda: fit_identified([], clenched_lateral=True)):
        with pytest.raises(IdentificationInputError, match="clenched_lateral: True only with"):
            call()
    prior = InternalForcePrior(converged=True, info={"inputs": "load_path",
                                                     "clenched_lateral": True})
    assert InternalForcePrior.from_json(prior.to_json()).info["clenched_lateral"] is True
    bad = InternalForcePrior(info={"inputs": "load_path", "clenched_lateral": 1}).to_dict()
    with pytest.raises(IdentificationInputError, match="info.clenched_lateral"):
        InternalForcePrior.from_dict(bad, "p.json")


def test_a_jaw_held_at_closed_is_not_clenched_whatever_its_round_off():
    """A weight hung with the jaw held at closed: the recorded jaw reads closed give or take
    round-off (a bench's +-1e-17 rad) or an encoder count. Those holds keep every sample; a jaw
    driven past closed by a grip's depth is still clenched."""
    import pandas as pd

    from psmforce.identification.load_path import CLENCH_TOLERANCE_RAD, clenched
    from psmforce.io.recording import JOINT_POSITIONS
    jaw = np.array([3.3e-17, -3.3e-17, -4.8e-17, -0.5 * CLENCH_TOLERANCE_RAD,
                    -2.0 * CLENCH_TOLERANCE_RAD, -1e-3])
    frame = pd.DataFrame({c: (jaw if k == 6 else np.zeros(len(jaw)))
                          for k, c in enumerate(JOINT_POSITIONS)})
    assert clenched(frame).tolist() == [False, False, False, False, True, True]


def test_wrist_sag_closed_forms_taut_and_slack():
    """A pitch effort alone loads the pitch pair: D = tau / r_p; taut (|D| < 2 T0) the cables
    stretch D / (2 k), slack (|D| - T0) / k; the wrist sags by that over r_p, along the load. A
    yaw effort loads both blade pairs alike and sags the yaw, not the jaw."""
    from psmforce.identification.load_path import WristCompliance, wrist_sag
    from psmforce.identification.prior_law import KAPPA
    c = WristCompliance(stiffness_n_per_m=2e5, pretension_total_n=6.0,
                        pulley_radius_pitch_m=2e-3, pulley_radius_blade_m=1.5e-3)
    t0 = 1.0  # N per cable
    taut, slack = 1.5 * 2e-3, -6.0 * 2e-3  # Nm: D = 1.5 N (taut), -6 N (slack)
    sag = wrist_sag(np.array([[taut, 0.0, 0.0], [slack, 0.0, 0.0]]), c)
    np.testing.assert_allclose(sag[:, 0], [1.5 / (2 * 2e5) / 2e-3, -(6.0 - t0) / 2e5 / 2e-3])
    np.testing.assert_allclose(sag[:, 2], 0.0, atol=1e-15)
    # 4 mNm of yaw: each blade pair 2 mNm / 1.5 mm (taut); the blade cables' pick-up over the
    # pitch pulleys loads the pitch pair with -KAPPA of their sum, which sags the pitch, and the
    # pitch's sag moves the blades back by KAPPA of it
    yaw = wrist_sag(np.array([[0.0, 0.004, 0.0]]), c)[0]
    pitch = -KAPPA * 0.004 / 2e-3 / (2 * 2e5) / 2e-3
    np.testing.assert_allclose(yaw, [pitch, 0.002 / 1.5e-3 / (2 * 2e5) / 1.5e-3 - KAPPA * pitch,
                                     0.0], atol=1e-15)
    with pytest.raises(IdentificationInputError, match="finite and > 0"):
        WristCompliance(0.0, 6.0, 2e-3, 1.5e-3)


def test_a_capstan_in_the_sag_gains_the_slack_pairs_differential_its_exponent():
    """With the friction turned one way (the wrist moved into its pose) a slack pitch pair
    reaches the section as ``|D| exp(mu z sgn D)``, and its cables stretch by that less ``T0``;
    a sag with friction needs the encoders' positions, and negative friction is refused."""
    import dataclasses

    from psmforce.identification.load_path import WristCompliance, wrist_sag
    c = WristCompliance(stiffness_n_per_m=2e5, pretension_total_n=6.0,
                        pulley_radius_pitch_m=2e-3, pulley_radius_blade_m=1.5e-3, capstan_mu=0.3)
    q = np.zeros((300, 7))
    q[:, 4] = np.r_[np.linspace(0.0, -0.5, 200), np.full(100, -0.5)]  # pitch moves down, holds
    e = np.zeros((300, 3))
    e[:, 0] = -6.0 * 2e-3                                            # D = -6 N: slack
    sag = wrist_sag(e, c, q)
    # z = -1 on the hold: the slack side gains exp(+0.3); moving the other way, exp(-0.3)
    # (to the law's smooth max between the taut sum and |D|, a few 1e-6 relative)
    np.testing.assert_allclose(sag[-1, 0], -(6.0 * np.exp(0.3) - 1.0) / 2e5 / 2e-3, rtol=1e-4)
    up = wrist_sag(e, c, -q)[-1, 0]
    np.testing.assert_allclose(up, -(6.0 * np.exp(-0.3) - 1.0) / 2e5 / 2e-3, rtol=1e-4)
    plain = wrist_sag(e, dataclasses.replace(c, capstan_mu=0.0))[-1, 0]
    np.testing.assert_allclose(plain, -(6.0 - 1.0) / 2e5 / 2e-3)
    with pytest.raises(IdentificationInputError, match="joint positions"):
        wrist_sag(e, c)
    with pytest.raises(IdentificationInputError, match="friction terms"):
        dataclasses.replace(c, pin_friction=-0.1)


def test_the_load_path_takes_the_moments_where_the_bench_wrist_sags():
    """A weight hung from the bench's elastic wrist (pretension, slack, elasticity only; the
    pairs symmetric, as the sag's law takes them): the load path's sagged wrist is the bench's
    true wrist, and its efforts are those of the true wrist, where the encoders' are ten times
    further off."""
    import dataclasses

    from psmforce.cli.excitation import WEIGHT_ARM_POSE
    from psmforce.identification.load_path import (WristCompliance, load_path_inputs,
                                                   sagged_positions)
    from psmforce.io.recording import JOINT_POSITIONS, TARGETS
    from psmforce.sim.bench import Contact, run_trajectory
    from psmforce.sim.params import Effects, InstrumentParams
    tool = dataclasses.replace(InstrumentParams(), cable_asymmetry=(0.0, 0.0, 0.0))
    effects = dataclasses.replace(Effects.none(), pretension=True, slack=True, elasticity=True)
    compliance = WristCompliance(tool.cable_stiffness_n_per_m, tool.pretension_total_n,
                                 tool.pulley_radius_pitch_m, tool.pulley_radius_blade_m)
    for wrist in ((0.0, -0.7, 0.7), (1.2, 0.5, -0.6)):
        q = np.repeat(np.r_[WEIGHT_ARM_POSE, *wrist, 0.0][None], 50, 0)
        frame = run_trajectory(q, 1e-3, Contact(kind="weight", mass_kg=0.2), tool, effects,
                               np.random.default_rng(0))
        true = frame[["sim_wrist_pitch_true", "sim_wrist_yaw_true"]].to_numpy()[-1]
        encoder = q[-1, 4:6]
        force = frame[list(TARGETS)].to_numpy()[-1:]
        got = sagged_positions(q[-1:], force, compliance)[0, 4:6]
        assert np.abs(encoder - true).max() > 0.01  # rad: the sag the test is about
        np.testing.assert_allclose(got, true, atol=0.1 * np.abs(encoder - true).max())
        # the efforts the load path reads: those of the bench's true wrist, not the encoders'
        efforts, _ = load_path_inputs(frame.iloc[-1:], compliance=compliance)
        at_true = wrist_efforts_for_tip_force(np.r_[q[-1, :4], true, 0.0][None], force)
        at_encoder = wrist_efforts_for_tip_force(q[-1:], force)
        assert (np.abs(efforts - at_true).max()
                < 0.1 * np.abs(at_encoder - at_true).max())


def test_the_path_tension_as_pretension_leaves_with_a_slack_blade_pair():
    """The blade cables' path tension c (1 - cos pitch) per cable: taut, the pretension form
    (pitch_path_pretension, the load path's) adds to each blade pair's sum what the outside form
    (pitch_path_tension, the efforts') adds; with both blade pairs slack under a yaw load, the
    pair's sum is |D| and the pretension form adds nothing, where the outside form still adds
    4 c (1 - cos pitch) of compression."""
    c, pitch = 0.9, 0.7
    base = dict(zip(NAMES, InternalForcePrior().params))
    base.update(pretension_total=6.0, pulley_radius_pitch=2e-3, pulley_radius_blade=1.5e-3,
                pitch_path_tension=0.0)

    def fz(yaw_effort_nm, **terms):
        p = np.array([{**base, **terms}.get(n) for n in NAMES])
        pos, e = np.array([[0.0, pitch]]), np.array([[0.0, yaw_effort_nm, 0.0]])
        return InternalForcePrior(params=p).law_arrays(pos, e, np.zeros((1, 3)),
                                                       np.zeros((1, 3)))[0, 2]

    path = 4.0 * c * (1.0 - np.cos(pitch))
    taut, slack = 1e-3, 0.03  # Nm of yaw: 0.33 N and 10 N per blade pair, T0 = 1 N per cable
    outside = {"pitch_path_tension": c}
    inside = {"pitch_path_pretension": c}
    assert fz(taut, **inside) == pytest.approx(fz(taut, **outside), abs=1e-3)
    assert fz(taut, **inside) == pytest.approx(fz(taut) - path, abs=1e-3)
    assert fz(slack, **inside) == pytest.approx(fz(slack), abs=0.01)
    assert fz(slack, **outside) == pytest.approx(fz(slack) - path, abs=1e-6)


def test_the_sags_design_values_are_the_laws():
    from psmforce.identification.load_path import DESIGN_COMPLIANCE, WristCompliance
    from psmforce.identification.prior_selection import DESIGN
    c = WristCompliance.design()
    assert c is DESIGN_COMPLIANCE
    assert (c.pretension_total_n, c.pulley_radius_pitch_m, c.pulley_radius_blade_m,
            c.asymmetry_pitch, c.asymmetry_blade, c.capstan_mu, c.capstan_pitch_gain,
            c.capstan_roll_gain, c.pin_friction) == tuple(DESIGN[n] for n in (
                "pretension_total", "pulley_radius_pitch", "pulley_radius_blade",
                "asymmetry_pitch", "asymmetry_blade", "capstan_mu", "capstan_pitch_gain",
                "capstan_roll_gain", "pin_friction"))
    assert not c.has_friction   # by design the sag is the pulleys' differential alone


def test_a_compliance_from_the_laws_values_and_from_a_file():
    """The sag a law's values give (the selection's second pass) takes each of its terms from
    the law: the design's law gives the design's sag. A compliance a prior file carries is read
    as user input: a missing field, a flag, NaN or a negative radius is refused by name."""
    from dataclasses import asdict

    from psmforce.identification.load_path import DESIGN_COMPLIANCE, LAW_TERMS, WristCompliance
    from psmforce.identification.prior_selection import DESIGN
    assert WristCompliance.from_law(DESIGN) == DESIGN_COMPLIANCE
    law = {**DESIGN, "capstan_mu": 0.2, "pin_friction": 0.05, "pretension_total": 9.0}
    c = WristCompliance.from_law(law, stiffness_n_per_m=1e5)
    assert (c.capstan_mu, c.pin_friction, c.pretension_total_n, c.stiffness_n_per_m) == (
        0.2, 0.05, 9.0, 1e5) and c.has_friction
    assert all(getattr(c, f) == law[n] for f, n in LAW_TERMS.items())
    assert WristCompliance.from_dict(asdict(c)) == c
    with pytest.raises(IdentificationInputError, match="needs"):
        WristCompliance.from_law({"capstan_mu": 0.1})
    d = asdict(c)
    for bad in ({k: v for k, v in d.items() if k != "pin_friction"}, {**d, "pin_friction": True},
                {**d, "extra": 1.0}, "compliance"):
        with pytest.raises(IdentificationInputError, match="p.json: a wrist compliance"):
            WristCompliance.from_dict(bad, "p.json")
    for bad in ({**d, "pulley_radius_pitch_m": -1e-3}, {**d, "capstan_mu": float("nan")}):
        with pytest.raises(IdentificationInputError):
            WristCompliance.from_dict(bad)


def test_a_load_path_prior_predicts_with_the_sag_it_was_fitted_with(monkeypatch):
    """A load-path prior keeps the compliance that sagged its wrist and sags it the same way
    when it predicts; one written before the record sags with the design's; a file whose
    compliance is malformed is refused; the efforts reading takes no compliance."""
    from dataclasses import asdict

    import psmforce.identification.load_path as load_path
    from psmforce.identification.load_path import DESIGN_COMPLIANCE, WristCompliance
    from psmforce.identification.prior_selection import DESIGN
    own = WristCompliance.from_law({**DESIGN, "capstan_mu": 0.3})
    prior = InternalForcePrior(converged=True, info={"inputs": "load_path",
                                                     "wrist_compliance": asdict(own)})
    assert InternalForcePrior.from_json(prior.to_json()).wrist_compliance == own
    assert InternalForcePrior(info={"inputs": "load_path"}).wrist_compliance is DESIGN_COMPLIANCE
    assert InternalForcePrior().wrist_compliance is None
    seen = []
    real = load_path.load_path_inputs

    def spy(frame, psm=None, compliance=None):
        seen.append(compliance)
        return real(frame, psm, compliance)
    monkeypatch.setattr(load_path, "load_path_inputs", spy)
    import pandas as pd

    from psmforce.io.recording import JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_EFFORTS, TARGETS
    cols = [*JOINT_POSITIONS, *JOINT_VELOCITIES, *JOINT_EFFORTS, *TARGETS]
    frame = pd.DataFrame(np.zeros((4, len(cols))), columns=cols)
    frame[list(JOINT_POSITIONS)] = _configurations(4)
    prior.predict(frame)
    assert seen == [own]
    bad = prior.to_dict()
    bad["info"]["wrist_compliance"]["stiffness_n_per_m"] = "stiff"
    with pytest.raises(IdentificationInputError, match="q.json: 'info.wrist_compliance'"):
        InternalForcePrior.from_dict(bad, "q.json")
    with pytest.raises(IdentificationInputError, match="load path only"):
        InternalForcePrior.fit([frame], compliance=own)
