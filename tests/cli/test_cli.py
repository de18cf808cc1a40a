"""The `psmforce` command line: help texts, one-line failures with no partial output, the demo."""

import json
from pathlib import Path

import pytest

from psmforce.cli.main import main

COMMANDS = ("simulate", "convert", "index", "fit-dynamics", "fit-prior", "train", "finetune",
            "evaluate", "reproduce", "export", "demo", "excitation")


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_explains_itself(command, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([command, "--help"])
    assert exit_.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith(f"usage: psmforce {command}")
    assert len(text.splitlines()) > 4


def _one_line_error(capsys, command):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(f"psmforce {command}: error: ")
    return err[0]


def test_simulate_rejects_bad_scale_before_writing(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["simulate", "--scale", "-1", "--out", str(out)]) == 2
    assert "scale" in _one_line_error(capsys, "simulate")
    assert not out.exists()


def test_convert_unreadable_file_leaves_nothing(tmp_path, capsys):
    bag = tmp_path / "broken.mcap"
    bag.write_bytes(b"not a bag at all")
    out = tmp_path / "out.csv"
    assert main(["convert", str(bag), "--out", str(out)]) == 2
    _one_line_error(capsys, "convert")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.mcap"]


def test_fit_prior_on_an_empty_folder_fails_clearly(tmp_path, capsys):
    out = tmp_path / "prior.json"
    assert main(["fit-prior", "--data", str(tmp_path), "--out", str(out)]) == 2
    _one_line_error(capsys, "fit-prior")
    assert not out.exists()


def test_evaluate_refuses_a_corrupt_checkpoint(tmp_path, capsys):
    ckpt = tmp_path / "model.pt"
    ckpt.write_bytes(b"\x00garbage")
    assert main(["evaluate", str(ckpt), "--data", str(tmp_path), "--out",
                 str(tmp_path / "eval")]) == 2
    _one_line_error(capsys, "evaluate")
    assert not (tmp_path / "eval").exists()


@pytest.mark.slow
def test_demo_runs_end_to_end_at_tiny_scale(tmp_path, capsys):
    from psmforce.cli.demo import run_demo
    summary = run_demo(tmp_path / "demo", scale=0.01, budget={"max_epochs": 1})
    printed = capsys.readouterr().out
    assert "| Fx |" in printed and "hybrid" in printed and "fcn" in printed
    assert set(summary["metrics"]) == {"hybrid", "fcn"}
    for metrics in summary["metrics"].values():
        assert set(metrics) == {"Fx", "Fy", "Fz"}
    assert summary["plots"] and all(Path(p).exists() for p in summary["plots"])
    saved = json.loads((tmp_path / "demo" / "demo.json").read_text())
    assert saved["metrics"] == json.loads(json.dumps(summary["metrics"]))
