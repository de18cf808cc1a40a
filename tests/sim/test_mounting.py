"""Re-mounting the instrument (psmforce/sim/mounting.py) and the HEX10 mount rotation it sets
(psmforce/sim/sensors.py): deterministic, inside its stated ranges, a zero re-mount leaves the
bench bit-identical, and the rotation turns the reading as stated."""

import dataclasses

import numpy as np
import pytest

from psmforce.sim import sensors
from psmforce.sim.bench import Contact, run_trajectory
from psmforce.sim.mounting import RANGES, Remount
from psmforce.sim.params import OMITTED_WHEN_OFF, Effects, InstrumentParams


def _q(n=300):
    t = np.arange(n) * 0.01
    q = np.zeros((n, 7))
    q[:, 2] = 0.15
    q[:, 3] = 1.5 * np.sin(0.9 * t)
    q[:, 4] = 0.6 * np.sin(1.7 * t)
    q[:, 5] = 0.4 * np.sin(2.3 * t + 0.5)
    q[:, 6] = 0.3
    return q


def _run(params, effects=None, seed=3):
    return run_trajectory(_q(), 0.01, Contact(), params, effects or Effects(),
                          np.random.default_rng(seed))


def test_draw_is_deterministic_and_seeds_differ():
    assert Remount.draw(7) == Remount.draw(7)
    assert Remount.draw(7) != Remount.draw(8)


def test_draws_stay_inside_the_stated_ranges_and_use_them():
    draws = [Remount.draw(s) for s in range(300)]
    assert all(d.within_ranges() for d in draws)
    pre = np.array([d.pretension_change_n for d in draws])
    off = np.array([d.hex10_offset_change_n for d in draws])
    shaft = np.array([d.rotation_change_rad[2] for d in draws])
    tilt = np.array([d.tilt_rad for d in draws])
    # the draws fill their ranges (not a tiny corner of them)
    assert pre.max() > 0.9 * RANGES["pretension_change_n"]["bound"] and pre.min() < -0.9
    assert np.abs(off).max() > 0.09 and np.abs(shaft).max() > 0.018 and tilt.max() > 0.0045
    assert all(v["source"] for v in RANGES.values())
    assert not Remount(pretension_change_n=1.5).within_ranges()
    assert not Remount(rotation_change_rad=(0.004, 0.004, 0.0)).within_ranges()   # tilt 5.7 mrad
    assert Remount.draw(1, spread=0.0) == Remount()


def test_a_zero_remount_leaves_the_bench_bit_identical():
    nominal = InstrumentParams()
    assert Remount().apply(nominal) == nominal
    a, b = _run(nominal), _run(Remount().apply(nominal))
    assert a.equals(b)
    assert set(OMITTED_WHEN_OFF) & set(Remount().apply(nominal).to_dict()) == set()


def test_apply_changes_only_what_a_remount_changes():
    r = Remount(0.5, (0.01, -0.02, 0.03), (0.001, -0.002, 0.01))
    p = r.apply(InstrumentParams())
    assert p.pretension_total_n == pytest.approx(6.5)
    assert p.hex10_residual_bias_n == pytest.approx((0.06, -0.10, 0.13))
    assert p.hex10_mount_rotation_rad == pytest.approx((0.001, -0.002, 0.01))
    changed = {f.name for f in dataclasses.fields(p)
               if getattr(p, f.name) != getattr(InstrumentParams(), f.name)}
    assert changed == {"pretension_total_n", "hex10_residual_bias_n", "hex10_mount_rotation_rad"}
    d = p.to_dict()
    assert InstrumentParams.from_dict(d) == p          # the metadata round-trips the rotation
    with pytest.raises(ValueError, match="pretension"):
        Remount(pretension_change_n=-7.0).apply(InstrumentParams())
    with pytest.raises(ValueError, match="finite"):
        Remount(pretension_change_n=float("nan"))


def test_the_mount_rotation_turns_the_whole_reading():
    # No sensor effects: the reading is R^T of the nominal bench's reading, force and moment.
    effects = dataclasses.replace(Effects.none(), pretension=True, distal_gravity=True)
    angles = (0.01, -0.02, 0.3)
    a = _run(InstrumentParams(), effects)
    b = _run(dataclasses.replace(InstrumentParams(), hex10_mount_rotation_rad=angles), effects)
    r = sensors.mount_rotation(angles)
    wa = a[["fx", "fy", "fz", "tx", "ty", "tz"]].to_numpy()
    wb = b[["fx", "fy", "fz", "tx", "ty", "tz"]].to_numpy()
    np.testing.assert_allclose(wb[:, :3], wa[:, :3] @ r, atol=1e-12)
    np.testing.assert_allclose(wb[:, 3:], wa[:, 3:] @ r, atol=1e-15)
    # a tilt about y leaks -sin(b) of the axial compression into fx
    assert np.mean(wb[:, 0] - (wa[:, :3] @ r)[:, 0]) == pytest.approx(0.0, abs=1e-12)
    r_y = sensors.mount_rotation((0.0, 0.003, 0.0))
    assert r_y[2, 0] == pytest.approx(-np.sin(0.003))
