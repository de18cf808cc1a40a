"""Causal post-filters of the streaming force estimate, one sample at a time or offline.

The paper's bidirectional median (k = 71) cannot run online; these can: ``"none"``;
``"median"``: trailing median over the last ``median_kernel`` estimates (lag (k - 1) / 2
samples on a ramp); ``"lowpass"``: Butterworth of ``lowpass_order`` at ``lowpass_hz`` as
second-order sections (lag = its group delay at 0 Hz, :meth:`CausalFilter.lag_samples`).
``benchmarks/streaming.py`` reports each one's lag and accuracy next to the paper's filter.

:meth:`CausalFilter.step` filters one estimate (the streaming path, buffers allocated at
construction), :meth:`CausalFilter.offline` a whole sequence from its start (the batch path);
both give the same numbers.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from psmforce.estimators.evaluation.metrics import lowpass_causal
from psmforce.estimators.runtime.steppers import StreamingError

_FILTER_SETTLED = 1e-4
"""The post-filter has forgotten a sample once its impulse response is below this (a
:data:`psmforce.estimators.data.bounds.MAX_FORCE_N` spike then contributes < 0.02 N)."""


class CausalFilter:
    """Causal post-filter of (3,) force estimates: ``"none"``, ``"median"`` or ``"lowpass"``."""

    def __init__(self, kind: str = "none", *, rate_hz: float = 100.0, median_kernel: int = 11,
                 lowpass_hz: float = 5.0, lowpass_order: int = 2):
        if kind not in ("none", "median", "lowpass"):
            raise StreamingError(f"post_filter must be 'none', 'median' or 'lowpass', got {kind!r}")
        if kind == "median" and median_kernel < 1:
            raise StreamingError(f"median_kernel must be >= 1, got {median_kernel}")
        if kind == "lowpass" and not 0 < lowpass_hz < rate_hz / 2:
            raise StreamingError(f"lowpass_hz must be in (0, {rate_hz / 2}) Hz, got {lowpass_hz}")
        self.kind, self.rate_hz = kind, rate_hz
        self.median_kernel = median_kernel
        self.lowpass_hz, self.lowpass_order = lowpass_hz, lowpass_order
        self._out = np.zeros(3)
        if kind == "median":
            self._ring = np.zeros((median_kernel, 3))
        if kind == "lowpass":
            self._sos = signal.butter(lowpass_order, lowpass_hz, fs=rate_hz, output="sos")
            self._zi_unit = signal.sosfilt_zi(self._sos)  # (sections, 2): steady state for 1
            self._z = np.zeros((len(self._sos), 2, 3))
            self._sec = np.zeros(3)
        self.reset()

    def reset(self) -> None:
        self._n = 0

    def memory_samples(self) -> int:
        """How many outputs one input still influences: 1 without a filter, the kernel for the
        median, for the low-pass until its impulse response falls below ``_FILTER_SETTLED``."""
        if self.kind == "median":
            return self.median_kernel
        if self.kind == "lowpass":
            impulse = np.zeros(int(20 * self.rate_hz / self.lowpass_hz))  # 20 cut-off periods
            impulse[0] = 1.0
            response = np.abs(signal.sosfilt(self._sos, impulse))
            return int(np.nonzero(response > _FILTER_SETTLED)[0].max()) + 1
        return 1

    def lag_samples(self) -> float:
        """Delay the filter adds to slow signals, samples: (k - 1) / 2 for the trailing median
        (exact on a ramp), the group delay at 0 Hz for the low-pass, 0 without a filter."""
        if self.kind == "median":
            return (self.median_kernel - 1) / 2
        if self.kind == "lowpass":
            b, a = signal.sos2tf(self._sos)
            return float(signal.group_delay((b, a), w=[1e-6], fs=self.rate_hz)[1][0])
        return 0.0

    def step(self, force: np.ndarray) -> np.ndarray:
        """One estimate (3,) -> filtered (3,) (internal buffer)."""
        if self.kind == "none":
            self._out[:] = force
        elif self.kind == "median":
            k = self.median_kernel
            self._ring[self._n % k] = force
            self._n += 1
            np.median(self._ring[:min(self._n, k)], axis=0, out=self._out)
        else:
            if self._n == 0:  # start at steady state on the first value: no start-up transient
                np.multiply(self._zi_unit[:, :, None], force, out=self._z)
                self._n = 1
            x = self._sec
            x[:] = force
            for s, (b0, b1, b2, _, a1, a2) in enumerate(self._sos):
                z = self._z[s]
                y = b0 * x + z[0]
                z[0] = b1 * x - a1 * y + z[1]
                z[1] = b2 * x - a2 * y
                x[:] = y
            self._out[:] = x
        return self._out

    def offline(self, force: np.ndarray) -> np.ndarray:
        """The same filter over a whole (N, 3) sequence from its start, vectorised."""
        force = np.asarray(force, np.float64)
        if self.kind == "none" or len(force) == 0:
            return force.copy()
        if self.kind == "median":
            k = self.median_kernel
            out = np.empty_like(force)
            head = min(k - 1, len(force))
            for i in range(head):  # the first k - 1 outputs see a shorter history
                out[i] = np.median(force[:i + 1], axis=0)
            if len(force) >= k:
                windows = np.lib.stride_tricks.sliding_window_view(force, k, axis=0)
                out[k - 1:] = np.median(windows, axis=-1)
            return out
        return lowpass_causal(force, self.rate_hz, self.lowpass_hz, self.lowpass_order)
