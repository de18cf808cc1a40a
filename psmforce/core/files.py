"""Files written whole or not at all, and never through or over what the user has.

Every file the project writes (recordings, dataset metadata, priors, arm models, checkpoints,
exports, figures, reports, task caches, bags) goes through :func:`atomic_path`: the content is
written to a temporary sibling and renamed onto the target only once complete, and the sibling
is removed if writing fails. The file gets the permissions of the file it replaces, or those a
plain write would give (0o666 less the umask). A rename within one folder is atomic on POSIX, so a reader, or a
writer interrupted by a signal or a full disk, sees the previous file or none, never half of one.

The temporary sibling is created exclusively under a name no other file has
(``.NAME.<random>.part``, :func:`tempfile.mkstemp`): a file the user keeps beside the target,
whatever its name, is never taken for it and never deleted, and a link planted under some
expected name is never written through. The target itself must be a regular file or absent:
a symbolic link, a folder, a named pipe, a socket or a device (``/dev/stdout`` included) is
refused (:class:`OutputError`), since the rename would replace it with a regular file. A folder
written as a whole (a bag's staging folder) is staged the same way (:func:`staging_folder`).
:func:`folder_sha256` tells whether two folders hold the same files, byte for byte.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

_KINDS = ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISDIR, "a folder"),
          (stat.S_ISFIFO, "a named pipe"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))


class OutputError(ValueError):
    """An output path the project will not write: it exists and is not a regular file."""


def check_output(path: str | Path) -> None:
    """Refuse ``path`` unless it is absent or a regular file (not followed if a link)."""
    try:
        mode = os.lstat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):  # absent; whether it can be written is
        return                                       # the writer's (or the caller's) check
    if stat.S_ISREG(mode):
        return
    kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
    raise OutputError(f"{path}: exists and is {kind}; refusing to replace it with a file "
                      f"(give the path of a regular file or a new name)")


MAX_JSON_BYTES = 64 << 20
"""The largest JSON file read back (a model, a prior, an export's JSON, a column map)."""
MAX_DATA_BYTES = 8 << 30
"""The largest recording or checkpoint file read back: a bound no real one nears."""


def check_input_file(path: str | Path, max_bytes: int, what: str = "input") -> None:
    """Refuse (ValueError naming it) an input ``path`` that is not a regular file (a link to one
    is followed) of at most ``max_bytes``: a pipe would hang its reader and a device
    (``/dev/zero``) exhaust the memory."""
    try:
        info = os.stat(path)
    except OSError as err:
        raise ValueError(f"{path}: cannot read the {what} ({err.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        raise ValueError(f"{path}: the {what} is not a regular file")
    if info.st_size > max_bytes:
        raise ValueError(f"{path}: the {what} holds {info.st_size} bytes, more than the "
                         f"{max_bytes} it may")


def read_input_text(path: str | Path, max_bytes: int, what: str = "input") -> str:
    """The text of the input file ``path`` (:func:`check_input_file`), read no further than
    ``max_bytes`` even if it grows meanwhile."""
    check_input_file(path, max_bytes, what)
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:  # grew while read
        raise ValueError(f"{path}: the {what} is longer than the {max_bytes} bytes it may hold")
    try:
        return data.decode()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: the {what} is not UTF-8 text") from None


def check_name(path: str | Path) -> None:
    """Refuse (ValueError) a path the file system cannot hold: a name longer than its folder
    allows, or a path longer than the system's limit; found before any work, not after it."""
    path = Path(path)
    folder = next((p for p in [path.parent, *path.parent.parents] if p.is_dir()), Path("."))
    name_max = os.pathconf(folder, "PC_NAME_MAX")
    long = next((part for part in path.parts if len(os.fsencode(part)) > name_max), None)
    if long is not None:
        raise ValueError(f"{path}: the name {long[:40]}... is {len(os.fsencode(long))} bytes, "
                         f"longer than the {name_max} the file system allows")
    path_max = os.pathconf(folder, "PC_PATH_MAX")
    if len(os.fsencode(os.path.abspath(path))) >= path_max:
        raise ValueError(f"{path}: longer than the {path_max} bytes a path may have")


@contextmanager
def atomic_path(path: str | Path, *, keep_suffix: bool = False) -> Iterator[Path]:
    """Yield a new, empty temporary sibling to write; on success it replaces ``path``.

    ``keep_suffix``: the temporary name ends in ``.part.SUFFIX`` (for writers that choose the
    format by suffix, such as matplotlib). Several processes may write one target at once: each
    has its own sibling, and the last complete write wins."""
    path = Path(path)
    check_output(path)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.",
                                suffix=".part" + (path.suffix if keep_suffix else ""),
                                dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        check_output(path)  # again: the target may have changed while the content was written
        os.chmod(tmp, _mode_for(path))
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def _mode_for(path: Path) -> int:
    """The permissions ``path`` gets: those of the file it replaces, else those a plain
    ``open(path, "w")`` would give (0o666 less the umask). The temporary sibling is created
    0o600, as :func:`tempfile.mkstemp` must, and would otherwise hide the output from the
    user's group."""
    try:
        return stat.S_IMODE(os.lstat(path).st_mode)
    except FileNotFoundError:
        mask = os.umask(0o022)  # read by setting: the only portable way; restored at once
        os.umask(mask)
        return 0o666 & ~mask


@contextmanager
def staging_folder(path: str | Path) -> Iterator[Path]:
    """Yield a new, empty temporary folder beside ``path`` (``.NAME.<random>.part``) for a
    writer that needs a folder of its own; it is removed with whatever is left in it."""
    path = Path(path)
    staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent))
    try:
        yield staging
    finally:
        shutil.rmtree(staging, ignore_errors=True)


LOCK_NAME = ".psmforce.lock"
"""The file in an output folder that a command holds locked while it writes the folder."""


@contextmanager
def locked_folder(folder: str | Path) -> Iterator[Path]:
    """Hold the output folder ``folder`` (created if absent) for the block: a second command
    (another process, or another call here) that asks for it meanwhile is refused at once
    (:class:`OutputError`, one line), so two writers never mix their files in one folder. The
    lock is an exclusive ``flock`` on :data:`LOCK_NAME` inside the folder, released when the block
    ends or the process dies (a killed command leaves no lock that blocks the next one); the file
    goes with the block, and so does the folder if the block made it and left it empty. Callers check the folder's contents (:func:`folder_is_empty`) inside the
    block, where no other command can change them."""
    folder = Path(folder)
    created = not os.path.lexists(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lock = folder / LOCK_NAME
    fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        if os.fstat(fd).st_ino != os.stat(lock, follow_symlinks=False).st_ino:
            raise BlockingIOError  # the holder removed the file between our open and our lock
    except (BlockingIOError, FileNotFoundError):
        os.close(fd)
        raise OutputError(f"{folder}: another command is writing this folder now; wait for it "
                          f"to end or give another folder") from None
    try:
        yield folder
    finally:
        Path(lock).unlink(missing_ok=True)
        os.close(fd)
        if created and not any(folder.iterdir()):
            folder.rmdir()  # made for a command that wrote nothing (refused): not left behind


def folder_is_empty(folder: str | Path) -> bool:
    """Whether ``folder`` holds nothing but, perhaps, the lock of :func:`locked_folder`."""
    return all(p.name == LOCK_NAME for p in Path(folder).iterdir())


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
        one = hashlib.sha256()  # by chunks: hashlib.file_digest is Python 3.11+ only
        with open(f, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                one.update(chunk)
        total.update(f.relative_to(folder).as_posix().encode() + b"\0" + one.digest())
    return total.hexdigest()
