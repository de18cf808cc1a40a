"""Signal conditioning for identification: zero-phase low-pass filtering and differentiation.

Choices (documented in docs/identification.md):

* Zero-phase Butterworth (``scipy.signal.sosfiltfilt``, second-order sections for numerical
  robustness at low cutoffs). The filter runs forward and backward, so the magnitude response is
  squared: a 4th-order design gives an 8th-order zero-phase response. The published WPI protocol
  uses 5.4 Hz on q, dq and tau at 200 Hz.
* Accelerations: central differences (``numpy.gradient``, second order inside, first order at the
  ends) of the FILTERED velocity; differentiating after filtering keeps the noise gain bounded by
  the cutoff (2 pi f_c per derivative) instead of by the Nyquist frequency.
* Filter edge transients: callers trim samples at both ends (``trim`` in the fit functions).
"""

from __future__ import annotations

import numpy as np
from scipy import signal as _signal

from psmforce.identification.errors import IdentificationInputError

DEFAULT_FILTER_ORDER = 4


def check_finite_2d(x, name: str, *, width: int | None = None, min_rows: int = 1) -> np.ndarray:
    """(N, width) float array, finite, at least ``min_rows`` rows; else IdentificationInputError."""
    arr = np.asarray(x, dtype=float)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise IdentificationInputError(f"{name} must be a 2-D array (N, k); got shape {arr.shape}")
    if width is not None and arr.shape[1] != width:
        raise IdentificationInputError(f"{name} must have {width} columns; got shape {arr.shape}")
    if arr.shape[0] < min_rows:
        raise IdentificationInputError(
            f"{name} has {arr.shape[0]} samples; at least {min_rows} are needed")
    bad = ~np.isfinite(arr)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise IdentificationInputError(
            f"{name} has a non-finite value (NaN or inf) at row {row}, column {col}")
    return arr


def zero_phase_lowpass(x, sample_rate_hz: float, cutoff_hz: float, *,
                       order: int = DEFAULT_FILTER_ORDER) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 of ``x`` (N,) or (N, k)."""
    if not (0.0 < cutoff_hz < 0.5 * sample_rate_hz):
        raise IdentificationInputError(
            f"cutoff {cutoff_hz} Hz must lie in (0, {0.5 * sample_rate_hz}) Hz (Nyquist)")
    arr = np.asarray(x, dtype=float)
    sos = _signal.butter(order, cutoff_hz, btype="low", fs=sample_rate_hz, output="sos")
    min_len = 3 * (2 * len(sos) + 1)
    if arr.shape[0] <= min_len:
        raise IdentificationInputError(
            f"{arr.shape[0]} samples are too few to filter (need more than {min_len})")
    return _signal.sosfiltfilt(sos, arr, axis=0)


def derivative(x, sample_rate_hz: float) -> np.ndarray:
    """Time derivative along axis 0 by central differences (units of x per second)."""
    arr = np.asarray(x, dtype=float)
    if arr.shape[0] < 3:
        raise IdentificationInputError("at least 3 samples are needed to differentiate")
    return np.gradient(arr, 1.0 / sample_rate_hz, axis=0)


def excitation_period(x, *, min_lag: int = 1, tolerance: float = 0.1) -> int | None:
    """Smallest lag (samples) >= ``min_lag`` at which the trajectory ``x`` (N, k) repeats itself:
    the first local minimum of ||x[lag:] - x[:-lag]|| / ||x[lag:] - mean(x)|| below
    ``tolerance``; None if it never does (within the first half of the recording). Periodic
    excitation (a Fourier series) makes a split of one recording into a first and a last part an
    in-sample test; this finds the period to split by phase instead."""
    arr = check_finite_2d(x, "trajectory", min_rows=4)

    def mismatch(lag):
        a = arr[lag:]
        return np.linalg.norm(a - arr[:-lag]) / np.linalg.norm(a - a.mean(axis=0))

    for lag in range(max(1, min_lag), arr.shape[0] // 2):
        if mismatch(lag) <= tolerance:
            # the first lag under the tolerance may sit just before the period: go to the minimum
            while lag + 1 < arr.shape[0] // 2 and mismatch(lag + 1) < mismatch(lag):
                lag += 1
            return lag
    return None
