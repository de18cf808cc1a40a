"""Data sanity before learning: a dataset's entries (each recording listed once, under a known
condition and split), every value inside its physical range, targets that are forces the
shaft could carry and that change; and recordings identified by content, so a test set that
repeats the trials a model was trained on is found before it is scored. Each check returns what
is wrong, in words, or None; :mod:`psmforce.estimators.data.dataset` raises it naming the file.

:func:`file_sha256` is a recording's content hash (its bytes);
:meth:`psmforce.estimators.training.checkpoint.TrainedModel.save` records it for every training and
validation trial (``provenance["trial_sha256"]``), and :func:`repeated_recordings` compares a
dataset split with those (``psmforce evaluate`` refuses a test set that repeats them unless told to
score it). The other check before learning, a constant target column, is
:func:`psmforce.estimators.data.dataset.load_dataset`'s.
"""

from __future__ import annotations

import hashlib
import json
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

from psmforce.estimators.data.bounds import MAX_FORCE_N
from psmforce.io.recording import TARGETS

METADATA = "metadata.json"
CONDITIONS = ("Free", "Traction", "Palpation", "Rigid", "Soft", "KnownLoad")
"""The conditions of the paper's protocols (automated: free space, traction, palpation;
teleoperation: rigid, soft, free): what the pipeline's splits, priors and calibrations read; and
``KnownLoad``, a known mass hung at the tip, what a calibration without an ATI reads
(:mod:`psmforce.estimators.training.ati_free`)."""
SPLITS = ("train", "test")


def entry_problem(entries: list[tuple[str, str, str]]) -> str | None:
    """What is wrong with a dataset's (path, condition, split) entries: a recording listed twice
    (it would train at double weight), a condition or split the pipeline does not know."""
    counts = Counter(path for path, _, _ in entries)
    repeated = next((path for path, n in counts.items() if n > 1), None)
    if repeated is not None:
        return f"recording {repeated} is listed {counts[repeated]} times"
    for path, condition, split in entries:
        if condition not in CONDITIONS:
            return (f"recording {path}: unknown condition {condition!r}; the conditions are "
                    f"{list(CONDITIONS)}")
        if split not in SPLITS:
            return f"recording {path}: unknown split {split!r}; the splits are {list(SPLITS)}"
    return None


def outside_physical_range(frame: pd.DataFrame, bounds: dict) -> str | None:
    """The first value outside the physical range the streaming estimator accepts
    (:func:`psmforce.estimators.data.bounds.physical_bounds`), in words: a model is never trained
    or scored on samples it would refuse when streaming (a roll of 1e30 rad would set a scaler and
    train silently)."""
    for column, (low, high) in bounds.items():
        values = frame[column].to_numpy(dtype=float)
        outside = (values < low) | (values > high)
        if outside.any():
            row = int(np.argmax(outside))
            return (f"{column} = {values[row]:.6g} at row {row} is outside its physical range "
                    f"[{low:.4g}, {high:.4g}] (psmforce.estimators.data.bounds.physical_bounds)")
    return None


def target_problem(frame: pd.DataFrame) -> str | None:
    """A target column that never changes (nothing to learn from or score against: the ATI of a
    real or simulated bench always reads some noise), or one beyond the force the shaft sensor
    can carry (:data:`psmforce.estimators.data.bounds.MAX_FORCE_N`: a unit slip, a wrong
    calibration)."""
    for column in TARGETS:
        values = frame[column].to_numpy(dtype=float)
        if len(values) and values.min() == values.max():
            return (f"target {column} is constant ({values[0]:g} in all {len(values)} rows): "
                    f"the force sensor recorded nothing (unplugged or not written)")
        beyond = np.abs(values) > MAX_FORCE_N
        if beyond.any():
            row = int(np.argmax(beyond))
            return (f"target {column} = {values[row]:.6g} N at row {row} is beyond the "
                    f"{MAX_FORCE_N:g} N the shaft sensor can carry")
    return None


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes (a recording's content hash)."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def repeated_recordings(root: str | Path, split: str, known: dict) -> list[tuple[str, str]]:
    """(recording of ``split`` in the dataset ``root``, the trial of ``known`` it repeats) for
    every recording whose content equals one of ``known`` (trial path -> SHA-256, a
    checkpoint's ``provenance["trial_sha256"]``); empty when none does. Reads only the
    metadata and the bytes of the files, so it runs before any parsing or scoring."""
    root = Path(root)
    try:
        entries = json.loads((root / METADATA).read_text())["trials"]
        listed = [e["path"] for e in entries if e.get("split") == split]
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return []  # load_dataset refuses such a folder by name
    by_hash = {h: t for t, h in known.items() if isinstance(h, str)}
    repeats = []
    for rel in listed:
        path = root / rel
        if isinstance(rel, str) and path.is_file() and ".." not in Path(rel).parts:
            match = by_hash.get(file_sha256(path))
            if match is not None:
                repeats.append((rel, match))
    return repeats
