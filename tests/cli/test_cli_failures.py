"""CLI failures (issue 14, items 5 and 6): one line naming the file or option, exit 2, nothing
left behind, found before the expensive work."""

from __future__ import annotations

import json
import os

import pandas as pd
import pytest
import torch

import psmforce.estimators.training.train
from psmforce.sim import simulate
from psmforce.sim.dataset import MAX_SCALE as MAX_SIMULATE_SCALE
from psmforce.cli.main import main


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "bench"
    simulate("automated", scale=0.01, seed=0, out=out)
    return out


def test_train_epochs_0_is_refused_first(bench, tmp_path, cli_error, no_training):
    ckpt = tmp_path / "m.pt"
    assert main(["train", "--data", str(bench), "--model", "fcn", "--epochs", "0",
                 "--out", str(ckpt)]) == 2
    assert "--epochs" in cli_error("train") and not ckpt.exists()
    assert main(["finetune", str(ckpt), "--data", str(bench), "--epochs", "-3",
                 "--out", str(tmp_path / "t.pt")]) == 2
    assert "--epochs" in cli_error("finetune")


def test_train_epochs_0_from_python_is_refused(bench, tmp_path):
    with pytest.raises(ValueError, match="epochs"):
        psmforce.estimators.training.train.train(bench, "fcn", tmp_path / "m.pt", epochs=0)
    assert not (tmp_path / "m.pt").exists()


@pytest.mark.skipif(torch.cuda.is_available(), reason="needs a machine without CUDA")
def test_device_cuda_without_cuda_is_refused_first(bench, tmp_path, cli_error, no_training):
    assert main(["train", "--data", str(bench), "--model", "fcn", "--device", "cuda",
                 "--out", str(tmp_path / "m.pt")]) == 2
    assert "--device cuda" in cli_error("train")
    assert not list(tmp_path.iterdir())


def test_unwritable_out_is_found_before_training(bench, tmp_path, cli_error, no_training):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    unwritable = [blocker / "sub" / "m.pt"]  # a file where a folder must be: even root fails
    if os.geteuid() != 0:  # root writes into read-only folders
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        unwritable.append(locked / "m.pt")
    try:
        for out in unwritable:
            assert main(["train", "--data", str(bench), "--model", "fcn", "--epochs", "1",
                         "--out", str(out)]) == 2
            line = cli_error("train")
            assert line.count("--out") == 1 and "not a writable folder" in line
    finally:
        if os.geteuid() != 0:
            locked.chmod(0o700)
    assert main(["train", "--data", str(bench), "--out", str(tmp_path)]) == 2
    assert "is a folder" in cli_error("train")


@pytest.mark.parametrize("command", ["evaluate", "export"])
def test_evaluate_and_export_refuse_a_non_empty_out(tmp_path, cli_error, command):
    out = tmp_path / "results"
    out.mkdir()
    (out / "metrics.json").write_text("{}\n")  # an earlier run's result
    ckpt = tmp_path / "m.pt"
    ckpt.write_bytes(b"")
    args = [command, str(ckpt), "--out", str(out)] + (
        ["--data", str(tmp_path)] if command == "evaluate" else [])
    assert main(args) == 2
    line = cli_error(command)
    assert "--out" in line and "not empty" in line
    assert [p.name for p in out.iterdir()] == ["metrics.json"]
    assert (out / "metrics.json").read_text() == "{}\n"


def test_simulate_scale_above_the_bound_is_refused_before_allocating(tmp_path, cli_error,
                                                                     monkeypatch):
    import psmforce.sim as sim
    monkeypatch.setattr(sim, "simulate", lambda **kw: pytest.fail("simulate was called"))
    out = tmp_path / "bench"
    assert main(["simulate", "--scale", "1e6", "--out", str(out)]) == 2
    assert "--scale" in cli_error("simulate") and not out.exists()
    assert MAX_SIMULATE_SCALE >= 1.0  # the paper's own protocol stays allowed


def test_json_into_a_missing_folder_is_refused_before_the_work(tmp_path, cli_error):
    out = tmp_path / "bench"
    assert main(["simulate", "--scale", "0.01", "--out", str(out),
                 "--json", str(tmp_path / "missing" / "s.json")]) == 2
    assert "--json" in cli_error("simulate")
    assert not out.exists()  # no dataset left behind without its summary


def test_text_cell_in_a_numeric_column_names_file_column_and_row(bench, tmp_path, cli_error):
    import shutil
    data = tmp_path / "data"
    shutil.copytree(bench, data)
    bad = sorted(data.rglob("train/Free/*.csv"))[0]
    frame = pd.read_csv(bad).astype({"roll_effort": object})
    frame.loc[7, "roll_effort"] = "abc"
    frame.to_csv(bad, index=False)
    ckpt = tmp_path / "m.pt"
    assert main(["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                 "--out", str(ckpt)]) == 2
    line = cli_error("train")
    assert str(bad) in line and "'roll_effort'" in line and "'abc'" in line and "row 7" in line
    assert not ckpt.exists()


@pytest.mark.skipif(torch.cuda.is_available(), reason="needs a machine without CUDA")
def test_a_gpu_run_finishes_on_the_cpu_and_computes_nowhere_else(tmp_path, cli_error,
                                                                  monkeypatch):
    """``reproduce --device cuda`` needs CUDA here; with ``--finish-on cpu`` the run keeps its
    GPU keys and computes on the CPU; ``--finish-on cuda`` needs CUDA as ``--device`` does."""
    import psmforce.experiments.reproduce
    calls = []
    monkeypatch.setattr(psmforce.experiments.reproduce, "reproduce", lambda *a, **k: calls.append(k) or {})
    out = str(tmp_path / "run")
    assert main(["reproduce", "--out", out, "--device", "cuda"]) == 2
    assert "--device cuda" in cli_error("reproduce") and calls == []
    assert main(["reproduce", "--out", out, "--finish-on", "cuda"]) == 2
    assert "--finish-on cuda" in cli_error("reproduce") and calls == []
    assert main(["reproduce", "--out", out, "--device", "cuda", "--finish-on", "cpu"]) == 0
    assert calls[0]["device"] == "cuda" and calls[0]["finish_on"] == "cpu"


# Issue 46, class 1: an output that exists and is not a regular file is refused before the work.

@pytest.mark.parametrize("kind", ["symlink", "fifo", "device"])
def test_a_json_output_that_is_not_a_regular_file_is_refused_before_the_work(tmp_path, kind,
                                                                              cli_error):
    kept = tmp_path / "kept.json"
    kept.write_text("the user's file")
    target = {"device": "/dev/null"}.get(kind, str(tmp_path / "report.json"))
    if kind == "symlink":
        os.symlink(kept, target)
    elif kind == "fifo":
        os.mkfifo(target)   # a writer opening it would hang; the refusal comes first
    out = tmp_path / "bench"
    assert main(["simulate", "--scale", "0.005", "--seed", "0", "--out", str(out),
                 "--json", target]) == 2
    assert "--json" in cli_error("simulate") and "not" not in kept.read_text()
    assert kept.read_text() == "the user's file" and not out.exists()


def test_json_dash_writes_to_standard_output(tmp_path, capsys):
    assert main(["index", str(tmp_path / "none"), "--json", "-"]) == 2  # refused: no folder
    out = tmp_path / "bench"
    assert main(["simulate", "--scale", "0.005", "--seed", "0", "--out", str(out),
                 "--json", "-"]) == 0
    printed = capsys.readouterr().out
    assert '"protocol": "automated"' in printed and not (tmp_path / "-").exists()


# Issue 46, class 11: refusals that were wrong or came after the work.

def test_a_long_inline_config_is_json_not_a_file_name(bench, tmp_path, cli_error, no_training):
    config = '{"hidden": 64, "dropout": 0.1' + ", " * 200 + "}"   # 300+ characters, invalid
    assert main(["train", "--data", str(bench), "--model", "fcn", "--epochs", "1", "--config",
                 config, "--out", str(tmp_path / "m.pt")]) == 2
    line = cli_error("train")
    assert "--config" in line and "inline JSON is not valid" in line
    assert "File name too long" not in line


@pytest.mark.parametrize("special", ["/dev/zero", "fifo"])
def test_a_config_file_that_is_not_a_regular_file_is_refused(bench, tmp_path, special,
                                                             cli_error, no_training):
    path = special
    if special == "fifo":
        path = str(tmp_path / "config.json")
        os.mkfifo(path)  # reading it would wait for a writer forever
    assert main(["train", "--data", str(bench), "--model", "fcn", "--epochs", "1", "--config",
                 path, "--out", str(tmp_path / "m.pt")]) == 2
    assert "not a regular file" in cli_error("train")


def test_an_out_name_the_file_system_cannot_hold_is_refused_before_training(
        bench, tmp_path, cli_error, no_training):
    out = tmp_path / ("m" * 300 + ".pt")
    assert main(["train", "--data", str(bench), "--model", "fcn", "--epochs", "1",
                 "--out", str(out)]) == 2
    line = cli_error("train")
    assert "--out" in line and "longer than the" in line
    out_folder = tmp_path / ("e" * 300)
    assert main(["simulate", "--scale", "0.005", "--out", str(out_folder)]) == 2
    assert "--out" in cli_error("simulate")


# Issue 46, class 8: every size an option or a file asks for is bounded before any allocation.

@pytest.mark.parametrize("argv, option", [
    (["convert", "x.mcap", "--out", "o.csv", "--rate", "1e9"], "--rate"),
    (["serve", "h.pt", "--sim", "--sim-rate", "1e9"], "--sim-rate"),
    (["serve", "h.pt", "--sim", "--sim-rate", "0"], "--sim-rate"),
    (["serve", "h.pt", "--sim", "--sim-rate", "-5"], "--sim-rate"),
    (["serve", "h.pt", "--duration", "nan"], "--duration"),
    (["serve", "h.pt", "--duration", "inf"], "--duration"),
    (["serve", "h.pt", "--idle-stop", "-1"], "--idle-stop"),
    (["serve", "h.pt", "--input-rate", "1e9"], "--input-rate"),
    (["serve", "h.pt", "--domain-id", "300"], "--domain-id"),
    (["serve", "h.pt", "--domain-id", "-5"], "--domain-id"),
    (["serve", "h.pt", "--rt-priority", "0"], "--rt-priority"),
    (["replay", "b", "h.pt", "--out", "o.mcap", "--port", "70000"], "--port"),
    (["replay", "b", "h.pt", "--out", "o.mcap", "--input-rate", "1000000000"], "--input-rate")])
def test_sizes_and_durations_outside_their_bounds_are_refused_in_one_line(argv, option, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(argv)
    assert exit_.value.code == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith(f"psmforce {argv[0]}: error: argument {option}: must be in")


def test_the_command_lines_rate_bound_is_the_librarys():
    from psmforce.cli.options import MAX_RATE_HZ
    from psmforce.io.recording import MAX_RATE_HZ as LIBRARY
    assert MAX_RATE_HZ == LIBRARY


@pytest.mark.parametrize("special", ["/dev/zero", "fifo"])
def test_inputs_that_are_not_regular_files_are_refused_not_read(tmp_path, special, cli_error):
    """``/dev/zero`` as ``--r-ati-psm`` or ``--prior`` ran out of memory; a pipe hung."""
    path = special
    if special == "fifo":
        path = str(tmp_path / "input")
        os.mkfifo(path)
    from psmforce.identification.prior import InternalForcePrior
    from psmforce.io.recording import RecordingError, read_recording
    with pytest.raises(ValueError, match="not a regular file"):
        InternalForcePrior.load(path)
    with pytest.raises(RecordingError, match="not a regular file"):
        read_recording(path)
    from psmforce.estimators.training.checkpoint import CheckpointError, load_checkpoint
    with pytest.raises(CheckpointError, match="not a regular file"):
        load_checkpoint(path)
    assert main(["convert", str(tmp_path / "no.mcap"), "--out", str(tmp_path / "o.csv"),
                 "--r-ati-psm", path]) == 2
    assert "not a regular file" in cli_error("convert")


def test_simulate_takes_a_simulator_version_and_refuses_an_unknown_one(tmp_path, cli_error):
    assert main(["simulate", "--scale", "0.01", "--seed", "1", "--sim-version", "2.3",
                 "--out", str(tmp_path / "v23")]) == 0
    assert json.loads((tmp_path / "v23" / "metadata.json").read_text())[
        "simulator_version"] == "2.3"
    assert main(["simulate", "--scale", "0.01", "--sim-version", "9.9",
                 "--out", str(tmp_path / "bad")]) == 2
    assert "unknown simulator version '9.9'" in cli_error("simulate")
    assert not (tmp_path / "bad").exists()
