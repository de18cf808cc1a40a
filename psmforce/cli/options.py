"""The checks every ``psmforce`` option passes before a command starts its work, so that a bad
argument is refused in one line and leaves nothing behind: output files and folders (writable,
new or empty, a name the file system can hold, never a link, pipe or device), options holding
JSON, devices, seeds and scales; and how a command's figures are written (``--json``)."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path


def writable_ancestor(target: Path, option: str) -> None:
    """The nearest existing folder above ``target`` must be writable (the library creates the
    missing ones): found before the work that produces the output, not after."""
    parent = target.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"{option}: cannot write {target}: {parent} is not a writable folder")


def output_file(path: str, option: str, *, parents: bool = True) -> None:
    """Refuse an output file that cannot be written (``parents``: missing folders get created),
    or that exists and is not a regular file (a link, a pipe, a device: never replaced,
    :func:`psmforce.core.files.check_output`). ``-`` for ``--json`` is standard output."""
    if path == "-" and option == "--json":
        return
    target = Path(path)
    if target.is_dir() and not target.is_symlink():
        raise ValueError(f"{option}: {target} is a folder, expected a file name")
    from psmforce.core.files import check_name, check_output
    try:
        check_name(target)
        check_output(target)
    except ValueError as err:
        raise ValueError(f"{option}: {err}" + ("; --json - writes to standard output"
                                                if option == "--json" else "")) from None
    if not parents and not target.parent.is_dir():
        raise ValueError(f"{option}: folder {target.parent} does not exist")
    writable_ancestor(target, option)


def fresh_folder(path: str, option: str) -> None:
    """An output folder must be new or empty: results are never mixed with older ones."""
    target = Path(path)
    from psmforce.core.files import check_name
    try:
        check_name(target)
    except ValueError as err:
        raise ValueError(f"{option}: {err}") from None
    if target.exists():
        if not target.is_dir():
            raise ValueError(f"{option}: {target} exists and is not a folder")
        from psmforce.core.files import folder_is_empty
        if not folder_is_empty(target):
            raise ValueError(f"{option}: {target} is not empty (refusing to overwrite or mix "
                             f"results; give a new folder)")
    writable_ancestor(target, option)


def device(device: str, option: str = "--device") -> None:
    """Refuse a CUDA ``device`` that is not there; ``option``: the flag that asked for it."""
    if device == "cuda":
        import torch
        if not torch.cuda.is_available():
            raise ValueError(f"{option} cuda: torch sees no CUDA device on this machine "
                             f"(use {option} cpu)")


def seed(value: int, option: str) -> None:
    from psmforce.sim.dataset import MAX_SEED  # the simulator's limit (numpy's seed range)
    if not 0 <= value <= MAX_SEED:
        raise ValueError(f"{option}: must be an integer in [0, {MAX_SEED}], got {value}")


def training_options(args) -> None:
    """What train / finetune would discover only after loading data or training."""
    if args.epochs < 1:
        raise ValueError(f"--epochs: must be at least 1, got {args.epochs}")
    seed(args.seed, "--seed")
    device(args.device)
    output_file(args.out, "--out")


MAX_JSON_OPTION_BYTES = 1 << 20
"""The largest file an option holding JSON (``--config``) may name: a model's arguments."""


def json_object(value: str | None, option: str) -> dict | None:
    """An option holding a JSON object, inline (it starts with ``{`` or ``[``) or as the path of a regular
    file of at most :data:`MAX_JSON_OPTION_BYTES` holding one; None when the option is not
    given."""
    if value is None:
        return None
    inline = value.lstrip().startswith(("{", "["))  # JSON, never tried as a path
    if inline:
        text = value
    else:
        from psmforce.core.files import read_input_text
        try:
            text = read_input_text(value, MAX_JSON_OPTION_BYTES, f"{option} file")
        except ValueError as err:
            raise ValueError(f"{option}: {err} (inline JSON starts with '{{')") from None
    try:
        parsed = json.loads(text)
    except json.JSONDecodeError as err:
        what = "the inline JSON is not valid" if inline else f"file {value} holds no valid JSON"
        raise ValueError(f"{option}: {what} ({err})") from None
    if not isinstance(parsed, dict):
        raise ValueError(f"{option}: expected a JSON object, got {type(parsed).__name__}")
    return parsed


def write_json(path: str | None, payload: dict) -> None:
    """``payload`` as JSON at ``path``, whole or not at all; ``-``: on standard output."""
    if path is None:
        return
    text = json.dumps(payload, indent=2, default=_jsonable) + "\n"
    if path == "-":
        sys.stdout.write(text)
        return
    from psmforce.core.files import write_text_atomic
    write_text_atomic(path, text)


def _jsonable(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def scale(value: float) -> None:
    from psmforce.sim.dataset import MAX_SCALE  # the simulator's limit, checked before it runs
    if not 0 < value <= MAX_SCALE:  # also refuses NaN
        raise ValueError(f"--scale: must be in (0, {MAX_SCALE:g}] (times the paper's "
                         f"protocol), got {value:g}")


MAX_RATE_HZ = 10_000.0  # psmforce.io.recording.MAX_RATE_HZ, without importing the library
"""The highest stream rate an option may ask for (:data:`psmforce.io.recording.MAX_RATE_HZ`)."""
MAX_SECONDS = 1e7
"""The longest duration an option may ask for (about four months)."""


def number_in(low: float, high: float, *, low_open: bool = True, integer: bool = False):
    """An argparse ``type``: a finite number in ``(low, high]`` (``[low, high]`` when not
    ``low_open``), refused in argparse's one line naming the option otherwise (NaN and
    infinity included), before any allocation or wait."""
    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        above = value > low if low_open else value >= low
        if not (math.isfinite(value) and above and value <= high):
            bracket = "(" if low_open else "["
            raise argparse.ArgumentTypeError(f"must be in {bracket}{low:g}, {high:g}], got {text}")
        return value
    return parse


RATE_HZ = number_in(0.0, MAX_RATE_HZ)
SECONDS = number_in(0.0, MAX_SECONDS)


def ros_name(*, namespace: bool = False):
    """An argparse ``type``: a ROS 2 topic name (``namespace``: an arm namespace), checked
    against ROS 2's naming rules (:mod:`psmforce.io.bags.names`) in argparse's one line naming
    the option, before anything is read or any endpoint is created."""
    from psmforce.io.bags.names import check_namespace, check_ros_name

    def parse(text: str) -> str:
        try:
            return check_namespace(text, "name") if namespace else check_ros_name(text, "name")
        except ValueError as err:
            raise argparse.ArgumentTypeError(str(err).replace("name ", "", 1)) from None
    return parse


HELD_VALUES = ("as-held", "checked")
"""``--held-values`` (psmforce.estimators.training.calibrate.HELD_VALUES, without importing the
library)."""

JACKKNIFE_UNITS = ("orientation", "sign_pair")
"""``--jackknife-unit`` (psmforce.estimators.training.ati_free.JACKKNIFE_UNITS, without importing
the library)."""

HOLD_RULES = ("imprecise", "unresolved", "least-uncertain")
"""``calibrate --hold-rule`` (psmforce.identification.prior_selection.HOLD_RULES, without
importing the library)."""

PRIOR_REFITS = ("all", "identified")
"""``calibrate --prior-refit`` (psmforce.estimators.training.calibrate.PRIOR_REFITS without
"per_mount", which ``psmforce remount`` runs; without importing the library)."""

NETWORK_OFF_RULES = ("none", "carried")
"""``calibrate --network-off`` rules (psmforce.estimators.training.calibrate.NETWORK_OFF_RULES,
without importing the library); axis names are the alternative."""


NETWORK_PRIORS = ("calibrated", "trained")
"""``calibrate --network-prior`` (psmforce.estimators.training.calibrate.NETWORK_PRIORS, without
importing the library)."""


def network_off(values: list[str]):
    """``calibrate --network-off``'s words as the library's ``network_off``: one rule of
    :data:`NETWORK_OFF_RULES`, or distinct axis names (Fx Fy Fz), else a one-line error."""
    if len(values) == 1 and values[0] in NETWORK_OFF_RULES:
        return values[0]
    axes = ("Fx", "Fy", "Fz")
    if any(v not in axes for v in values) or len(set(values)) != len(values):
        raise ValueError(f"--network-off: one of {', '.join(NETWORK_OFF_RULES)} or distinct "
                         f"axis names of {' '.join(axes)}, got {' '.join(values)}")
    return tuple(values)


CROSSTALK_OPTIONS = {"reading": None, "none": False, "axial": True, "full": "full"}
"""``--crosstalk`` -> the fit's ``crosstalk`` (psmforce.identification.prior.CROSSTALK_CHOICES,
without importing the library): as the reading does, none, the axial column, every force
column."""
