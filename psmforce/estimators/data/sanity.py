"""Data sanity that needs no parsing: recordings identified by content, so a test set that
repeats the trials a model was trained on is found before it is scored.

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
from pathlib import Path

METADATA = "metadata.json"


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
