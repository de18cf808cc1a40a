"""Files written whole or not at all.

Every file the project writes (recordings, dataset metadata, priors, arm models, checkpoints,
exports, figures, reports, task caches) goes through :func:`atomic_path`: the content is written
to a sibling ``NAME.part`` and renamed onto ``NAME`` only once complete, and the sibling is
removed if writing fails. A rename within one folder is atomic on POSIX, so a reader, or a writer
interrupted by a signal or a full disk, sees the previous file or none, never half of one.
:func:`folder_sha256` tells whether two folders hold the same files, byte for byte.
"""

from __future__ import annotations

import hashlib
import json
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator


@contextmanager
def atomic_path(path: str | Path, *, keep_suffix: bool = False,
                per_process: bool = False) -> Iterator[Path]:
    """Yield the temporary sibling to write; on success it replaces ``path``.

    ``keep_suffix``: ``NAME.part.SUFFIX`` (for writers that choose the format by suffix, such as
    matplotlib). ``per_process``: ``.NAME.PID.part``, for caches that several processes may
    write at once (the last complete write wins, none sees another's half)."""
    path = Path(path)
    if per_process:
        tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    elif keep_suffix:
        tmp = path.with_name(f"{path.stem}.part{path.suffix}")
    else:
        tmp = path.with_name(f"{path.name}.part")
    try:
        yield tmp
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def write_text_atomic(path: str | Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_json_atomic(path: str | Path, obj) -> None:
    """``obj`` as indented JSON; NaN and infinity are refused (ValueError), not written as the
    non-standard ``NaN`` / ``Infinity``."""
    write_text_atomic(path, json.dumps(obj, indent=2, allow_nan=False) + "\n")


def folder_sha256(folder: str | Path) -> str:
    """SHA-256 over every file under ``folder``: each one's path relative to it and its
    contents, in path order; equal for two folders only when they hold the same files."""
    folder = Path(folder)
    total = hashlib.sha256()
    for f in sorted(q for q in folder.rglob("*") if q.is_file()):
        with open(f, "rb") as fh:
            total.update(f.relative_to(folder).as_posix().encode() + b"\0"
                         + hashlib.file_digest(fh, "sha256").digest())
    return total.hexdigest()
