"""The cable-transmission figures (psmforce/experiments/cable_law_figures.py) on closed-form cases,
the simulated bench's cable law against its own closed forms, and the real EndoWrist against the
bench's cable law (skipped where the MRD Lab data is absent)."""

import dataclasses
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from psmforce.sim import Effects, InstrumentParams
from psmforce.sim import cables, versions
from psmforce.experiments import cable_law_figures as tf

ROOT = Path(__file__).resolve().parents[2]
MRDLAB = ROOT.parent / "shared" / "data" / "mrdlab"
CABLE_LAW_JSON = ROOT / "results" / "benchmarks" / "sim_calibration_cable_law.json"
KNOWN_MISSES = {("Tool_5_Maryland_L_2", "compliance_fraction")}
"""Simulator 2.2's ratios outside the band (0.668 against 0.67; docs/simulator.md section 12b)."""
AMPLITUDE = np.deg2rad(30.0)
LOADS = (0.01, 0.04, 0.07, 0.1)
FREQS = (0.1, 0.5)


def _run(freq, load, n=0.9, mu=0.0, backlash=0.0, compliance=0.0, loader_swing=0.0,
         friction_gain=1.0, level=0, stop=0, wind_up_offset=0.0, coulomb=0.0):
    """A closed-form transmission: input -A cos(2 pi f t); closing sign s; output torque
    L + loader_swing s / 2; input torque n (L e^(mu s)) * friction_gain on the excess; output
    angle n theta_in - backlash s / 2 - compliance L."""
    t = np.arange(0.0, 20.0, 0.01)
    theta = -AMPLITUDE * np.cos(2 * np.pi * freq * t)
    s = np.sign(np.sin(2 * np.pi * freq * t))
    tau_out = load + 0.5 * loader_swing * s
    friction = (load * (np.exp(mu * s) - 1.0) + coulomb * s) * friction_gain
    tau_in = n * (tau_out + friction)
    out = n * theta - 0.5 * backlash * s - compliance * load - wind_up_offset
    return tf.TransmissionRun(name=f"f{freq} L{load}", frequency_hz=freq, load_level=level,
                              time_s=t, input_angle_rad=theta, input_torque_nm=tau_in,
                              output_angle_rad=out, output_torque_nm=tau_out, stop_index=stop)


def _grid(**kw):
    return [_run(f, load, level=i, **kw) for f in FREQS for i, load in enumerate(LOADS)]


def test_pure_capstan_gives_sinh_mu_and_no_loop():
    fig = tf.session_figures(_grid(mu=0.3))
    assert fig["kinematic_ratio"] == pytest.approx(0.9, rel=1e-9)
    assert fig["friction_load_slope"] == pytest.approx(np.sinh(0.3), rel=1e-3)
    assert fig["zero_load_friction_fraction"] == pytest.approx(0.0, abs=1e-3)
    assert fig["friction_frequency_ratio"] == pytest.approx(1.0, rel=1e-6)
    assert fig["loop_width_fraction"] == pytest.approx(0.0, abs=1e-9)
    assert fig["compliance_fraction"] == pytest.approx(0.0, abs=1e-9)


def test_loader_swing_is_not_counted_as_transmission_friction():
    # The load itself differs between the passes (the loader's own friction): F excludes it.
    fig = tf.session_figures(_grid(mu=0.2, loader_swing=0.005))
    assert fig["friction_load_slope"] == pytest.approx(np.sinh(0.2), rel=2e-3)


def test_pure_backlash_gives_its_loop_width_and_no_compliance():
    b = 0.05
    fig = tf.session_figures(_grid(backlash=b))
    stroke_out = 0.9 * 2 * AMPLITUDE
    assert fig["stroke_out_rad"] == pytest.approx(stroke_out, rel=2e-3)
    assert fig["loop_width_fraction"] == pytest.approx(b / stroke_out, rel=3e-3)
    assert fig["compliance_rad_per_nm"] == pytest.approx(0.0, abs=1e-9)


def test_pure_compliance_gives_its_lag_per_torque():
    c = 1.3   # rad/Nm at the output
    fig = tf.session_figures(_grid(compliance=c))
    assert fig["compliance_rad_per_nm"] == pytest.approx(c, rel=1e-9)
    assert fig["compliance_fraction"] == pytest.approx(c * max(LOADS) / fig["stroke_out_rad"],
                                                       rel=1e-9)
    assert fig["loop_width_fraction"] == pytest.approx(0.0, abs=1e-9)


def test_coulomb_friction_gives_the_zero_load_friction():
    fig = tf.session_figures(_grid(mu=0.2, coulomb=0.03))
    assert fig["zero_load_friction_nm"] == pytest.approx(0.03, rel=1e-3)
    assert fig["zero_load_friction_fraction"] == pytest.approx(0.03 / max(LOADS), rel=1e-3)
    assert fig["friction_load_slope"] == pytest.approx(np.sinh(0.2), rel=2e-3)
    assert "zero_load_friction_fraction" in tf.CHECKED


def test_stopping_positions_get_their_own_wind_up_zero_and_frequency_pairs():
    c = 1.3
    runs = [_run(f, load, compliance=c, level=i, stop=z, wind_up_offset=0.2 * z,
                 friction_gain=1.0 if f == 0.1 else 1.0 + 0.1 * (z + 1), mu=0.3)
            for z in (0, 1) for f in FREQS for i, load in enumerate(LOADS)]
    fig = tf.session_figures(runs)
    assert fig["stopping_positions"] == 2
    assert fig["compliance_rad_per_nm"] == pytest.approx(c, rel=1e-9)
    # per (stop, load) pair: 1.1 at stop 0, 1.2 at stop 1 -> mean 1.15 (not the last stop's)
    assert fig["friction_frequency_ratio"] == pytest.approx(1.15, rel=1e-3)


def test_the_header_frequency_is_used_and_checked_against_the_spectrum():
    t = np.arange(2000) * 0.01
    motor = 0.5 * np.sin(2 * np.pi * 0.3 * t)
    rec = SimpleNamespace(name="X/012", rate_hz=100.0, frequency_index=1, load_index=2,
                          stop_index=0, header={"Freq_Hz": 0.3, "Yaw_rad": 0.52}, time_s=t,
                          motor_angle_rad=motor, spindle_angle_rad=-motor, jaw_angle_rad=0.9 * motor,
                          spindle_torque_nm=np.zeros_like(t), jaw_torque_nm=np.zeros_like(t))
    run = tf.from_recording(rec)
    assert run.frequency_hz == 0.3 and run.stop_index == 0 and run.stop_yaw_rad == 0.52
    with pytest.raises(tf.TransmissionFigureError, match="its name says 0.2"):
        tf.from_recording(SimpleNamespace(**{**vars(rec), "header": {}}))


def test_session_pose_from_the_readme(tmp_path):
    (tmp_path / "ReadME.txt").write_text("This is a roll of 0 degrees (i.e. 90 on the ring)\n"
                                         "This is a pitch of +60 degrees (i.e. 120 on top)\n")
    assert tf.session_pose(tmp_path) == {"roll_rad": 0.0, "pitch_rad": pytest.approx(np.pi / 3)}
    (tmp_path / "ReadME.txt").unlink()
    assert tf.session_pose(tmp_path) == {"roll_rad": 0.0, "pitch_rad": 0.0}


def _fake(ratio_by_folder, real_by_folder):
    return {n: {"comparison": {"friction_load_slope": {
        "real": real_by_folder[n], "sim": ratio_by_folder[n] * real_by_folder[n],
        "ratio": ratio_by_folder[n], "measurable": True,
        "ok": tf.RATIO_RANGE[0] <= ratio_by_folder[n] <= tf.RATIO_RANGE[1]}}}
        for n in ratio_by_folder}


def test_the_rule_over_folders_band_or_real_spread():
    narrow = tf.across_folders(_fake({"a": 1.2, "b": 0.6}, {"a": 1.0, "b": 1.5}),
                               figures=("friction_load_slope",))["friction_load_slope"]
    assert narrow["rule"] == "band" and narrow["met"] is False
    # real 1.0 and 3.0 spread x3 > 1.5 / 0.67: sim 0.9 (b: ratio 0.3) is inside neither;
    # sim 2.0 at b (ratio 0.67) is in the band; sim 1.6 at a (ratio 1.6) within the spread.
    wide = tf.across_folders(_fake({"a": 1.6, "b": 0.67}, {"a": 1.0, "b": 3.0}),
                             figures=("friction_load_slope",))["friction_load_slope"]
    assert wide["rule"] == "real spread" and wide["met"] is True
    assert wide["folders"]["a"]["in_band"] is False and wide["folders"]["a"]["ok"] is True


def test_rate_dependent_friction_gives_its_frequency_ratio():
    runs = [_run(f, load, mu=0.3, friction_gain=1.0 if f == 0.1 else 1.2, level=i)
            for f in FREQS for i, load in enumerate(LOADS)]
    assert tf.session_figures(runs)["friction_frequency_ratio"] == pytest.approx(1.2, rel=1e-3)


def test_clear_errors():
    with pytest.raises(tf.TransmissionFigureError, match="loads span"):
        tf.session_figures([_run(0.1, 0.05), _run(0.5, 0.05)])
    still = dataclasses.replace(_run(0.1, 0.05), input_angle_rad=np.zeros(2000))
    with pytest.raises(tf.TransmissionFigureError, match="does not move"):
        tf.mid_stroke(still)
    with pytest.raises(tf.TransmissionFigureError, match="one length"):
        tf.mid_stroke(dataclasses.replace(_run(0.1, 0.05), output_torque_nm=np.zeros(3)))


def _sim_grid(params, effects):
    return [tf.simulate_run(f, load, params, effects, load_level=i, duration_s=10.0)
            for f in FREQS for i, load in enumerate(LOADS)]


def test_sim_capstan_alone_gives_sinh_of_the_total_wrap():
    # No pretension, cables slack on the unloaded side: D_motor = D_distal exp((mu_d + mu_p) z).
    p = InstrumentParams()
    effects = dataclasses.replace(Effects.none(), capstan=True, hysteresis=True, slack=True)
    fig = tf.session_figures(_sim_grid(p, effects))
    assert fig["kinematic_ratio"] == pytest.approx(tf.BLADE_PER_DISC, rel=1e-9)
    assert fig["friction_load_slope"] == pytest.approx(
        np.sinh(p.capstan_mu_wrap_distal + p.capstan_mu_wrap_proximal), rel=1e-3)
    assert fig["friction_frequency_ratio"] == pytest.approx(1.0, abs=0.01)
    assert fig["compliance_rad_per_nm"] == pytest.approx(0.0, abs=1e-12)


def test_sim_coulomb_friction_gives_its_zero_load_friction_and_loop():
    # No pretension, no capstan wrap: the motor pays f on the moving cable (F0 = r_blade f at
    # the blade), the stretching run carries share x f (loop 2 share f / (k r_blade)).
    f, share = 20.0, 0.3
    p = dataclasses.replace(InstrumentParams(), cable_coulomb_n=f,
                            cable_coulomb_stretch_share=share, capstan_mu_wrap_distal=0.0,
                            capstan_mu_wrap_proximal=0.0)
    effects = dataclasses.replace(Effects.none(), capstan=True, hysteresis=True, slack=True,
                                  elasticity=True)
    fig = tf.session_figures(_sim_grid(p, effects))
    assert fig["zero_load_friction_nm"] == pytest.approx(p.pulley_radius_blade_m * f, rel=1e-3)
    assert fig["friction_load_slope"] == pytest.approx(0.0, abs=1e-3)
    loop = 2 * share * f / (p.cable_stiffness_n_per_m * p.pulley_radius_blade_m)
    assert fig["loop_width_fraction"] * fig["stroke_out_rad"] == pytest.approx(loop, rel=2e-2)
    # The default version has no such term: no friction at zero load.
    off = tf.session_figures(_sim_grid(InstrumentParams(), Effects()))
    assert off["zero_load_friction_nm"] == pytest.approx(0.0, abs=1e-6)


def test_sim_elasticity_alone_gives_the_cable_compliance():
    # One loaded blade pair stretches by D / k; the pitch pair holding the blade cable's
    # pick-up over the pitch pulleys carries kappa L / r_p and adds its stretch through G^-1.
    p = InstrumentParams()
    effects = dataclasses.replace(Effects.none(), elasticity=True, slack=True)
    fig = tf.session_figures(_sim_grid(p, effects))
    kappa = cables.BLADE_PITCH_PICKUP
    expected = (1 / p.pulley_radius_blade_m ** 2 + kappa ** 2 / p.pulley_radius_pitch_m ** 2) \
        / p.cable_stiffness_n_per_m
    assert fig["compliance_rad_per_nm"] == pytest.approx(expected, rel=1e-6)
    assert fig["loop_width_fraction"] == pytest.approx(0.0, abs=1e-9)
    assert fig["friction_load_slope"] == pytest.approx(0.0, abs=1e-9)


def _committed():
    if not CABLE_LAW_JSON.is_file():
        pytest.skip(f"{CABLE_LAW_JSON} not written")
    return json.loads(CABLE_LAW_JSON.read_text())["cable_law"]


def _replayed(c, version):
    """Each committed folder's real figures against ``version``'s cable law, replayed now."""
    out = {}
    for name, s in c["sessions"].items():
        real = s["real"]
        sim = tf.session_figures(tf.simulated_session(real, versions.instrument(version),
                                                      pose=s["pose"]))
        out[name] = {"comparison": tf.compare(real, sim)}
    return out


def test_v22_ratios_are_inside_the_stated_bands_on_every_folder():
    c = _committed()
    assert len(c["sessions"]) == 7 and c["calibrated_version"] == "2.2"
    replay = _replayed(c, "2.2")
    for name, r in replay.items():      # the committed JSON is what the code gives
        for k, row in r["comparison"].items():
            committed = c["sessions"][name]["table"][k]["ratio_2.2"]
            if committed is None:
                assert row["ratio"] is None, (name, k)
            else:
                assert row["ratio"] == pytest.approx(committed, rel=1e-9), (name, k)
    across = tf.across_folders(replay)
    for k, a in across.items():
        for name, f in a["folders"].items():
            if f["ok"] is None:
                continue
            if (name, k) in KNOWN_MISSES:      # stated in docs/simulator.md section 12b
                assert 0.6 < f["ratio"] < tf.RATIO_RANGE[0] and not f["ok"], (name, k, f)
            else:
                assert f["ok"], (name, k, f)
    assert c["cable_law_ok"] is False and c["met"]["2.2"] is False


def test_v21_misses_the_zero_load_friction_everywhere():
    c = _committed()
    across = tf.across_folders(_replayed(c, versions.DEFAULT_VERSION))
    zero = across["zero_load_friction_fraction"]
    assert zero["met"] is False
    assert all(abs(f["ratio"]) < 0.05 for f in zero["folders"].values())


@pytest.mark.slow
def test_real_endowrist_against_the_bench_cable_law():
    session = MRDLAB / "Tool_4_Maryland_L_4"
    if not session.is_dir():
        pytest.skip(f"MRD Lab transmission data not found at {MRDLAB}")
    result = tf.real_vs_sim(session)
    real = result["real"]
    # The real transmission as read: jaw follows the spindle at ~0.9, friction grows with load.
    assert 0.8 < real["kinematic_ratio"] < 1.0 and real["friction_load_slope"] > 0
    assert len(real["runs"]) == 49          # 07 fails the data checks (a runaway): left out
    assert not any(r["name"].endswith("/07") for r in real["runs"])
    calibrated = tf.real_vs_sim(session, versions.instrument("2.2"), real=real)
    for name in tf.CHECKED:
        row = calibrated["comparison"][name]
        assert tf.RATIO_RANGE[0] <= row["ratio"] <= tf.RATIO_RANGE[1], (name, row)
    # The default version (2.1) has no friction at zero load.
    assert result["comparison"]["zero_load_friction_fraction"]["ok"] is False
