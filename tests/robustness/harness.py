"""What every robustness case shares: the verdicts, the inputs every case starts from
(:class:`Shared`: a tiny bench, a nominal prior, an arm model, two one-epoch checkpoints, an
untrained LSTM's and an export, built once), how one case runs and is classified (:func:`run_case`), and the helpers
that damage a file. The cases themselves, one module per artefact, are in
:mod:`tests.robustness.cases`; ``python -m tests.robustness`` runs them (the package docstring
defines the verdicts).
"""

import contextlib
import io
import json
import shutil
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable
from unittest import mock

import numpy as np
import pandas as pd
import torch

from psmforce.experiments.task_cache import task
from tests.checkpoints import untrained_checkpoint
from tests.robustness.adversarial_stream import NOMINAL_INSERTION  # a fit is not tested here

SCALE = 0.005
"""The bench's protocol scale: tiny, every trial at or near the simulator's minimum length."""
RECOVERED_N = 1e-3
"""Some 250 samples after one corrupted sample a stream is back on the clean stream's estimates
within a millinewton (far below any sensor's resolution): a refused sample never entered the
network or the filter, and the 5 Hz filter has long forgotten a one-sample shift."""
EXPECTED = ("REJECTED", "HANDLED")
FAILING = ("SILENT", "UNCLEAR", "CRASH", "ESCAPE", "LOSS")
OUTPUT_OPTIONS = ("--out", "--json", "--model-out")
"""The options that name what a command writes: a file the user had there may be replaced (that
is what the option asks), no other file may change (LOSS)."""


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
    outputs: tuple[str, ...] = ()              # files a Python call may write over (CLI: options)
    cleanup: Callable | None = None            # run after the case (a process it started)


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
        from psmforce.estimators.training.train import train
        from psmforce.identification.insertion import InsertionEffortModel
        from psmforce.identification.prior import InternalForcePrior
        from psmforce.sim import simulate
        self.root = root
        self.bench = root / "bench"
        simulate("automated", scale=SCALE, seed=0, out=self.bench)
        self.prior = root / "prior.json"
        InternalForcePrior(converged=True, insertion=InsertionEffortModel(
            NOMINAL_INSERTION, 0.005, {})).save(self.prior)
        from psmforce.identification import fit_dynamics_cli
        self.arm = root / "arm.json"
        with contextlib.redirect_stdout(io.StringIO()):  # IPOPT's banner
            fit_dynamics_cli(data=self.bench, model_out=self.arm, accept_poor_fit=True)
        quiet = io.StringIO()
        with contextlib.redirect_stderr(quiet):  # progress bars
            self.fcn = Path(train(self.bench, "fcn", root / "fcn.pt", epochs=1)["checkpoint"])
            self.hybrid = Path(train(self.bench, "hybrid", root / "hybrid.pt", epochs=1,
                                     prior=self.prior)["checkpoint"])
        self.lstm = untrained_checkpoint("lstm", root / "lstm.pt")  # one that does not stream
        from psmforce.estimators.runtime.export import export
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


def _contents(*roots: Path) -> dict:
    """Every regular file under ``roots`` with the SHA-256 of its bytes, and every link with its
    target (links are not followed, pipes and devices not read): what the user has, byte for
    byte."""
    import hashlib
    import os
    import stat
    state = {}
    for root in roots:
        for p in sorted(root.rglob("*")):
            mode = os.lstat(p).st_mode
            if stat.S_ISLNK(mode):
                state[str(p)] = ("link", os.readlink(p))
            elif stat.S_ISREG(mode):
                state[str(p)] = hashlib.sha256(p.read_bytes()).hexdigest()
    return state


def _declared(attempt: Attempt) -> set[str]:
    """The paths a case's command or call is asked to write (resolved as the case names them)."""
    named = set(attempt.outputs)
    argv = attempt.argv or []
    named |= {argv[i + 1] for i, a in enumerate(argv[:-1]) if a in OUTPUT_OPTIONS}
    return {str(Path(n)) for n in named}


def _changes(before: dict, after: dict) -> list[str]:
    return sorted({k for k in before.keys() | after.keys() if before.get(k) != after.get(k)})


def _guarded(target: str | None):
    if target is None:
        return contextlib.nullcontext()
    return mock.patch(target, side_effect=Reached(target))


def run_case(case: Case, shared: Shared, folder: Path) -> Outcome:
    """Run one case in ``folder`` and classify it (the package docstring's verdicts); what the
    case started (its ``cleanup``) is ended once it is classified."""
    cleanups: list[Callable] = []
    try:
        return _run_case(case, shared, folder, cleanups)
    finally:
        for cleanup in cleanups:
            cleanup()


def _run_case(case: Case, shared: Shared, folder: Path, cleanups: list) -> Outcome:
    folder.mkdir(parents=True)
    outside = folder.parent.parent / "outside"  # beside the cases: nothing may change it
    outside.mkdir(exist_ok=True)
    attempt = case.prepare(shared, folder)
    if attempt.cleanup is not None:
        cleanups.append(attempt.cleanup)
    before = _tree(folder, shared.root, outside)
    around = _tree(shared.root, outside)
    had = _contents(folder, shared.root, outside)
    out, err = io.StringIO(), io.StringIO()
    result, error, rc = None, None, None
    start = time.perf_counter()
    with _guarded(attempt.guard), contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        try:
            if attempt.argv is not None:
                from psmforce.cli.main import main
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
    now, asked = _contents(folder, shared.root, outside), _declared(attempt)
    lost = [p for p, digest in had.items() if p not in asked and now.get(p) != digest]
    if lost:
        return outcome("LOSS", "changed or removed a file the user had: "
                               + ", ".join(Path(p).name for p in lost[:5]))
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


def flip_weights(path: Path, out: Path) -> None:
    """Overwrite 8 bytes inside the largest stored tensor (uncompressed in the zip)."""
    from psmforce.estimators.training.checkpoint import load_checkpoint
    state = load_checkpoint(path).model.state_dict()
    tensor = max(state.values(), key=lambda t: t.numel())
    raw = path.read_bytes()
    at = raw.find(tensor.detach().numpy().tobytes()[:64])
    out.write_bytes(raw[:at + 16] + b"\x7f" * 8 + raw[at + 24:])

CHECKPOINT_DAMAGE = {
    "zero-byte": lambda s, out: out.write_bytes(b""),
    "text": lambda s, out: out.write_text("hello, this is not a checkpoint\n"),
    "truncated to half": lambda s, out: out.write_bytes(s.fcn.read_bytes()[
        :s.fcn.stat().st_size // 2]),
    "flipped weight bytes": lambda s, out: flip_weights(s.fcn, out),
    "a prior JSON": lambda s, out: shutil.copy(s.prior, out),
    "missing": lambda s, out: None,
}
"""Ways to damage a checkpoint: ``(shared, out) -> None`` writes the damaged file."""


def out_option(found: list, command: str, folder: str, guard: str):
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


# ---------------------------------------------------------------------------- the cases


# ---------------------------------------------------------------------------- issue 26

def edit_checkpoint(src: Path, out: Path, edit: Callable[[dict, dict], None],
                    reseal: bool = False) -> Path:
    """``src`` rewritten to ``out`` with ``edit(meta, payload)`` applied; ``reseal``: the
    envelope recomputed afterwards, as a careless tool would, so only the content checks
    remain."""
    from psmforce.core.integrity import seal
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
    "resealed: target std 1e-300 (0 in float32)": (_meta(target_scaler=_scaler(
        "target_scaler", std=[1e-300, 1.0, 1.0])), True),
    "resealed: target std 1e39 (inf in float32)": (_meta(target_scaler=_scaler(
        "target_scaler", std=[1e39, 1.0, 1.0])), True),
    "resealed: input mean 1e39 (inf in float32)": (_meta(input_scaler=_scaler(
        "input_scaler", mean=lambda n: [1e39] + [0.0] * (n - 1))), True),
    "resealed: input std 1e-12 (below the floor)": (_meta(input_scaler=_scaler(
        "input_scaler", std=lambda n: [1e-12] + [1.0] * (n - 1))), True),
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


def registrar(found: list[Case]) -> Callable:
    """``case(kind, name, expect="REJECTED")``: a decorator adding its ``prepare`` function to
    ``found`` as a :class:`Case`."""
    def case(kind: str, name: str, expect: str = "REJECTED"):
        return _register(found, kind, name, expect)
    return case


def _register(found: list[Case], kind: str, name: str, expect: str = "REJECTED"):
    def register(prepare):
        found.append(Case(kind, name, expect, prepare))
        return prepare
    return register


def _link_case(s, d, own_copy):
    ckpt = own_copy(s, d)
    (d / "link.pt").symlink_to(ckpt)
    return (["calibrate", str(ckpt), "--data", str(s.bench), "--out", str(d / "link.pt"),
             "--epochs", "1"], None)


@task("fuzz_double")
def _grid_task(params: dict) -> dict:
    return {"y": 2 * params["x"]}


def _resealed(record: dict, **changes) -> dict:
    from psmforce.core.integrity import seal
    return seal({**record, **changes})


def warmed_up(estimates) -> int:
    """Index of the first estimate after the warm-up (held NaN until then)."""
    return next(k for k, e in enumerate(estimates) if np.isfinite(e.force_hex10).all())


# ---------------------------------------------------------------------------- main


