"""Arm dynamics from recordings in the library layout (``psmforce.io.recording``): the data of a fit,
model selection on the training recordings, the fit report, and the external wrench of a recording.

Coordinates. Recordings hold dVRK joints q, dq and efforts tau (N, 7), yaw .. jaw, already
through the instrument coupling. Friction acts where the motors are, so the fit runs in actuator
coordinates exactly as on the WPI data: ``c = T^-1 q`` with T the 8 mm instrument coupling
(:func:`psmforce.identification.wpi.coordinates_to_dvrk_matrix`; the Cadiere forceps 400049
has the same matrix) and ``tau_c = T^T tau`` (virtual work). ``ArmDynamicsModel.predict`` maps
back to dVRK joints.

Sampling. Any rate: each recording's rate is 1 / the median step of its ``time`` column. A step
longer than 1.5 periods is a gap (``psmforce convert`` drops rows inside stream gaps): the
recording is cut there into segments, each conditioned on its own (zero-phase low-pass, ddq from
the filtered dq, ``options.trim`` samples trimmed at both ends, as the WPI protocol); segments
too short for that are left out and listed in the report. Other irregular steps are an error.

Free space. The arm model is identified where no external force acts: from a dataset folder
only its ``Free`` recordings are used when the dataset names conditions (metadata or folder
names), every recording otherwise.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import psmforce.identification.wpi as wpi
from psmforce.identification.dynamics import ArmDynamicsModel, external_wrench_on_tool
from psmforce.identification.dynamics_fit import (check_excitation, condition_signals,
                                                   fit_conditioned, relative_error)
from psmforce.identification.dynamics_options import (N_COORD, SELECTION_CANDIDATES,
                                                       DynamicsFitOptions)
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.signals import derivative, zero_phase_lowpass
from psmforce.io.recording import (FREE_SPACE, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES,
                                 TIME, list_recordings, read_recording)

GAP_PERIODS = 1.5
"""A time step longer than this many nominal periods is a gap: the recording is cut there."""
STEP_TOLERANCE = 0.05
"""Relative deviation from the nominal period allowed for the other steps (clock jitter)."""
MAX_FIT_SAMPLES = 30_000
"""Cap on the conditioned training samples of one fit (memory of the regressor: about 7 kB a
sample); above it every k-th sample is kept. The signals are low-passed at ``cutoff_hz`` first,
so neighbouring samples carry little new information, and a regression on samples needs no
Nyquist rate (``thinning_stride`` in the report)."""

@dataclass(frozen=True)
class Segment:
    """One time-contiguous stretch of a recording in actuator coordinates (see module docstring):
    c, dc, tau_c (N, 7) and its sample rate (Hz)."""

    c: np.ndarray
    dc: np.ndarray
    tau: np.ndarray
    sample_rate_hz: float
    source: str


def dynamics_recordings(data, *, split: str | None = None) -> list[Path]:
    """The recordings of ``data`` (a folder or one CSV file) to identify the arm on.

    Free-space recordings only where the dataset names conditions (module docstring).
    ``split="test"`` keeps the dataset's test split, ``"train"`` everything else, None all.
    """
    listed = list_recordings(data)
    if any(r.condition == FREE_SPACE for r in listed):
        listed = [r for r in listed if r.condition == FREE_SPACE]
    if split is not None:
        listed = [r for r in listed if (r.split == "test") == (split == "test")]
    return [r.path for r in listed]


def recording_segments(frame, source: str) -> list[tuple[slice, float]]:
    """Time-contiguous row ranges of a recording and its sample rate: [(rows, rate_hz)].

    Cuts at gaps (steps > :data:`GAP_PERIODS` periods); raises IdentificationInputError naming
    ``source`` when the other steps are not uniform within :data:`STEP_TOLERANCE`."""
    t = frame[TIME].to_numpy(dtype=float)
    if len(t) < 3:
        raise IdentificationInputError(f"{source}: {len(t)} samples; a recording needs more")
    step = np.diff(t)
    period = float(np.median(step))
    gap = step > GAP_PERIODS * period
    off = ~gap & (np.abs(step - period) > STEP_TOLERANCE * period)
    if off.any():
        row = int(np.argmax(off)) + 1
        raise IdentificationInputError(
            f"{source}: time step {step[row - 1]:.6g} s at row {row} differs from the nominal "
            f"{period:.6g} s by more than {100 * STEP_TOLERANCE:.0f} %; resample the recording "
            "onto a uniform clock (psmforce convert --rate)")
    cuts = np.concatenate([[0], np.flatnonzero(gap) + 1, [len(t)]])
    return [(slice(a, b), 1.0 / period) for a, b in zip(cuts[:-1], cuts[1:])]


def _actuator_arrays(frame):
    """(c, dc, tau_c) (N, 7) in actuator coordinates from a recording's dVRK joint columns."""
    T = wpi.coordinates_to_dvrk_matrix()
    Tinv_t = np.linalg.inv(T).T
    q, dq, tau = (frame[list(cols)].to_numpy(dtype=float)
                  for cols in (JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_EFFORTS))
    return q @ Tinv_t, dq @ Tinv_t, tau @ T


def load_segments(paths) -> list[Segment]:
    """Read recordings (RecordingError / IdentificationInputError name a bad file) and cut them
    into :class:`Segment` s in actuator coordinates."""
    segments = []
    for path in paths:
        frame = read_recording(path)
        c, dc, tau = _actuator_arrays(frame)
        for rows, rate in recording_segments(frame, str(path)):
            suffix = "" if rows.start == 0 and rows.stop == len(frame) else \
                f" rows {rows.start}-{rows.stop - 1}"
            segments.append(Segment(c[rows], dc[rows], tau[rows], rate, f"{path}{suffix}"))
    return segments


def condition_segments(segments, options: DynamicsFitOptions):
    """Condition every segment long enough (``2 * trim`` plus the filter's own padding) and
    stack them: ((c, dc, ddc, tau) each (N, 7) and the hysteresis states (N, 7, 4), integrated
    per segment, or None if none was; skipped sources)."""
    parts, skipped = [], []
    for s in segments:
        if len(s.c) <= 2 * options.trim + 3 * (2 * options.filter_order + 1):
            skipped.append(f"{s.source}: {len(s.c)} samples, fewer than twice the "
                           f"{options.trim}-sample trim")
            continue
        parts.append(condition_signals(s.c, s.dc, s.tau, s.sample_rate_hz, options,
                                       with_states=True))
    if not parts:
        return None, skipped
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(5)), skipped


def _thin(arrays, max_samples: int):
    stride = max(1, -(-len(arrays[0]) // max_samples))
    return tuple(a[::stride] for a in arrays), stride


def _fit(arrays, options, rate_hz, provenance):
    return fit_conditioned(*arrays[:4], wpi.coordinates_to_dvrk_matrix(), wpi.MOTOR_COORDINATES,
                           options, rate_hz, provenance, time.perf_counter(), states=arrays[4])


def select_options(arrays, rate_hz: float, *, candidates=None, folds: int = 5,
                   max_samples: int = MAX_FIT_SAMPLES) -> tuple[str, dict]:
    """Model selection on training samples only: blocked cross-validation.

    ``arrays`` = conditioned (c, dc, ddc, tau) of the training recordings, in time order. They are
    cut into ``folds`` contiguous blocks; each candidate (default :data:`SELECTION_CANDIDATES`)
    is fitted on all blocks but one and scored on that one, in turn. Score: the mean over the 7
    coordinates of ||tau - tau_hat|| / ||tau|| pooled over the held-out blocks. Returns the
    best candidate's name and every candidate's figures. (A periodic excitation repeats itself, so
    its blocks are not independent: for one periodic trajectory use
    ``dynamics_validation.phase_cross_validation``, as the WPI study does.)"""
    candidates = SELECTION_CANDIDATES if candidates is None else candidates
    if folds < 2:
        raise IdentificationInputError(f"model selection needs at least 2 folds; got {folds}")
    arrays, _ = _thin(arrays, max_samples)
    fold = np.minimum(np.arange(len(arrays[0])) * folds // len(arrays[0]), folds - 1)
    table = {}
    for name, opts in candidates.items():
        sq_err, sq_tau, status = np.zeros(N_COORD), np.zeros(N_COORD), []
        for k in range(folds):
            m = _fit(tuple(a[fold != k] for a in arrays), opts, rate_hz, "")
            held = tuple(a[fold == k] for a in arrays)
            sq_err += np.sum((held[3] - m.predict_coordinates(*held[:3], held[4])) ** 2,
                             axis=0)
            sq_tau += np.sum(held[3] ** 2, axis=0)
            status.append(m.info["solver_status"])
        err = 100 * np.sqrt(sq_err / sq_tau)
        table[name] = {"held_out_percent": err.tolist(), "mean_percent": float(err.mean()),
                       "solver_status": status}
    best = min(table, key=lambda n: table[n]["mean_percent"])
    return best, table


def fit_recordings_report(data, *, test=None, select: bool = False, folds: int = 5,
                          options: DynamicsFitOptions | None = None, gravity=None,
                          max_samples: int = MAX_FIT_SAMPLES):
    """Fit the arm on recordings in our layout: (model, report).

    ``data``: a dataset folder (its train split trains, its test split tests), a folder of
    recordings or one recording (all of it trains). ``test``: a folder or file that replaces
    the dataset's test split. ``select``: choose the model variant by :func:`select_options` on
    the training recordings (never the test ones); else ``options`` (default: the defaults).
    ``gravity``: (3,) m/s^2 in the base (RCM) frame where the mounting is known, for every
    variant (default: identified, |g| = ``psmforce.robot.conventions.GRAVITY_MPS2``).
    """
    if select and options is not None:
        raise IdentificationInputError("give either options or select=True, not both")
    candidates = SELECTION_CANDIDATES
    if gravity is not None:
        g = tuple(float(x) for x in np.ravel(gravity))
        if len(g) != 3 or not np.isfinite(g).all():
            raise IdentificationInputError(
                f"gravity must be 3 finite numbers (m/s^2); got {gravity!r}")
        options = dataclasses.replace(options or DynamicsFitOptions(), gravity=g)
        candidates = {n: dataclasses.replace(o, gravity=g) for n, o in candidates.items()}
    train_paths = dynamics_recordings(data, split=None if test is not None else "train")
    test_paths = (dynamics_recordings(test) if test is not None
                  else dynamics_recordings(data, split="test"))
    if not train_paths:
        raise IdentificationInputError(f"{data}: no training recordings")
    segments = load_segments(train_paths)
    base = options or DynamicsFitOptions()
    arrays, skipped = condition_segments(segments, base)
    n_conditioned = 0 if arrays is None else len(arrays[0])
    if n_conditioned < base.min_samples:
        raise IdentificationInputError(
            f"{data}: {n_conditioned} training samples after trimming {base.trim} at both ends "
            f"of each stretch; the fit needs at least {base.min_samples}")
    check_excitation(arrays[1], wpi.MOTOR_COORDINATES, f"{data} (training recordings)")
    rates = sorted({round(s.sample_rate_hz, 6) for s in segments})
    report = {"data": str(data), "train_recordings": [str(p) for p in train_paths],
              "segments_skipped": skipped, "sample_rates_hz": rates}
    chosen = base
    if select:
        name, table = select_options(arrays, rates[0], candidates=candidates, folds=folds,
                                     max_samples=max_samples)
        chosen = candidates[name]
        report["selection"] = {"method": f"blocked {folds}-fold cross-validation on the "
                                         "training recordings", "selected": name,
                               "candidates": table}
    fit_arrays, stride = _thin(arrays, max_samples)
    model = _fit(fit_arrays, chosen, rates[0],
                 f"recordings {', '.join(str(p) for p in train_paths)}")
    report["thinning_stride"] = stride
    if test_paths:
        test_arrays, test_skipped = condition_segments(load_segments(test_paths), chosen)
        report["test_recordings"] = [str(p) for p in test_paths]
        report["test_segments_skipped"] = test_skipped
        if test_arrays is not None:
            tau_hat = model.predict_coordinates(*test_arrays[:3], test_arrays[4])
            report["test_relative_error_percent"] = (
                100 * relative_error(test_arrays[3], tau_hat)).tolist()
            # absolute too: a coordinate with almost no torque on the test recordings (pitch of
            # an upright arm near q = 0) has a large relative error that means little
            report["test_rms_error_nm_or_n"] = np.sqrt(
                np.mean((test_arrays[3] - tau_hat) ** 2, axis=0)).tolist()
            report["test_samples"] = len(test_arrays[0])
    report["protocol"] = (f"{chosen.cutoff_hz} Hz zero-phase Butterworth (order "
                          f"{chosen.filter_order}) on q, dq, tau per time-contiguous stretch; ddq "
                          f"from filtered dq; {chosen.trim}-sample trim; joints 5-7 in the "
                          "instrument's actuator coordinates")
    return model, report


def conditioned_joint_states(frame, source: str, cutoff_hz: float, order: int):
    """q, dq, ddq, tau (N, 7) in dVRK joints, zero-phase low-passed per time-contiguous stretch
    (no trim: one row out per row in) with ddq from the filtered dq."""
    q, dq, tau = (frame[list(cols)].to_numpy(dtype=float)
                  for cols in (JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_EFFORTS))
    out = [np.empty_like(q) for _ in range(4)]
    for rows, rate in recording_segments(frame, source):
        try:
            qf, dqf, tauf = (zero_phase_lowpass(x[rows], rate, cutoff_hz, order=order)
                             for x in (q, dq, tau))
        except IdentificationInputError as err:
            raise IdentificationInputError(f"{source} rows {rows.start}-{rows.stop - 1}: "
                                           f"{err}") from None
        for o, x in zip(out, (qf, dqf, derivative(dqf, rate), tauf)):
            o[rows] = x
    return tuple(out)


WRENCH_COLUMNS = ("ext_fx", "ext_fy", "ext_fz", "ext_tx", "ext_ty", "ext_tz")


def recording_wrench(model: ArmDynamicsModel, path, *, frame: str = "cp",
                     expressed_in: str = "frame", psm=None):
    """External wrench on the tool per sample of a recording, from its joint efforts minus the
    identified dynamics: a DataFrame with ``time``, :data:`WRENCH_COLUMNS` (N, Nm) and the
    conditioning report ``sigma_min`` (Jacobian units, m or 1), ``damped`` (0/1).

    Sign: the wrench applied BY the environment ON the tool. ``frame`` / ``expressed_in`` as in
    ``PSM.wrench_from_torques`` ("frame": moment about ``frame``'s origin, its axes; "base": about
    the RCM, base axes; "base_at_frame": about ``frame``'s origin, base axes). q, dq, tau are
    low-passed zero-phase at the model's cutoff (offline;
    :mod:`psmforce.estimators.runtime.streaming` is the causal path) and ddq is the derivative of
    the filtered dq, as in the fit. The solve is :func:`external_wrench_on_tool`, i.e.
    ``PSM.wrench_from_torques``, the map the LSTM baseline
    (``psmforce.estimators.data.lstm_inputs.lstm_columns``) uses.
    """
    import pandas as pd

    recording = read_recording(path)
    q, dq, ddq, tau = conditioned_joint_states(recording, str(path), model.options.cutoff_hz,
                                               model.options.filter_order)
    w, info = external_wrench_on_tool(model, q, dq, ddq, tau, psm=psm, frame=frame,
                                      expressed_in=expressed_in, return_info=True)
    out = pd.DataFrame(w, columns=list(WRENCH_COLUMNS))
    out.insert(0, TIME, recording[TIME].to_numpy(dtype=float))
    out["sigma_min"] = info.sigma_min
    out["damped"] = info.damped.astype(np.int8)
    return out

