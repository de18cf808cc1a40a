"""The finished trainings of a study kept as records: one JSON file per (seed, scale, name) under
its work folder, so processes on different seeds never write the same file, and the study's
JSON assembled from them.

The work folder is scratch: a fresh checkout does not have it (``runs/`` is not committed), so a
study's JSON also carries its records, and assembling keeps each record the JSON already holds
unless the work folder has one of the same seed, scale and name (a training run again). A run on
a new machine adds to the committed JSON instead of replacing it with what that machine trained.
Every record, from a file or from the JSON, is checked as user input: a record that is not JSON,
is not a training of the study or lacks a figure its table reads is refused in one line that
names it and says how to train it again.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable, Iterable

from psmforce.core.files import MAX_JSON_BYTES, read_input_text

Key = tuple[float, int]
"""(scale, seed)."""


def check_record(record, where: str, name: str, names, keys) -> dict:
    """``record`` if it is a dict holding every key of ``keys`` and ``name`` is one of ``names``;
    else ValueError naming ``where``."""
    if name not in names:
        raise ValueError(f"{where}: not a training of this study ({', '.join(names)})")
    missing = [k for k in keys if not isinstance(record, dict) or k not in record]
    if missing:
        raise ValueError(f"{where}: lacks {', '.join(missing)}; remove it to train it again")
    return record


def read_json(path: Path, what: str):
    """The JSON in ``path``, read through the input guard; ValueError naming it otherwise."""
    try:
        return json.loads(read_input_text(path, MAX_JSON_BYTES, what))
    except json.JSONDecodeError as err:
        raise ValueError(f"{path}: not JSON ({err.msg})") from None


def read_record(path: Path, names, keys) -> dict:
    """The record in ``path`` (its stem is the training's name), checked."""
    return check_record(read_json(path, "training record"), str(path), path.stem, names, keys)


def gather(work: Path, folder: str, json_path: Path, names, keys,
           in_json: Callable[[dict], Iterable[tuple[float, int, str, object]]]
           ) -> dict[Key, dict[str, dict]]:
    """Every record, ``{(scale, seed): {name: record}}``: those the study's JSON at
    ``json_path`` holds (``in_json`` lists them as (scale, seed, name, record)), then those under
    ``work/seed{S}_scale{X}/{folder}/``, which replace the JSON's of the same key and name."""
    records: dict[Key, dict[str, dict]] = {}
    if json_path.exists():
        result = read_json(json_path, "study results")
        try:
            kept = list(in_json(result))
        except (AttributeError, KeyError, TypeError, ValueError) as err:
            raise ValueError(f"{json_path}: not this study's results ({err!r:.80}); move it "
                             f"aside to assemble from the work folder alone") from None
        for scale, seed, name, record in kept:
            where = f"{json_path}: scale {scale:g} seed {seed} {name}"
            records.setdefault((float(scale), int(seed)), {})[name] = check_record(
                record, where, name, names, keys)
    for path in sorted(work.glob(f"seed*_scale*/{folder}/*.json")):
        seed, scale = path.parent.parent.name[4:].split("_scale")
        records.setdefault((float(scale), int(seed)), {})[path.stem] = read_record(
            path, names, keys)
    return records
