"""Bad input against writes (issue 46, classes 1, 6 and 11): temporaries that could take a user's
file or follow a planted link, targets that are not regular files, two commands on one output
folder, names the file system cannot hold, option files that would hang or exhaust a reader."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from tests.robustness.harness import Attempt, Case, registrar, trial

TARGET_KINDS = ("a link to a file the user has", "a dangling link", "a named pipe", "a folder")
"""What a command's output may find at its path, none of which it may replace."""


def _plant(kind: str, target: Path, d: Path) -> None:
    theirs = d / "theirs.json"
    theirs.write_text('{"the user": "has this"}')
    if kind == TARGET_KINDS[0]:
        target.symlink_to(theirs)
    elif kind == TARGET_KINDS[1]:
        target.symlink_to(d / "nowhere.json")
    elif kind == TARGET_KINDS[2]:
        os.mkfifo(target)
    else:
        target.mkdir()


def _commands(s, d) -> dict:
    """Commands with an output file, as (argv without the output, the output's option)."""
    return {
        "simulate --json": (["simulate", "--scale", "0.005", "--out", str(d / "sim")], "--json"),
        "index --json": (["index", str(s.copy(d))], "--json"),
        "fit-prior --out": (["fit-prior", "--data", str(s.bench)], "--out"),
        "wrench --out": (["wrench", str(trial(s.bench)), "--dynamics", str(s.arm)], "--out"),
        "train --out": (["train", "--data", str(s.bench), "--model", "fcn", "--epochs", "1"],
                        "--out"),
        "upgrade-checkpoint --out": (["upgrade-checkpoint", str(s.fcn)], "--out"),
    }


COMMANDS = ("simulate --json", "index --json", "fit-prior --out", "wrench --out", "train --out",
            "upgrade-checkpoint --out")


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)

    # --- a target that is not a regular file: refused before the work, nothing replaced ------
    for command in COMMANDS:
        for kind in TARGET_KINDS:
            def prepare(s, d, command=command, kind=kind):
                argv, option = _commands(s, d)[command]
                target = d / "out.json"
                _plant(kind, target, d)
                return Attempt(argv=[*argv, option, str(target)], names=(option,),
                               guard="psmforce.estimators.training.train.load_dataset")
            found.append(Case(f"cli {command}: the target", kind, "REJECTED", prepare))
        for device in ("/dev/null", "/dev/stdout"):
            def to_device(s, d, command=command, device=device):
                argv, option = _commands(s, d)[command]
                return Attempt(argv=[*argv, option, device], names=(option,),
                               guard="psmforce.estimators.training.train.load_dataset")
            found.append(Case(f"cli {command}: the target", device, "REJECTED", to_device))

    # --- files beside the target, named as temporaries once were: never taken, never followed
    for name in ("{}.part", ".{}.part", ".{}.{pid}.part"):
        for planted in ("a file the user has", "a link to a file the user has"):
            def beside(s, d, name=name, planted=planted):
                out = d / "report.json"
                path = d / name.format(out.name, pid=os.getpid())
                theirs = d / "theirs.json"
                theirs.write_text('{"the user": "has this"}')
                if planted.startswith("a link"):
                    path.symlink_to(theirs)
                else:
                    shutil.copy(theirs, path)

                def check(_):
                    kept = theirs.read_text() == '{"the user": "has this"}' and (
                        path.is_symlink() or path.read_text() == theirs.read_text())
                    return kept and out.is_file(), f"written; {path.name} kept: {kept}"
                return Attempt(argv=["simulate", "--scale", "0.005", "--out", str(d / "sim"),
                                     "--json", str(out)], check=check)
            found.append(Case("cli simulate --json: beside the target",
                              f"{planted} named {name.format('NAME', pid='PID')}", "HANDLED",
                              beside))

    # --- two commands, one output folder: the second is refused while the first writes -------
    def held(run):
        def prepare(s, d):
            import subprocess
            import sys
            out = d / "out"
            out.mkdir()  # the user's folder, empty: the holder's lock is all it will hold
            holder = subprocess.Popen(
                [sys.executable, "-c", "import sys\nfrom psmforce.core.files import "
                 f"locked_folder\nwith locked_folder({str(out)!r}):\n    print('held', "
                 "flush=True)\n    sys.stdin.read()\n"], stdin=subprocess.PIPE,
                stdout=subprocess.PIPE, text=True)
            assert holder.stdout.readline().strip() == "held"
            argv = run(s, out)

            def release():
                holder.communicate("", timeout=60)
            return Attempt(argv=argv, names=(str(out),), cleanup=release)
        return prepare

    for name, run in (("simulate", lambda s, out: ["simulate", "--scale", "0.005", "--seed", "3",
                                                    "--out", str(out)]),
                      ("export", lambda s, out: ["export", str(s.hybrid), "--out", str(out)]),
                      ("evaluate", lambda s, out: ["evaluate", str(s.fcn), "--data",
                                                   str(s.bench), "--out", str(out)])):
        found.append(Case(f"cli {name}", "--out held by another command", "REJECTED",
                          held(run)))

    # --- names and option files checked before the work --------------------------------------
    for command in ("train --out", "fit-prior --out", "simulate --json"):
        def too_long(s, d, command=command):
            argv, option = _commands(s, d)[command]
            return Attempt(argv=[*argv, option, str(d / ("n" * 300 + ".json"))], names=(option,),
                           guard="psmforce.estimators.training.train.load_dataset")
        found.append(Case(f"cli {command}", "a name longer than the file system holds",
                          "REJECTED", too_long))

    for what in ("a named pipe", "/dev/zero", "a folder", "a 300-character inline JSON"):
        def config(s, d, what=what):
            if what == "a named pipe":
                value = str(d / "config.json")
                os.mkfifo(value)
            elif what == "a folder":
                value = str(d)
            elif what == "/dev/zero":
                value = what
            else:
                value = '{"hidden": 64' + ", " * 150 + "}"
            return Attempt(argv=["train", "--data", str(s.bench), "--model", "fcn", "--epochs",
                                 "1", "--config", value, "--out", str(d / "m.pt")],
                           names=("--config",),
                           guard="psmforce.estimators.training.train.load_dataset")
        found.append(Case("cli train --config", what, "REJECTED", config))
    # --- side files and every path read: through the same guard (class 2) ---------------------
    def replay_bag(s, d):
        from psmforce.io.bags.writing import write_bag
        from psmforce.io.recording import read_recording
        bag = d / "session"
        write_bag(read_recording(trial(s.bench)), bag, start_ns=1_700_000_000 * 10**9)
        return bag

    @case("cli replay", "a layout already beside --out")
    def _(s, d):
        bag = replay_bag(s, d)
        (d / "run.layout.json").write_text('{"the user": "has this"}')
        return Attempt(argv=["replay", str(bag), str(s.hybrid), "--out", str(d / "run.mcap")],
                       names=("--out",))

    @case("cli replay", "--json names the layout it writes")
    def _(s, d):
        bag = replay_bag(s, d)
        return Attempt(argv=["replay", str(bag), str(s.hybrid), "--out", str(d / "run.mcap"),
                             "--json", str(d / "run.layout.json")], names=("--json",))

    @case("cli serve", "--json names the --sim-recording it publishes")
    def _(s, d):
        rec = d / "rec.csv"
        shutil.copy(trial(s.bench), rec)
        return Attempt(argv=["serve", str(s.hybrid), "--sim", "--sim-recording", str(rec),
                             "--json", str(rec)], names=("--json",))
    return found
