"""Reading back an identified model's JSON file: the one check every model's ``load`` starts
with (readable, valid JSON, an object of the expected format), refused by name."""

from __future__ import annotations

import json
from pathlib import Path

from psm_model.identification.errors import IdentificationInputError


def read_model_json(path, file_format: str, what: str) -> dict:
    """The JSON object in ``path`` whose ``format`` is ``file_format``; otherwise an
    :class:`IdentificationInputError` naming the file and ``what`` it should hold (``"an
    InternalForcePrior"``)."""
    try:
        d = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise IdentificationInputError(f"{path}: cannot read {what} JSON ({err})") from None
    if not isinstance(d, dict) or d.get("format") != file_format:
        raise IdentificationInputError(f"{path}: not {what} file ({file_format})")
    return d
