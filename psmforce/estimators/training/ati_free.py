"""The calibration trials without an ATI (``psmforce calibrate --free-space [--known-loads DIR]``,
issue 44): recordings whose external force is known without a reference sensor.

**Free space** (:func:`free_space_trials`). The ``train`` split's ``Free`` recordings of the
calibration folder, in ``metadata.json`` order, the longest prefix within ``minutes`` (at least
:data:`MIN_FREE_SPACE_TRIALS`: one to fit on, one to stop on). In free space the external force
is zero, so the targets are set to 0 N by that declaration; a recording that holds ATI columns
reading more than :data:`MAX_FREE_SPACE_FORCE_N` is refused as not free space. The designed
excitation (``psmforce excitation``, its clenches the self-loading) is free space too and is
listed among these recordings.

**Known loads** (:func:`known_load_trials`). A second folder of recordings of a known mass hung
from the jaw tip at rest, every one listed in its ``metadata.json`` with the field
:data:`KNOWN_LOAD_FIELD` (kg, as weighed) under the condition :data:`KNOWN_LOAD_CONDITION`,
split ``train``. The external force on the tool is the weight, ``m g``, and the targets
(``ati_fx..ati_fz``: the force on the tool in the HEX10 frame, docs/conventions.md) are computed
from the recorded joint positions through the kinematics (:func:`known_load_force_hex10`:
``R_PSM_HEX10(q)^T m g``, the paper's eq. 3 applied to the weight). Gravity is the upright
base's (:data:`psmforce.robot.conventions.GRAVITY_UPRIGHT_MPS2`), the one the prior's own
gravity terms assume; a folder whose metadata declares another ``gravity_base`` is refused.
Every known-load recording is used (the holds a lab makes are few); ``minutes`` bounds the free
space only. A missing, non-numeric, non-finite or non-positive mass, or ATI columns that
disagree with the declared weight by more than :data:`MAX_FREE_SPACE_FORCE_N`, is one
:class:`CalibrationError` naming the file.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from psmforce.estimators.data.dataset import Dataset, Trial
from psmforce.io.recording import JOINT_POSITIONS, TARGETS
from psmforce.robot.conventions import GRAVITY_UPRIGHT_MPS2

MIN_FREE_SPACE_TRIALS = 2
"""Free-space calibration: one recording to fit on, one to stop on."""
MAX_FREE_SPACE_FORCE_N = 0.5
"""A recording declared free space whose ATI columns (when it has them) read more than this
(N, any axis, any sample) holds a contact: refused rather than trained towards 0 N; a
known-load recording whose ATI differs from its declared weight by more is refused alike."""
KNOWN_LOAD_CONDITION = "KnownLoad"
KNOWN_LOAD_FIELD = "known_load_kg"
"""The ``metadata.json`` trial-entry field holding a known-load recording's hung mass (kg)."""
GRAVITY_TOLERANCE_MPS2 = 1e-6


class CalibrationError(ValueError):
    """A calibration request that cannot run as asked; the message says why."""


def check_minutes(minutes) -> None:
    if (isinstance(minutes, bool) or not isinstance(minutes, numbers.Real)
            or not math.isfinite(minutes) or minutes <= 0):
        raise CalibrationError(f"minutes: must be a finite number > 0, got {minutes!r}")


def trial_minutes(trial: Trial) -> float:
    """Duration of a recording in minutes from its ``time`` column (any sample rate)."""
    t = trial.frame["time"].to_numpy(dtype=float)
    if len(t) < 2:
        return 0.0
    return float((t[-1] - t[0] + np.median(np.diff(t))) / 60.0)


def _with_targets(trial: Trial, targets: np.ndarray | float) -> Trial:
    """A copy of ``trial`` whose target columns hold ``targets`` ((N, 3) or a scalar)."""
    values = np.broadcast_to(np.asarray(targets, dtype=float), (len(trial.frame), 3))
    return Trial(trial.path, trial.condition, trial.split,
                 trial.frame.assign(**{c: values[:, k] for k, c in enumerate(TARGETS)}),
                 dict(trial.params))


def _ati_gap_n(trial: Trial, expected: np.ndarray | float) -> float | None:
    """Largest |ATI - expected| (N) over the recording's target columns; None without them."""
    present = [c for c in TARGETS if c in trial.frame.columns]
    if not present:
        return None
    expected = np.broadcast_to(np.asarray(expected, dtype=float), (len(trial.frame), 3))
    cols = [TARGETS.index(c) for c in present]
    return float(np.nanmax(np.abs(trial.frame[present].to_numpy(dtype=float)
                                  - expected[:, cols])))


def free_space_trials(dataset: Dataset, minutes: float) -> list[Trial]:
    """The free-space calibration trials (module docstring): copies of the train split's
    free-space recordings with their targets set to 0 N."""
    where = dataset.root
    check_minutes(minutes)
    free = dataset.select(split="train", condition="Free")
    for t in free:
        peak = _ati_gap_n(t, 0.0)
        if peak is not None and not peak <= MAX_FREE_SPACE_FORCE_N:
            raise CalibrationError(
                f"{where}/{t.path}: declared free space, but its ATI reads {peak:.2f} N "
                f"(more than {MAX_FREE_SPACE_FORCE_N} N): not a free-space recording")
    ends = np.cumsum([trial_minutes(t) for t in free])
    chosen = free[:int(np.searchsorted(ends, minutes, side="right"))]
    if len(chosen) < MIN_FREE_SPACE_TRIALS:
        have = len(free)
        need = (f"--minutes {math.ceil(ends[MIN_FREE_SPACE_TRIALS - 1] * 100) / 100:g}"
                if have >= MIN_FREE_SPACE_TRIALS else "more free-space recordings")
        raise CalibrationError(
            f"{where}: {minutes:g} min hold {len(chosen)} free-space recordings (train/Free, "
            f"{have} in all); calibration without an ATI needs {MIN_FREE_SPACE_TRIALS}: give "
            f"{need}")
    return [_with_targets(t, 0.0) for t in chosen]


def known_load_force_hex10(positions: np.ndarray, mass_kg: float, psm=None) -> np.ndarray:
    """(N, 3) the weight of ``mass_kg`` hung at the tip, as the force on the tool in the HEX10
    frame, for joint positions ``positions`` (N, 6|7, dVRK order): ``R_PSM_HEX10(q)^T m g``
    with the upright base's gravity."""
    from psmforce.robot.frames import base_to_hex10
    weight_n = mass_kg * np.asarray(GRAVITY_UPRIGHT_MPS2, dtype=float)
    rows = np.asarray(positions, dtype=float)
    return base_to_hex10(np.broadcast_to(weight_n, (len(rows), 3)), rows, psm)


def _mass_problem(value) -> str | None:
    if value is None:
        return f"no '{KNOWN_LOAD_FIELD}' (the hung mass, kg)"
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return f"'{KNOWN_LOAD_FIELD}' must be a number (kg), got {value!r:.60}"
    if not math.isfinite(value):
        return f"'{KNOWN_LOAD_FIELD}' must be finite, got {value!r}"
    if value <= 0:
        return (f"'{KNOWN_LOAD_FIELD}' must be > 0 kg, got {value!r} (a recording without a "
                f"load belongs with the free-space recordings)")
    return None


def _check_gravity(dataset: Dataset) -> None:
    declared = dataset.metadata.get("gravity_base")
    if declared is None:
        return
    try:
        g = np.asarray(declared, dtype=float)
    except (TypeError, ValueError):
        g = np.full(1, np.nan)
    upright = np.asarray(GRAVITY_UPRIGHT_MPS2, dtype=float)
    if g.shape != (3,) or not np.all(np.abs(g - upright) <= GRAVITY_TOLERANCE_MPS2):
        raise CalibrationError(
            f"{dataset.root}: metadata.json gravity_base {declared!r:.80} is not the upright "
            f"base's {list(upright)}: the known loads' weight and the prior's gravity terms "
            f"assume an upright base")


def known_load_trials(dataset: Dataset) -> list[Trial]:
    """The known-load recordings of ``dataset`` with their targets set to the weight in the
    HEX10 frame (module docstring)."""
    where = dataset.root
    _check_gravity(dataset)
    listed = list(dataset.trials)
    others = [t for t in listed if (t.split, t.condition) != ("train", KNOWN_LOAD_CONDITION)]
    if others:
        raise CalibrationError(
            f"{where}/{others[0].path}: a known-loads folder lists train/{KNOWN_LOAD_CONDITION} "
            f"recordings only, this one is {others[0].split}/{others[0].condition}")
    out = []
    for t in listed:
        problem = _mass_problem(t.params.get(KNOWN_LOAD_FIELD))
        if problem:
            raise CalibrationError(f"{where}/{t.path}: metadata.json trial entry has {problem}")
        force = known_load_force_hex10(t.frame[list(JOINT_POSITIONS)].to_numpy(dtype=float),
                                       float(t.params[KNOWN_LOAD_FIELD]))
        gap = _ati_gap_n(t, force)
        if gap is not None and not gap <= MAX_FREE_SPACE_FORCE_N:
            raise CalibrationError(
                f"{where}/{t.path}: declared a hung {t.params[KNOWN_LOAD_FIELD]:g} kg, but its "
                f"ATI differs from that weight by {gap:.2f} N (more than "
                f"{MAX_FREE_SPACE_FORCE_N} N): not a known-load recording")
        out.append(_with_targets(t, force))
    return out


ORIENTATION_TOLERANCE_RAD = 0.05
"""Two known-load holds whose held joints (:func:`hold_orientations`) differ by less than this
(rad, every joint) hang their weight in the same orientation."""
_HELD_JOINTS = (0, 1, 3, 4, 5)  # yaw, pitch, roll, wrist pitch, wrist yaw: what turns the weight


def hold_orientations(trials: list[Trial], unit: str = "orientation") -> list[int | None]:
    """Each trial's group for the orientations' jackknife (``fit_identified(...,
    pose_labels=..., pose_unit=unit)``): known-load holds (:data:`KNOWN_LOAD_CONDITION`) whose
    joints, as held (the median over the recording's second half, after any move into the
    pose), agree within :data:`ORIENTATION_TOLERANCE_RAD` share a label (0, 1, ... in order of
    first appearance); every other trial (free space) gets None. Read from the recordings, so a
    lab's own holds need no pose field in their metadata.

    ``unit`` (:data:`JACKKNIFE_UNITS`): ``"orientation"``, each orientation its own group;
    ``"sign_pair"``, an orientation and its opposite (the same arm pose and roll, the wrist's
    pitch and yaw negated: a paired design's two halves, :data:`psmforce.cli.excitation.
    WEIGHT_WRIST_POSES_PAIRED`) one group, labelled in order of the pair's first appearance;
    an orientation without its opposite among the holds stays a group alone."""
    if unit not in JACKKNIFE_UNITS:
        raise CalibrationError(f"unit must be one of {JACKKNIFE_UNITS}, got {unit!r}")
    columns = [JOINT_POSITIONS[j] for j in _HELD_JOINTS]
    centres: list[np.ndarray] = []
    labels: list[int | None] = []
    for t in trials:
        if t.condition != KNOWN_LOAD_CONDITION:
            labels.append(None)
            continue
        q = t.frame[columns].to_numpy(dtype=float)
        held = np.median(q[len(q) // 2:], axis=0)
        match = next((k for k, c in enumerate(centres)
                      if np.max(np.abs(c - held)) < ORIENTATION_TOLERANCE_RAD), None)
        if match is None:
            centres.append(held)
            match = len(centres) - 1
        labels.append(match)
    if unit == "orientation":
        return labels
    group = _sign_pairs(centres)
    rank = {g: k for k, g in enumerate(dict.fromkeys(group[k] for k in labels if k is not None))}
    return [None if k is None else rank[group[k]] for k in labels]


JACKKNIFE_UNITS = ("orientation", "sign_pair")
"""What the orientations' jackknife leaves out at a time (:func:`hold_orientations`)."""


def _sign_pairs(centres: list[np.ndarray]) -> list[int]:
    """Per orientation (held joints as :data:`_HELD_JOINTS`), the index of the first orientation
    of its sign pair: the same yaw, pitch and roll, the wrist's pitch and yaw negated, within
    :data:`ORIENTATION_TOLERANCE_RAD`. A straight wrist is its own opposite and stays alone, and
    each orientation pairs at most once."""
    mirror = np.array([1.0, 1.0, 1.0, -1.0, -1.0])
    group = list(range(len(centres)))
    paired: set[int] = set()
    for k, c in enumerate(centres):
        if k in paired:
            continue
        partner = next((m for m in range(k + 1, len(centres)) if m not in paired
                        and np.max(np.abs(centres[m] - mirror * c)) < ORIENTATION_TOLERANCE_RAD
                        and np.max(np.abs(c[3:])) >= ORIENTATION_TOLERANCE_RAD), None)
        if partner is not None:
            group[partner] = k
            paired |= {k, partner}
    return group
