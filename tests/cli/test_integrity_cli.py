"""Issue 26 at the command line: one error boundary (exit 3 and one line for a bug, --debug for
the traceback), no command writes over its inputs, configs and seeds checked before the work,
degenerate or leaked data refused by file, and fits that print their verdict and gate."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pandas as pd
import pytest
import torch

from psmforce.estimators.training import checkpoint as ck
from psmforce.estimators.data.dataset import Scaler
from psmforce.estimators.data.sanity import file_sha256
from psmforce.estimators.networks.recipes import build_model
from psmforce.io.recording import PAPER_FEATURES
from psmforce.sim import simulate
from psmforce.cli import guards, offline
from psmforce.cli.main import main

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("integrity") / "bench"
    simulate("automated", scale=0.005, seed=0, out=out)
    return out


def _fcn(path, provenance=None):
    torch.manual_seed(0)
    n = len(PAPER_FEATURES)
    xs = Scaler(np.zeros(n, np.float32), np.ones(n, np.float32))
    ys = Scaler(np.zeros(3, np.float32), np.ones(3, np.float32))
    return ck.TrainedModel("fcn", {}, PAPER_FEATURES, xs, ys, model=build_model("fcn", n),
                           provenance=provenance or {}).save(path)


def test_calibrate_out_equal_to_its_input_is_refused(bench, tmp_path, cli_error, no_training):
    ckpt = _fcn(tmp_path / "m.pt")
    before = ckpt.read_bytes()
    assert main(["calibrate", str(ckpt), "--data", str(bench), "--out", str(ckpt),
                 "--epochs", "1"]) == 2
    line = cli_error("calibrate")
    assert "--out" in line and "checkpoint" in line and "write over an input" in line
    link = tmp_path / "link.pt"
    link.symlink_to(ckpt)  # the same file by another name
    assert main(["calibrate", str(ckpt), "--data", str(bench), "--out", str(link),
                 "--epochs", "1"]) == 2
    assert "write over an input" in cli_error("calibrate")
    assert ckpt.read_bytes() == before
    from psmforce.estimators.training.calibrate import calibrate  # the library refuses it too
    with pytest.raises(ValueError, match="refusing to write over its input"):
        calibrate(ckpt, bench, ckpt, epochs=1)
    assert ckpt.read_bytes() == before


@pytest.mark.parametrize("argv, option", [
    (["finetune", "CKPT", "--data", "BENCH", "--out", "CKPT"], "--out"),
    (["train", "--data", "BENCH", "--model", "fcn", "--out", "REC"], "--out"),
    (["train", "--data", "BENCH", "--model", "fcn", "--out", "NEW", "--json", "NEW"], "--json"),
    (["fit-prior", "--data", "BENCH", "--out", "BENCH/metadata.json"], "--out"),
    (["wrench", "REC", "--dynamics", "CKPT", "--out", "REC"], "--out"),
    (["convert", "REC", "--out", "REC"], "--out"),
    (["evaluate", "CKPT", "--data", "BENCH", "--out", "BENCH"], "--out")])
def test_no_command_writes_over_one_of_its_inputs(bench, tmp_path, cli_error, no_training,
                                                 argv, option):
    data = tmp_path / "bench"
    shutil.copytree(bench, data)
    ckpt = tmp_path / "m.pt"
    ckpt.write_bytes(b"a checkpoint")
    rec = sorted(data.glob("train/Free/*.csv"))[0]
    names = {"CKPT": str(ckpt), "BENCH": str(data), "REC": str(rec), "NEW": str(tmp_path / "n")}
    argv = [names.get(a, a.replace("BENCH", str(data))) for a in argv]
    before = {p: p.read_bytes() for p in [ckpt, *data.rglob("*") ] if p.is_file()}
    assert main(argv) == 2
    line = cli_error(argv[0])
    assert option in line and ("write over an input" in line or "share one file" in line)
    assert {p: p.read_bytes() for p in before} == before


def test_a_config_with_zero_heads_is_refused_before_training(bench, tmp_path, cli_error,
                                                             no_training):
    for config, key in (('{"n_heads": 0}', "n_heads"), ('{"d_model": 0}', "d_model"),
                        ('{"attention_window": 100000000}', "attention_window"),
                        ('{"n_heads": 3}', "n_heads must divide d_model")):
        assert main(["train", "--data", str(bench), "--model", "hybrid", "--config", config,
                     "--out", str(tmp_path / "h.pt")]) == 2
        assert key in cli_error("train")
    assert not list(tmp_path.iterdir())


def test_duplicate_seeds_are_refused_before_any_work(tmp_path, cli_error, monkeypatch):
    import psmforce.experiments.reproduce
    monkeypatch.setattr(psmforce.experiments.reproduce, "run_grid",
                        lambda *a, **k: pytest.fail("reproduce started its grid"))
    assert main(["reproduce", "--out", str(tmp_path / "run"), "--seeds", "0", "0"]) == 2
    assert "--seeds: 0 given more than once" in cli_error("reproduce")
    assert not (tmp_path / "run").exists()


def test_an_unexpected_exception_is_one_line_exit_3_and_debug_shows_the_traceback(
        tmp_path, capsys, monkeypatch):
    def bug(args):
        return 1 / 0
    monkeypatch.setattr(offline, "index_command", bug)  # a bug in a command
    assert main(["index", str(tmp_path)]) == 3
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("psmforce index: internal error: "
                                                   "ZeroDivisionError")
    assert "--debug" in lines[0]
    for argv in (["--debug", "index", str(tmp_path)], ["index", str(tmp_path), "--debug"]):
        assert main(argv) == 3
        err = capsys.readouterr().err
        assert "Traceback (most recent call last)" in err and "1 / 0" in err


def test_all_zero_targets_are_refused_by_file(bench, tmp_path, cli_error):
    data = tmp_path / "bench"
    shutil.copytree(bench, data)
    bad = sorted(data.glob("train/Traction/*.csv"))[0]
    frame = pd.read_csv(bad)
    frame[["ati_fx", "ati_fy", "ati_fz"]] = 0.0
    frame.to_csv(bad, index=False)
    assert main(["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                 "--out", str(tmp_path / "m.pt")]) == 2
    line = cli_error("train")
    assert str(bad) in line and "ati_fx is constant" in line
    assert not (tmp_path / "m.pt").exists()


def test_a_test_set_repeating_training_recordings_is_refused_or_flagged(bench, tmp_path,
                                                                        cli_error, capsys):
    data = tmp_path / "bench"
    shutil.copytree(bench, data)
    train_rel = sorted(p.relative_to(data).as_posix() for p in data.glob("train/Traction/*"))[0]
    test = sorted(data.glob("test/Traction/*.csv"))[0]
    shutil.copy(data / train_rel, test)  # a training recording copied into the test split
    ckpt = _fcn(tmp_path / "m.pt", {"data_dir": str(data), "train_trials": [train_rel],
                                    "val_trials": []})
    saved = ck.load_checkpoint(ckpt).provenance["trial_sha256"]
    assert saved == {train_rel: file_sha256(data / train_rel)}
    out = tmp_path / "eval"
    assert main(["evaluate", str(ckpt), "--data", str(data), "--out", str(out)]) == 2
    line = cli_error("evaluate")
    assert str(test) in line and train_rel in line and "--allow-train-overlap" in line
    assert not out.exists()
    assert main(["evaluate", str(ckpt), "--data", str(data), "--out", str(out),
                 "--allow-train-overlap", "--json", str(tmp_path / "e.json")]) == 0
    err = capsys.readouterr().err
    assert f"test recording {test.relative_to(data).as_posix()} has the content" in err
    report = json.loads((tmp_path / "e.json").read_text())
    assert report["train_overlap"] == [{"test": test.relative_to(data).as_posix(),
                                        "train": train_rel}]


def _dynamics_report(errors, poor):
    return {"coordinates": ["yaw", "pitch", "insertion"], "solver_status": "Solve_Succeeded",
            "fit_time_s": 1.0, "n_base_parameters": 40, "physically_consistent": True,
            "model": None, "test_relative_error_percent": errors, "poor_fit": poor,
            "poor_fit_threshold_relative_error_percent": 50.0}


def test_fit_dynamics_prints_its_verdict_and_gates(tmp_path, capsys, monkeypatch):
    import psmforce.identification as ident
    monkeypatch.setattr(ident, "fit_dynamics_cli",
                        lambda **kw: _dynamics_report([63.0, 148.0, 8.0], False))
    assert main(["fit-dynamics", "--data", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "verdict: passes the gate" in out and "yaw 63 %" in out and "pitch 148 %" in out
    monkeypatch.setattr(ident, "fit_dynamics_cli",
                        lambda **kw: _dynamics_report([97.0, 99.0, 101.0], True))
    assert main(["fit-dynamics", "--data", str(tmp_path)]) == 2
    captured = capsys.readouterr()
    assert "verdict: POOR FIT" in captured.out and "--accept-poor-fit" in captured.err
    assert main(["fit-dynamics", "--data", str(tmp_path), "--accept-poor-fit"]) == 0


def test_fit_prior_prints_the_targets_it_misses(tmp_path, capsys, monkeypatch):
    import psmforce.identification as ident
    metrics = {c: {"rms": 0.4, "r2": 0.5} for c in ("fx", "fy", "fz", "tx", "ty", "tz")}
    report = {"solver_status": "Solve_Succeeded", "fit_time_s": 1.0, "poor_fit": False,
              "test_free_metrics": metrics, "model": str(tmp_path / "p.json"),
              "targets_not_met": ["test Free fz R2 0.5 < 0.90", "test Free fx RMS 0.400 N >= 0.3 N"]}
    monkeypatch.setattr(ident, "fit_prior_cli", lambda *a, **k: report)
    assert main(["fit-prior", "--data", str(tmp_path), "--out", str(tmp_path / "p.json")]) == 0
    out = capsys.readouterr().out
    assert "targets NOT met: test Free fz R2 0.5 < 0.90; test Free fx RMS" in out


def test_progress_speaks_during_a_long_block(capsys):
    import time
    with guards.progress("fit", every_s=0.05):
        time.sleep(0.18)
    assert "fit: still running" in capsys.readouterr().err
