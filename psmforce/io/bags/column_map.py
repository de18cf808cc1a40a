"""CSV exports with other column names: a JSON column map and a converter to the recording layout.

A column map file is one JSON object ``{"their_column": "our_column", ...}``, for example::

    {"t": "time", "q1": "yaw_position", "Fx_hex": "fx"}

Every target must be a column of the recording layout (:data:`psmforce.io.recording.COLUMNS`) or a
``sim_*`` column, and no two source columns may map to the same target. Columns the map does not
name keep their names.
"""

from __future__ import annotations

import json
from pathlib import Path

from psmforce.core.files import MAX_JSON_BYTES, read_input_text
from psmforce.io.recording import COLUMNS, RecordingError, read_recording, write_recording


def load_column_map(path: str | Path) -> dict[str, str]:
    """Read and check a column map JSON file; raises :class:`RecordingError` naming the problem."""
    path = Path(path)
    try:
        text = read_input_text(path, MAX_JSON_BYTES, "column map")
    except (OSError, ValueError) as err:
        raise RecordingError(str(err)) from None
    try:
        mapping = json.loads(text)
    except json.JSONDecodeError as err:
        raise RecordingError(f"{path}: column map is not valid JSON ({err})") from None
    return check_column_map(mapping, str(path))


def check_column_map(mapping, where: str = "column map") -> dict[str, str]:
    """Check a ``{"their_column": "our_column"}`` dict against the recording layout."""
    if not isinstance(mapping, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in mapping.items()):
        raise RecordingError(f"{where}: a column map must be a JSON object of strings "
                             f'{{"their_column": "our_column"}}')
    unknown = sorted(v for v in mapping.values() if v not in COLUMNS and not v.startswith("sim_"))
    if unknown:
        raise RecordingError(f"{where}: maps to unknown columns {unknown}; targets must be "
                             f"recording columns (see psmforce.io.recording.COLUMNS)")
    targets = list(mapping.values())
    repeated = sorted({v for v in targets if targets.count(v) > 1})
    if repeated:
        raise RecordingError(f"{where}: several columns map to {repeated}")
    return dict(mapping)


def convert_csv(src: str | Path, out_csv: str | Path,
                column_map: dict[str, str] | str | Path | None = None) -> dict:
    """Rename a CSV export's columns to ours, check it as a recording and write it atomically.

    ``column_map``: a dict or the path of a column map JSON file. The export must already be on one
    clock with ``time`` in seconds (it is checked, not resampled). Returns a small report dict.
    """
    if column_map is not None and not isinstance(column_map, dict):
        column_map = load_column_map(column_map)
    elif column_map is not None:
        column_map = check_column_map(column_map)
    frame = read_recording(src, column_map=column_map)
    write_recording(frame, out_csv)
    return {"source": str(src), "out": str(out_csv), "rows": len(frame),
            "renamed": dict(column_map or {}),
            "columns": list(frame.columns)}
