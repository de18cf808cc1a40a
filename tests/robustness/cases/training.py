"""Bad input against training: its options, model configs refused before any data is read, calibration to another tool."""

from __future__ import annotations

import json

import torch

from tests.robustness.harness import Attempt, CHECKPOINT_DAMAGE, Case, registrar


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)


    # --- train options -----------------------------------------------------------------------
    def train_option(name, extra, names, out="m.pt", guard="psmforce.estimators.training.train.load_dataset"):
        def prepare(s, d):
            target = d / out
            if out == "folder":
                target.mkdir()
            return Attempt(argv=["train", "--data", str(s.bench), "--model", "fcn",
                                 "--out", str(target), *extra], names=names, guard=guard)
        found.append(Case("cli train: options", name, "REJECTED", prepare))

    train_option("--epochs 0", ["--epochs", "0"], ("--epochs",))
    train_option("--epochs -1", ["--epochs", "-1"], ("--epochs",))
    train_option("--epochs 1e9 (not an integer)", ["--epochs", "1e9"], ("--epochs",))
    train_option("--epochs nan", ["--epochs", "nan"], ("--epochs",))
    if not torch.cuda.is_available():
        train_option("--device cuda without CUDA", ["--device", "cuda"], ("--device",))
    train_option("--device tpu", ["--device", "tpu"], ("--device",))
    train_option("--seed 1e23", ["--seed", "1e23"], ("--seed",))
    train_option("--seed -1", ["--seed", "-1"], ("--seed",), guard=None)
    train_option("--seed 2**70", ["--seed", str(2 ** 70)], ("--seed",), guard=None)
    train_option("--model svm", ["--model", "svm"], ("--model",))
    train_option("--features unknown", ["--features", "everything"], ("everything", "feature"),
                 guard=None)
    train_option("--out is a folder", [], ("--out",), out="folder")
    train_option("--json into a missing folder", ["--json", "/nonexistent/dir/t.json"],
                 ("--json",))

    @case("cli train: options", "--out under a file (parent is a file)")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["train", "--data", str(s.bench), "--model", "fcn",
                             "--out", str(d / "blocker" / "m.pt")], names=("--out",),
                       guard="psmforce.estimators.training.train.load_dataset")

    # --- calibrate ----------------------------------------------------------------------------
    def calibrate_option(name, extra, names, damage=None):
        def prepare(s, d):
            ckpt = s.fcn
            if damage:
                ckpt = d / "model.pt"
                damage(s, ckpt)
            return Attempt(argv=["calibrate", str(ckpt), "--data", str(s.bench),
                                 "--out", str(d / "c.pt"), *extra],
                           names=tuple(str(ckpt) if n == "CKPT" else n for n in names))
        found.append(Case("cli calibrate", name, "REJECTED", prepare))

    calibrate_option("--minutes 0", ["--minutes", "0", "--epochs", "1"],
                     ("--minutes", "minutes"))
    calibrate_option("--minutes -1", ["--minutes", "-1", "--epochs", "1"],
                     ("--minutes", "minutes"))
    calibrate_option("--minutes nan", ["--minutes", "nan", "--epochs", "1"],
                     ("--minutes", "minutes"))
    calibrate_option("--epochs 0", ["--epochs", "0"], ("--epochs",))
    calibrate_option("zero-byte checkpoint", ["--epochs", "1"], ("CKPT",),
                     damage=CHECKPOINT_DAMAGE["zero-byte"])
    calibrate_option("flipped weight bytes", ["--epochs", "1"], ("CKPT",),
                     damage=CHECKPOINT_DAMAGE["flipped weight bytes"])

    # --- model configs: refused before any data is read, naming the key ------------------------
    for model, config, key in (
            ("hybrid", {"n_heads": 0}, "n_heads"), ("hybrid", {"d_model": 0}, "d_model"),
            ("hybrid", {"n_heads": 3}, "n_heads"), ("hybrid", {"d_ff": 0}, "d_ff"),
            ("hybrid", {"attention_window": 10 ** 9}, "attention_window"),
            ("hybrid", {"attention_window": 4096, "n_layers": 16, "d_model": 512},
             "attention_window"),
            ("hybrid", {"n_layers": -1}, "n_layers"), ("hybrid", {"n_layers": 2.5}, "n_layers"),
            ("hybrid", {"dropout": 1.5}, "dropout"), ("hybrid", {"dropout": "NaN"}, "dropout"),
            ("hybrid", {"uncertainty": 1}, "uncertainty"), ("hybrid", {"width": 8}, "width"),
            ("transformer", {"n_heads": 7}, "n_heads"), ("transformer", {"window": 0}, "window"),
            ("fcn", {"hidden": 0}, "hidden"), ("lstm", {"max_torque": [1, 2]}, "max_torque"),
            ("rocket", {"window": 5}, "window"),
            ("rocket", {"n_kernels_hydra": 10 ** 9}, "n_kernels_hydra")):
        def train_config(s, d, model=model, config=config, key=key):
            return Attempt(argv=["train", "--data", str(s.bench), "--model", model, "--config",
                                 json.dumps(config), "--out", str(d / "m.pt")], names=(key,),
                           guard="psmforce.estimators.training.train.load_dataset")
        found.append(Case("cli train --config", f"{model} {json.dumps(config)}", "REJECTED",
                          train_config))
    return found
