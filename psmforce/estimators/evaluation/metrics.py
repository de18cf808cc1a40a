"""The seed paper's evaluation: post-processing and per-axis error metrics.

Post-processing of one trial's predictions, three ways (:data:`POSTPROCESSING`):

* ``"paper"`` (paper, "Training and Inference Data Processing" and the teleoperation section):
  subtract the mean prediction over the first 0.5 s (the tool is held still in free space
  there), then a centred ("bidirectional") running median of k = 71 samples (0.71 s at 100 Hz);
  at the ends the window is filled by repeating the edge sample. The centred median looks 0.35 s
  ahead, which no haptic loop can, and it also flattens what changes faster than 0.71 s in the
  force, so every estimator scored this way meets a floor (:func:`floor_metrics`);
* ``"causal"``: what a haptic loop gets sample by sample: the same free-space bias (a tare taken
  once at start-up), no filter, no look-ahead;
* ``"causal_lowpass"``: the same through the causal filter a user would run, a 2nd-order
  Butterworth low-pass at 5 Hz (:data:`CAUSAL_LOWPASS_HZ`; group delay at DC
  :func:`lowpass_lag_samples`, 4.5 samples = 45 ms at 100 Hz), started at steady state.

The two filters live in :mod:`psmforce.core.filters` (the simulator's calibration uses them too) and
are re-exported here with their constants.

Metrics per axis over the samples given (N, 3 arrays in N):
RMSE = sqrt(mean((pred - truth)^2)); NRMSE = RMSE / (max(truth) - min(truth)) x 100 (%);
R^2 = 1 - SS_res / SS_tot (as a fraction; tables print it in %).
"""

from __future__ import annotations

import numpy as np

from psmforce.core.filters import (  # noqa: F401
    CAUSAL_LOWPASS_HZ,
    CAUSAL_LOWPASS_ORDER,
    MEDIAN_KERNEL,
    centred_median,
    lowpass_causal,
    lowpass_lag_samples,
)

from psmforce.io.recording import AXES  # re-exported: the evaluation names its axes so

BIAS_SECONDS = 0.5
POSTPROCESSING = ("paper", "causal", "causal_lowpass")


class MetricError(ValueError):
    """Inputs a metric cannot be computed on (shape mismatch, empty, constant truth)."""


def _check(pred: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    pred, truth = np.asarray(pred, dtype=float), np.asarray(truth, dtype=float)
    if pred.shape != truth.shape:
        raise MetricError(f"prediction shape {pred.shape} != ground-truth shape {truth.shape}")
    if pred.shape[0] == 0:
        raise MetricError("no samples to score")
    return pred, truth


def rmse(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    pred, truth = _check(pred, truth)
    return np.sqrt(np.mean((pred - truth) ** 2, axis=0))


def nrmse(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """RMSE over the ground truth's range, in %."""
    pred, truth = _check(pred, truth)
    span = truth.max(axis=0) - truth.min(axis=0)
    if np.any(span <= 0):
        raise MetricError("ground truth is constant on an axis: NRMSE undefined")
    return rmse(pred, truth) / span * 100.0


def r2(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    pred, truth = _check(pred, truth)
    ss_tot = np.sum((truth - truth.mean(axis=0)) ** 2, axis=0)
    if np.any(ss_tot <= 0):
        raise MetricError("ground truth is constant on an axis: R^2 undefined")
    return 1.0 - np.sum((pred - truth) ** 2, axis=0) / ss_tot


def axis_metrics(pred: np.ndarray, truth: np.ndarray) -> dict[str, dict[str, float]]:
    """{axis: {range_n, rmse_n, nrmse_pct, r2_pct}} for Fx, Fy, Fz."""
    pred, truth = _check(pred, truth)
    span = truth.max(axis=0) - truth.min(axis=0)
    e, n, r = rmse(pred, truth), nrmse(pred, truth), r2(pred, truth)
    return {a: {"range_n": float(span[i]), "rmse_n": float(e[i]), "nrmse_pct": float(n[i]),
                "r2_pct": float(r[i] * 100.0)} for i, a in enumerate(AXES)}


def postprocess(pred: np.ndarray, rate_hz: float = 100.0, *, bias: bool = True,
                kernel: int = MEDIAN_KERNEL, bias_seconds: float = BIAS_SECONDS,
                mode: str = "paper") -> np.ndarray:
    """One trial's (N, 3) predictions -> bias-corrected, then filtered as ``mode`` says
    (module docstring). ``bias=False`` skips the bias step (the paper does so for the LSTM)."""
    pred = np.asarray(pred, dtype=float)
    if pred.ndim != 2 or pred.shape[0] == 0:
        raise MetricError(f"expected (N, 3) predictions, got shape {pred.shape}")
    if mode not in POSTPROCESSING:
        raise MetricError(f"post-processing must be one of {POSTPROCESSING}, got {mode!r}")
    if kernel < 1 or kernel % 2 == 0:
        raise MetricError(f"median kernel must be a positive odd number, got {kernel}")
    out = pred
    if bias:
        n_bias = max(1, int(round(bias_seconds * rate_hz)))
        out = out - out[:n_bias].mean(axis=0)
    if mode == "causal":
        return out
    if mode == "causal_lowpass":
        return lowpass_causal(out, rate_hz)
    return centred_median(out, kernel)
