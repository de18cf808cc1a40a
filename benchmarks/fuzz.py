"""Bad input against the command line and the Python API (issue 14): every case runnable, each
classified automatically.

    python benchmarks/fuzz.py [--json results/benchmarks/fuzz.json] [--only TEXT]

Builds once, in a temporary folder, a tiny simulated bench (scale 0.005, seed 0: 20 recordings of
240-1120 samples), a nominal prior (default parameters, the insertion model at physical values)
and two one-epoch checkpoints (fcn, hybrid); then runs each case in its own folder, CLI cases
in-process (``psmforce.cli.main``, stdout and stderr captured). Verdicts:

REJECTED  exit 2 (CLI) or a library error (a ValueError or OSError: the library's own error
          types derive from ValueError) whose one-line message names the file or option the
          case names, and every file in the case's folder and the shared inputs unchanged;
HANDLED   accepted, and the case's own check of the output holds (output correct, or the problem
          flagged in it);
UNCLEAR   rejected, but the message is not one line naming the file or option;
SILENT    accepted with wrong, NaN or misleading output, or rejected leaving files behind;
CRASH     a traceback: an exception the CLI does not catch, or from the API one that is not a
          library error (TypeError, IndexError, AttributeError, ...), or an exit code not 0 / 2
          (3 is the CLI's "internal error": a bug its error boundary caught);
ESCAPE    the case reached outside its folder: a file changed in the shared inputs or in the
          ``outside`` folder beside the cases, or a case that points a file outside its folder
          (an export's graph) was accepted.

Issue 26 added the classes of :func:`integrity_cases`: checkpoints with one metadata field
edited, a non-integer format version or a config out of range (some resealed, as a careless tool
would); model configs; timestamps that overflow the stream's gap arithmetic; the export runner
(edited or foreign folders, a graph outside its folder, bad recordings); outputs naming an
input; repeated seeds; degenerate targets and train/test overlap; edited cached task results;
fits that must print their verdict. :func:`prior_envelope_cases` and
:func:`more_integrity_cases` go beyond the issue's report: prior files with one field edited or a
version that is not the integer, timestamps on a decimating stream and on a clock past float
resolution, array samples of a non-real dtype, tables the export runner cannot read as the
stream would (a column twice, complex, no rows), repeated seeds from Python.

Each case also states the verdict it should get (REJECTED or HANDLED). Cases whose acceptance
would start expensive work (a simulation at scale 1e6, a reproduce run) patch that work to raise
:class:`Reached`: reaching it with the bad input is SILENT. Prints the counts and every case that
is not REJECTED or HANDLED (and any verdict other than expected), writes the JSON, exits 1 if any
case is SILENT, UNCLEAR or CRASH or differs from its expected verdict.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import contextlib  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from collections import Counter  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Callable  # noqa: E402
from unittest import mock  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import torch  # noqa: E402

from _report import write_json  # noqa: E402
from streaming_fuzz import NOMINAL_INSERTION  # noqa: E402  (a fit is not what is tested here)

SCALE = 0.005
"""The bench's protocol scale: tiny, every trial at or near the simulator's minimum length."""
RECOVERED_N = 1e-3
"""Some 250 samples after one corrupted sample a stream is back on the clean stream's estimates
within a millinewton (far below any sensor's resolution): a refused sample never entered the
network or the filter, and the 5 Hz filter has long forgotten a one-sample shift."""
EXPECTED = ("REJECTED", "HANDLED")
FAILING = ("SILENT", "UNCLEAR", "CRASH", "ESCAPE")


class Reached(Exception):
    """Raised by a patched expensive step: the bad input got past every check to the work."""


@dataclass
class Attempt:
    """One prepared case: what to run and what its outcome must show."""
    argv: list[str] | None = None              # CLI arguments (``psmforce`` ...)
    call: Callable | None = None               # or a Python call
    names: tuple[str, ...] = ()                # a rejection must name one of these
    check: Callable | None = None              # acceptance: result -> (ok, note)
    guard: str | None = None                   # dotted attribute that acceptance would reach
    escape: bool = False                       # acceptance means a file outside was used


@dataclass
class Case:
    kind: str
    name: str
    expect: str
    prepare: Callable  # (shared: Shared, folder: Path) -> Attempt


@dataclass
class Outcome:
    verdict: str
    detail: str
    seconds: float = 0.0


# ---------------------------------------------------------------------------- shared inputs

class Shared:
    """The bench, prior, arm model and checkpoints every case starts from (never modified by a
    case)."""

    def __init__(self, root: Path):
        from hybrid.train import train
        from psm_model.identification.insertion import InsertionEffortModel
        from psm_model.identification.prior import InternalForcePrior
        from psm_model.sim import simulate
        self.root = root
        self.bench = root / "bench"
        simulate("automated", scale=SCALE, seed=0, out=self.bench)
        self.prior = root / "prior.json"
        InternalForcePrior(converged=True, insertion=InsertionEffortModel(
            NOMINAL_INSERTION, 0.005, {})).save(self.prior)
        from psm_model.identification import fit_dynamics_cli
        self.arm = root / "arm.json"
        with contextlib.redirect_stdout(io.StringIO()):  # IPOPT's banner
            fit_dynamics_cli(data=self.bench, model_out=self.arm, accept_poor_fit=True)
        quiet = io.StringIO()
        with contextlib.redirect_stderr(quiet):  # progress bars
            self.fcn = Path(train(self.bench, "fcn", root / "fcn.pt", epochs=1)["checkpoint"])
            self.hybrid = Path(train(self.bench, "hybrid", root / "hybrid.pt", epochs=1,
                                     prior=self.prior)["checkpoint"])
        from hybrid.export import export
        self.export = root / "export"
        export(self.hybrid, self.export)

    def copy(self, folder: Path) -> Path:
        data = folder / "bench"
        shutil.copytree(self.bench, data)
        return data


def trial(data: Path, split: str = "train", condition: str = "Free") -> Path:
    return sorted(data.glob(f"{split}/{condition}/*.csv"))[0]


def edit_csv(path: Path, change: Callable[[pd.DataFrame], pd.DataFrame | None]) -> None:
    """Rewrite a recording through pandas (not write_recording, which refuses bad values)."""
    change(pd.read_csv(path)).to_csv(path, index=False)


def _set(column: str, value, row: int = 7):
    def change(frame):
        if isinstance(value, str):
            frame[column] = frame[column].astype(object)
        frame.loc[row, column] = value
        return frame
    return change


def _time(change):
    def edit(frame):
        t = frame["time"].to_numpy().copy()
        change(t)
        frame["time"] = t
        return frame
    return edit


def _swap(t):
    t[10], t[11] = t[11], t[10]


def _repeat(t):
    t[11] = t[10]


def _garbage(path: Path) -> None:
    path.write_bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes())


RECORDING_DAMAGE: dict[str, Callable[[Path], None]] = {
    "zero-byte file": lambda p: p.write_bytes(b""),
    "text, not CSV": lambda p: p.write_text("this is not a recording\n"),
    "binary garbage": _garbage,
    "header only": lambda p: p.write_text(p.read_text().splitlines()[0] + "\n"),
    "ragged row": lambda p: p.write_text(p.read_text() + "1,2,3\n"),
    "missing column": lambda p: edit_csv(p, lambda f: f.drop(columns=["roll_effort"])),
    "NaN cell": lambda p: edit_csv(p, _set("yaw_effort", np.nan)),
    "inf cell": lambda p: edit_csv(p, _set("fz", np.inf)),
    "text cell": lambda p: edit_csv(p, _set("roll_effort", "abc")),
    "backwards time": lambda p: edit_csv(p, _time(_swap)),
    "duplicate time": lambda p: edit_csv(p, _time(_repeat)),
}
"""What a recording file can be instead of a recording: each read refuses it naming the file."""


# ---------------------------------------------------------------------------- running a case

def _tree(*roots: Path) -> dict:
    """Every file under ``roots`` with its size and modification time: what a rejection must
    leave as it found it."""
    state = {}
    for root in roots:
        for p in sorted(root.rglob("*")):
            if p.is_file():
                st = p.stat()
                state[str(p)] = (st.st_size, st.st_mtime_ns)
            elif p.is_dir():
                state[str(p)] = "dir"
    return state


def _changes(before: dict, after: dict) -> list[str]:
    return sorted({k for k in before.keys() | after.keys() if before.get(k) != after.get(k)})


def _guarded(target: str | None):
    if target is None:
        return contextlib.nullcontext()
    return mock.patch(target, side_effect=Reached(target))


def run_case(case: Case, shared: Shared, folder: Path) -> Outcome:
    folder.mkdir(parents=True)
    outside = folder.parent.parent / "outside"  # beside the cases: nothing may change it
    outside.mkdir(exist_ok=True)
    attempt = case.prepare(shared, folder)
    before = _tree(folder, shared.root, outside)
    around = _tree(shared.root, outside)
    out, err = io.StringIO(), io.StringIO()
    result, error, rc = None, None, None
    start = time.perf_counter()
    with _guarded(attempt.guard), contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        try:
            if attempt.argv is not None:
                from psmforce.cli import main
                try:
                    rc = main(attempt.argv)
                except SystemExit as exit_:  # argparse
                    rc = exit_.code if isinstance(exit_.code, int) else 1
            else:
                result = attempt.call()
        except Exception as exc:  # noqa: BLE001 - classified below
            error = exc
            trace = traceback.format_exc()
    seconds = time.perf_counter() - start
    left = _changes(before, _tree(folder, shared.root, outside))
    escaped = _changes(around, _tree(shared.root, outside))
    stderr = err.getvalue()

    def outcome(verdict, detail):
        return Outcome(verdict, detail, seconds)

    if escaped:
        return outcome("ESCAPE", "changed outside its folder: "
                                 + ", ".join(Path(p).name for p in escaped[:5]))
    if isinstance(error, Reached):
        return outcome("SILENT", f"accepted: reached {error} with the bad input" + (
            "; wrote " + ", ".join(Path(p).name for p in left[:5]) if left else ""))
    if error is not None and (attempt.argv is not None or not isinstance(error, (ValueError,
                                                                                  OSError))):
        return outcome("CRASH", f"{type(error).__name__}: {error} | "
                                f"{trace.strip().splitlines()[-3].strip()}")
    if attempt.argv is not None:
        if rc not in (0, 2):
            return outcome("CRASH", f"exit {rc}: {stderr.strip()[-300:]}")  # 3: a caught bug
        if "Traceback" in stderr:
            return outcome("CRASH", f"traceback on stderr: {stderr.strip()[-300:]}")
        if rc == 2:
            lines = [ln for ln in stderr.splitlines() if ln.startswith("psmforce ")]
            message = lines[-1] if lines else stderr.strip()
            return _rejected(message, len(lines) == 1, attempt, left, outcome)
    elif error is not None:
        message = str(error)
        return _rejected(message, "\n" not in message.strip(), attempt, left, outcome)
    if attempt.escape:
        return outcome("ESCAPE", "accepted, using a file outside its folder: "
                                 + (stderr.strip() or out.getvalue().strip())[-200:])
    if attempt.check is None:
        return outcome("SILENT", "accepted: " + (stderr.strip() or out.getvalue().strip())[-200:])
    ok, note = attempt.check(result if attempt.argv is None else out.getvalue())
    return outcome("HANDLED" if ok else "SILENT", note)


def _rejected(message: str, one_line: bool, attempt: Attempt, left: list[str], outcome):
    if left:
        return outcome("SILENT", f"rejected ({message}) but left behind: "
                                 + ", ".join(Path(p).name for p in left[:5]))
    named = [n for n in attempt.names if n in message]
    if not one_line or not named:
        return outcome("UNCLEAR", f"names none of {list(attempt.names)}: {message}")
    return outcome("REJECTED", message)


# ---------------------------------------------------------------------------- the cases

def cases() -> list[Case]:
    found: list[Case] = []

    def case(kind: str, name: str, expect: str = "REJECTED"):
        def register(prepare):
            found.append(Case(kind, name, expect, prepare))
            return prepare
        return register

    # --- recordings: every reader refuses a damaged file naming it --------------------------
    for damage, apply in RECORDING_DAMAGE.items():
        def read(s, d, apply=apply):
            from psm_model.recording import read_recording
            path = d / "rec.csv"
            shutil.copy(trial(s.bench), path)
            apply(path)
            return Attempt(call=lambda: read_recording(path), names=(str(path),))
        found.append(Case("api read_recording", damage, "REJECTED", read))

        def train_on(s, d, apply=apply):
            data = s.copy(d)
            bad = trial(data)
            apply(bad)
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(str(bad),))
        found.append(Case("cli train: recording", damage, "REJECTED", train_on))

        def evaluate_on(s, d, apply=apply):
            data = s.copy(d)
            bad = trial(data, "test", "Palpation")
            apply(bad)
            return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                                 "--out", str(d / "eval")], names=(str(bad),))
        found.append(Case("cli evaluate: recording", damage, "REJECTED", evaluate_on))

    for damage in ("zero-byte file", "NaN cell", "text cell", "backwards time",
                   "missing column"):
        def wrench_on(s, d, apply=RECORDING_DAMAGE[damage]):
            rec = d / "rec.csv"
            shutil.copy(trial(s.bench), rec)
            apply(rec)
            return Attempt(argv=["wrench", str(rec), "--dynamics", str(s.arm),
                                 "--out", str(d / "w.csv")], names=(str(rec),))
        found.append(Case("cli wrench: recording", damage, "REJECTED", wrench_on))

        def finetune_on(s, d, apply=RECORDING_DAMAGE[damage]):
            data = s.copy(d)
            bad = trial(data)
            apply(bad)
            return Attempt(argv=["finetune", str(s.fcn), "--data", str(data), "--epochs", "1",
                                 "--out", str(d / "t.pt")], names=(str(bad),))
        found.append(Case("cli finetune: recording", damage, "REJECTED", finetune_on))

    for damage in ("zero-byte file", "NaN cell", "text cell", "backwards time"):
        def fit_prior_on(s, d, apply=RECORDING_DAMAGE[damage]):
            data = s.copy(d)
            bad = trial(data)
            apply(bad)
            return Attempt(argv=["fit-prior", "--data", str(data), "--out", str(d / "p.json")],
                           names=(str(bad),))
        found.append(Case("cli fit-prior: recording", damage, "REJECTED", fit_prior_on))

        def convert_on(s, d, apply=RECORDING_DAMAGE[damage]):
            src = d / "export.csv"
            shutil.copy(trial(s.bench), src)
            apply(src)
            return Attempt(argv=["convert", str(src), "--out", str(d / "out.csv")],
                           names=(str(src),))
        found.append(Case("cli convert: CSV export", damage, "REJECTED", convert_on))

    # --- write_recording refuses what read_recording would refuse ---------------------------
    for damage, change in (("NaN cell", _set("yaw_effort", np.nan)),
                           ("inf cell", _set("fz", -np.inf)),
                           ("backwards time", _time(_swap)),
                           ("duplicate time", _time(_repeat)),
                           ("missing column", lambda f: f.drop(columns=["roll_effort"]))):
        def write(s, d, change=change):
            from psm_model.recording import write_recording
            frame = change(pd.read_csv(trial(s.bench)))
            path = d / "rec.csv"
            return Attempt(call=lambda: write_recording(frame, path), names=(str(path),))
        found.append(Case("api write_recording", damage, "REJECTED", write))

    # --- physically impossible values ------------------------------------------------------
    for what, column, value in (("insertion 5 m", "insertion_position", 5.0),
                                ("roll 1e30 rad", "roll_position", 1e30),
                                ("fz 1e39 N", "fz", 1e39)):
        def impossible(s, d, column=column, value=value):
            data = s.copy(d)
            bad = trial(data)
            edit_csv(bad, _set(column, value))
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(str(bad),))
        found.append(Case("cli train: recording", f"out of range: {what}", "REJECTED",
                          impossible))

    # --- datasets: whole or refused ---------------------------------------------------------
    def dataset_case(name, damage, expect="REJECTED"):
        def prepare(s, d):
            data = s.copy(d)
            named = damage(data)
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(named or str(data),))
        found.append(Case("cli train: dataset", name, expect, prepare))

    def metadata(text):
        def damage(data):
            (data / "metadata.json").write_text(text)
            return str(data / "metadata.json")
        return damage

    def meta_trials(edit):
        def damage(data):
            meta = json.loads((data / "metadata.json").read_text())
            meta["trials"] = edit(meta["trials"])
            (data / "metadata.json").write_text(json.dumps(meta))
            return str(data / "metadata.json")
        return damage

    dataset_case("interrupted simulate (no metadata.json)",
                 lambda data: (data / "metadata.json").unlink())
    dataset_case("metadata.json zero bytes", metadata(""))
    dataset_case("metadata.json invalid JSON", metadata("{trials: ["))
    dataset_case("metadata.json a list", metadata("[1, 2]"))
    dataset_case("metadata trials []", meta_trials(lambda t: []))
    dataset_case("metadata trial without path",
                 meta_trials(lambda t: [{k: v for k, v in e.items() if k != "path"} for e in t]))
    dataset_case("metadata trial path outside the folder",
                 meta_trials(lambda t: [{**t[0], "path": "../../etc/passwd"}] + t[1:]))
    dataset_case("metadata trial path a number",
                 meta_trials(lambda t: [{**t[0], "path": 3}] + t[1:]))

    def listed_missing(data):
        path = trial(data)
        path.unlink()
        return str(path)
    dataset_case("a listed recording deleted", listed_missing)
    def no_train_split(data):
        meta_trials(lambda t: [e for e in t if e["split"] != "train"])(data)
        return str(data)
    dataset_case("no train split", no_train_split)

    def no_targets(data):
        bad = trial(data)
        edit_csv(bad, lambda f: f.drop(columns=["ati_fx", "ati_fy", "ati_fz"]))
        return str(bad)
    dataset_case("recording without ATI targets", no_targets)

    @case("cli train: dataset", "train recording shorter than the transformer's window")
    def _(s, d):
        data = s.copy(d)
        bad = trial(data, "train", "Traction")
        edit_csv(bad, lambda f: f.iloc[:50])
        return Attempt(argv=["train", "--data", str(data), "--model", "transformer",
                             "--epochs", "1", "--out", str(d / "m.pt")],
                       names=(bad.relative_to(data).as_posix(),))

    @case("cli train: dataset", "data folder missing")
    def _(s, d):
        return Attempt(argv=["train", "--data", str(d / "nowhere"), "--model", "fcn",
                             "--out", str(d / "m.pt")], names=(str(d / "nowhere"),))

    @case("cli train: dataset", "data folder empty")
    def _(s, d):
        (d / "empty").mkdir()
        return Attempt(argv=["train", "--data", str(d / "empty"), "--model", "fcn",
                             "--out", str(d / "m.pt")], names=(str(d / "empty"),))

    @case("cli train: dataset", "data is a file")
    def _(s, d):
        return Attempt(argv=["train", "--data", str(s.fcn), "--model", "fcn",
                             "--out", str(d / "m.pt")], names=(str(s.fcn),))

    @case("api train", "short Traction trials (240 < chunk 400) trained on, not dropped",
          "HANDLED")
    def _(s, d):
        from hybrid.checkpoint import load_checkpoint
        from hybrid.data import load_dataset
        from hybrid.train import train
        out = d / "h.pt"

        def check(result):
            ckpt = load_checkpoint(out)
            used = set(ckpt.provenance["train_trials"]) | set(ckpt.provenance["val_trials"])
            listed = {t.path for t in load_dataset(s.bench).select(split="train")}
            traction = [p for p in used if "/Traction/" in p]
            return (used == listed and bool(traction),
                    f"chunk {result['chunk']}: all {len(listed)} train recordings used, "
                    f"{len(traction)} Traction")

        def run():
            with contextlib.redirect_stderr(io.StringIO()):
                return train(s.bench, "hybrid", out, epochs=1, prior=s.prior)
        return Attempt(call=run, check=check)

    @case("cli index", "interrupted simulate indexed explicitly", "HANDLED")
    def _(s, d):
        data = s.copy(d)
        (data / "metadata.json").unlink()
        n = len(list(data.rglob("*.csv")))

        def check(stdout):
            from hybrid.data import load_dataset
            got = len(load_dataset(data).trials)
            return got == n, f"{got} of {n} recordings listed: {stdout.strip()}"
        return Attempt(argv=["index", str(data)], check=check)

    @case("cli index", "folder already a dataset")
    def _(s, d):
        data = s.copy(d)
        return Attempt(argv=["index", str(data)], names=(str(data),))

    @case("cli index", "missing folder")
    def _(s, d):
        return Attempt(argv=["index", str(d / "nowhere")], names=(str(d / "nowhere"),))

    @case("cli index", "folder without recordings")
    def _(s, d):
        (d / "empty").mkdir()
        (d / "empty" / "notes.txt").write_text("no csv here\n")
        return Attempt(argv=["index", str(d / "empty")], names=(str(d / "empty"),))

    @case("cli index", "a file")
    def _(s, d):
        path = d / "rec.csv"
        shutil.copy(trial(s.bench), path)
        return Attempt(argv=["index", str(path)], names=(str(path),))

    # --- train options -----------------------------------------------------------------------
    def train_option(name, extra, names, out="m.pt", guard="hybrid.train.load_dataset"):
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
                       guard="hybrid.train.load_dataset")

    # --- priors ------------------------------------------------------------------------------
    def prior_file(s, d, edit):
        """The shared prior with ``edit`` applied: text as given, an edited document resealed
        (a careless tool), so that its parameter bounds, not its envelope, must refuse it."""
        from hybrid.integrity import seal
        path = d / "prior.json"
        doc = json.loads(s.prior.read_text())
        text = edit(doc)
        path.write_text(text if isinstance(text, str) else json.dumps(seal(doc)))
        return path

    def set_param(name, value):
        def edit(doc):
            doc["parameters"][name]["value"] = value
        return edit

    prior_damage = {
        "zero-byte": lambda doc: "",
        "not JSON": lambda doc: "prior: yes\n",
        "a list": lambda doc: "[1, 2, 3]",
        "a string": lambda doc: '"prior"',
        "another format": lambda doc: json.dumps({"format": "psm-arm-dynamics"}),
        "string parameter": set_param("bias_fz", "0.1"),
        "NaN parameter": set_param("pretension_total", float("nan")),
        "infinite parameter": set_param("bias_fx", float("inf")),
        "negative pulley radius": set_param("pulley_radius_pitch", -1.0),
        "null parameter": set_param("distal_mass", None),
        "parameters a list": lambda doc: json.dumps({**doc, "parameters": [1, 2]}),
    }
    for damage, edit in prior_damage.items():
        def load(s, d, edit=edit):
            from psm_model.identification.prior import InternalForcePrior
            path = prior_file(s, d, edit)
            return Attempt(call=lambda: InternalForcePrior.load(path), names=(str(path),))
        found.append(Case("api InternalForcePrior.load", damage, "REJECTED", load))

        def train_with(s, d, edit=edit):
            path = prior_file(s, d, edit)
            return Attempt(argv=["train", "--data", str(s.bench), "--model", "hybrid",
                                 "--prior", str(path), "--epochs", "1", "--out", str(d / "h.pt")],
                           names=(str(path),))
        found.append(Case("cli train --prior", damage, "REJECTED", train_with))

    @case("cli train --prior", "missing file")
    def _(s, d):
        return Attempt(argv=["train", "--data", str(s.bench), "--model", "hybrid", "--prior",
                             str(d / "none.json"), "--epochs", "1", "--out", str(d / "h.pt")],
                       names=(str(d / "none.json"),))

    @case("cli fit-prior", "one training trial reads fz = 1e6 N (poor fit)")
    def _(s, d):
        data = s.copy(d)
        edit_csv(trial(data), lambda f: f.assign(fz=1e6))
        out = d / "p.json"
        return Attempt(argv=["fit-prior", "--data", str(data), "--out", str(out)],
                       names=("--accept-poor-fit",))

    @case("cli fit-prior", "--data missing")
    def _(s, d):
        return Attempt(argv=["fit-prior", "--data", str(d / "none"), "--out", str(d / "p.json")],
                       names=(str(d / "none"),))

    @case("cli fit-prior", "--out is a folder")
    def _(s, d):
        return Attempt(argv=["fit-prior", "--data", str(s.bench), "--out", str(d)],
                       names=("--out", str(d)), guard="psm_model.identification.fit_prior_cli")

    @case("cli fit-prior", "--json into a missing folder")
    def _(s, d):
        return Attempt(argv=["fit-prior", "--data", str(s.bench), "--out", str(d / "p.json"),
                             "--json", str(d / "no" / "p.json")], names=("--json",),
                       guard="psm_model.identification.fit_prior_cli")

    # --- checkpoints -------------------------------------------------------------------------
    def flip_weights(path: Path, out: Path) -> None:
        """Overwrite 8 bytes inside the largest stored tensor (uncompressed in the zip)."""
        from hybrid.checkpoint import load_checkpoint
        state = load_checkpoint(path).model.state_dict()
        tensor = max(state.values(), key=lambda t: t.numel())
        raw = path.read_bytes()
        at = raw.find(tensor.detach().numpy().tobytes()[:64])
        out.write_bytes(raw[:at + 16] + b"\x7f" * 8 + raw[at + 24:])

    ckpt_damage = {
        "zero-byte": lambda s, out: out.write_bytes(b""),
        "text": lambda s, out: out.write_text("hello, this is not a checkpoint\n"),
        "truncated to half": lambda s, out: out.write_bytes(s.fcn.read_bytes()[
            :s.fcn.stat().st_size // 2]),
        "flipped weight bytes": lambda s, out: flip_weights(s.fcn, out),
        "a prior JSON": lambda s, out: shutil.copy(s.prior, out),
        "missing": lambda s, out: None,
    }
    for damage, make in ckpt_damage.items():
        def checkpoint(s, d, make=make):
            path = d / "model.pt"
            make(s, path)
            return path

        def evaluate_with(s, d, checkpoint=checkpoint):
            path = checkpoint(s, d)
            return Attempt(argv=["evaluate", str(path), "--data", str(s.bench),
                                 "--out", str(d / "eval")], names=(str(path),))

        def finetune_with(s, d, checkpoint=checkpoint):
            path = checkpoint(s, d)
            return Attempt(argv=["finetune", str(path), "--data", str(s.bench), "--epochs", "1",
                                 "--out", str(d / "t.pt")], names=(str(path),))

        def export_with(s, d, checkpoint=checkpoint):
            path = checkpoint(s, d)
            return Attempt(argv=["export", str(path), "--out", str(d / "onnx")],
                           names=(str(path),))

        def stream_with(s, d, checkpoint=checkpoint):
            from hybrid.streaming import StreamingEstimator
            path = checkpoint(s, d)
            return Attempt(call=lambda: StreamingEstimator.from_checkpoint(path),
                           names=(str(path),))
        found.append(Case("cli evaluate: checkpoint", damage, "REJECTED", evaluate_with))
        found.append(Case("cli finetune: checkpoint", damage, "REJECTED", finetune_with))
        found.append(Case("cli export: checkpoint", damage, "REJECTED", export_with))
        found.append(Case("api StreamingEstimator.from_checkpoint", damage, "REJECTED",
                          stream_with))

    @case("cli export: checkpoint", "an fcn checkpoint (only the hybrid exports)")
    def _(s, d):
        return Attempt(argv=["export", str(s.fcn), "--out", str(d / "onnx")],
                       names=(str(s.fcn),))

    @case("cli evaluate: options", "--out not empty")
    def _(s, d):
        (d / "eval").mkdir()
        (d / "eval" / "metrics.json").write_text("{}\n")
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(s.bench),
                             "--out", str(d / "eval")], names=("--out",))

    @case("cli evaluate: options", "--out is a file")
    def _(s, d):
        (d / "eval").write_text("")
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(s.bench),
                             "--out", str(d / "eval")], names=("--out",))

    @case("cli evaluate: dataset", "a test recording shorter than the evaluation start")
    def _(s, d):
        data = s.copy(d)
        bad = trial(data, "test", "Traction")
        edit_csv(bad, lambda f: f.iloc[:60])
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(bad.relative_to(data).as_posix(),))

    @case("cli evaluate: dataset", "no test split")
    def _(s, d):
        data = s.copy(d)
        meta = json.loads((data / "metadata.json").read_text())
        meta["trials"] = [e for e in meta["trials"] if e["split"] != "test"]
        (data / "metadata.json").write_text(json.dumps(meta))
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(str(data),))

    @case("cli evaluate: dataset", "interrupted simulate (no metadata.json)")
    def _(s, d):
        data = s.copy(d)
        (data / "metadata.json").unlink()
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(str(data),))

    @case("cli evaluate: options", "--out under a file")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(s.bench),
                             "--out", str(d / "blocker" / "eval")], names=("--out",))

    @case("cli export: options", "--out is a file")
    def _(s, d):
        (d / "onnx").write_text("")
        return Attempt(argv=["export", str(s.hybrid), "--out", str(d / "onnx")],
                       names=("--out",))

    @case("cli finetune: dataset", "interrupted simulate (no metadata.json)")
    def _(s, d):
        data = s.copy(d)
        (data / "metadata.json").unlink()
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(data), "--epochs", "1",
                             "--out", str(d / "t.pt")], names=(str(data),))

    @case("cli export: options", "--out not empty")
    def _(s, d):
        (d / "onnx").mkdir()
        (d / "onnx" / "model.onnx").write_text("older\n")
        return Attempt(argv=["export", str(s.hybrid), "--out", str(d / "onnx")],
                       names=("--out",))

    @case("cli finetune: options", "--epochs 0")
    def _(s, d):
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(s.bench), "--epochs", "0",
                             "--out", str(d / "t.pt")], names=("--epochs",))

    @case("cli finetune: options", "--out is the folder itself")
    def _(s, d):
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(s.bench), "--epochs", "1",
                             "--out", str(d)], names=("--out",))

    # --- simulate ----------------------------------------------------------------------------
    def out_option(command, folder, guard):
        """A case adder for ``command --out d/folder EXTRA``: refused before ``guard`` runs."""
        def add(name, extra, names, prepare_out=None):
            def prepare(s, d):
                out = d / folder
                if prepare_out:
                    prepare_out(out)
                return Attempt(argv=[command, "--out", str(out), *extra], names=names,
                               guard=guard)
            found.append(Case(f"cli {command}", name, "REJECTED", prepare))
        return add

    simulate_option = out_option("simulate", "sim", "psm_model.sim.protocols.automated")

    simulate_option("--scale 1e6", ["--scale", "1e6"], ("--scale",))
    simulate_option("--scale 0", ["--scale", "0"], ("--scale", "scale"))
    simulate_option("--scale -1", ["--scale", "-1"], ("--scale", "scale"))
    simulate_option("--scale nan", ["--scale", "nan"], ("--scale", "scale"))
    simulate_option("--scale inf", ["--scale", "inf"], ("--scale", "scale"))
    simulate_option("--scale abc", ["--scale", "abc"], ("--scale",))
    simulate_option("--seed 1e23", ["--seed", "1e23"], ("--seed",))
    simulate_option("--seed -1", ["--seed", "-1"], ("--seed", "seed"))
    simulate_option("--tool-spread without --tool-seed", ["--tool-spread", "2"],
                    ("--tool-spread",))
    simulate_option("--tool-spread -1", ["--tool-seed", "1", "--tool-spread", "-1"],
                    ("--tool-spread", "tool_spread"))
    simulate_option("--tool-spread nan", ["--tool-seed", "1", "--tool-spread", "nan"],
                    ("--tool-spread", "tool_spread"))
    simulate_option("--protocol surgery", ["--protocol", "surgery"], ("--protocol",))
    simulate_option("--json into a missing folder", ["--json", "/nonexistent/dir/s.json"],
                    ("--json",))
    simulate_option("--out holds a dataset", [], ("--out", "out"),
                    prepare_out=lambda out: (out.mkdir(), (out / "metadata.json").write_text(
                        '{"trials": []}')))
    simulate_option("--out is a file", [], ("--out", "out"),
                    prepare_out=lambda out: out.write_text(""))

    @case("cli simulate", "--out under a file")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["simulate", "--scale", "0.005", "--out", str(d / "blocker" / "b")],
                       names=(str(d / "blocker"),), guard="psm_model.sim.protocols.automated")

    # --- convert -----------------------------------------------------------------------------
    def convert_case(name, build):
        def prepare(s, d):
            src, named = build(s, d)
            return Attempt(argv=["convert", str(src), "--out", str(d / "out.csv")],
                           names=(str(named),))
        found.append(Case("cli convert", name, "REJECTED", prepare))

    def missing_bag(s, d):
        return d / "run.mcap", d / "run.mcap"

    def empty_bag(s, d):
        (d / "run.mcap").write_bytes(b"")
        return d / "run.mcap", d / "run.mcap"

    def text_bag(s, d):
        (d / "run.bag").write_text("not a bag\n")
        return d / "run.bag", d / "run.bag"

    def empty_bag_folder(s, d):
        (d / "bag").mkdir()
        return d / "bag", d / "bag"

    def csv_with_map(text):
        def build(s, d):
            shutil.copy(trial(s.bench), d / "e.csv")
            (d / "map.json").write_text(text)
            return d / "e.csv", d / "map.json"
        return build

    convert_case("missing bag", missing_bag)
    convert_case("zero-byte .mcap", empty_bag)
    convert_case("text file as ROS 1 bag", text_bag)
    convert_case("empty folder as ROS 2 bag", empty_bag_folder)
    for text, name in (("[1, 2]", "column map a list"), ("{not json", "column map not JSON"),
                       ('{"no_such_column": "time"}', "column map names absent columns")):
        def with_map(s, d, text=text):
            src, mp = csv_with_map(text)(s, d)
            return Attempt(argv=["convert", str(src), "--column-map", str(mp),
                                 "--out", str(d / "out.csv")], names=(str(mp), str(src)))
        found.append(Case("cli convert", name, "REJECTED", with_map))
    @case("cli convert", "--out is a folder")
    def _(s, d):
        src = d / "e.csv"
        shutil.copy(trial(s.bench), src)
        return Attempt(argv=["convert", str(src), "--out", str(d)], names=("--out",))
    for rate in ("0", "-5", "nan"):
        def bad_rate(s, d, rate=rate):
            (d / "bag").mkdir()
            return Attempt(argv=["convert", str(d / "bag"), "--rate", rate,
                                 "--out", str(d / "out.csv")], names=("--rate", "rate"))
        found.append(Case("cli convert", f"--rate {rate}", "REJECTED", bad_rate))
    for text, name in (("[[1, 0], [0, 1]]", "--r-ati-psm 2x2"),
                       ("[[2, 0, 0], [0, 2, 0], [0, 0, 2]]", "--r-ati-psm not a rotation"),
                       ("rotation", "--r-ati-psm not JSON")):
        def bad_rotation(s, d, text=text):
            (d / "bag").mkdir()
            (d / "r.json").write_text(text)
            return Attempt(argv=["convert", str(d / "bag"), "--r-ati-psm", str(d / "r.json"),
                                 "--out", str(d / "out.csv")],
                           names=("--r-ati-psm", str(d / "r.json")))
        found.append(Case("cli convert", name, "REJECTED", bad_rotation))

    # --- fit-dynamics and wrench -------------------------------------------------------------
    @case("cli fit-dynamics", "default --format csv without --data")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--model-out", str(d / "arm.json")],
                       names=("--data",))

    @case("cli fit-dynamics", "--format wpi without --train")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--format", "wpi", "--model-out",
                             str(d / "arm.json")], names=("--train",))

    @case("cli fit-dynamics", "--data missing")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--data", str(d / "none"), "--model-out",
                             str(d / "arm.json")], names=(str(d / "none"),))

    @case("cli fit-dynamics", "--data a text file")
    def _(s, d):
        (d / "free.csv").write_text("hello\n")
        return Attempt(argv=["fit-dynamics", "--data", str(d / "free.csv"), "--model-out",
                             str(d / "arm.json")], names=(str(d / "free.csv"),))

    @case("cli fit-dynamics", "--gravity nan nan nan")
    def _(s, d):
        return Attempt(argv=["fit-dynamics", "--data", str(s.bench), "--gravity", "nan", "nan",
                             "nan", "--model-out", str(d / "arm.json")],
                       names=("--gravity", "gravity"),
                       guard="psm_model.identification.recordings.fit_conditioned")

    @case("cli fit-dynamics", "--format wpi on 3000 x 21 random numbers")
    def _(s, d):
        noise = np.random.default_rng(0).standard_normal((3000, 21))
        for name in ("train.csv", "test.csv"):
            np.savetxt(d / name, noise, delimiter=",")
        return Attempt(argv=["fit-dynamics", "--format", "wpi", "--train", str(d / "train.csv"),
                             "--test", str(d / "test.csv"), "--model-out", str(d / "arm.json")],
                       names=("--accept-poor-fit", str(d / "train.csv")))

    def dynamics_file(name, write):
        @case("cli wrench", f"--dynamics {name}")
        def _(s, d):
            path = d / "arm.json"
            write(s, path)
            return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(path),
                                 "--out", str(d / "w.csv")], names=(str(path),))

    @case("cli wrench", "--out is a folder")
    def _(s, d):
        return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(s.arm),
                             "--out", str(d)], names=("--out",))

    @case("cli wrench", "--out in a missing folder")
    def _(s, d):
        return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(s.arm),
                             "--out", str(d / "no" / "w.csv")], names=("--out",))

    @case("cli wrench", "--dynamics with a NaN parameter")
    def _(s, d):
        doc = json.loads(s.arm.read_text())
        doc["gravity_mps2"][0] = float("nan")
        path = d / "arm.json"
        path.write_text(json.dumps(_resealed(doc)))  # resealed: the NaN check must refuse it
        return Attempt(argv=["wrench", str(trial(s.bench)), "--dynamics", str(path),
                             "--out", str(d / "w.csv")], names=(str(path),))

    dynamics_file("missing", lambda s, path: None)
    dynamics_file("zero-byte", lambda s, path: path.write_text(""))
    dynamics_file("not JSON", lambda s, path: path.write_text("arm: yes\n"))
    dynamics_file("a list", lambda s, path: path.write_text("[1, 2]"))
    dynamics_file("a prior JSON", lambda s, path: shutil.copy(s.prior, path))

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
                     damage=ckpt_damage["zero-byte"])
    calibrate_option("flipped weight bytes", ["--epochs", "1"], ("CKPT",),
                     damage=ckpt_damage["flipped weight bytes"])

    # --- reproduce and demo: bad arguments found before any folder or work --------------------
    reproduce_option = out_option("reproduce", "run", "hybrid.reproduce.run_grid")

    reproduce_option("--scale 0", ["--scale", "0"], ("--scale",))
    reproduce_option("--scale -1", ["--scale", "-1"], ("--scale",))
    reproduce_option("--scale nan", ["--scale", "nan"], ("--scale",))
    reproduce_option("--scale 1e6", ["--scale", "1e6"], ("--scale",))
    reproduce_option("--seeds -1", ["--seeds", "-1"], ("--seeds",))
    reproduce_option("--seeds 1e23", ["--seeds", "1e23"], ("--seeds",))
    reproduce_option("--budget huge", ["--budget", "huge"], ("--budget",))
    reproduce_option("--models svm", ["--models", "svm"], ("--models",))
    if not torch.cuda.is_available():
        reproduce_option("--device cuda without CUDA", ["--device", "cuda"], ("--device",))
    reproduce_option("--out is a file", [], ("--out",),
                     prepare_out=lambda out: out.write_text(""))

    @case("cli reproduce", "--out under a file")
    def _(s, d):
        (d / "blocker").write_text("")
        return Attempt(argv=["reproduce", "--out", str(d / "blocker" / "run")],
                       names=("--out",), guard="hybrid.reproduce.run_grid")

    for name, kwargs in (("scale=-1", {"scale": -1.0}), ("scale=nan", {"scale": float("nan")}),
                         ("seeds=[-1]", {"seeds": [-1]})):
        def reproduce_api(s, d, kwargs=kwargs):
            from hybrid.reproduce import reproduce
            return Attempt(call=lambda: reproduce(d / "run", **kwargs),
                           names=tuple(kwargs), guard="hybrid.reproduce.run_grid")
        found.append(Case("api reproduce", name, "REJECTED", reproduce_api))

    @case("cli demo", "--out not empty")
    def _(s, d):
        (d / "demo").mkdir()
        (d / "demo" / "notes.txt").write_text("mine\n")
        return Attempt(argv=["demo", "--out", str(d / "demo")], names=("--out",),
                       guard="psm_model.sim.simulate")

    # --- the streaming estimator -------------------------------------------------------------
    def warmed(estimates):
        """Index of the first estimate after the warm-up (held NaN until then)."""
        return next(k for k, e in enumerate(estimates) if np.isfinite(e.force_hex10).all())

    def streaming(name, corrupt, flag="INVALID_INPUT", expect="HANDLED"):
        """One corrupted sample in a clean stream: flagged, every estimate after the warm-up
        finite, every estimate farther than hybrid.streaming_fuzz.FAR_N from the clean stream's
        flagged, and the last ones back on the clean stream's."""
        def prepare(s, d):
            from hybrid.streaming import Flags, StreamingEstimator
            frame = pd.read_csv(trial(s.bench, "test", "Palpation"))
            rows = frame.to_dict("records")
            bad_at = 300

            def run():
                def stream(bad):
                    est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
                    return [est.step(corrupt(dict(r)) if bad and k == bad_at else r)
                            for k, r in enumerate(rows)]
                return stream(False), stream(True)

            def check(result):
                from hybrid.streaming_fuzz import FAR_N
                clean, dirty = result
                flagged = dirty[bad_at].flags & Flags[flag]
                start = warmed(dirty)
                finite = all(np.isfinite(e.force_hex10).all() for e in dirty[start:])
                far_unflagged = sum(
                    1 for a, b in zip(clean[start:], dirty[start:])
                    if np.abs(a.force_hex10 - b.force_hex10).max() > FAR_N and not b.flags)
                after = max(np.abs(a.force_hex10 - b.force_hex10).max() for a, b in
                            zip(clean[-50:], dirty[-50:]))
                return (bool(flagged) and finite and not far_unflagged and after < RECOVERED_N,
                        f"flags {Flags(dirty[bad_at].flags)!r}, estimates finite {finite}, "
                        f"{far_unflagged} unflagged estimates over {FAR_N} N off, last 50 "
                        f"within {after:.2g} N of the clean stream's")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step", name, expect, prepare))

    streaming("roll_position 1e30", lambda r: {**r, "roll_position": 1e30})
    streaming("fz 1e39", lambda r: {**r, "fz": 1e39})
    streaming("jaw_velocity 1e39", lambda r: {**r, "jaw_velocity": 1e39})
    streaming("insertion_effort 1e20", lambda r: {**r, "insertion_effort": 1e20})
    streaming("insertion_effort 1e4 spike", lambda r: {**r, "insertion_effort": 1e4})
    streaming("NaN yaw_position", lambda r: {**r, "yaw_position": float("nan")})
    streaming("time None", lambda r: {**r, "time": None})
    streaming("text value", lambda r: {**r, "fx": "abc"})
    streaming("a column missing", lambda r: {k: v for k, v in r.items() if k != "fy"})
    streaming("time 1 s backwards", lambda r: {**r, "time": r["time"] - 1.0}, "TIME_BACKWARDS")
    streaming("time inf", lambda r: {**r, "time": float("inf")})
    streaming("a list, not a mapping", lambda r: list(r.values()))
    streaming("hex10_overload 'yes'", lambda r: {**r, "hex10_overload": "yes"})

    @case("api StreamingEstimator.step", "a 5 s gap: flagged, the stream restarts", "HANDLED")
    def _(s, d):
        from hybrid.streaming import Flags, StreamingEstimator
        rows = pd.read_csv(trial(s.bench, "test", "Palpation")).to_dict("records")

        def run():
            est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
            return [est.step({**r, "time": r["time"] + (5.0 if k >= 300 else 0.0)})
                    for k, r in enumerate(rows)]

        def check(estimates):
            after = estimates[300]
            finite = all(np.isfinite(e.force_hex10).all() for e in estimates[warmed(estimates):])
            return (bool(after.flags & Flags.GAP) and finite,
                    f"flags after the gap {Flags(after.flags)!r}, estimates finite {finite}")
        return Attempt(call=run, check=check)

    @case("api StreamingEstimator", "rate_hz nan")
    def _(s, d):
        from hybrid.streaming import StreamingEstimator
        return Attempt(call=lambda: StreamingEstimator.from_checkpoint(s.hybrid,
                                                                       rate_hz=float("nan")),
                       names=("rate_hz",))

    @case("api StreamingEstimator", "max_gap_samples -1")
    def _(s, d):
        from hybrid.streaming import StreamingEstimator
        return Attempt(call=lambda: StreamingEstimator.from_checkpoint(s.hybrid,
                                                                       max_gap_samples=-1),
                       names=("max_gap_samples",))

    @case("api StreamingEstimator", "an fcn checkpoint")
    def _(s, d):
        from hybrid.streaming import StreamingEstimator
        return Attempt(call=lambda: StreamingEstimator.from_checkpoint(s.fcn),
                       names=(str(s.fcn),))

    # --- Python API arguments ----------------------------------------------------------------
    @case("api train", "epochs=0")
    def _(s, d):
        from hybrid.train import train
        return Attempt(call=lambda: train(s.bench, "fcn", d / "m.pt", epochs=0),
                       names=("epochs",))

    @case("api train", "epochs=2.5")
    def _(s, d):
        from hybrid.train import train
        return Attempt(call=lambda: train(s.bench, "fcn", d / "m.pt", epochs=2.5),
                       names=("epochs",))

    @case("api simulate", "scale=-1")
    def _(s, d):
        from psm_model.sim import simulate
        return Attempt(call=lambda: simulate("automated", scale=-1, out=d / "b"),
                       names=("scale",))

    @case("api simulate", "seed=1e23")
    def _(s, d):
        from psm_model.sim import simulate
        return Attempt(call=lambda: simulate("automated", scale=0.005, seed=1e23, out=d / "b"),
                       names=("seed",))

    @case("api simulate", "scale=1e-9: every trial at its minimum length", "HANDLED")
    def _(s, d):
        from hybrid.data import load_dataset
        from psm_model.sim import simulate

        def check(summary):
            trials = load_dataset(d / "b").trials
            kinds = {(t.split, t.condition) for t in trials}
            return (len(kinds) == 6 and min(len(t) for t in trials) > 1,
                    f"{len(trials)} readable trials covering {len(kinds)} split x condition, "
                    f"{min(len(t) for t in trials)} samples or more each")
        return Attempt(call=lambda: simulate("automated", scale=1e-9, out=d / "b"), check=check)

    @case("api fit_prior_cli", "a poor fit is saved marked poor_fit", "HANDLED")
    def _(s, d):
        from psm_model.identification import fit_prior_cli
        data = s.copy(d)
        edit_csv(trial(data), lambda f: f.assign(fz=1e6))

        def check(report):
            return (bool(report.get("poor_fit")) and report["model"] is not None,
                    f"saved with poor_fit={report.get('poor_fit')} (test Free fz RMS "
                    f"{report['test_free_metrics']['fz']['rms']:.3g} N)")
        return Attempt(call=lambda: fit_prior_cli(data, d / "p.json"), check=check)

    @case("api PSM", "q of 5 joints")
    def _(s, d):
        from psm_model import PSM
        return Attempt(call=lambda: PSM().spatial_jacobian(np.zeros(5)), names=("q", "6"))

    @case("api PSM", "forward_kinematics of NaN joints")
    def _(s, d):
        from psm_model import PSM
        return Attempt(call=lambda: PSM().forward_kinematics(np.full(6, np.nan)), names=("q",))

    @case("api PSM", "frame 'elbow'")
    def _(s, d):
        from psm_model import PSM
        return Attempt(call=lambda: PSM().forward_kinematics(np.zeros(6), frame="elbow"),
                       names=("elbow", "frame"))

    @case("api PSM", "wrench_from_torques with NaN torques")
    def _(s, d):
        from psm_model import PSM
        q = np.array([0.1, -0.2, 0.12, 0.3, 0.1, -0.1])
        return Attempt(call=lambda: PSM().wrench_from_torques(q, np.full(6, np.nan)),
                       names=("tau", "torque", "NaN", "finite"))

    return found + integrity_cases()


# ---------------------------------------------------------------------------- issue 26

def edit_checkpoint(src: Path, out: Path, edit: Callable[[dict, dict], None],
                    reseal: bool = False) -> Path:
    """``src`` rewritten to ``out`` with ``edit(meta, payload)`` applied; ``reseal``: the
    envelope recomputed afterwards, as a careless tool would, so only the content checks
    remain."""
    from hybrid.integrity import seal
    payload = torch.load(src, weights_only=True)
    meta = json.loads(payload["meta"])
    edit(meta, payload)
    payload["meta"] = json.dumps(seal(meta) if reseal else meta)
    torch.save(payload, out)
    return out


def _meta(**changes):
    def edit(meta, payload):
        for key, value in changes.items():
            if value is _DROP:
                meta.pop(key, None)
            else:
                meta[key] = value(meta) if callable(value) else value
    return edit


_DROP = object()


def _swap_features(meta):
    f = list(meta["features"])
    f[0], f[1] = f[1], f[0]
    return f


def _scaler(which, **fields):
    def value(meta):
        n = len(meta[which]["mean"])
        return {**meta[which], **{k: (v(n) if callable(v) else v) for k, v in fields.items()}}
    return value


CHECKPOINT_EDITS: dict[str, tuple[Callable, bool]] = {
    "features: two names swapped": (_meta(features=_swap_features), False),
    "input_scaler collapsed (mean 0, std 1)": (_meta(input_scaler=_scaler(
        "input_scaler", mean=lambda n: [0.0] * n, std=lambda n: [1.0] * n)), False),
    "target_scaler mean shifted": (_meta(target_scaler=_scaler(
        "target_scaler", mean=[5.0, 0.0, 0.0])), False),
    "base_columns emptied": (_meta(base_columns=[]), False),
    "derivation prior -> none": (_meta(derivation="none"), False),
    "config: uncertainty true": (_meta(config=lambda m: {**m["config"], "uncertainty": True}),
                                 False),
    "provenance: data_dir edited": (_meta(provenance=lambda m: {**m["provenance"],
                                                                "data_dir": "/elsewhere"}), False),
    "versions edited": (_meta(versions={"psmforce": "9.9"}), False),
    "sample_rate_hz 1000": (_meta(sample_rate_hz=1000.0), False),
    "prior JSON edited": (lambda meta, payload: payload.update(
        prior_json=payload["prior_json"].replace('"converged": true', '"converged": false')),
        False),
    "weights_sha256 edited": (_meta(weights_sha256="0" * 64), False),
    "envelope removed": (_meta(sha256=_DROP), False),
    "a field added": (_meta(note="trust me"), False),
    "format_version '3' (text)": (_meta(format_version="3"), False),
    "format_version 3.0 (float)": (_meta(format_version=3.0), False),
    "format_version true": (_meta(format_version=True), False),
    "format_version null": (_meta(format_version=None), False),
    "format_version 99": (_meta(format_version=99), False),
    "format_version 1 (no checksum)": (_meta(format_version=1, weights_sha256=_DROP), True),
    "resealed: config n_heads 0": (_meta(config=lambda m: {**m["config"], "n_heads": 0}), True),
    "resealed: config attention_window 1e7": (_meta(config=lambda m: {
        **m["config"], "attention_window": 10 ** 7}), True),
    "resealed: config d_model 0": (_meta(config=lambda m: {**m["config"], "d_model": 0}), True),
    "resealed: config unknown key": (_meta(config=lambda m: {**m["config"], "depth": 9}), True),
    "resealed: model 'svm'": (_meta(model="svm"), True),
    "resealed: input_scaler std 0": (_meta(input_scaler=_scaler(
        "input_scaler", std=lambda n: [0.0] * n)), True),
    "resealed: target_scaler NaN mean": (_meta(target_scaler=_scaler(
        "target_scaler", mean=[float("nan"), 0.0, 0.0])), True),
    "resealed: target_scaler of 2 values": (_meta(target_scaler=_scaler(
        "target_scaler", mean=[0.0, 0.0], std=[1.0, 1.0])), True),
    "resealed: features repeated": (_meta(features=lambda m: [m["features"][0]]
                                          + m["features"][:-1]), True),
    "resealed: base_columns of 2": (_meta(base_columns=lambda m: m["base_columns"][:2]), True),
}
"""What a checkpoint's metadata can be made to say: every one refused, naming the file."""


TIMESTAMPS = {
    "time 1e307 (the gap overflows)": (1e307, "GAP"),
    "time 1.7e308": (1.7e308, "GAP"),
    "time -1e307": (-1e307, "TIME_BACKWARDS"),
    "time 10**400 (an int beyond float)": (10 ** 400, "INVALID_INPUT"),
    "time 1e15 jump": (1e15, "GAP"),
    "time True (a bool)": (True, "TIME_BACKWARDS"),
}


def integrity_cases() -> list[Case]:
    """The classes of issue 26 (module docstring)."""
    found: list[Case] = []

    def case(kind: str, name: str, expect: str = "REJECTED"):
        def register(prepare):
            found.append(Case(kind, name, expect, prepare))
            return prepare
        return register

    # --- checkpoints: one field edited, a version that is not an integer, resealed nonsense --
    for damage, (edit, reseal) in CHECKPOINT_EDITS.items():
        def edited(s, d, edit=edit, reseal=reseal):
            return edit_checkpoint(s.hybrid, d / "model.pt", edit, reseal)

        def evaluate_with(s, d, edited=edited):
            path = edited(s, d)
            return Attempt(argv=["evaluate", str(path), "--data", str(s.bench),
                                 "--out", str(d / "eval")], names=(str(path),))

        def export_with(s, d, edited=edited):
            path = edited(s, d)
            return Attempt(argv=["export", str(path), "--out", str(d / "onnx")],
                           names=(str(path),))

        def finetune_with(s, d, edited=edited):
            path = edited(s, d)
            return Attempt(argv=["finetune", str(path), "--data", str(s.bench), "--epochs", "1",
                                 "--out", str(d / "t.pt")], names=(str(path),))

        def stream_with(s, d, edited=edited):
            from hybrid.streaming import StreamingEstimator
            path = edited(s, d)
            return Attempt(call=lambda: StreamingEstimator.from_checkpoint(path),
                           names=(str(path),))
        found.append(Case("cli evaluate: checkpoint metadata", damage, "REJECTED",
                          evaluate_with))
        found.append(Case("cli export: checkpoint metadata", damage, "REJECTED", export_with))
        found.append(Case("cli finetune: checkpoint metadata", damage, "REJECTED",
                          finetune_with))
        found.append(Case("api StreamingEstimator.from_checkpoint: metadata", damage,
                          "REJECTED", stream_with))

    @case("api load_checkpoint", "a version 2 file (previous format) loads", "HANDLED")
    def _(s, d):
        from hybrid.checkpoint import load_checkpoint

        def to_v2(meta, payload):
            meta.pop("sha256")
            meta.pop("prior_sha256")
            meta["format_version"] = 2
        path = edit_checkpoint(s.hybrid, d / "v2.pt", to_v2)

        def check(record):
            same = record.features == load_checkpoint(s.hybrid).features
            return same, f"loaded, features as written: {same}"
        return Attempt(call=lambda: load_checkpoint(path), check=check)

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
                           guard="hybrid.train.load_dataset")
        found.append(Case("cli train --config", f"{model} {json.dumps(config)}", "REJECTED",
                          train_config))

    # --- the stream: timestamps that overflow its arithmetic are flagged, never raised --------
    for name, (value, flag) in TIMESTAMPS.items():
        def timestamp(s, d, value=value, flag=flag):
            from hybrid.streaming import Flags, StreamingEstimator
            rows = pd.read_csv(trial(s.bench, "test", "Palpation")).to_dict("records")

            def run():
                est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
                return [est.step({**r, "time": value} if k == 300 else r)
                        for k, r in enumerate(rows)]

            def check(estimates):
                odd = estimates[300]
                finite = all(np.isfinite(e.force_hex10).all()
                             for e in estimates[warmed_up(estimates):])
                last = estimates[-1]
                ok = (bool(odd.flags & Flags[flag]) and finite
                      and not last.flags & Flags.INVALID_INPUT)
                return ok, (f"flags at the odd sample {Flags(odd.flags)!r}, estimates finite "
                            f"{finite}, last flags {Flags(last.flags)!r}")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step: timestamp", name, "HANDLED", timestamp))

    # --- the export runner: as strict as the stream, confined to its folder -------------------
    def export_copy(s, d, edit=None, reseal=False):
        from hybrid.integrity import seal
        out = d / "exp"
        shutil.copytree(s.export, out)
        if edit is not None:
            spec = json.loads((out / "hybrid.json").read_text())
            edit(spec)
            (out / "hybrid.json").write_text(json.dumps(seal(spec) if reseal else spec))
        return out

    def runner(name, edit=None, reseal=False, frame=None, names=None, escape=False,
               prepare_more=None):
        def prepare(s, d):
            from hybrid.export import run_export
            out = export_copy(s, d, edit, reseal)
            if prepare_more is not None:
                prepare_more(s, d, out)
            rec = pd.read_csv(trial(s.bench, "test", "Palpation"))
            if frame is not None:
                rec = frame(rec)
            return Attempt(call=lambda: run_export(out, rec),
                           names=names or (str(out / "hybrid.json"),), escape=escape)
        found.append(Case("api run_export", name, "REJECTED", prepare))

    @case("api run_export", "JSON names an absolute path to a matching graph outside")
    def _(s, d):
        from hybrid.export import run_export
        from hybrid.integrity import seal
        out = export_copy(s, d)
        target = d.parent.parent / "outside" / f"{d.name}.onnx"
        target.write_bytes((s.export / "hybrid_step.onnx").read_bytes())
        spec = json.loads((out / "hybrid.json").read_text())
        (out / "hybrid.json").write_text(json.dumps(seal({**spec, "onnx": str(target)})))
        rec = pd.read_csv(trial(s.bench, "test", "Palpation"))
        return Attempt(call=lambda: run_export(out, rec), names=(str(out / "hybrid.json"),),
                       escape=True)
    for label, rel in (("'../' path", "../exp2/hybrid_step.onnx"),
                       ("'sub/../..' path", "sub/../../x.onnx"), ("'.'", "."), ("''", ""),
                       ("a number", 3)):
        runner(f"JSON names the graph as {label}", lambda sp, rel=rel: sp.update(onnx=rel),
               reseal=True, escape=True)

    @case("api run_export", "the graph is a link to a file outside the folder")
    def _(s, d):
        from hybrid.export import run_export
        out = export_copy(s, d)
        target = d.parent.parent / "outside" / f"{d.name}.onnx"
        target.write_bytes((s.export / "hybrid_step.onnx").read_bytes())
        (out / "hybrid_step.onnx").unlink()
        (out / "hybrid_step.onnx").symlink_to(target)
        rec = pd.read_csv(trial(s.bench, "test", "Palpation"))
        return Attempt(call=lambda: run_export(out, rec), names=(str(out / "hybrid.json"),),
                       escape=True)

    runner("JSON target_scaler edited", lambda sp: sp["target_scaler"]["mean"].__setitem__(
        0, 9.0))
    runner("JSON features swapped", lambda sp: sp.update(
        features=[sp["features"][1], sp["features"][0], *sp["features"][2:]]))
    runner("JSON raw_columns edited", lambda sp: sp.update(raw_columns=sp["raw_columns"][1:]))
    runner("JSON envelope removed", lambda sp: sp.pop("sha256"))
    runner("JSON format_version '3'", lambda sp: sp.update(format_version="3"))
    runner("JSON format_version 2 (before the envelope)", lambda sp: (
        sp.pop("sha256"), sp.update(format_version=2)))
    runner("resealed: a state tensor of 1e12 values", lambda sp: sp["graph"]["state"][0].update(
        shape=[10 ** 6, 10 ** 6]), reseal=True)
    runner("resealed: input_scaler std 0", lambda sp: sp["input_scaler"].update(
        std=[0.0] * len(sp["features"])), reseal=True)
    runner("resealed: graph.y of 4 columns", lambda sp: sp["graph"]["y"].update(shape=[1, 4]),
           reseal=True)
    runner("JSON not JSON", prepare_more=lambda s, d, out: (out / "hybrid.json").write_text(
        "{graph: "))
    runner("JSON a list", prepare_more=lambda s, d, out: (out / "hybrid.json").write_text(
        "[1, 2]"))

    def flip_graph(s, d, out):
        raw = bytearray((out / "hybrid_step.onnx").read_bytes())
        raw[-32] ^= 0xFF
        (out / "hybrid_step.onnx").write_bytes(bytes(raw))
    runner("graph bytes flipped", prepare_more=flip_graph,
           names=(str(Path("exp") / "hybrid_step.onnx"),))
    runner("graph missing", prepare_more=lambda s, d, out: (out / "hybrid_step.onnx").unlink(),
           names=("hybrid_step.onnx",))
    for label, column, value, in (("NaN", "fx", np.nan), ("1e30", "roll_position", 1e30),
                                  ("inf", "insertion_effort", np.inf),
                                  ("-1e39", "fz", -1e39)):
        runner(f"recording: {column} {label}", frame=lambda f, c=column, v=value: f.assign(
            **{c: f[c].where(f.index != 7, v)}), names=(f"column {column} row 7",))
    runner("recording: a text cell", frame=lambda f: f.astype({"fy": object}).assign(
        fy=lambda g: g["fy"].where(g.index != 4, "abc")), names=("column fy",))
    runner("recording: a column missing", frame=lambda f: f.drop(columns=["tz"]),
           names=("['tz']",))
    runner("recording: a numpy array, not a table", frame=lambda f: f.to_numpy(),
           names=("DataFrame",))

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

    # --- runs refuse repeated seeds -------------------------------------------------------------
    for seeds in (["0", "0"], ["1", "2", "1"], ["3", "3", "3"]):
        @case("cli reproduce: seeds", f"--seeds {' '.join(seeds)}")
        def _(s, d, seeds=seeds):
            return Attempt(argv=["reproduce", "--out", str(d / "run"), "--seeds", *seeds],
                           names=("--seeds",), guard="hybrid.reproduce.run_grid")

    # --- data sanity before learning ------------------------------------------------------------
    def zero_targets(f):
        return f.assign(ati_fx=0.0, ati_fy=0.0, ati_fz=0.0)

    for label, condition, change in (
            ("all-zero ATI in a Traction recording", "Traction", zero_targets),
            ("all-zero ATI in a Free recording", "Free", zero_targets),
            ("constant ATI fz = 5 N", "Palpation", lambda f: f.assign(ati_fz=5.0))):
        def degenerate(s, d, condition=condition, change=change):
            data = s.copy(d)
            bad = trial(data, "train", condition)
            edit_csv(bad, change)
            return Attempt(argv=["train", "--data", str(data), "--model", "fcn", "--epochs", "1",
                                 "--out", str(d / "m.pt")], names=(str(bad),))
        found.append(Case("cli train: targets", label, "REJECTED", degenerate))

        def degenerate_eval(s, d, condition=condition, change=change):
            data = s.copy(d)
            bad = trial(data, "test", condition)
            edit_csv(bad, change)
            return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                                 "--out", str(d / "eval")], names=(str(bad),))
        found.append(Case("cli evaluate: targets", label, "REJECTED", degenerate_eval))

    @case("cli finetune: targets", "every ATI column zero in every recording")
    def _(s, d):
        data = s.copy(d)
        for path in sorted(data.rglob("*.csv")):
            edit_csv(path, zero_targets)
        return Attempt(argv=["finetune", str(s.fcn), "--data", str(data), "--epochs", "1",
                             "--out", str(d / "t.pt")], names=("ati_fx is constant",))

    def leaked(s, d):
        data = s.copy(d)
        train_rel = sorted(data.glob("train/Traction/*.csv"))[0]
        test = trial(data, "test", "Traction")
        shutil.copy(train_rel, test)
        return data, test

    @case("cli evaluate: overlap", "a test recording is a training recording of the checkpoint")
    def _(s, d):
        data, test = leaked(s, d)
        return Attempt(argv=["evaluate", str(s.fcn), "--data", str(data),
                             "--out", str(d / "eval")], names=(str(test),))

    @case("cli evaluate: overlap", "the same with --allow-train-overlap: flagged per file",
          "HANDLED")
    def _(s, d):
        data, test = leaked(s, d)
        out = d / "eval"
        argv = ["evaluate", str(s.fcn), "--data", str(data), "--out", str(out),
                "--allow-train-overlap", "--json", str(d / "e.json")]

        def check(stdout):
            report = json.loads((d / "e.json").read_text())
            rel = test.relative_to(data).as_posix()
            return (report.get("train_overlap", [{}])[0].get("test") == rel,
                    f"scored, overlap recorded: {report.get('train_overlap')}")
        return Attempt(argv=argv, check=check)

    # --- cached task results: an edited one is recomputed, never returned ---------------------
    def cache_case(name, damage):
        def prepare(s, d):
            from hybrid.grid import cache_path, run_grid
            cache = d / "cache"
            tasks = [(_grid_task, {"x": x}) for x in (1, 2)]
            with contextlib.redirect_stdout(io.StringIO()):
                run_grid(tasks, cache, log=lambda text: None)
            path = cache_path(cache, _grid_task, {"x": 2})
            damage(path)

            def run():
                logged = []
                return run_grid(tasks, cache, log=logged.append), logged

            def check(result):
                results, logged = result
                redone = any("recomputing" in line for line in logged)
                return (results == [{"y": 2}, {"y": 4}] and redone,
                        f"results {results}, recomputed {redone}")
            return Attempt(call=run, check=check)
        found.append(Case("api run_grid: cache", name, "HANDLED", prepare))

    def edit_record(change):
        def damage(path):
            record = json.loads(path.read_text())
            change(record)
            path.write_text(json.dumps(record))
        return damage

    cache_case("a result number edited", edit_record(lambda r: r["result"].update(y=400)))
    cache_case("parameters edited", edit_record(lambda r: r["params"].update(x=7)))
    cache_case("written before the envelope", edit_record(lambda r: [
        r.pop(k) for k in ("sha256", "format", "format_version")]))
    cache_case("format_version '1'", edit_record(lambda r: r.update(format_version="1")))
    cache_case("truncated", lambda path: path.write_text(path.read_text()[:40]))
    cache_case("edited and resealed for another task", lambda path: path.write_text(json.dumps(
        _resealed(json.loads(path.read_text()), task="fuzz:_other")) + "\n"))

    # --- gates that speak ----------------------------------------------------------------------
    @case("cli fit-prior: gate", "the verdict is printed on the console", "HANDLED")
    def _(s, d):
        out = d / "p.json"

        def check(stdout):
            verdict = [ln for ln in stdout.splitlines() if ln.startswith("verdict: ")]
            return bool(verdict) and out.exists(), f"{verdict}"
        return Attempt(argv=["fit-prior", "--data", str(s.bench), "--out", str(out),
                             "--accept-poor-fit"], check=check)

    found.extend(prior_envelope_cases() + more_integrity_cases())
    return found


def prior_envelope_cases() -> list[Case]:
    """Prior files carry the envelope too: one field edited (inside every bound, so only the
    envelope can tell), a version that is not the integer, a file from before the envelope."""
    found: list[Case] = []

    def edited_prior(s, d, edit, reseal=False):
        from hybrid.integrity import seal
        doc = json.loads(s.prior.read_text())
        edit(doc)
        path = d / "prior.json"
        path.write_text(json.dumps(seal(doc) if reseal else doc))
        return path

    def in_bounds(doc):
        entry = doc["parameters"]["bias_fz"]
        entry["value"] = entry["lower"] + 0.37 * (entry["upper"] - entry["lower"])

    edits = {
        "a parameter edited inside its bounds": (in_bounds, False),
        "axis_weights edited": (lambda doc: doc.update(axis_weights=[0.5] * 6), False),
        "insertion model edited": (lambda doc: doc["insertion"].update(note="edited"), False),
        "converged flipped": (lambda doc: doc.update(converged=False), False),
        "a field added": (lambda doc: doc.update(note="trust me"), False),
        "envelope removed, version kept": (lambda doc: doc.pop("sha256"), False),
        "version removed, envelope kept": (lambda doc: doc.pop("format_version"), False),
        "format_version '2' (text)": (lambda doc: doc.update(format_version="2"), True),
        "format_version 2.0 (float)": (lambda doc: doc.update(format_version=2.0), True),
        "format_version true": (lambda doc: doc.update(format_version=True), True),
        "format_version 3": (lambda doc: doc.update(format_version=3), True),
    }
    for damage, (edit, reseal) in edits.items():
        def load(s, d, edit=edit, reseal=reseal):
            from psm_model.identification.prior import InternalForcePrior
            path = edited_prior(s, d, edit, reseal)
            return Attempt(call=lambda: InternalForcePrior.load(path), names=(str(path),))
        found.append(Case("api InternalForcePrior.load: envelope", damage, "REJECTED", load))

        def train_with(s, d, edit=edit, reseal=reseal):
            path = edited_prior(s, d, edit, reseal)
            return Attempt(argv=["train", "--data", str(s.bench), "--model", "hybrid",
                                 "--prior", str(path), "--epochs", "1", "--out", str(d / "h.pt")],
                           names=(str(path),), guard="hybrid.train.train_model")
        found.append(Case("cli train --prior: envelope", damage, "REJECTED", train_with))

    def legacy(doc):
        doc.pop("sha256")
        doc.pop("format_version")

    @_register(found, "api InternalForcePrior.load: envelope",
               "a file written before the envelope loads", "HANDLED")
    def _(s, d):
        from psm_model.identification.prior import InternalForcePrior
        path = edited_prior(s, d, legacy)

        def check(prior):
            same = np.array_equal(prior.params, InternalForcePrior.load(s.prior).params)
            return same, f"loaded, parameters as written: {same}"
        return Attempt(call=lambda: InternalForcePrior.load(path), check=check)
    return found


def _register(found: list[Case], kind: str, name: str, expect: str = "REJECTED"):
    def register(prepare):
        found.append(Case(kind, name, expect, prepare))
        return prepare
    return register


def more_integrity_cases() -> list[Case]:
    """Cases of issue 26's classes beyond its report: more timestamps (a decimating stream, a
    clock past float resolution), the runner's tables, repeated seeds from Python."""
    found: list[Case] = []

    # --- the stream's timestamps: flagged, never raised -----------------------------------
    def stream_case(name, times, flag, at=300, input_rate_hz=None, expect_finite=True):
        def prepare(s, d):
            from hybrid.streaming import Flags, StreamingEstimator
            rows = pd.read_csv(trial(s.bench, "test", "Palpation")).to_dict("records")
            period = 1.0 / (input_rate_hz or 100.0)
            clean = [r["time"] if input_rate_hz is None else k * period
                     for k, r in enumerate(rows)]
            stamps = times(clean)

            def run():
                options = {} if input_rate_hz is None else {"input_rate_hz": input_rate_hz}
                est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass",
                                                         **options)
                return [est.step(r, time=t) for r, t in zip(rows, stamps)]

            def check(estimates):
                odd = estimates[at]
                flagged = bool(odd.flags & Flags[flag])
                if not expect_finite:  # every later sample flagged, none raised
                    rest = all(e.flags & (Flags.TIME_BACKWARDS | Flags.GAP)
                               for e in estimates[at:])
                    return flagged and rest, (f"flags at sample {at} {Flags(odd.flags)!r}, "
                                              f"every later one flagged {rest}")
                finite = all(np.isfinite(e.force_hex10).all()
                             for e in estimates[warmed_up(estimates):])
                last = estimates[-1]
                ok = flagged and finite and not last.flags & Flags.INVALID_INPUT
                return ok, (f"flags at sample {at} {Flags(odd.flags)!r}, estimates finite "
                            f"{finite}, last flags {Flags(last.flags)!r}")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step: timestamp", name, "HANDLED", prepare))

    def one(value):
        def times(clean):
            return [value if k == 300 else t for k, t in enumerate(clean)]
        return times

    stream_case("time NaN", one(float("nan")), "INVALID_INPUT")
    stream_case("time -inf", one(float("-inf")), "INVALID_INPUT")
    stream_case("time numpy 1e307", one(np.float64(1e307)), "GAP")
    stream_case("time a numpy array of one value", one(np.array([1e307])), "GAP")
    stream_case("time 'abc' (text)", one("abc"), "INVALID_INPUT")
    stream_case("time 1e307 at 1 kHz in (decimated x10)", one(1e307), "GAP",
                input_rate_hz=1000.0)
    stream_case("time NaN at 1 kHz in (decimated x10)", one(float("nan")), "INVALID_INPUT",
                input_rate_hz=1000.0)
    stream_case("clock past float resolution from sample 300 (1e300 + k dt)",
                lambda clean: [t if k < 300 else 1e300 + t for k, t in enumerate(clean)],
                "GAP", expect_finite=False)

    def array_case(name, corrupt):
        def prepare(s, d):
            from hybrid.streaming import Flags, StreamingEstimator
            frame = pd.read_csv(trial(s.bench, "test", "Palpation"))

            def run():
                est = StreamingEstimator.from_checkpoint(s.hybrid, post_filter="lowpass")
                values = frame[list(est.columns)].to_numpy(np.float64)
                return [est.step(corrupt(x) if k == 300 else x, time=t)
                        for k, (x, t) in enumerate(zip(values, frame["time"]))]

            def check(estimates):
                odd, last = estimates[300], estimates[-1]
                finite = all(np.isfinite(e.force_hex10).all()
                             for e in estimates[warmed_up(estimates):])
                ok = (bool(odd.flags & Flags.INVALID_INPUT) and finite
                      and not last.flags & Flags.INVALID_INPUT)
                return ok, (f"flags at sample 300 {Flags(odd.flags)!r}, estimates finite "
                            f"{finite}, last flags {Flags(last.flags)!r}")
            return Attempt(call=run, check=check)
        found.append(Case("api StreamingEstimator.step: array sample", name, "HANDLED",
                          prepare))

    array_case("complex dtype (numpy would drop the imaginary part)", lambda x: x + 0j)
    array_case("text dtype", lambda x: x.astype(str))
    array_case("bool dtype", lambda x: x > 0)
    array_case("one value short", lambda x: x[:-1])
    array_case("two-dimensional", lambda x: x[None, :])

    # --- the export runner: tables it cannot read as the stream would --------------------
    def runner_frame(name, frame, names):
        def prepare(s, d):
            from hybrid.export import run_export
            rec = frame(pd.read_csv(trial(s.bench, "test", "Palpation")))
            return Attempt(call=lambda: run_export(s.export, rec), names=names)
        found.append(Case("api run_export", name, "REJECTED", prepare))

    runner_frame("recording: a column twice", lambda f: pd.concat([f, f[["fx"]]], axis=1),
                 ("fx",))
    runner_frame("recording: a bool column", lambda f: f.assign(fy=f["fy"] > 0), ("fy",))
    runner_frame("recording: a complex column", lambda f: f.assign(fz=f["fz"] + 1j),
                 ("fz",))
    runner_frame("recording: no rows", lambda f: f.iloc[:0], ("no rows", "empty"))

    # --- gates that speak: every fit's verdict on the console -----------------------------
    @_register(found, "cli fit-dynamics: gate", "the verdict is printed on the console",
               "HANDLED")
    def _(s, d):
        out = d / "arm.json"

        def check(stdout):
            verdict = [ln for ln in stdout.splitlines() if ln.startswith("verdict: ")]
            return bool(verdict) and out.exists(), f"{verdict}"
        return Attempt(argv=["fit-dynamics", "--data", str(s.bench), "--model-out", str(out),
                             "--accept-poor-fit"], check=check)

    # --- repeated seeds from Python, before any work ----------------------------------------
    for seeds in ((1, 1), (2, 3, 2)):
        @_register(found, "api reproduce: seeds", f"seeds={seeds}")
        def _(s, d, seeds=seeds):
            from hybrid.reproduce import reproduce
            return Attempt(call=lambda: reproduce(d / "run", seeds=seeds), names=("seeds",),
                           guard="hybrid.reproduce.run_grid")
    return found


def _link_case(s, d, own_copy):
    ckpt = own_copy(s, d)
    (d / "link.pt").symlink_to(ckpt)
    return (["calibrate", str(ckpt), "--data", str(s.bench), "--out", str(d / "link.pt"),
             "--epochs", "1"], None)


def _grid_task(params: dict) -> dict:
    return {"y": 2 * params["x"]}


def _resealed(record: dict, **changes) -> dict:
    from hybrid.integrity import seal
    return seal({**record, **changes})


def warmed_up(estimates) -> int:
    """Index of the first estimate after the warm-up (held NaN until then)."""
    return next(k for k, e in enumerate(estimates) if np.isfinite(e.force_hex10).all())


# ---------------------------------------------------------------------------- main

def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the table here")
    parser.add_argument("--only", help="run the cases whose kind or name contains this")
    args = parser.parse_args()
    torch.set_num_threads(1)
    selected = [c for c in cases() if not args.only or args.only in f"{c.kind}: {c.name}"]
    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        shared = Shared(root / "inputs")
        setup_s = time.perf_counter() - started
        for k, case in enumerate(selected):
            outcome = run_case(case, shared, root / "cases" / f"{k:03d}")
            rows.append({"kind": case.kind, "case": case.name, "expected": case.expect,
                         "verdict": outcome.verdict, "detail": outcome.detail.replace(tmp, "TMP"),
                         "seconds": round(outcome.seconds, 3)})
    counts = Counter(r["verdict"] for r in rows)
    unexpected = [r for r in rows if r["verdict"] != r["expected"]]
    print(f"{len(rows)} cases in {time.perf_counter() - started:.0f} s (inputs {setup_s:.0f} s): "
          + ", ".join(f"{v} {counts.get(v, 0)}" for v in EXPECTED + FAILING))
    for r in rows:
        if r["verdict"] not in EXPECTED or r["verdict"] != r["expected"]:
            print(f"  {r['verdict']:8} (expected {r['expected']}) {r['kind']}: {r['case']}\n"
                  f"           {r['detail'][:400]}")
    if args.json:
        write_json(args.json, {"machine": platform.platform(), "scale": SCALE,
                               "counts": {v: counts.get(v, 0) for v in EXPECTED + FAILING},
                               "unexpected": len(unexpected), "cases": rows})
    failed = any(r["verdict"] in FAILING for r in rows) or unexpected
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
