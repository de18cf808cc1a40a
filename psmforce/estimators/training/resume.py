"""Resumable training: the training loop's whole state after each epoch, written atomically and
read back as strictly as a checkpoint.

A training killed between epochs (a session's end, Ctrl-C, a lost machine) resumes from its last
completed epoch and ends bit-identical to an uninterrupted run on the same device and thread count
(``tests/estimators/test_resume.py``). It may also resume on another device (a GPU training whose
machine is gone goes on on the CPU): the result is then a training like any other, not bit-identical
to either device's, and its history names each epoch's device. The state holds what the next epoch
depends on: the model's weights, the best weights so far, the optimiser's and the scheduler's state,
the early stopping counters, the history, the random stream that orders each epoch's batches and
torch's global random state (dropout draws from it; CUDA's too on a GPU). A kill inside an epoch
loses that epoch only.

The file: ``torch.save`` of ``{"format", "format_version", "fingerprint", "sha256",
"payload"}``, where ``payload`` is the state serialised by ``torch.save`` (plain tensors, dicts,
lists and numbers; read back with ``weights_only=True``) and ``sha256`` its digest. The
fingerprint is a digest of everything the training depends on (:func:`fingerprint`: the
training configuration but the device, the model's name, constructor config and input columns,
the number of training and validation windows). Loading refuses, with :class:`ResumeError`
naming the file: a file of another format or format version (an integer, strictly), a payload
that does not match its digest, and a state written for another training; it is never silently
continued or silently restarted.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path

import torch

from psmforce.core.files import atomic_path

FORMAT = "psmforce-training-state"
FORMAT_VERSION = 1


class ResumeError(ValueError):
    """A training state that cannot be read, or belongs to another training."""


def fingerprint(parts: dict) -> str:
    """SHA-256 of ``parts`` (JSON-serialisable values; keys sorted)."""
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()


def save_state(path: str | Path, fingerprint_: str, state: dict) -> None:
    """Write ``state`` (see the module docstring) atomically: a kill while writing leaves the
    previous epoch's file whole."""
    buf = io.BytesIO()
    torch.save(state, buf)
    payload = buf.getvalue()
    record = {"format": FORMAT, "format_version": FORMAT_VERSION, "fingerprint": fingerprint_,
              "sha256": hashlib.sha256(payload).hexdigest(), "payload": payload}
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        torch.save(record, tmp)


def load_state(path: str | Path, fingerprint_: str) -> dict | None:
    """The state saved at ``path`` for the training of ``fingerprint_``; None when there is no
    file (a fresh start). Refuses anything else with :class:`ResumeError` (module docstring)."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        record = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # torch raises several types for a corrupt or foreign file
        raise ResumeError(f"{path}: not a readable training state ({type(err).__name__})") \
            from None
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise ResumeError(f"{path}: not a {FORMAT} file")
    version = record.get("format_version")
    if type(version) is not int or version != FORMAT_VERSION:
        raise ResumeError(f"{path}: format version {version!r}, this code reads "
                          f"{FORMAT_VERSION}")
    payload = record.get("payload")
    if not isinstance(payload, bytes) or hashlib.sha256(payload).hexdigest() != record.get(
            "sha256"):
        raise ResumeError(f"{path}: the saved state does not match its SHA-256 (changed or "
                          "truncated); delete it to train from the start")
    if record.get("fingerprint") != fingerprint_:
        raise ResumeError(f"{path}: this state was written by another training (other "
                          "configuration, model, inputs or data); delete it or resume the "
                          "training it belongs to")
    try:
        state = torch.load(io.BytesIO(payload), map_location="cpu", weights_only=True)
    except Exception as err:
        raise ResumeError(f"{path}: unreadable saved state ({type(err).__name__})") from None
    if not isinstance(state, dict):
        raise ResumeError(f"{path}: the saved state is not a dict")
    return state


def clear_state(path: str | Path | None) -> None:
    """Remove a training's state once its result is safely written elsewhere."""
    if path is not None:
        Path(path).unlink(missing_ok=True)
