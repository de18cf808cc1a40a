"""Bad input against the live commands (issue 46, class 9): names outside ROS 2's rules, a
corrupt message in a bag, a checkpoint that names a module of its own, a node stopped by a
signal."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

from tests.robustness.harness import Attempt, Case, edit_checkpoint, registrar, trial

BAD_NAMES = {
    "a space": "PS M1", "a newline": "PSM\n1", "a leading digit": "1PSM", "a hyphen": "PSM-1",
    "an empty token": "PSM//1", "a tilde": "~/PSM1", "a substitution": "{node}",
    "a non-ASCII letter": "PSMé", "300 characters": "P" * 300, "only a slash": "/",
}
"""Names ROS 2 refuses (rmw_validate_full_topic_name), each typed where a name goes."""
TOPIC_OPTIONS = {"serve": ("--topic-js", "--topic-jaw", "--topic-hex10"),
                 "replay": ("--topic-js", "--topic-jaw", "--topic-hex10", "--topic-ati"),
                 "convert": ("--topic-js", "--topic-hex10")}

DAMAGE = {
    "cut to 10 bytes": lambda raw: raw[:10],
    "empty": lambda raw: b"",
    "its frame_id 2 GiB long": lambda raw: raw[:12] + (0x7FFFFFFF).to_bytes(4, "little")
    + raw[16:],
    "its bytes reversed": lambda raw: raw[::-1],
}
"""Ways a recorded message's bytes stop holding it (offset 12: the frame_id's length, after
the CDR header and the stamp)."""


def _session(s, d):
    from psmforce.io.bags.writing import write_bag
    from psmforce.io.recording import read_recording
    bag = d / "session"
    write_bag(read_recording(trial(s.bench)), bag, start_ns=1_700_000_000 * 10**9)
    return bag


def corrupt_bag(bag, out, topic: str, damage, which) -> int:
    """``bag`` copied to ``out`` with ``damage`` applied to the messages of ``topic`` whose
    index ``which(k)`` selects; returns how many were damaged."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import Writer

    from psmforce.io.bags import ROS2_TYPESTORE
    damaged = 0
    with AnyReader([bag], default_typestore=ROS2_TYPESTORE) as reader, \
            Writer(out, version=9) as writer:
        connections = {c.topic: writer.add_connection(c.topic, c.msgtype,
                                                      typestore=ROS2_TYPESTORE)
                       for c in reader.connections}
        seen: dict[str, int] = {}
        for connection, log_ns, raw in reader.messages():
            raw = bytes(raw)
            k = seen[connection.topic] = seen.get(connection.topic, -1) + 1
            if connection.topic == topic and which(k):
                raw, damaged = damage(raw), damaged + 1
            writer.write(connections[connection.topic], log_ns, raw)
    return damaged


def _skipped(n: int):
    def check(stdout: str):
        ok = f"skipped {n} messages that did not decode" in stdout
        return ok, stdout.strip().splitlines()[-1][-200:] if stdout.strip() else "no output"
    return check


def _stopped_by(signum: int):
    """``serve --sim`` in its own process, sent ``signum`` once it answers: it must end with
    exit 0 and its report written."""
    def prepare(s, d):
        def run():
            report = d / "report.json"
            env = {**os.environ, "OMP_NUM_THREADS": "1"}
            node = subprocess.Popen([sys.executable, "-m", "psmforce.cli.main", "serve",
                                     str(s.hybrid), "--sim", "--json", str(report)],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                    env=env)
            try:
                node.stdout.readline()  # listening
                time.sleep(3.0)
                node.send_signal(signum)
                out, err = node.communicate(timeout=60)
            finally:
                node.kill()
            return node.returncode, report, err
        def check(result):
            rc, report, err = result
            if rc != 0 or not report.exists():
                return False, f"exit {rc}, report {'written' if report.exists() else 'missing'}: {err.strip()[-200:]}"
            received = json.loads(report.read_text())["received"]
            return True, f"exit 0, report written ({received['hex10']} HEX10 messages)"
        return Attempt(call=run, check=check, outputs=("report.json",))
    return prepare


def cases() -> list[Case]:
    """The cases of this artefact, in a fixed order."""
    found: list[Case] = []
    case = registrar(found)

    # --- names: ROS 2's rules, refused by argparse before anything is read or created -----
    def argv(s, d, command):
        if command == "serve":
            return ["serve", str(s.hybrid), "--duration", "0.1"]
        if command == "replay":
            return ["replay", str(d / "session"), str(s.hybrid), "--out", str(d / "out.mcap")]
        return ["convert", str(d / "session"), "--out", str(d / "out.csv")]
    for command in ("serve", "replay", "convert"):
        for label, name in BAD_NAMES.items():
            def arm(s, d, command=command, name=name):
                return Attempt(argv=[*argv(s, d, command), "--arm", name], names=("--arm",))
            found.append(Case(f"cli {command} --arm", f"{label}", "REJECTED", arm))
        for option in TOPIC_OPTIONS[command]:
            for label in ("a space", "a hyphen", "an empty token"):
                def topic(s, d, command=command, option=option, name=BAD_NAMES[label]):
                    return Attempt(argv=[*argv(s, d, command), option, name], names=(option,))
                found.append(Case(f"cli {command} {option}", label, "REJECTED", topic))

    # --- a corrupt message in a bag: skipped and counted, the replay goes on ---------------
    streams = {"HEX10": "/hex10/measured_cf", "arm": "/PSM1/measured_js",
               "jaw": "/PSM1/jaw/measured_js"}
    for stream, topic in streams.items():
        for label, damage in DAMAGE.items():
            if stream != "HEX10" and label != "cut to 10 bytes":
                continue
            def one(s, d, topic=topic, damage=damage):
                n = corrupt_bag(_session(s, d), d / "corrupt", topic, damage, lambda k: k == 40)
                return Attempt(argv=["replay", str(d / "corrupt"), str(s.hybrid), "--out",
                                     str(d / "out.mcap")], check=_skipped(n))
            found.append(Case("cli replay", f"one {stream} message {label}", "HANDLED", one))
    for label, which in (("the first five HEX10 messages", lambda k: k < 5),
                         ("every tenth HEX10 message", lambda k: k % 10 == 3)):
        def many(s, d, which=which):
            n = corrupt_bag(_session(s, d), d / "corrupt", streams["HEX10"], DAMAGE["empty"],
                            which)
            return Attempt(argv=["replay", str(d / "corrupt"), str(s.hybrid), "--out",
                                 str(d / "out.mcap")], check=_skipped(n))
        found.append(Case("cli replay", f"{label} empty", "HANDLED", many))

    # --- serve: refused before it subscribes ---------------------------------------------
    @case("cli serve", "a checkpoint that does not exist")
    def _(s, d):
        return Attempt(argv=["serve", str(d / "missing.pt"), "--duration", "5"],
                       names=("missing.pt",))

    @case("cli serve", "a checkpoint of a model that does not stream (LSTM)")
    def _(s, d):
        return Attempt(argv=["serve", str(s.lstm), "--duration", "5"], names=("lstm",))

    # --- modules: a file never decides which code is imported (class 3) -------------------
    for label, module in (("not a module name", "os; rm -rf"), ("a script", "__main__"),
                          ("not importable", "no_such_module_xyz"),
                          ("an attribute path", "json:loads")):
        def plugin(s, d, module=module):
            return Attempt(argv=["--plugin", module, "evaluate", str(s.fcn), "--data",
                                 str(s.bench), "--out", str(d / "eval")], names=("plugin",))
        found.append(Case("cli --plugin", label, "REJECTED", plugin))

    @case("cli evaluate", "resealed: names a module of its own that would run if imported")
    def _(s, d):
        planted = d / "modules"
        planted.mkdir()
        ran = d.parent.parent / "outside" / f"{d.name}.ran"
        (planted / "planted_models.py").write_text(
            f"import pathlib\npathlib.Path({str(ran)!r}).write_text('imported')\n")
        sys.path.insert(0, str(planted))

        def edit(meta, payload):
            meta.update(model="planted", recipe="planted_models:PLANTED")
        ckpt = edit_checkpoint(s.fcn, d / "planted.pt", edit, reseal=True)
        return Attempt(argv=["evaluate", str(ckpt), "--data", str(s.bench), "--out",
                             str(d / "eval")], names=("planted_models",),
                       cleanup=lambda: (sys.path.remove(str(planted)),
                                        sys.modules.pop("planted_models", None)))

    # --- signals: the node ends with its report --------------------------------------------
    for signum in (signal.SIGINT, signal.SIGTERM):
        found.append(Case("cli serve --sim", f"{signal.Signals(signum).name} while it answers",
                          "HANDLED", _stopped_by(signum)))
    return found
