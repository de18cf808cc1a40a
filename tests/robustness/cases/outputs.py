"""Bad input against outputs: no command writes over one of its inputs."""

from __future__ import annotations

import shutil

from tests.robustness.harness import Attempt, Case, _link_case, trial


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []

    # --- no command writes over one of its inputs ---------------------------------------------
    def over_input(command, build, option):
        def prepare(s, d):
            argv, names = build(s, d)
            return Attempt(argv=argv, names=(option,))
        found.append(Case("cli outputs vs inputs", command, "REJECTED", prepare))

    def own_copy(s, d, name="model.pt", src=None):
        path = d / name
        shutil.copy(src or s.fcn, path)
        return path

    over_input("calibrate CKPT --out CKPT", lambda s, d: (lambda c: (
        ["calibrate", str(c), "--data", str(s.bench), "--out", str(c), "--epochs", "1"],
        None))(own_copy(s, d)), "--out")
    over_input("calibrate --out a link to CKPT", lambda s, d: _link_case(s, d, own_copy),
               "--out")
    over_input("finetune CKPT --out CKPT", lambda s, d: (lambda c: (
        ["finetune", str(c), "--data", str(s.bench), "--out", str(c), "--epochs", "1"],
        None))(own_copy(s, d)), "--out")
    over_input("train --out a recording of --data", lambda s, d: (lambda data: (
        ["train", "--data", str(data), "--model", "fcn", "--out", str(trial(data))],
        None))(s.copy(d)), "--out")
    over_input("train --json = --out", lambda s, d: (
        ["train", "--data", str(s.bench), "--model", "fcn", "--out", str(d / "m.pt"),
         "--json", str(d / "m.pt")], None), "--json")
    over_input("train --out = --prior", lambda s, d: (lambda p: (
        ["train", "--data", str(s.bench), "--model", "hybrid", "--prior", str(p),
         "--out", str(p)], None))(own_copy(s, d, "prior.json", s.prior)), "--out")
    over_input("fit-prior --out DATA/metadata.json", lambda s, d: (lambda data: (
        ["fit-prior", "--data", str(data), "--out", str(data / "metadata.json")],
        None))(s.copy(d)), "--out")
    over_input("fit-dynamics --model-out a recording of --data", lambda s, d: (lambda data: (
        ["fit-dynamics", "--data", str(data), "--model-out", str(trial(data))],
        None))(s.copy(d)), "--model-out")
    over_input("wrench --out = the recording", lambda s, d: (lambda r: (
        ["wrench", str(r), "--dynamics", str(s.arm), "--out", str(r)], None))(
        own_copy(s, d, "rec.csv", trial(s.bench))), "--out")
    over_input("wrench --out = --dynamics", lambda s, d: (lambda a: (
        ["wrench", str(trial(s.bench)), "--dynamics", str(a), "--out", str(a)], None))(
        own_copy(s, d, "arm.json", s.arm)), "--out")
    over_input("convert --out = its CSV input", lambda s, d: (lambda r: (
        ["convert", str(r), "--out", str(r)], None))(
        own_copy(s, d, "rec.csv", trial(s.bench))), "--out")
    over_input("evaluate --out = --data", lambda s, d: (lambda data: (
        ["evaluate", str(s.fcn), "--data", str(data), "--out", str(data)], None))(s.copy(d)),
        "--out")
    over_input("train --json = a recording of --data", lambda s, d: (lambda data: (
        ["train", "--data", str(data), "--model", "fcn", "--out", str(d / "m.pt"),
         "--json", str(trial(data))], None))(s.copy(d)), "--json")
    return found
