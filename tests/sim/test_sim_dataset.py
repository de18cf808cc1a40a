"""The simulator's dataset: layout, recording contract, metadata, determinism, bad input."""

import json
import os

import numpy as np
import pandas as pd
import pytest

from psmforce.io.recording import COLUMNS, read_recording
from psmforce.sim import Effects, InstrumentParams, SimulationConfigError, simulate

SCALE = 0.01


@pytest.fixture(scope="module")
def automated(tmp_path_factory):
    out = tmp_path_factory.mktemp("auto") / "ds"
    summary = simulate("automated", scale=SCALE, seed=3, out=out)
    return out, summary


def _files(out):
    return sorted(p.relative_to(out).as_posix() for p in out.rglob("*.csv"))


def test_automated_layout_metadata_and_recording_contract(automated):
    out, summary = automated
    meta = json.loads((out / "metadata.json").read_text())
    assert meta["protocol"] == "automated" and meta["seed"] == 3 and meta["scale"] == SCALE
    assert meta["simulator_version"] and meta["software_version"]
    assert meta["instrument"]["pretension_total_n"] == InstrumentParams().pretension_total_n
    assert all(meta["effects"].values())
    assert np.allclose(np.array(meta["R_base_ati"]) @ np.array(meta["R_base_ati"]).T, np.eye(3))
    paths = [t["path"] for t in meta["trials"]]
    assert sorted(paths) == _files(out) and summary["trials"] == len(paths)
    folders = {p.rsplit("/", 1)[0] for p in paths}
    assert folders == {f"{s}/{c}" for s in ("train", "test") for c in ("Free", "Traction", "Palpation")}
    assert sum(p.startswith("test/Free/") for p in paths) >= 3   # a spread for every condition
    rows = 0
    for trial in meta["trials"]:
        assert {"split", "condition", "phi_deg", "theta_deg"} <= set(trial)
        if trial["condition"] == "Traction":
            assert trial["force_level"] in (0, 1, 2)
        frame = read_recording(out / trial["path"], require_targets=True)
        assert list(frame.columns[:len(COLUMNS)]) == list(COLUMNS)
        assert np.allclose(np.diff(frame.time), 0.01)
        rows += len(frame)
    assert rows == summary["rows"]


def test_loaded_trials_compress_the_shaft_far_beyond_the_tip_force(automated):
    out, _ = automated
    frame = pd.concat([pd.read_csv(p) for p in (out / "train" / "Traction").glob("*.csv")])
    tip = np.sqrt((frame[["ati_fx", "ati_fy", "ati_fz"]] ** 2).sum(axis=1))
    assert tip.max() > 1.0
    assert frame.fz.min() < -5 * tip.max()


def test_teleop_layout(tmp_path):
    summary = simulate("teleop", scale=0.02, seed=1, out=tmp_path / "t")
    files = _files(tmp_path / "t")
    assert files == sorted(f"config_{c}/{cond}/demo_{k}.csv" for c in range(3)
                           for cond in ("Rigid", "Soft", "Free") for k in range(3))
    assert summary["trials"] == 27
    rigid = read_recording(tmp_path / "t" / "config_0" / "Rigid" / "demo_0.csv", require_targets=True)
    free = read_recording(tmp_path / "t" / "config_0" / "Free" / "demo_0.csv", require_targets=True)
    assert np.abs(rigid[["ati_fx", "ati_fy", "ati_fz"]]).to_numpy().max() > 0.5
    assert np.abs(free[["ati_fx", "ati_fy", "ati_fz"]]).to_numpy().max() < 0.1


def test_teleop_bias_window_is_contact_free(tmp_path):
    """The evaluation subtracts the mean prediction over its bias window as the free-space zero:
    the protocol must guarantee no contact there (ground truth at the ATI's noise level)."""
    from psmforce.estimators.evaluation.evaluate import EVAL_START
    from psmforce.estimators.evaluation.metrics import BIAS_SECONDS
    simulate("teleop", scale=0.02, seed=1, out=tmp_path / "t")
    window = slice(EVAL_START, EVAL_START + int(round(BIAS_SECONDS * 100)))
    for path in sorted((tmp_path / "t").rglob("*.csv")):
        truth = read_recording(path)[["ati_fx", "ati_fy", "ati_fz"]].to_numpy()
        assert np.abs(truth[window]).max() < 0.03, path


@pytest.mark.slow
def test_same_seed_is_bit_exact_and_another_seed_differs(tmp_path):
    kw = dict(protocol="teleop", scale=0.02)
    simulate(seed=5, out=tmp_path / "a", **kw)
    simulate(seed=5, out=tmp_path / "b", **kw)
    simulate(seed=6, out=tmp_path / "c", **kw)
    name = "config_1/Soft/demo_2.csv"
    a, b, c = ((tmp_path / d / name).read_bytes() for d in "abc")
    assert a == b and a != c
    assert (tmp_path / "a" / "metadata.json").read_bytes() == (tmp_path / "b" / "metadata.json").read_bytes()


@pytest.mark.parametrize("kwargs, message", [
    (dict(protocol="manual"), "protocol"),
    (dict(scale=0.0), "scale"),
    (dict(scale=-1.0), "scale"),
    (dict(scale=float("nan")), "scale"),
    (dict(seed=-2), "seed"),
    (dict(instrument="nominal"), "instrument"),
    (dict(effects={"slack": False}), "effects"),
])
def test_bad_arguments_fail_before_writing(tmp_path, kwargs, message):
    out = tmp_path / "never"
    with pytest.raises(SimulationConfigError, match=message):
        simulate(out=out, **{"scale": SCALE, **kwargs})
    assert not out.exists()


def test_unwritable_or_occupied_output_fails_before_writing(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    with pytest.raises(SimulationConfigError, match="out"):
        simulate(scale=SCALE, out=blocker / "sub")
    with pytest.raises(SimulationConfigError, match="not a folder"):
        simulate(scale=SCALE, out=blocker)
    occupied = tmp_path / "occupied"
    occupied.mkdir()
    (occupied / "keep.txt").write_text("x")
    with pytest.raises(SimulationConfigError, match="not empty"):
        simulate(scale=SCALE, out=occupied)
    assert sorted(p.name for p in occupied.iterdir()) == ["keep.txt"]
    if os.geteuid() != 0:  # root ignores permission bits
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        try:
            with pytest.raises(SimulationConfigError, match="writable"):
                simulate(scale=SCALE, out=locked / "ds")
        finally:
            locked.chmod(0o700)
        assert not (locked / "ds").exists()


def test_instrument_and_effects_are_recorded_and_used(tmp_path):
    tool = InstrumentParams().sample(7)
    simulate("teleop", scale=0.02, seed=0, out=tmp_path / "x", instrument=tool, effects=Effects.reduced(noise=False))
    meta = json.loads((tmp_path / "x" / "metadata.json").read_text())
    assert meta["instrument"]["pretension_total_n"] == tool.pretension_total_n
    assert meta["effects"] == Effects.reduced(noise=False).to_dict()
    free = read_recording(tmp_path / "x" / "config_2" / "Free" / "demo_0.csv")
    # reduced class, free space, tared bias: fz = -pretension + distal weight component + bias
    assert free.fz.std() < 0.05
    assert free.fz.mean() == pytest.approx(-tool.pretension_total_n, abs=0.3)


@pytest.mark.slow
@pytest.mark.e2e
def test_csv_benches_and_training_need_no_bag_stack():
    """Only fmt="mcap" writes bags: the simulator and the training pipeline import without
    rosbags, so a bench simulates (and a model trains) where the bag stack is absent."""
    import subprocess
    import sys
    code = ("import sys; sys.modules['rosbags'] = None\n"
            "import psmforce.sim, psmforce.experiments.reproduce, psmforce.estimators.training.train\n"
            "assert not any(m.startswith('rosbags') for m in sys.modules if sys.modules[m])")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
