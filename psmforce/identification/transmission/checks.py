"""Data checks on a cable-transmission recording before anything learns from it.

Each check reads the file's raw 1 kHz columns (:mod:`.recording` names them) and returns
:class:`Finding` records; a file with any finding is left out of a session by
:func:`.recording.read_transmission_session` (named in a warning) unless the caller keeps it
explicitly. The bounds are physical or instrumental, stated here once:

``drive_saturation``
    the back-end command (column 8) is the drive's analog set point, specified -1..1 (the
    dataset's README); at or beyond the rail the drive no longer does what it is told, and the
    measured current stops following the command.
``current_beyond_drive``
    the drive is a current drive: its measured current is :data:`CURRENT_PER_COMMAND_A` times the
    command (0.995-0.999 correlated in every folder), so its range is that gain at a full-scale
    command; a larger reading is not a current the drive can make.
``motor_overspeed``
    the input spindle faster than :data:`MAX_SPINDLE_SPEED_RAD_S`: six times the fastest drive in
    the dataset (30 degree sinusoids at up to 0.5 Hz, 1.6 rad/s at the jaw): a runaway, not the
    experiment.
``encoder_jump``
    one 1 ms step of an encoder that its neighbours do not share by more than the bound in
    :data:`ENCODER_JUMP_COUNTS` (an acceleration no motor of this bench makes; a lost or
    spurious count burst).
``torque_saturation``
    a torque sensor at the converter's rail (:data:`ADC_RAIL_COUNTS`) or stuck at its own
    extreme for :data:`FLAT_TOP_SAMPLES` samples or more (a live Futek channel always moves by its
    noise).
``current_excursion`` (session level, :func:`session_findings`)
    a file whose current range is more than :data:`EXCURSION_RATIO` times the median file's of
    its session: the same protocol drove the motor far outside what the others needed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CURRENT_PER_COMMAND_A = 2.05
"""A per unit command: the measured current's slope against the command (2.04-2.08 per folder,
least squares over every file of every folder)."""
MAX_SPINDLE_SPEED_RAD_S = 10.0
MOTOR_COUNTS_PER_REV = 4196 * 35
ENCODER_JUMP_COUNTS = {"motor": 50, "spindle": 20, "jaw": 20}
"""counts in one 1 ms step beyond the mean of the two neighbouring steps (motor: 4196 x 35 per
spindle revolution, 2 mrad; spindle: 8192 per revolution, 15 mrad; jaw: 4000, 31 mrad); the
largest in the seven folders' usable files is 12, 3 and 4."""
ADC_RAIL_COUNTS = 32767
FLAT_TOP_SAMPLES = 20
EXCURSION_RATIO = 2.0
CHECKS = ("drive_saturation", "current_beyond_drive", "motor_overspeed", "encoder_jump",
          "torque_saturation", "current_excursion")
_COLUMNS = {"spindle": 1, "spindle_torque": 2, "current": 3, "jaw": 4, "jaw_torque": 5,
            "command": 7, "motor": 8}


@dataclass(frozen=True)
class Finding:
    """One failed check: which, on which column, where (1 kHz sample index of the first
    offending sample) and how often."""

    check: str
    column: str
    first_sample: int
    samples: int
    detail: str

    def __str__(self) -> str:
        where = f" ({self.samples} samples from sample {self.first_sample})" if self.samples else ""
        return f"{self.check} on {self.column}: {self.detail}{where}"

    def to_dict(self) -> dict:
        return {"check": self.check, "column": self.column, "first_sample": self.first_sample,
                "samples": self.samples, "detail": self.detail}


def _finding(check, column, mask, detail) -> list[Finding]:
    idx = np.flatnonzero(mask)
    return [Finding(check, column, int(idx[0]), int(len(idx)), detail)] if len(idx) else []


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """(length, start) of the longest run of True."""
    if not mask.any():
        return 0, 0
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    k = int(np.argmax(stops - starts))
    return int(stops[k] - starts[k]), int(starts[k])


def check_columns(raw: np.ndarray) -> list[Finding]:
    """Every file-level check on the raw (N, 10) columns of one file (module docstring)."""
    out: list[Finding] = []
    command = raw[:, _COLUMNS["command"]]
    out += _finding("drive_saturation", "back-end command", np.abs(command) >= 1.0,
                    f"|command| up to {np.abs(command).max():.3g}, its range is -1..1")
    current = raw[:, _COLUMNS["current"]]
    limit = CURRENT_PER_COMMAND_A
    out += _finding("current_beyond_drive", "measured current", np.abs(current) > limit,
                    f"|current| up to {np.abs(current).max():.3g} A, the drive makes at most "
                    f"{limit:g} A")
    speed = np.abs(np.diff(raw[:, _COLUMNS["motor"]])) * 1000.0 * 2 * np.pi / MOTOR_COUNTS_PER_REV
    out += _finding("motor_overspeed", "back-end Maxon encoder", speed > MAX_SPINDLE_SPEED_RAD_S,
                    f"spindle speed up to {speed.max():.3g} rad/s, bound "
                    f"{MAX_SPINDLE_SPEED_RAD_S:g}")
    for name, bound in ENCODER_JUMP_COUNTS.items():
        step = np.diff(raw[:, _COLUMNS[name]])
        if len(step) < 3:
            continue
        off = np.abs(step[1:-1] - 0.5 * (step[:-2] + step[2:]))
        out += _finding("encoder_jump", f"{name} encoder", off > bound,
                        f"a step {off.max():.0f} counts off its neighbours, bound {bound}")
    for name in ("spindle_torque", "jaw_torque"):
        x = raw[:, _COLUMNS[name]]
        out += _finding("torque_saturation", f"{name.replace('_', ' ')} sensor",
                        np.abs(x) >= ADC_RAIL_COUNTS, f"at the converter's rail "
                        f"({ADC_RAIL_COUNTS} counts)")
        for extreme in (x.max(), x.min()):
            length, start = _longest_run(x == extreme)
            if length >= FLAT_TOP_SAMPLES:
                out.append(Finding("torque_saturation", f"{name.replace('_', ' ')} sensor", start,
                                   length, f"stuck at its extreme {extreme:.0f} counts for "
                                           f"{length} samples"))
    return out


def session_findings(current_ranges_a: dict[str, float]) -> dict[str, list[Finding]]:
    """``{file: [Finding]}`` for the files whose current range (A, max - min over the file) is
    more than :data:`EXCURSION_RATIO` times the session's median file's (module docstring);
    a whole-file finding (``samples`` 0)."""
    if len(current_ranges_a) < 3:
        return {}
    median = float(np.median(list(current_ranges_a.values())))
    return {name: [Finding("current_excursion", "measured current", 0, 0,
                           f"current range {r:.3g} A, {r / median:.2g}x the session's median "
                           f"file ({median:.3g} A)")]
            for name, r in current_ranges_a.items() if r > EXCURSION_RATIO * median}
