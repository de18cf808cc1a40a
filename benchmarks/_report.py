"""What every benchmark does with its figures: write them as JSON, whole or not at all."""

from __future__ import annotations

import json
from pathlib import Path

from psm_model.files import write_text_atomic


def write_json(path: str | Path, figures: dict) -> None:
    """``figures`` as indented JSON at ``path`` (parents created), whole or not at all
    (:func:`psm_model.files.write_text_atomic`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(figures, indent=2, default=float) + "\n")
    print(f"wrote {path}")
