"""What the studies, benchmarks and robustness runs share: the options of one on a dataset
folder, writing its figures as JSON, whole or not at all, keeping a step's JSON so that a rerun
resumes, and naming paths in them without a machine's absolute path."""

from __future__ import annotations

import argparse
import json
import os
import platform
from pathlib import Path
from typing import Any, Callable

from psmforce.core.files import (
    MAX_JSON_BYTES,
    read_input_text,
    write_json_atomic,
    write_text_atomic,
)


def write_json(path: str | Path, figures: dict) -> None:
    """``figures`` as indented JSON at ``path`` (parents created), whole or not at all
    (:func:`psmforce.core.files.write_text_atomic`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(figures, indent=2, default=float) + "\n")
    print(f"wrote {path}")


def kept_json(path: str | Path, compute: Callable[[], Any]) -> Any:
    """The JSON at ``path``, or ``compute()``'s result written there first (parents created;
    whole or not at all, NaN refused: :func:`psmforce.core.files.write_json_atomic`) and
    returned: a study's step that finished is read back, so a rerun of the study resumes after
    it. What is read back is checked as an input (:func:`psmforce.core.files.read_input_text`):
    anything but a regular file of JSON, NaN included, is refused with a ValueError that names
    it, and is left in place for the user to look at or delete."""
    path = Path(path)
    if os.path.lexists(path):
        text = read_input_text(path, MAX_JSON_BYTES, "kept step of a study")
        try:
            return json.loads(text, parse_constant=_refuse_constant)
        except ValueError as err:
            raise ValueError(f"{path}: the kept step of a study is not JSON ({err}); delete it "
                             f"to compute the step again") from None
    path.parent.mkdir(parents=True, exist_ok=True)
    result = compute()
    write_json_atomic(path, result)
    return result


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def shown_path(path: str | Path, under: str | Path | None = None) -> str:
    """``path`` as a committed JSON names it: relative to ``under`` (a run's work folder) when
    it lies there, else to the repository (:func:`repository`)."""
    path = Path(path).resolve()
    if under is not None and path.is_relative_to(Path(under).resolve()):
        return str(path.relative_to(Path(under).resolve()))
    return os.path.relpath(path, repository())


def cpu_model() -> str:
    """The processor's model name (``platform.processor()`` is empty on many Linux machines)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            names = [ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")]
    except OSError:
        names = []
    return names[0] if names else platform.processor()


def repository() -> Path:
    """The checkout this package runs from (the folder above ``psmforce/`` holding its
    ``pyproject.toml``), else the working folder: an installed wheel has no repository."""
    above = Path(__file__).resolve().parents[2]
    return above if (above / "pyproject.toml").is_file() else Path.cwd()


def dataset_arguments(doc: str) -> argparse.Namespace:
    """``--data DIR`` (a dataset folder), ``--seed`` (the validation split's, default 0) and
    ``--json OUT`` for a benchmark described by the first paragraph of ``doc``."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=Path)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path)
    return ap.parse_args()
