"""The cases the robustness suite (``python -m tests.robustness``) found silent, unclear or
crashing (issue 14), one test each: refused where the bad input is made or first seen, in one line
naming the file or option, leaving nothing behind."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import psmforce.experiments.reproduce
from psmforce.estimators.data.dataset import DatasetError, Scaler, load_dataset
from psmforce.estimators.evaluation.evaluate import EVAL_START, evaluate
from psmforce.estimators.data.bounds import physical_bounds
from psmforce.estimators.runtime.streaming import StreamingError, StreamingEstimator
from psmforce.identification import ArmDynamicsModel, fit_dynamics_cli
from psmforce.identification.dynamics_report import POOR_FIT_RELATIVE_ERROR_PERCENT
from psmforce.identification.errors import IdentificationInputError
from psmforce.io.recording import RecordingError, read_recording, write_recording
from psmforce.sim import simulate
from psmforce.cli.main import main
from tests.checkpoints import untrained_checkpoint


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("fuzz") / "bench"
    simulate("automated", scale=0.005, seed=0, out=out)
    return out


@pytest.mark.parametrize("column, value, reason", [
    ("yaw_effort", np.nan, "non-finite value"), ("fz", -np.inf, "non-finite value"),
    ("time", "backwards", "not strictly increasing"), ("time", "repeated", "not strictly")])
def test_write_recording_refuses_what_read_recording_would(bench, tmp_path, column, value,
                                                            reason):
    frame = read_recording(sorted(bench.glob("train/Free/*.csv"))[0])
    if value == "backwards":
        frame.loc[10, "time"], frame.loc[11, "time"] = frame.loc[11, "time"], frame.loc[10, "time"]
    elif value == "repeated":
        frame.loc[11, "time"] = frame.loc[10, "time"]
    else:
        frame.loc[7, column] = value
    path = tmp_path / "rec.csv"
    with pytest.raises(RecordingError, match=reason) as err:
        write_recording(frame, path)
    assert str(path) in str(err.value)
    if column != "time":
        assert f"'{column}'" in str(err.value)
    assert list(tmp_path.iterdir()) == []  # no file, no .part


@pytest.mark.parametrize("column, value", [("insertion_position", 5.0),
                                           ("roll_position", 1e30), ("fz", 1e39)])
def test_a_value_outside_its_physical_range_is_refused_by_name(bench, tmp_path, cli_error,
                                                               column, value):
    import shutil
    data = tmp_path / "data"
    shutil.copytree(bench, data)
    bad = sorted(data.glob("train/Free/*.csv"))[0]
    frame = pd.read_csv(bad)
    frame.loc[7, column] = value
    frame.to_csv(bad, index=False)  # pandas, not write_recording: a file from elsewhere
    low, high = physical_bounds()[column]
    assert not low <= value <= high
    with pytest.raises(DatasetError, match=f"{column} = .* at row 7 is outside its physical"):
        load_dataset(data)
    ckpt = tmp_path / "m.pt"
    assert main(["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                 "--out", str(ckpt)]) == 2
    assert str(bad) in cli_error("train") and not ckpt.exists()


def test_the_simulated_bench_is_inside_the_physical_ranges(bench):
    assert load_dataset(bench).trials  # the bound does not refuse what the simulator writes


@pytest.mark.parametrize("seed", ["-1", str(2**70)])
def test_a_seed_numpy_cannot_take_is_refused_naming_the_option(bench, tmp_path, cli_error,
                                                                no_training, seed):
    assert main(["train", "--data", str(bench), "--model", "fcn", "--seed", seed,
                 "--out", str(tmp_path / "m.pt")]) == 2
    assert "--seed" in cli_error("train")


@pytest.mark.parametrize("command", [
    ["fit-prior", "--data", "BENCH", "--out", "OUT"],
    ["convert", "REC", "--out", "OUT"],
    ["wrench", "REC", "--dynamics", "arm.json", "--out", "OUT"],
    ["fit-dynamics", "--data", "BENCH", "--model-out", "OUT"]])
def test_an_output_file_that_is_a_folder_is_refused_first(bench, tmp_path, cli_error, command):
    rec = sorted(bench.glob("train/Free/*.csv"))[0]
    argv = [{"BENCH": str(bench), "REC": str(rec), "OUT": str(tmp_path)}.get(a, a)
            for a in command]
    assert main(argv) == 2
    assert "is a folder" in cli_error(command[0])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("text", ["[[1, 0], [0, 1]]", "[[2, 0, 0], [0, 2, 0], [0, 0, 2]]",
                                  "rotation", '[["a", 0, 0], [0, 1, 0], [0, 0, 1]]'])
def test_convert_names_a_bad_r_ati_psm(tmp_path, cli_error, text):
    (tmp_path / "bag").mkdir()
    (tmp_path / "r.json").write_text(text)
    assert main(["convert", str(tmp_path / "bag"), "--r-ati-psm", str(tmp_path / "r.json"),
                 "--out", str(tmp_path / "out.csv")]) == 2
    assert f"--r-ati-psm {tmp_path / 'r.json'}" in cli_error("convert")
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("args, option", [
    (["--scale", "0"], "--scale"), (["--scale", "-1"], "--scale"), (["--scale", "nan"], "--scale"),
    (["--scale", "1e6"], "--scale"), (["--seeds", "1", "-1"], "--seeds"),
    (["--out", "FILE"], "--out"), (["--out", "FILE/run"], "--out")])
def test_reproduce_refuses_bad_arguments_before_writing_anything(tmp_path, cli_error, monkeypatch,
                                                                 args, option):
    monkeypatch.setattr(psmforce.experiments.reproduce, "run_grid",
                        lambda *a, **k: pytest.fail("reproduce started its tasks"))
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    argv = [a.replace("FILE", str(blocker)) for a in args]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "run")]
    assert main(["reproduce", *argv]) == 2
    assert option in cli_error("reproduce")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


@pytest.mark.parametrize("kw, name", [({"scale": -1}, "scale"), ({"scale": float("nan")}, "scale"),
                                      ({"scale": 1e6}, "scale"), ({"seeds": [1, -1]}, "seeds")])
def test_reproduce_from_python_refuses_bad_scale_or_seed_before_writing(tmp_path, kw, name):
    with pytest.raises(ValueError, match=f"^{name}: must be"):
        psmforce.experiments.reproduce.reproduce(tmp_path / "run", **{"seeds": [1], **kw})
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("text, reason", [
    ("", "cannot read"), ("arm: yes", "cannot read"), ("[1, 2]", "not an ArmDynamicsModel"),
    ("FORMAT_ONLY", "malformed")])
def test_a_file_that_is_not_an_arm_model_is_refused_naming_it(tmp_path, text, reason):
    from psmforce.identification.dynamics import MODEL_FORMAT
    path = tmp_path / "arm.json"
    path.write_text(json.dumps({"format": MODEL_FORMAT}) if text == "FORMAT_ONLY" else text)
    with pytest.raises(IdentificationInputError, match=reason) as err:
        ArmDynamicsModel.load(path)
    assert str(path) in str(err.value) and "\n" not in str(err.value)


def test_streaming_names_a_checkpoint_of_a_model_that_does_not_stream(tmp_path):
    path = untrained_checkpoint("lstm", tmp_path / "lstm.pt")
    with pytest.raises(StreamingError, match="does not stream") as err:
        StreamingEstimator.from_checkpoint(path)
    assert str(path) in str(err.value)


def test_evaluate_refuses_a_test_recording_too_short_to_score_by_name(bench, tmp_path):
    import shutil
    data = tmp_path / "data"
    shutil.copytree(bench, data)
    short = sorted(data.glob("test/Traction/*.csv"))[0]
    write_recording(read_recording(short).iloc[:EVAL_START], short)
    out = tmp_path / "eval"
    with pytest.raises(ValueError, match="cannot be scored") as err:
        evaluate(untrained_checkpoint("fcn", tmp_path / "fcn.pt"), data, out, plots=False)
    assert short.relative_to(data).as_posix() in str(err.value)
    assert not out.exists()  # no metrics of the other trials left behind


@pytest.fixture(scope="module")
def noise(tmp_path_factory):
    """3000 x 21 random numbers in the WPI layout (issue 14's reproduction)."""
    path = tmp_path_factory.mktemp("wpi") / "noise.csv"
    np.savetxt(path, np.random.default_rng(0).standard_normal((3000, 21)), delimiter=",")
    return path


@pytest.fixture
def fit_once(monkeypatch):
    """The test below fits one file with the same options three times (the CLI refusing, the
    CLI accepting, the library): the first fit is kept and each later call gets it instead of
    a refit of the same input. What is under test is what the CLI and the library do with a
    poor fit; the fit itself is deterministic, so each call still sees the fit it would have
    computed (identical arrays and options are asserted through the key)."""
    import hashlib

    from psmforce.identification import wpi_report
    real, kept = wpi_report.fit_arm_dynamics, {}

    def once(q, dq, tau, **kwargs):
        key = (hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes()
                                       for a in (q, dq, tau))).hexdigest(),
               repr(sorted(kwargs.items(), key=lambda kv: kv[0])))
        if key not in kept:
            kept[key] = real(q, dq, tau, **kwargs)
        return kept[key]

    monkeypatch.setattr(wpi_report, "fit_arm_dynamics", once)
    return kept


@pytest.mark.slow
def test_fit_dynamics_refuses_a_poor_fit_unless_accepted(noise, tmp_path, capsys, fit_once):
    model = tmp_path / "arm.json"
    argv = ["fit-dynamics", "--format", "wpi", "--train", str(noise), "--test", str(noise),
            "--model-out", str(model)]
    assert main(argv) == 2
    printed, err = capsys.readouterr()
    assert "test relative torque error %" in printed  # the figures are printed either way
    assert len(err.strip().splitlines()) == 1 and "--accept-poor-fit" in err and str(model) in err
    assert not model.exists()
    assert main(argv + ["--accept-poor-fit"]) == 0 and model.exists()
    report = fit_dynamics_cli(noise, noise, "wpi", model_out=tmp_path / "lib.json")
    assert report["poor_fit"] and report["model"] == str(tmp_path / "lib.json")  # library: saves
    assert min(report["test_relative_error_percent"]) > POOR_FIT_RELATIVE_ERROR_PERCENT
    assert len(fit_once) == 1  # the three calls fitted the one input


@pytest.mark.parametrize("signal, flagged", [
    ("no", "INVALID_INPUT"), ("yes", "INVALID_INPUT"), (float("nan"), "INVALID_INPUT"),
    (1, "OVERLOAD"), (True, "OVERLOAD"), (0, None)])
def test_a_non_numeric_overload_signal_is_invalid_not_an_overload(tmp_path, signal, flagged):
    from psmforce.estimators.networks.causal import CausalTransformer
    from psmforce.estimators.data.hybrid_inputs import hybrid_columns
    from psmforce.estimators.runtime.streaming import Flags
    features, base = hybrid_columns(use_prior=False)
    n = len(features)
    scaler = Scaler(np.zeros(n, np.float32), np.ones(n, np.float32))
    target = Scaler(np.zeros(3, np.float32), np.ones(3, np.float32))
    model = CausalTransformer(n, d_model=16, n_heads=2, d_ff=32, attention_window=8)
    est = StreamingEstimator(model, features, scaler, target, base)
    sample = {c: 0.0 for c in est.columns} | {"time": 0.0, "insertion_position": 0.1,
                                               "hex10_overload": signal}
    flags = Flags(est.step(sample).flags)
    assert (Flags.INVALID_INPUT in flags) == (flagged == "INVALID_INPUT")
    assert (Flags.OVERLOAD in flags) == (flagged == "OVERLOAD")
