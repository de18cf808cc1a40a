"""Arm identification on recordings in our layout (`psmforce fit-dynamics --data`) and the
external wrench from joint torques (`psmforce wrench`), checked against the simulator's truth."""
import json

import numpy as np
import pandas as pd
import pytest

from psmforce.identification import recordings
from psmforce.identification import DynamicsFitOptions
from psmforce.identification.signals import zero_phase_lowpass
from psmforce.io.recording import list_recordings, read_recording, write_recording
from psmforce.cli.main import main

# Documented in docs/identification.md ("Wrench from joint torques"): pooled RMS error of the
# force on the contact recordings of a tiny simulated bench, dynamics fitted on its free space.
LATERAL_TOLERANCE_N = 0.35
AXIAL_TOLERANCE_N = 0.2
RELATIVE_TOLERANCE = 0.3


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    """Free-space-calibrated conditions: the simulator's reduced class (arm rigid body + smooth
    friction + white noise in the efforts; what the identified model can represent), 1 % of the
    automated protocol (4 free-space training recordings, ~2000 conditioned samples)."""
    from psmforce.sim import Effects, simulate

    out = tmp_path_factory.mktemp("own") / "bench"
    simulate(protocol="automated", scale=0.01, seed=0, out=str(out), effects=Effects.reduced())
    gravity = json.loads((out / "metadata.json").read_text())["gravity_base"]
    return out, gravity


@pytest.fixture(scope="module")
def cli_fit(bench, tmp_path_factory):
    """``psmforce fit-dynamics --data --gravity`` on the bench's free-space training recordings,
    gravity known (the bench's mounting) and the default options (their sharp Coulomb transition
    suits the bench's free-space recordings, which dwell a lot): (model, report JSON, what it
    printed). One fit, shared: the CLI test checks it, the wrench tests use its model."""
    import contextlib
    import io
    data, gravity = bench
    folder = tmp_path_factory.mktemp("sharp")
    model, report = folder / "arm.json", folder / "report.json"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        # no --format: our layout is the default
        code = main(["fit-dynamics", "--data", str(data), "--gravity", *map(str, gravity),
                     "--model-out", str(model), "--json", str(report)])
    return code, model, report, printed.getvalue()


@pytest.fixture(scope="module")
def sharp_model(cli_fit):
    """The dynamics :func:`cli_fit` fitted (it used to be fitted a second time from Python,
    ``fit_dynamics_cli(data=, gravity=, options=DynamicsFitOptions())``: the same call the CLI
    makes, options None meaning the defaults, so the same fit)."""
    code, model, report, _ = cli_fit
    assert code == 0 and json.loads(report.read_text())["converged"]
    return model


def _one_line_error(capsys, command):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"psmforce {command}: error: ")
    return err[0]


@pytest.mark.slow
def test_fit_dynamics_on_a_simulated_folder_reports(bench, cli_fit):
    data, gravity = bench
    code, model, report, printed = cli_fit
    assert code == 0
    assert "test relative torque error %: yaw" in printed
    rep = json.loads(report.read_text())
    assert rep["converged"] and rep["physically_consistent"] and rep["model"] == str(model)
    assert model.is_file()
    listed = {str(r.path): r for r in list_recordings(data)}
    assert rep["train_recordings"] and rep["test_recordings"]
    assert all(listed[p].condition == "Free" and listed[p].split == "train"
               for p in rep["train_recordings"])
    assert all(listed[p].condition == "Free" and listed[p].split == "test"
               for p in rep["test_recordings"])
    assert rep["sample_rates_hz"] == [100.0] and np.allclose(rep["gravity_mps2"], gravity)
    assert len(rep["test_relative_error_percent"]) == 7
    # the insertion carries the arm's weight: well identified on a held-out trajectory
    assert rep["test_relative_error_percent"][2] < 10.0
    assert rep["test_rms_error_nm_or_n"][2] < 0.1


@pytest.mark.slow
def test_selection_sees_only_training_recordings(bench, monkeypatch):
    data, _ = bench
    seen = {}

    def spy(arrays, rate_hz, **kwargs):
        seen["samples"] = len(arrays[0])
        return select(arrays, rate_hz, **kwargs)

    select = recordings.select_options
    monkeypatch.setattr(recordings, "select_options", spy)
    # two short fits per fold keep the test fast; the mechanism is what is checked
    monkeypatch.setattr(recordings, "SELECTION_CANDIDATES", {
        "default": DynamicsFitOptions(max_iter=30),
        "symmetric Coulomb": DynamicsFitOptions(asymmetric_coulomb=(), max_iter=30)})
    _, report = recordings.fit_recordings_report(data, select=True, folds=2)
    trim = DynamicsFitOptions().trim
    train = [len(read_recording(p)) - 2 * trim for p in report["train_recordings"]]
    assert seen["samples"] == sum(train)
    sel = report["selection"]
    scores = {n: c["mean_percent"] for n, c in sel["candidates"].items()}
    assert set(scores) == {"default", "symmetric Coulomb"}
    assert sel["selected"] == min(scores, key=scores.get)
    assert all(len(c["solver_status"]) == 2 for c in sel["candidates"].values())


@pytest.mark.slow
def test_fit_dynamics_bad_input_fails_in_one_line(bench, tmp_path, capsys):
    data, _ = bench
    model = tmp_path / "arm.json"
    assert main(["fit-dynamics", "--data", str(tmp_path / "nowhere"),
                 "--model-out", str(model)]) == 2
    assert "nowhere" in _one_line_error(capsys, "fit-dynamics")
    assert main(["fit-dynamics", "--train", "x.csv"]) == 2
    assert "--data" in _one_line_error(capsys, "fit-dynamics")
    assert main(["fit-dynamics", "--format", "wpi", "--data", str(data)]) == 2
    assert "--train" in _one_line_error(capsys, "fit-dynamics")
    # a clock that is neither uniform nor cut by a gap: named, with the row
    frame = read_recording(next(p for p in (data / "train" / "Free").glob("*.csv")))
    frame.loc[100:, "time"] += 0.004
    bad = tmp_path / "jitter.csv"
    write_recording(frame, bad)
    assert main(["fit-dynamics", "--data", str(bad), "--model-out", str(model)]) == 2
    line = _one_line_error(capsys, "fit-dynamics")
    assert "jitter.csv" in line and "row 100" in line
    assert not model.exists()


def test_recording_cut_at_gaps():
    t = np.concatenate([np.arange(500), np.arange(600, 900)]) * 0.005
    parts = recordings.recording_segments(pd.DataFrame({"time": t}), "x.csv")
    assert [(p.start, p.stop) for p, _ in parts] == [(0, 500), (500, 800)]
    assert all(abs(rate - 200.0) < 1e-9 for _, rate in parts)


@pytest.mark.slow
def test_wrench_recovers_the_simulated_force(bench, sharp_model, tmp_path, capsys):
    """Dynamics fitted on the free-space training recordings, wrench of every contact test
    recording by the CLI, compared with the simulator's ATI truth (HEX10 frame) through the same
    zero-phase filter."""
    data, _ = bench
    errors, truths = [], []
    contact = [r.path for r in list_recordings(data) if r.split == "test" and r.condition != "Free"]
    assert len(contact) >= 6
    for k, path in enumerate(contact):
        out = tmp_path / f"wrench_{k}.csv"
        assert main(["wrench", str(path), "--dynamics", str(sharp_model), "--out", str(out),
                     "--frame", "hex10"]) == 0
        table = pd.read_csv(out)
        assert list(table.columns) == ["time", *recordings.WRENCH_COLUMNS, "sigma_min", "damped"]
        recording = read_recording(path)
        assert len(table) == len(recording)
        assert (table["sigma_min"] > 0).all() and not table["damped"].any()
        truth = zero_phase_lowpass(recording[["ati_fx", "ati_fy", "ati_fz"]].to_numpy(), 100.0,
                                   DynamicsFitOptions().cutoff_hz)
        errors.append(table[["ext_fx", "ext_fy", "ext_fz"]].to_numpy() - truth)
        truths.append(truth)
    capsys.readouterr()
    err, truth = np.concatenate(errors), np.concatenate(truths)
    rms = np.sqrt(np.mean(err ** 2, axis=0))
    # the figures docs/identification.md quotes (pytest -s)
    print(f"wrench RMS error x/y/z {np.round(rms, 3)} N, truth RMS "
          f"{np.round(np.sqrt(np.mean(truth ** 2, axis=0)), 2)} N")
    assert rms[0] < LATERAL_TOLERANCE_N and rms[1] < LATERAL_TOLERANCE_N, rms
    assert rms[2] < AXIAL_TOLERANCE_N, rms
    assert np.linalg.norm(rms) < RELATIVE_TOLERANCE * np.linalg.norm(
        np.sqrt(np.mean(truth ** 2, axis=0))), rms


@pytest.mark.slow
def test_wrench_is_the_lstm_baselines_map(bench, sharp_model):
    """`psmforce wrench`'s force in the HEX10 frame equals the LSTM baseline's A(q)(tau - tau_hat)
    (psmforce.estimators.data.lstm_inputs.lstm_columns) for the same conditioned joint states: one path, not two."""
    from psmforce.estimators.data.dataset import Trial
    from psmforce.estimators.data.lstm_inputs import LSTM_JACOBIAN_COLUMNS, lstm_columns
    from psmforce.robot import PSM
    from psmforce.identification import ArmDynamicsModel
    from psmforce.io.recording import JOINT_POSITIONS

    data, _ = bench
    model = ArmDynamicsModel.load(sharp_model)
    path = next(r.path for r in list_recordings(data) if r.condition == "Traction")
    psm = PSM()
    ours = recordings.recording_wrench(model, path, frame="hex10", psm=psm)
    recording = read_recording(path)
    q, dq, ddq, tau = recordings.conditioned_joint_states(recording, str(path), 5.4, 4)
    frame = recording.copy()
    frame[list(JOINT_POSITIONS)] = q
    amap = pd.DataFrame(lstm_columns(psm)(Trial(str(path), "Traction", "train", frame)))
    amap = amap[list(LSTM_JACOBIAN_COLUMNS)].to_numpy().reshape(-1, 3, 6)
    lstm = np.einsum("nij,nj->ni", amap, (tau - model.predict(q, dq, ddq))[:, :6])
    assert np.allclose(ours[["ext_fx", "ext_fy", "ext_fz"]].to_numpy(), lstm, atol=1e-9)
