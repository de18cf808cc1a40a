"""The force filters the evaluation scores with, below every layer that uses them.

* :func:`lowpass_causal`: a 2nd-order Butterworth low-pass at 5 Hz (:data:`CAUSAL_LOWPASS_HZ`),
  causal, started at steady state: what a loop filtering sample by sample outputs; its delay for
  slow signals is :func:`lowpass_lag_samples` (4.5 samples = 45 ms at 100 Hz);
* :func:`centred_median`: the seed paper's centred ("bidirectional") running median of
  :data:`MEDIAN_KERNEL` = 71 samples, the window at the ends filled by repeating the edge sample.

:mod:`psmforce.estimators.evaluation.metrics` builds the evaluation's post-processing from them, and
:mod:`psmforce.experiments.bench_calibration` summarises a simulated residual through the same two,
so the simulator is judged by the filters its estimators are scored with.
"""

from __future__ import annotations

import numpy as np
from scipy import signal
from scipy.ndimage import median_filter

MEDIAN_KERNEL = 71
CAUSAL_LOWPASS_HZ = 5.0
CAUSAL_LOWPASS_ORDER = 2


def lowpass_causal(x: np.ndarray, rate_hz: float = 100.0, cutoff_hz: float = CAUSAL_LOWPASS_HZ,
                   order: int = CAUSAL_LOWPASS_ORDER) -> np.ndarray:
    """Butterworth low-pass of (N, k) samples along time, causal, started at steady state on the
    first sample (no start-up transient): what a loop filtering sample by sample outputs."""
    x = np.asarray(x, dtype=float)
    sos = signal.butter(order, cutoff_hz, fs=rate_hz, output="sos")
    zi = signal.sosfilt_zi(sos)[:, :, None] * x[0]
    return signal.sosfilt(sos, x, axis=0, zi=zi)[0]


def lowpass_lag_samples(rate_hz: float = 100.0, cutoff_hz: float = CAUSAL_LOWPASS_HZ,
                        order: int = CAUSAL_LOWPASS_ORDER) -> float:
    """Delay of :func:`lowpass_causal` for slow signals: its group delay at 0 Hz, samples."""
    b, a = signal.butter(order, cutoff_hz, fs=rate_hz)
    return float(signal.group_delay((b, a), w=[1e-6], fs=rate_hz)[1][0])


def centred_median(x: np.ndarray, kernel: int = MEDIAN_KERNEL) -> np.ndarray:
    """Running median of ``kernel`` samples centred on each sample of (N, k) ``x``, per column;
    at the ends the window is filled by repeating the edge sample."""
    return median_filter(np.asarray(x, dtype=float), size=(kernel, 1), mode="nearest")
