"""Reading back an identified model's JSON file: the one check every model's ``load`` starts
with (readable, valid JSON, an object of the expected format), refused by name; from a file
(:func:`read_model_json`) or from its text in memory (:func:`parse_model_json`); and its
integrity envelope (:func:`check_sealed`: :mod:`psmforce.core.integrity`)."""

from __future__ import annotations

import json

from psmforce.identification.errors import IdentificationInputError
from psmforce.core.files import MAX_JSON_BYTES, read_input_text
from psmforce.core.integrity import check_version, verify


def read_model_json(path, file_format: str, what: str) -> dict:
    """The JSON object in ``path`` whose ``format`` is ``file_format``; otherwise an
    :class:`IdentificationInputError` naming the file and ``what`` it should hold (``"an
    InternalForcePrior"``)."""
    try:
        text = read_input_text(path, MAX_JSON_BYTES, f"{what} JSON")
    except (OSError, ValueError) as err:
        raise IdentificationInputError(f"{err}" if str(path) in str(err)
                                       else f"{path}: cannot read {what} JSON ({err})") from None
    return parse_model_json(text, file_format, what, path)


def parse_model_json(text: str, file_format: str, what: str, source="model JSON") -> dict:
    """:func:`read_model_json` on text already in memory (a checkpoint's copy of the file);
    ``source`` names it in the refusals."""
    try:
        d = json.loads(text)
    except (TypeError, json.JSONDecodeError) as err:
        raise IdentificationInputError(f"{source}: cannot read {what} JSON ({err})") from None
    if not isinstance(d, dict) or d.get("format") != file_format:
        raise IdentificationInputError(f"{source}: not {what} file ({file_format})")
    return d


def check_sealed(d: dict, source, what: str, version: int) -> None:
    """Refuse ``d`` (an :class:`IdentificationInputError` naming ``source`` and the field)
    unless its ``format_version`` is the integer ``version`` and its fields match its SHA-256
    envelope. A file with neither was written before them and passes (the model's own checks
    follow); one with only one of them is refused."""
    if "format_version" in d or "sha256" in d:
        check_version(d.get("format_version"), (version,), str(source), what,
                      IdentificationInputError)
        verify(d, str(source), what, IdentificationInputError)
