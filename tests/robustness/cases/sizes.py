"""Bad input against sizes (issue 46, class 8): every size or duration an option asks for is
bounded before any allocation or wait, and every input must be a regular file of bounded size
(a pipe would hang its reader, a device exhaust the memory)."""

from __future__ import annotations

import os

from tests.robustness.harness import Attempt, Case, trial

OPTIONS = (
    ("convert", ["--rate", "1e9"], "--rate"),
    ("convert", ["--rate", "-100"], "--rate"),
    ("serve", ["--sim", "--sim-rate", "1e9"], "--sim-rate"),
    ("serve", ["--sim", "--sim-rate", "0"], "--sim-rate"),
    ("serve", ["--sim", "--sim-rate", "-1000"], "--sim-rate"),
    ("serve", ["--duration", "nan"], "--duration"),
    ("serve", ["--duration", "-1"], "--duration"),
    ("serve", ["--idle-stop", "inf"], "--idle-stop"),
    ("serve", ["--tare-s", "0"], "--tare-s"),
    ("serve", ["--input-rate", "1e12"], "--input-rate"),
    ("serve", ["--domain-id", "300"], "--domain-id"),
    ("serve", ["--domain-id", "-5"], "--domain-id"),
    ("serve", ["--rt-priority", "100"], "--rt-priority"),
    ("replay", ["--port", "70000"], "--port"),
    ("replay", ["--view-wait", "nan"], "--view-wait"),
)
"""(command, the bad option and its value, the option a refusal must name)."""


def _argv(s, d, command: str) -> list[str]:
    if command == "convert":
        return ["convert", str(d / "session"), "--out", str(d / "out.csv")]
    if command == "replay":
        return ["replay", str(d / "session"), str(s.hybrid), "--out", str(d / "out.mcap")]
    return ["serve", str(s.hybrid)]


SPECIAL = ("/dev/zero", "a named pipe")


def _special(kind: str, d) -> str:
    if kind == "/dev/zero":
        return kind
    path = d / "input"
    os.mkfifo(path)
    return str(path)


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    for command, bad, option in OPTIONS:
        def prepare(s, d, command=command, bad=bad, option=option):
            return Attempt(argv=[*_argv(s, d, command), *bad], names=(option,))
        found.append(Case(f"cli {command}", " ".join(bad), "REJECTED", prepare))

    inputs = {
        "train --prior": lambda s, d, p: (["train", "--data", str(s.bench), "--model", "hybrid",
                                           "--prior", p, "--epochs", "1",
                                           "--out", str(d / "m.pt")], p),
        "convert --r-ati-psm": lambda s, d, p: (["convert", str(d / "session"), "--out",
                                                 str(d / "o.csv"), "--r-ati-psm", p], p),
        "wrench --dynamics": lambda s, d, p: (["wrench", str(trial(s.bench)), "--dynamics", p,
                                               "--out", str(d / "w.csv")], p),
        "wrench RECORDING": lambda s, d, p: (["wrench", p, "--dynamics", str(s.arm), "--out",
                                              str(d / "w.csv")], p),
        "evaluate CKPT": lambda s, d, p: (["evaluate", p, "--data", str(s.bench), "--out",
                                           str(d / "eval")], p),
        "export CKPT": lambda s, d, p: (["export", p, "--out", str(d / "export")], p),
    }
    for name, build in inputs.items():
        for kind in SPECIAL:
            def special(s, d, build=build, kind=kind):
                argv, path = build(s, d, _special(kind, d))
                return Attempt(argv=argv, names=(path,),
                               guard="psmforce.estimators.training.train.load_dataset")
            found.append(Case(f"cli {name}", f"{kind} as the input", "REJECTED", special))
    return found
