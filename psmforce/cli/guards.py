"""Guards every ``psmforce`` command gets from :func:`psmforce.cli.main.main`: no output written over
an input, and a sign of life on stderr while a long fit runs. Kept free of heavy imports, so
``psmforce --help`` stays fast.
"""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from pathlib import Path

_INPUTS = ("checkpoint", "data", "bag", "recording", "dynamics", "prior", "config", "train",
           "test", "session", "r_ati_psm", "column_map", "sim_recording", "known_loads")
"""Argument names that hold a command's inputs (files or folders), whatever the command."""
_OUTPUTS = ("out", "json", "model_out")
"""Argument names that hold what a command writes."""
SIDE_OUTPUTS = {
    "replay": lambda args: [Path(args.out).with_suffix(".layout.json")],
}
"""Files a command writes beside the outputs it is given (command -> args -> paths): checked as
outputs, and never written over a file that is already there, since no option named it."""


def _option(name: str) -> str:
    return "--" + name.replace("_", "-")


def _exists(value: str) -> bool:
    """Whether ``value`` names an existing path; a text no file system could hold as a name (an
    inline JSON ``--config``, a name too long) names none, and its own option says so."""
    try:
        return Path(value).exists()
    except OSError:
        return False


def outputs_spare_inputs(args) -> None:
    """No command writes over one of its inputs: an output that is an input file or folder
    (links followed), or an existing file inside an input folder (a recording, a
    metadata.json), is refused; so are two outputs naming the same file, and a side file a
    command writes beside its outputs (:data:`SIDE_OUTPUTS`) where a file is already."""
    inputs = []
    for name in _INPUTS:
        value = getattr(args, name, None)
        if isinstance(value, str) and value and _exists(value):
            inputs.append((name, Path(value).resolve()))
    outputs: dict[Path, str] = {}
    for name in _OUTPUTS:
        value = getattr(args, name, None)
        if not isinstance(value, str) or not value:
            continue
        from psmforce.core.files import check_name
        try:
            check_name(value)  # a name no file system holds: refused before any work
        except ValueError as err:
            raise ValueError(f"{_option(name)}: {err}") from None
        target = Path(value).resolve()
        if target in outputs:
            raise ValueError(f"{_option(name)}: {value} is also {outputs[target]}: two outputs "
                             f"cannot share one file")
        outputs[target] = _option(name)
        _spares(inputs, target, value, _option(name))
    for side in SIDE_OUTPUTS.get(getattr(args, "command", None), lambda _: [])(args):
        target = side.resolve()
        if target in outputs:
            raise ValueError(f"{outputs[target]}: {side} is where {args.command} writes its "
                             f"{side.name.split('.', 1)[1]} beside --out: give another path")
        if side.exists() or side.is_symlink():
            raise ValueError(f"--out: {args.command} writes {side} beside it, and a file is there "
                             f"already: move it or give another --out")
        outputs[target] = str(side)
        _spares(inputs, target, str(side), "--out")


def _spares(inputs: list, target: Path, value: str, option: str) -> None:
    """Refuse the output ``target`` (``value`` as given, after ``option``) when it is one of
    ``inputs`` or an existing file inside an input folder."""
    for source_name, source in inputs:
        inside = source.is_dir() and target.is_file() and source in target.parents
        if target == source or inside:
            what = "is" if target == source else "lies inside"
            label = source_name if source_name in ("checkpoint", "bag", "recording",
                                                   "session") else _option(source_name)
            raise ValueError(f"{option}: {value} {what} the command's input {label}: refusing "
                             f"to write over an input (give another path)")


@contextlib.contextmanager
def progress(label: str, every_s: float = 30.0):
    """While the block runs, a line on stderr every ``every_s`` seconds saying it still runs
    (a fit that takes minutes is not silent); nothing for a block shorter than that."""
    done = threading.Event()
    start = time.monotonic()

    def beat():
        while not done.wait(every_s):
            print(f"  ... {label}: still running, {time.monotonic() - start:.0f} s",
                  file=sys.stderr, flush=True)
    thread = threading.Thread(target=beat, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()
