"""Simulator 2.3's effects (psmforce/sim/versions.py; docs/simulator.md section 12c): the roll
drive's dead band, the HEX10's thermal settling, the re-mount with the zeroing before every trial.
Each on a closed-form case, off in the default version (bit for bit), deterministic in its seed."""

import dataclasses
import json

import numpy as np
import pytest

from psmforce.sim import protocols, sensors, shaft, simulate, versions
from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.mounting import Remount
from psmforce.sim.params import OMITTED_WHEN_OFF, Effects, InstrumentParams


def test_roll_dead_band_loses_its_width_at_each_reversal():
    w = 0.04
    up = np.linspace(0.0, 0.5, 501)
    down = np.linspace(0.5, 0.3, 201)[1:]
    q = np.concatenate([up, down])
    s = shaft.distal_roll(q, w)
    assert s[0] == q[0]
    # Moving up, the shaft trails by half the band once the first half band is taken up.
    np.testing.assert_allclose((q - s)[:len(up)][up > w / 2 + 1e-9], w / 2, atol=1e-12)
    np.testing.assert_array_equal(s[:len(up)][up <= w / 2 - 1e-9], 0.0)  # the band taken up
    # After the reversal the shaft stays put until the motor has come back the whole band ...
    still = down > 0.5 - w
    np.testing.assert_allclose(s[len(up):][still], s[len(up) - 1], atol=1e-12)
    # ... then follows, leading the motor by half the band on the way down.
    np.testing.assert_allclose((q - s)[len(up):][down < 0.5 - w - 1e-9], -w / 2, atol=1e-12)
    assert np.all(np.abs(q - s) <= w / 2 + 1e-12)


def test_no_dead_band_is_the_encoder_itself():
    q = np.linspace(-1, 1, 50)
    assert shaft.distal_roll(q, 0.0) is q
    q7 = np.zeros((5, 7))
    assert shaft.distal_joints(q7, InstrumentParams()) is q7
    with pytest.raises(ValueError):
        shaft.distal_roll(q, -0.1)


def _tilted_hold(n_move=100, n_hold=100):
    """Arm pitched 0.5 rad (gravity has a lateral part in the HEX10 frame), roll moved up 0.3 rad
    then held."""
    q = np.zeros((n_move + n_hold, 7))
    q[:, 1] = 0.5
    q[:, 2] = 0.12
    q[:n_move, 3] = np.linspace(0.0, 0.3, n_move)
    q[n_move:, 3] = 0.3
    return q


def test_roll_dead_band_turns_the_hex10_reading_against_the_targets():
    q = _tilted_hold()
    w = 0.05
    params = dataclasses.replace(InstrumentParams(), roll_backlash_rad=w)
    rng = np.random.default_rng(0)
    weight = Contact(kind="weight", mass_kg=0.2)
    frame = run_trajectory(q, 0.01, weight, params, Effects.none(), rng)
    hex_xy = frame[["fx", "fy"]].to_numpy()[-1]
    tgt_xy = frame[["ati_fx", "ati_fy"]].to_numpy()[-1]
    assert np.linalg.norm(tgt_xy) > 0.5
    angle = np.arctan2(tgt_xy[0] * hex_xy[1] - tgt_xy[1] * hex_xy[0], tgt_xy @ hex_xy)
    # The shaft trails the encoder by w/2: the sensor's frame is turned by -w/2 about the
    # shaft, so it reads the force turned by +w/2 against the encoders' frame.
    assert angle == pytest.approx(w / 2, abs=1e-6)
    np.testing.assert_allclose(frame["sim_roll_true"].to_numpy()[-1], 0.3 - w / 2, atol=1e-12)
    # Without the dead band the two agree.
    plain = run_trajectory(q, 0.01, weight, InstrumentParams(), Effects.none(),
                           np.random.default_rng(0))
    np.testing.assert_allclose(plain[["fx", "fy"]].to_numpy(), plain[["ati_fx", "ati_fy"]].to_numpy(),
                               atol=1e-9)
    assert "sim_roll_true" not in plain


def test_thermal_settling_follows_its_exponential():
    params = dataclasses.replace(InstrumentParams(), hex10_thermal_drift_n=0.1,
                                 hex10_thermal_time_s=2.0)
    off = sensors.thermal_offset(1001, 0.01, params, np.random.default_rng(3))
    amplitude = 0.1 * np.random.default_rng(3).standard_normal(3)
    np.testing.assert_array_equal(off[0], 0.0)
    np.testing.assert_allclose(off[200], (1 - np.exp(-1.0)) * amplitude, rtol=1e-12)
    np.testing.assert_allclose(off[1000], (1 - np.exp(-5.0)) * amplitude, rtol=1e-12)
    with pytest.raises(ValueError):
        sensors.thermal_offset(10, 0.01, dataclasses.replace(params, hex10_thermal_time_s=0.0),
                               np.random.default_rng(0))


def _quiet():
    return dataclasses.replace(Effects(), sensor_noise=False, hex10_drift=False,
                               distal_gravity=False, encoder_quantisation=False,
                               coloured_effort_noise=False, remount_offsets=False)


def test_zeroing_after_a_remount_leaves_only_the_zeros_residual_at_rest():
    q = np.zeros((50, 7))
    q[:, 2] = 0.12
    base = InstrumentParams()
    r = Remount(0.8, (0.03, -0.02, 0.05), (0.004, -0.003, 0.015))
    before = run_trajectory(q, 0.01, Contact(), base, _quiet(), np.random.default_rng(0))
    after = run_trajectory(q, 0.01, Contact(), r.zeroed(base), _quiet(), np.random.default_rng(0))
    change = after[["fx", "fy", "fz"]].to_numpy() - before[["fx", "fy", "fz"]].to_numpy()
    np.testing.assert_allclose(change, np.tile(r.hex10_offset_change_n, (50, 1)), atol=1e-9)
    # Without the zeroing, the pretension change and the tilt show at rest.
    raw = run_trajectory(q, 0.01, Contact(), r.apply(base), _quiet(), np.random.default_rng(0))
    assert abs(raw["fz"].iat[-1] - before["fz"].iat[-1]) > 0.7


def test_trial_remounts_are_deterministic_and_distinct():
    assert Remount.draw_for_trial(5, 3) == Remount.draw_for_trial(5, 3)
    assert Remount.draw_for_trial(5, 3) != Remount.draw_for_trial(5, 4)
    assert Remount.draw_for_trial(5, 3) != Remount.draw_for_trial(6, 3)
    assert Remount.draw_for_trial(5, 3).within_ranges()
    assert Remount.draw(7) == Remount._drawn(np.random.default_rng([7, 44]), 1.0)


def test_versions_define_23_on_top_of_22_and_keep_the_default():
    v21, v23 = versions.version(), versions.version("2.3")
    assert v21.remount_spread == 0.0 and v21.instrument() == InstrumentParams()
    assert versions.version("2.2").remount_spread == 0.0
    for k, v in versions.CHANGES["2.2"].items():
        assert v23.changes[k] == v
    assert v23.instrument().roll_backlash_rad > 0 and v23.remount_spread > 0
    assert versions.Version.from_dict(json.loads(json.dumps(v23.to_dict()))) == v23
    d = InstrumentParams().to_dict()
    assert not set(OMITTED_WHEN_OFF) & set(d)
    with pytest.raises(ValueError):
        versions.Version("x", {"no_such_field": 1.0})
    with pytest.raises(ValueError):
        versions.Version("x", {}, remount_spread=-1.0)


def _teleop(tmp_path, name, **kw):
    out = tmp_path / name
    simulate("teleop", scale=0.01, seed=4, out=out, **kw)
    meta = json.loads((out / "metadata.json").read_text())
    files = sorted(p for p in out.rglob("*.csv"))
    return meta, [f.read_bytes() for f in files]


def test_default_version_is_bit_identical_and_23_is_seeded(tmp_path):
    meta0, files0 = _teleop(tmp_path, "default")
    assert versions.version("2.1") == versions.version(None)   # the same path as the default
    assert "simulator" not in meta0 and meta0["simulator_version"] == "2.1"
    assert all("remount" not in t for t in meta0["trials"])
    meta3, files3 = _teleop(tmp_path, "v23", version="2.3")
    meta3b, files3b = _teleop(tmp_path, "v23b", version="2.3")
    assert files3 == files3b and files3 != files0
    assert meta3["simulator_version"] == "2.3" and meta3["simulator"]["remount_spread"] > 0
    assert len({json.dumps(t["remount"]) for t in meta3["trials"]}) == len(meta3["trials"])
    with pytest.raises(ValueError, match="version"):
        simulate("teleop", scale=0.01, seed=4, out=tmp_path / "bad", version="9.9")


def test_reproduce_keys_a_version_into_its_benches(tmp_path):
    from psmforce.experiments.reproduce import prepare_benches
    prepare_benches(tmp_path / "a", 0.05, (), teleop=False)
    prepare_benches(tmp_path / "b", 0.05, (), teleop=False, sim_version="2.3")
    assert json.loads((tmp_path / "a" / "work" / "scale.json").read_text()) == {"scale": 0.05}
    b = json.loads((tmp_path / "b" / "work" / "scale.json").read_text())
    assert b["sim"] == versions.version("2.3").to_dict()
    with pytest.raises(ValueError, match="another run"):
        prepare_benches(tmp_path / "b", 0.05, (), teleop=False)


def test_readout_lag_trails_a_ramp_by_its_time_constant():
    dt, tau, slope = 0.01, 0.05, 2.0
    w = np.zeros((400, 6))
    w[:, 0] = slope * np.arange(400) * dt
    w[:, 2] = -6.0
    y = sensors.readout_lag(w, dt, tau)
    a = np.exp(-dt / tau)
    np.testing.assert_allclose(w[-1, 0] - y[-1, 0], slope * dt * a / (1 - a), rtol=1e-9)
    np.testing.assert_allclose(y[:, 2], -6.0, rtol=1e-12)   # at rest from the start: no transient
    frame_lag = dataclasses.replace(InstrumentParams(), hex10_readout_lag_s=tau)
    fast = sensors.hex10_reading(w, dt, InstrumentParams(), Effects.none(), np.random.default_rng(0))[0]
    slow = sensors.hex10_reading(w, dt, frame_lag, Effects.none(), np.random.default_rng(0))[0]
    np.testing.assert_allclose(fast, w)
    np.testing.assert_allclose(slow, y)


def test_23_keeps_22s_cable_law_which_the_mrdlab_figures_check():
    t = np.arange(300) * 0.01
    q = np.zeros((300, 7))
    q[:, 3] = 1.0 * np.sin(0.7 * t)
    q[:, 4] = 0.6 * np.sin(1.3 * t)
    q[:, 5] = 0.5 * np.sin(2.1 * t)
    tau = np.stack([0.02 * np.sin(1.1 * t), 0.03 * np.cos(0.9 * t), -0.02 * np.sin(1.7 * t)], axis=1)
    from psmforce.sim import cables
    a = cables.transmission(q, tau, versions.instrument("2.2"), Effects())
    b = cables.transmission(q, tau, versions.instrument("2.3"), Effects())
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
