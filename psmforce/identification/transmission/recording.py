"""A cable-transmission recording: one EndoWrist spindle driven by a motor, its jaw loaded, both
ends measured (the MRD Lab bench of O'Neill et al., RA-L 2018; ``../shared/data/mrdlab``).

Read one file with :func:`read_transmission_file`, a session folder with
:func:`read_transmission_session`. Each file is resampled to ``rate_hz`` (default 100 Hz) for the
estimators:

* the proximal signals a robot has (motor current, motor command, motor encoder) pass through a
  causal low-pass (2nd-order Butterworth at 0.4 ``rate_hz``, run forward only) before they are
  taken every ``1000 / rate_hz``-th sample, so nothing from the future leaks in;
* the distal truth (jaw torque, jaw angle) and the input-spindle torque sensor are taken at the
  same instants unfiltered: the target is the measurement, not a smoothed version of it.

Frames, units and signs (one place; :func:`read_transmission_file` applies them):

``motor_angle_rad``
    input-spindle angle from the motor encoder through the 35:1 gearbox (rad at the spindle,
    4196 x 35 counts per revolution, the dataset's figure). Positive: the encoder's own direction,
    which on this bench moves the jaw in its positive direction (towards closing, against the load).
``motor_velocity_rad_s``
    backward difference of the filtered motor angle (causal).
``motor_current_a``
    motor current (A), as stored: a positive current drives the positive motor angle.
``motor_command``
    the drive's command (-1..1), sign flipped from the stored column so that it agrees with the
    current (on this bench the stored command is negative while the current drives forwards).
``jaw_torque_nm``
    front-end torque sensor (Nm, 0.000039811 Nm per count): the loader's torque on the jaw, as
    stored. Negative: resisting the positive (closing) motion.
``jaw_angle_rad``
    front-end encoder (rad, 4000 counts per revolution), positive with the motor angle.
``spindle_torque_nm``, ``spindle_angle_rad``
    input-spindle torque sensor and encoder (a robot has neither; kept for the physics checks).

The encoders are incremental: each session has its own zero on both ends.

File names: ``XY.TXT`` (X the drive frequency index, Y the load index) or, in the roll and pitch
folders, ``ZXY.TXT`` (Z the jaw's stopping position, whose angle the ``%Yaw_rad=`` header line
gives). The folder's ``ReadME.txt`` states the wrist's roll and pitch where they are not 0
(:func:`read_configuration`: ``roll_rad``, ``pitch_rad``). Header lines ``%Yaw_rad=``,
``%Freq_Hz=``, ``%Torque_Pct=`` are kept in ``header`` as
numbers where present (the dataset says its headers were edited by hand: trust the data first).

Every file is checked before it is used (:mod:`.checks`); a session leaves a file with findings
out and names it in a :class:`TransmissionDataWarning`, unless told to keep it. The first
:data:`SETTLE_S` of every file are dropped: both torque channels start up to 22 ms away from
their level (the acquisition's own start-up transient, in every folder).
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import signal as _signal

from psmforce.identification.transmission.checks import Finding, check_columns, session_findings

FUTEK_NM_PER_COUNT = 0.000039811
MOTOR_COUNTS_PER_REV = 4196 * 35
SPINDLE_COUNTS_PER_REV = 8192
JAW_COUNTS_PER_REV = 4000
FILE_RATE_HZ = 1000.0
_N_COLUMNS = 10
SETTLE_S = 0.03
_NAME = re.compile(r"^(\d)?(\d)(\d)\.TXT$", re.IGNORECASE)
_HEADER_KEYS = ("Yaw_rad", "Freq_Hz", "Torque_Pct")


class TransmissionDataError(ValueError):
    """A transmission file or folder that cannot be read; the message names it and the problem."""


class TransmissionDataWarning(UserWarning):
    """Files a session left out because a data check flagged them (:mod:`.checks`)."""


@dataclass(frozen=True)
class TransmissionRecording:
    """One file at ``rate_hz``; every array is (N,) on the same clock (see the module docstring)."""

    name: str
    session: str
    frequency_index: int
    load_index: int
    rate_hz: float
    time_s: np.ndarray
    motor_angle_rad: np.ndarray
    motor_velocity_rad_s: np.ndarray
    motor_current_a: np.ndarray
    motor_command: np.ndarray
    jaw_torque_nm: np.ndarray
    jaw_angle_rad: np.ndarray
    spindle_torque_nm: np.ndarray
    spindle_angle_rad: np.ndarray
    stop_index: int | None = None
    header: dict = field(default_factory=dict)
    findings: tuple[Finding, ...] = ()
    current_range_a: float = float("nan")
    pitch_rad: float = 0.0
    roll_rad: float = 0.0

    def __len__(self) -> int:
        return len(self.time_s)

    @property
    def closing(self) -> np.ndarray:
        """(N,) bool: the closing portions of the grasp, the jaw driven against the load (motor
        moving in the positive direction), as the 2018 paper scored them. From the motor
        encoder only, so an estimator may use it."""
        return self.motor_velocity_rad_s > 0.02

    def slice(self, start: int, stop: int) -> "TransmissionRecording":
        """The samples ``[start, stop)`` as a recording of their own (few-shot calibration)."""
        arrays = {k: v[start:stop] for k, v in self.__dict__.items() if isinstance(v, np.ndarray)}
        return replace(self, name=f"{self.name}[{start}:{stop}]", **arrays)


def _header(lines: list[str]) -> dict:
    out = {}
    for line in lines:
        key, sep, value = line[1:].partition("=")
        if sep and key.strip() in _HEADER_KEYS:
            try:
                out[key.strip()] = float(value)
            except ValueError:
                continue
    return out


_CONFIGURATION = re.compile(r"(roll|pitch) of ([+-]?\d+(?:\.\d+)?) degrees", re.IGNORECASE)


def read_configuration(folder) -> dict:
    """The wrist configuration of a session folder from its ``ReadME.txt`` (``This is a roll of
    -90 degrees ...``, ``This is a pitch of +60 degrees ...``): ``{"roll_rad", "pitch_rad"}``,
    each 0 where the folder (or the file) does not state it: the dataset's nominal pose."""
    out = {"roll_rad": 0.0, "pitch_rad": 0.0}
    readme = Path(folder) / "ReadME.txt"
    if readme.is_file():
        for key, value in _CONFIGURATION.findall(readme.read_text(errors="replace")):
            out[f"{key.lower()}_rad"] = float(np.radians(float(value)))
    return out


def _parse(path: Path) -> tuple[np.ndarray, dict]:
    try:
        text = path.read_text(errors="strict")
    except (OSError, UnicodeDecodeError) as err:
        raise TransmissionDataError(f"{path}: cannot read ({err})") from None
    lines = text.splitlines()
    rows = [line for line in lines if line.strip() and not line.startswith("%")]
    try:  # numpy's parser: the values float() gives, bit for bit, at twice the speed
        data = (np.loadtxt(rows, delimiter=",", ndmin=2, dtype=np.float64) if rows
                else np.empty(0))
    except ValueError as err:
        raise TransmissionDataError(f"{path}: a data line is not comma-separated numbers "
                                    f"({err})") from None
    if data.ndim != 2 or data.shape[1] != _N_COLUMNS:
        raise TransmissionDataError(f"{path}: expected {_N_COLUMNS} columns per line, got "
                                    f"{data.shape[1:] or 'none'}")
    if len(data) < 2000:
        raise TransmissionDataError(f"{path}: {len(data)} samples; at least 2 s at 1 kHz needed")
    if not np.isfinite(data).all():
        raise TransmissionDataError(f"{path}: non-finite values in the data")
    dt = np.diff(data[:, 0])
    if np.abs(dt - 1.0 / FILE_RATE_HZ).max() > 1e-4:
        raise TransmissionDataError(f"{path}: the time column does not step by 1 ms "
                                    f"(steps {dt.min():.4g}..{dt.max():.4g} s)")
    return data, _header([line for line in lines if line.startswith("%")])


def read_transmission_file(path, rate_hz: float = 100.0) -> TransmissionRecording:
    """Read one ``XY.TXT`` or ``ZXY.TXT`` file (Z: jaw stopping position, X: drive frequency
    index, Y: load index) at ``rate_hz``, with its data checks' findings."""
    path = Path(path)
    m = _NAME.match(path.name)
    if m is None:
        raise TransmissionDataError(f"{path}: expected a file named XY.TXT or ZXY.TXT (stopping "
                                    "position, frequency index, load index)")
    step = FILE_RATE_HZ / rate_hz
    if not (rate_hz > 0 and abs(step - round(step)) < 1e-9 and round(step) >= 1):
        raise TransmissionDataError(f"rate_hz must divide {FILE_RATE_HZ:g} Hz, got {rate_hz}")
    step = int(round(step))
    raw, header = _parse(path)
    findings = tuple(check_columns(raw))
    d = raw[int(round(SETTLE_S * FILE_RATE_HZ)):]
    motor = d[:, 8] * 2 * np.pi / MOTOR_COUNTS_PER_REV
    proximal = np.stack([motor, d[:, 3], -d[:, 7]], axis=1)
    if step > 1:
        sos = _signal.butter(2, 0.4 * rate_hz, fs=FILE_RATE_HZ, output="sos")
        zi = _signal.sosfilt_zi(sos)[:, :, None] * proximal[0][None, None, :]
        proximal, _ = _signal.sosfilt(sos, proximal, axis=0, zi=zi)
    take = slice(0, len(d), step)
    motor_f = proximal[take, 0]
    velocity = np.diff(motor_f, prepend=motor_f[0]) * rate_hz
    return TransmissionRecording(
        name=f"{path.parent.name}/{path.stem}", session=path.parent.name,
        frequency_index=int(m.group(2)), load_index=int(m.group(3)), rate_hz=float(rate_hz),
        time_s=d[take, 0] - d[0, 0], motor_angle_rad=motor_f, motor_velocity_rad_s=velocity,
        motor_current_a=proximal[take, 1], motor_command=proximal[take, 2],
        jaw_torque_nm=d[take, 5] * FUTEK_NM_PER_COUNT,
        jaw_angle_rad=d[take, 4] * 2 * np.pi / JAW_COUNTS_PER_REV,
        spindle_torque_nm=d[take, 2] * FUTEK_NM_PER_COUNT,
        spindle_angle_rad=d[take, 1] * 2 * np.pi / SPINDLE_COUNTS_PER_REV,
        stop_index=None if m.group(1) is None else int(m.group(1)), header=header,
        findings=findings, current_range_a=float(np.ptp(raw[:, 3])),
        **read_configuration(path.parent))


def read_transmission_session(folder, rate_hz: float = 100.0, *,
                              keep_flagged: bool = False) -> list[TransmissionRecording]:
    """Every ``XY.TXT`` / ``ZXY.TXT`` file of a session folder, in name order, each with its
    findings (file checks and the session's current-excursion check, :mod:`.checks`). Files
    with findings are left out and named in a :class:`TransmissionDataWarning` unless
    ``keep_flagged``; a session whose every file is flagged is refused."""
    recs = check_session(folder, rate_hz)
    flagged = [r for r in recs if r.findings]
    if keep_flagged or not flagged:
        return recs
    if len(flagged) == len(recs):
        raise TransmissionDataError(f"{folder}: every file fails a data check "
                                    f"(first: {flagged[0].name}: {flagged[0].findings[0]})")
    warnings.warn(TransmissionDataWarning(
        f"{folder}: left out {len(flagged)} file(s) that fail a data check: "
        + "; ".join(f"{r.name}: {r.findings[0]}" for r in flagged)), stacklevel=2)
    return [r for r in recs if not r.findings]


def check_session(folder, rate_hz: float = 100.0) -> list[TransmissionRecording]:
    """Every file of a session folder, flagged or not, each carrying its ``findings``."""
    folder = Path(folder)
    if not folder.is_dir():
        raise TransmissionDataError(f"{folder}: not a folder")
    files = sorted(p for p in folder.iterdir() if _NAME.match(p.name))
    if not files:
        raise TransmissionDataError(f"{folder}: no XY.TXT or ZXY.TXT transmission files")
    recs = [read_transmission_file(p, rate_hz) for p in files]
    extra = session_findings({r.name: r.current_range_a for r in recs})
    return [replace(r, findings=r.findings + tuple(extra.get(r.name, ()))) for r in recs]


def home_session(recordings: list[TransmissionRecording]) -> list[TransmissionRecording]:
    """The session's recordings with the motor and jaw encoders zeroed at one homing pose, as a
    robot homes an instrument once when it is engaged.

    The motor and jaw encoders are incremental: each session starts from its own zero, and the
    sessions start at different ends of the stroke. The input-spindle encoder reads the same
    stroke in every session (0 to about 1370 counts), so the homing pose is the first sample of
    the session's first file (name order) where the spindle sits at its zero (the end of its
    stroke): both encoders read 0 there. A model carried to another session or instrument sees
    angles relative to that pose. Torques are untouched."""
    if not recordings:
        raise TransmissionDataError("no recordings to home")
    first = min(recordings, key=lambda r: r.name)
    at_zero = first.spindle_angle_rad <= first.spindle_angle_rad.min() + 2 * np.pi / SPINDLE_COUNTS_PER_REV
    k = int(np.argmax(at_zero))
    offsets = {"motor_angle_rad": first.motor_angle_rad[k], "jaw_angle_rad": first.jaw_angle_rad[k],
               "spindle_angle_rad": first.spindle_angle_rad[k]}
    return [replace(r, **{name: getattr(r, name) - v for name, v in offsets.items()})
            for r in recordings]
