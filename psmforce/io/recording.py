"""The recording layout shared by the simulated bench, bag conversion and the estimators.

One recording (a "trial") is one CSV file sampled on one clock (100 Hz by default), one row per
sample, with a header. Columns, units and frames:

``time``
    seconds since the start of the trial.
``{joint}_position``, ``{joint}_velocity``, ``{joint}_effort`` for ``joint`` in :data:`JOINTS`
    dVRK joint space as the dVRK reports it (already through the instrument coupling):
    rad, rad/s, Nm for revolute joints; m, m/s, N for the insertion. Efforts come from motor
    currents. ``jaw`` is the opening angle between the two blades.
``fx, fy, fz, tx, ty, tz``
    HEX10 reading, N and Nm, in the HEX10 frame (z along the shaft towards the tip). Sign: the
    force and moment that everything distal of the sensor section (wrist, jaws, cables' pull on the
    wrist, external load, distal gravity) applies across the section, so that with no internal
    forces and no gravity it equals the external force on the tool. Shaft compression reads
    negative ``fz``.
``hex10_overload``
    1 where any HEX10 channel was beyond its overload range (reading clipped), else 0. Optional.
``ati_fx, ati_fy, ati_fz``
    ground truth: external force applied by the environment on the tool, N, expressed in the
    HEX10 frame (paper eq. 4). These are the estimators' targets.
``ati_raw_fx .. ati_raw_tz``
    the ATI Nano17's own reading in its own frame (N, Nm). Optional.
``sim_*``
    simulator-only truth signals (never estimator inputs). Optional.

The paper's 21 model inputs are :data:`PAPER_FEATURES` in the paper's order.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from psmforce.robot.conventions import JOINTS
from psmforce.core.files import MAX_DATA_BYTES, atomic_path, check_input_file

JOINT_QUANTITIES = ("position", "velocity", "effort")


def joint_column(joint: str, quantity: str) -> str:
    """The column of ``joint`` (:data:`JOINTS`, dVRK order from ``psmforce.robot.conventions``) and
    ``quantity`` (:data:`JOINT_QUANTITIES`)."""
    if joint not in JOINTS or quantity not in JOINT_QUANTITIES:
        raise ValueError(f"no joint column for joint {joint!r} and quantity {quantity!r}; "
                         f"joints {JOINTS}, quantities {JOINT_QUANTITIES}")
    return f"{joint}_{quantity}"


TIME = "time"
JOINT_POSITIONS = tuple(joint_column(j, "position") for j in JOINTS)
JOINT_VELOCITIES = tuple(joint_column(j, "velocity") for j in JOINTS)
JOINT_EFFORTS = tuple(joint_column(j, "effort") for j in JOINTS)
HEX10_FORCE = ("fx", "fy", "fz")
HEX10_TORQUE = ("tx", "ty", "tz")
HEX10 = HEX10_FORCE + HEX10_TORQUE
MAX_RATE_HZ = 10_000.0
"""The highest sample rate a recording or a stream may be asked for: ten times the dVRK's
fastest stream (1 kHz), far below what would exhaust the memory (1e9 Hz asked for some 40 GiB)."""
TARGETS = ("ati_fx", "ati_fy", "ati_fz")
AXES = ("Fx", "Fy", "Fz")
"""The force axes of :data:`TARGETS` (and of every estimate), as tables and reports name them."""
ATI_RAW = ("ati_raw_fx", "ati_raw_fy", "ati_raw_fz", "ati_raw_tx", "ati_raw_ty", "ati_raw_tz")
OVERLOAD = "hex10_overload"

REQUIRED = (TIME,) + JOINT_POSITIONS + JOINT_VELOCITIES + JOINT_EFFORTS + HEX10
"""Columns every recording must have (targets only where ground truth exists)."""

COLUMNS = REQUIRED + (OVERLOAD,) + TARGETS + ATI_RAW
"""The full layout, in the order the simulator and the bag converter write it."""

PAPER_FEATURES = (
    "jaw_position", "wrist_pitch_position", "wrist_yaw_position", "roll_position",
    "wrist_pitch_velocity", "wrist_yaw_velocity", "jaw_velocity", "roll_velocity",
    "wrist_pitch_effort", "wrist_yaw_effort", "roll_effort", "jaw_effort",
    "insertion_effort", "yaw_effort", "pitch_effort",
    "tx", "ty", "tz", "fx", "fy", "fz",
)
"""The seed paper's 21 inputs per time step, in its order."""


class RecordingError(ValueError):
    """A recording that cannot be used as it is; the message names the file and the problem."""


FREE_SPACE = "Free"
"""The condition of recordings without contact (the folder name the simulator writes them to)."""


@dataclass(frozen=True)
class ListedRecording:
    """One recording of a dataset: its file, condition (``Free``, ``Traction``, ...; '' unknown)
    and split (``train``, ``test``, ``config_k``; '' unknown)."""

    path: Path
    condition: str
    split: str


def list_recordings(root: str | Path) -> list[ListedRecording]:
    """The recordings under ``root``, a dataset folder or one recording CSV.

    Condition and split come from the folder's ``metadata.json`` ``trials`` list where there is
    one (the simulator writes it), else from the folders: condition = the parent folder's name,
    split = the grandparent's ('' for files directly under ``root``). A single file gets ''
    for both. Raises :class:`RecordingError` for a missing path, unreadable metadata or a folder
    without ``*.csv`` files. Files are not read here (:func:`read_recording` checks them).
    """
    root = Path(root)
    if root.is_file():
        return [ListedRecording(root, "", "")]
    if not root.is_dir():
        raise RecordingError(f"{root}: no such recording file or folder")
    meta_path = root / "metadata.json"
    entries = None
    if meta_path.is_file():
        try:
            entries = json.loads(meta_path.read_text()).get("trials")
            listed = [ListedRecording(root / e["path"], str(e["condition"]), str(e["split"]))
                      for e in entries or ()]
        except (json.JSONDecodeError, AttributeError, TypeError) as err:
            raise RecordingError(f"{meta_path}: not a dataset metadata file ({err})") from None
        except KeyError as err:
            raise RecordingError(f"{meta_path}: a trial entry lacks {err}") from None
    if not entries:
        listed = [ListedRecording(p, p.parent.name if p.parent != root else "",
                                  p.parent.parent.name if p.parent.parent != root
                                  and p.parent != root else "")
                  for p in sorted(root.rglob("*.csv"))]
    if not listed:
        raise RecordingError(f"{root}: no recordings (*.csv)")
    return listed


def _repeated_header_name(path: Path) -> str | None:
    """The first name the CSV header at ``path`` holds twice, else None (also for a file whose
    header cannot be read: :func:`read_recording`'s reader says why)."""
    import csv
    try:
        with open(path, newline="") as fh:
            header = next(csv.reader(fh), [])
    except (OSError, UnicodeDecodeError, csv.Error):
        return None
    seen = set()
    for name in (h.strip() for h in header):
        if name in seen:
            return name
        seen.add(name)
    return None


def read_recording(path: str | Path, *, require_targets: bool = False,
                   column_map: dict[str, str] | None = None) -> pd.DataFrame:
    """Read one recording CSV and check it.

    ``column_map`` renames the file's columns to ours (``{"their_name": "our_name"}``).
    Raises :class:`RecordingError` naming the file and the first problem found: unreadable file,
    missing columns, non-numeric or non-finite values, time not strictly increasing.
    """
    path = Path(path)
    if path.is_dir():
        bag = (path / "metadata.yaml").is_file()
        raise RecordingError(f"{path}: a folder, not a recording CSV" + (
            " (a ROS 2 bag: 'psmforce convert' it to a recording first)" if bag else ""))
    try:
        check_input_file(path, MAX_DATA_BYTES, "recording")
    except ValueError as err:
        raise RecordingError(str(err)) from None
    repeated = _repeated_header_name(path)
    if repeated:  # the CSV reader would rename the second copy (fx.1) and read the first
        raise RecordingError(f"{path}: column {repeated!r} appears more than once in the header")
    try:
        frame = pd.read_csv(path, engine="c")
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as err:
        raise RecordingError(f"{path}: cannot read as CSV ({err})") from None
    if column_map:
        unknown = sorted(set(column_map) - set(frame.columns))
        if unknown:
            raise RecordingError(f"{path}: column map names columns the file lacks: {unknown}")
        frame = frame.rename(columns=column_map)
    needed = REQUIRED + (TARGETS if require_targets else ())
    missing = [c for c in needed if c not in frame.columns]
    if missing:
        raise RecordingError(f"{path}: missing columns {missing}")
    if len(frame) == 0:
        raise RecordingError(f"{path}: no rows")
    numeric = _numeric_columns(frame)
    values = frame[numeric]
    # is_numeric_dtype, not np.issubdtype: pandas reads a text cell as a string (extension)
    # dtype numpy cannot interpret
    bad = [c for c, t in values.dtypes.items() if not pd.api.types.is_numeric_dtype(t)]
    if bad:
        column = frame[bad[0]]
        text = column.notna() & pd.to_numeric(column, errors="coerce").isna()
        row = int(np.argmax(text.to_numpy())) if text.any() else 0
        raise RecordingError(f"{path}: non-numeric value {column.iloc[row]!r} in column "
                             f"'{bad[0]}' at row {row}" + (f" (also columns {bad[1:]})"
                                                           if len(bad) > 1 else ""))
    _check_values(frame, numeric, path)
    return frame


def _numeric_columns(frame: pd.DataFrame) -> list[str]:
    """The layout's columns and the simulator's truth signals: the ones that must be numbers."""
    return [c for c in frame.columns if c in COLUMNS or c.startswith("sim_")]


def _check_values(frame: pd.DataFrame, numeric: list[str], path: Path) -> None:
    """Every ``numeric`` value finite and time strictly increasing, else RecordingError naming
    ``path``, the column and the row: what reading refuses, writing refuses too."""
    finite = np.isfinite(frame[numeric].to_numpy(dtype=float))
    if not finite.all():
        row, col = np.argwhere(~finite)[0]
        raise RecordingError(f"{path}: non-finite value (NaN or inf) in column "
                             f"'{numeric[col]}' at row {row}")
    t = frame[TIME].to_numpy(dtype=float)
    if len(t) > 1 and not (np.diff(t) > 0).all():
        row = int(np.argmin(np.diff(t) > 0)) + 1
        raise RecordingError(f"{path}: time is not strictly increasing at row {row}")


def write_recording(frame: pd.DataFrame, path: str | Path) -> None:
    """Write a recording atomically (temporary file, then rename): no partial files on failure.
    Refuses (:class:`RecordingError`) what :func:`read_recording` would: NaN or infinite values,
    time not strictly increasing.

    Columns in :data:`COLUMNS` order, extra columns after. Numbers with 7 significant digits
    (beyond every sensor's resolution), ``time`` in microseconds (7 digits would stop it
    increasing after ~1e4 s), integer columns (flags) as integers. One C-level format string per
    block of rows: several times faster than pandas' per-cell formatter on million-row data.
    """
    path = Path(path)
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise RecordingError(f"{path}: refusing to write a recording without columns {missing}")
    # a file read_recording would refuse is not written: the error comes where the bad values
    # were made, not when someone reads them later
    _check_values(frame, _numeric_columns(frame), path)
    names = [c for c in COLUMNS if c in frame.columns]
    names += [c for c in frame.columns if c not in COLUMNS]
    formats = ["%.6f" if c == TIME else
               "%d" if np.issubdtype(frame[c].dtype, np.integer) else "%.7g" for c in names]
    values = np.column_stack([frame[c].to_numpy(dtype=float) for c in names])
    row = ",".join(formats) + "\n"
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        fh.write(",".join(names) + "\n")
        for start in range(0, len(values), 20000):
            block = values[start:start + 20000]
            fh.write((row * len(block)) % tuple(block.ravel().tolist()))
