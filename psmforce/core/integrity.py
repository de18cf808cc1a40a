"""The integrity envelope of every artefact psmforce writes and reads back: a SHA-256 over all
that gives the artefact its meaning, a strictly typed format version, and one error naming the
file when either does not match. It lives at the bottom layer (it imports nothing of the
project), so the identified models (a prior, an arm dynamics model, a cable transmission)
seal their files as the estimators' artefacts do;
:mod:`psmforce.core.integrity` is the same functions under the estimators' name.

An artefact is a JSON-ready record (a checkpoint's metadata, an export's JSON, a cached task's
result); its binary parts (weights, an ONNX graph) enter the record as their own SHA-256, so the
envelope covers them too. :func:`seal` returns the record with a ``sha256`` entry: for every
other top-level field the SHA-256 of its canonical JSON (sorted keys, no whitespace, floats as
Python writes them, which read back to the same bits), and under ``"all"`` one SHA-256 over the
field names and their digests. :func:`verify` recomputes them and raises naming the file and the
fields that changed, appeared or disappeared; a record without its ``sha256`` is refused too.
Any field counts, present or future (a ``sample_rate_hz`` added to a checkpoint is covered
without a change here).

The digest guards against corruption and careless or accidental edits, not against an
attacker: whoever edits a field can recompute its digest. It is not a signature.

:func:`check_version` accepts only an ``int`` (not a bool, not ``2.0``, not ``"2"``) among the
versions the reader knows: a version that is not an integer never skips a check.
"""

from __future__ import annotations

import hashlib
import json
from typing import Sequence

DIGEST = "sha256"
"""The record's field holding the envelope."""


class IntegrityError(ValueError):
    """An artefact whose digest or format version does not match; the message names the file."""


def canonical(value) -> bytes:
    """The canonical JSON bytes of a JSON-ready value (what the digests hash)."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=True,
                      ensure_ascii=True).encode()


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _digests(record: dict) -> dict:
    fields = {name: sha256_bytes(canonical(value))
              for name, value in record.items() if name != DIGEST}
    fields["all"] = sha256_bytes(canonical(sorted(fields.items())))
    return fields


def seal(record: dict) -> dict:
    """``record`` (JSON-ready; tuples become lists, as they read back) with its ``sha256``."""
    plain = json.loads(json.dumps({k: v for k, v in record.items() if k != DIGEST},
                                  allow_nan=True))
    return {**plain, DIGEST: _digests(plain)}


def verify(record: dict, where: str, what: str, error: type[ValueError] = IntegrityError
           ) -> None:
    """Raise ``error`` (one line naming ``where`` and the fields) unless ``record``'s fields
    match its ``sha256``; ``what`` names the artefact ("checkpoint")."""
    stored = record.get(DIGEST)
    if not isinstance(stored, dict) or not isinstance(stored.get("all"), str):
        raise error(f"{where}: {what} carries no SHA-256 envelope, so its contents cannot be "
                    f"verified")
    fresh = _digests(record)
    if fresh == stored:
        return
    changed = sorted(k for k in fresh.keys() & stored.keys() - {"all"} if fresh[k] != stored[k])
    added = sorted(fresh.keys() - stored.keys())
    removed = sorted(stored.keys() - fresh.keys())
    parts = ([f"changed: {', '.join(changed)}"] if changed else []) + (
        [f"added: {', '.join(added)}"] if added else []) + (
        [f"removed: {', '.join(removed)}"] if removed else [])
    raise error(f"{where}: {what} does not match its SHA-256 envelope ("
                + ("; ".join(parts) or "the envelope itself was edited")
                + "): edited or corrupted since it was written")


def check_version(value, readable: Sequence[int], where: str, what: str,
                  error: type[ValueError] = IntegrityError) -> int:
    """``value`` if it is an ``int`` among ``readable``, else ``error`` naming ``where``."""
    if type(value) is not int:  # noqa: E721 - bool and float versions are refused, not coerced
        raise error(f"{where}: {what} format version {value!r} is not an integer "
                    f"(this code reads versions {list(readable)})")
    if value not in readable:
        raise error(f"{where}: {what} format version {value}, this code reads versions "
                    f"{list(readable)}")
    return value
