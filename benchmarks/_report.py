"""What every benchmark does with its figures: write them as JSON, whole or not at all."""

from __future__ import annotations

import json
from pathlib import Path


def write_json(path: str | Path, figures: dict) -> None:
    """``figures`` as indented JSON at ``path`` (parents created), atomically: a ``.part`` file
    renamed into place, so an interrupted run leaves no partial file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    try:
        tmp.write_text(json.dumps(figures, indent=2, default=float) + "\n")
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)
    print(f"wrote {path}")
