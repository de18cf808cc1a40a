"""Sample rates: the rate a model was trained at, the rate a stream arrives at, and the causal
decimation between them.

A network learns its dynamics on samples at one rate (its window of ``window`` samples spans
``window / rate`` seconds), so it must run at that rate, whatever rate the robot publishes at.
:func:`trials_rate_hz` measures the training data's rate from the ``time`` column
(:mod:`psmforce.io.recording`: seconds, one clock per recording); the checkpoint and the export
record it as ``sample_rate_hz`` (:mod:`psmforce.estimators.training.checkpoint`). A checkpoint that
does not record it (written before the field) is read as :data:`DEFAULT_SAMPLE_RATE_HZ`, the rate of
the simulated bench and of ``psmforce convert``'s default clock.

A stream is served when its rate is an integer multiple ``D`` of the model's rate (within
:data:`RATE_TOLERANCE`): :func:`decimation_factor` gives ``D`` or refuses the stream in one line.
On the way down the signals pass :class:`AntiAlias`, a causal low-pass (Butterworth of order
:data:`ANTI_ALIAS_ORDER` at :data:`ANTI_ALIAS_FRACTION` of the model's rate, below its Nyquist
frequency, run forward only, so nothing from the future leaks in). Its lag is its group delay at
0 Hz (:meth:`AntiAlias.lag_s`: 5.6 ms for a 100 Hz model); ``D = 1`` filters nothing.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy import signal

from psmforce.io.recording import MAX_RATE_HZ, TIME

DEFAULT_SAMPLE_RATE_HZ = 100.0
"""The rate assumed for a checkpoint that does not record ``sample_rate_hz`` (Hz)."""

RATE_TOLERANCE = 0.01
"""Relative difference under which two rates are the same rate (clock drift, jitter)."""

ANTI_ALIAS_ORDER = 2
ANTI_ALIAS_FRACTION = 0.4
"""The anti-alias cut-off as a fraction of the model's rate (its Nyquist frequency is 0.5)."""


class RateError(ValueError):
    """A rate that cannot be measured or served; the message says why in one line."""


def check_rate(rate_hz, name: str = "rate_hz") -> float:
    """``rate_hz`` as a float, refused unless a finite number > 0 (Hz)."""
    if isinstance(rate_hz, bool) or not isinstance(rate_hz, (int, float, np.floating)) \
            or not math.isfinite(rate_hz) or rate_hz <= 0:
        raise RateError(f"{name} must be a finite number > 0 (Hz), got {rate_hz!r}")
    return float(rate_hz)


def recording_rate_hz(time: np.ndarray, where: str = "recording") -> float:
    """The sample rate (Hz) of one clock, from its times (s): 1 / the median interval."""
    time = np.asarray(time, dtype=np.float64)
    dt = np.diff(time)
    if len(dt) == 0 or not np.isfinite(dt).all() or (dt <= 0).any():
        raise RateError(f"{where}: needs at least two finite, strictly increasing times to "
                        f"measure its rate")
    return 1.0 / float(np.median(dt))


def stream_rate_hz(stamps_ns, where: str = "stream") -> float:
    """The rate (Hz) of a live stream from the header stamps (ns) of its first messages, as
    they came: unset (0) stamps, repeats and steps back are what a stream may carry and the
    estimator flags one by one, so they are set aside here, not fatal. The rate is 1 / the
    median step between the distinct stamps in order; refused (:class:`RateError`) when fewer
    than half the messages carry distinct stamps."""
    stamps = np.asarray([s for s in stamps_ns if s], dtype=np.int64)
    distinct = np.unique(stamps)
    if len(distinct) < 2 or len(distinct) < len(stamps_ns) / 2:
        raise RateError(f"{where}: needs distinct header stamps on most of its first "
                        f"{len(stamps_ns)} messages to measure its rate, found {len(distinct)}")
    return 1.0 / float(np.median(np.diff(distinct) * 1e-9))


def trials_rate_hz(trials: Sequence, time_column: str = TIME, root=None) -> float:
    """The one rate (Hz) of recordings (objects with a ``frame`` and a ``path``, such as
    :class:`psmforce.estimators.data.dataset.Trial`): refused when they do not share it within
    :data:`RATE_TOLERANCE`. Returns the median of their rates. ``root``: the folder their paths
    are relative to, named in a refusal."""
    if not trials:
        raise RateError("no recordings to measure a rate from")

    def where(t) -> str:
        return str(t.path if root is None else Path(root) / t.path)
    rates = [recording_rate_hz(t.frame[time_column].to_numpy(), where(t)) for t in trials]
    median = float(np.median(rates))
    worst = int(np.argmax([abs(r - median) for r in rates]))
    if abs(rates[worst] - median) > RATE_TOLERANCE * median:
        raise RateError(f"{where(trials[worst])}: sampled at {rates[worst]:.4g} Hz, the other "
                        f"recordings at {median:.4g} Hz; a model is trained at one rate")
    return median


MIN_TRAINING_RATE_HZ = 1.0
"""The lowest rate training data may have: below it the time column is not in seconds."""


def training_rate_hz(trials: Sequence, time_column: str = TIME, root=None) -> float:
    """The rate (Hz) a model trained on ``trials`` is trained at (:func:`trials_rate_hz`),
    refused (:class:`RateError`, naming a file) when the trials do not share one, or when it lies
    outside [:data:`MIN_TRAINING_RATE_HZ`, :data:`psmforce.io.recording.MAX_RATE_HZ`]: times in
    milliseconds or nanoseconds where the recording layout has seconds."""
    rate = trials_rate_hz(trials, time_column, root)
    if not MIN_TRAINING_RATE_HZ <= rate <= MAX_RATE_HZ:
        first = trials[0].path if root is None else Path(root) / trials[0].path
        raise RateError(f"{first}: sampled at {rate:.4g} Hz by its '{time_column}' "
                        f"column, outside [{MIN_TRAINING_RATE_HZ:g}, {MAX_RATE_HZ:g}] Hz: the "
                        f"recording layout's time is in seconds (milliseconds or nanoseconds?)")
    return rate


def decimation_factor(input_rate_hz: float, model_rate_hz: float) -> int:
    """How many input samples make one model sample: ``input / model`` rounded, refused in one
    line unless an integer >= 1 within :data:`RATE_TOLERANCE`."""
    input_rate_hz = check_rate(input_rate_hz, "input_rate_hz")
    model_rate_hz = check_rate(model_rate_hz, "the model's rate")
    factor = round(input_rate_hz / model_rate_hz)
    if factor < 1 or abs(input_rate_hz / factor - model_rate_hz) > RATE_TOLERANCE * model_rate_hz:
        raise RateError(f"a {input_rate_hz:g} Hz stream cannot feed a model trained at "
                        f"{model_rate_hz:g} Hz: the input rate must be a whole multiple of it "
                        f"({model_rate_hz:g}, {2 * model_rate_hz:g}, ... Hz)")
    return factor


class AntiAlias:
    """Causal low-pass of (C,) samples before keeping one in ``factor`` (module docstring).

    :meth:`step` filters one sample (buffers allocated at construction), :meth:`offline`
    a whole (N, C) sequence from its start; both start at rest on their first sample (the
    filter's steady state for it, so a constant passes unchanged) and give the same numbers
    within float64 rounding. ``factor`` 1: both return their input unchanged.
    """

    def __init__(self, n_columns: int, factor: int, model_rate_hz: float):
        self.factor = int(factor)
        self.model_rate_hz = float(model_rate_hz)
        self.n_columns = int(n_columns)
        self._out = np.zeros(self.n_columns)
        if self.factor > 1:
            self.sos = signal.butter(ANTI_ALIAS_ORDER, ANTI_ALIAS_FRACTION * self.model_rate_hz,
                                     fs=self.factor * self.model_rate_hz, output="sos")
            self._zi_unit = signal.sosfilt_zi(self.sos)  # (sections, 2) for a unit step
            self._z = np.zeros((len(self.sos), 2, self.n_columns))
            # per section: (b0, b1, b2) and (a1, a2) as columns, and views of its two state rows;
            # with the scratch rows below a step allocates nothing (once per input sample, at
            # 1 kHz on the live node)
            self._sections = [(section[:3, None].copy(), section[4:, None].copy(), z[0], z[1])
                              for section, z in zip(self.sos, self._z)]
            self._bu = np.zeros((3, self.n_columns))  # b0 u, b1 u, b2 u
            self._ay = np.zeros((2, self.n_columns))  # a1 y, a2 y
        self.reset()

    def reset(self) -> None:
        """The next sample starts the filter at rest on it."""
        self._fresh = True

    def lag_s(self) -> float:
        """The filter's group delay at 0 Hz (s); 0 for ``factor`` 1."""
        if self.factor == 1:
            return 0.0
        b, a = signal.sos2tf(self.sos)
        _, delay = signal.group_delay((b, a), w=[1e-6], fs=self.factor * self.model_rate_hz)
        return float(delay[0]) / (self.factor * self.model_rate_hz)

    def step(self, x: np.ndarray) -> np.ndarray:
        """Filter one (C,) sample; returns an internal buffer (copy it to keep it)."""
        if self.factor == 1:
            self._out[:] = x
            return self._out
        if self._fresh:
            self._z[:] = self._zi_unit[:, :, None] * x[None, None, :]
            self._fresh = False
        y, bu, ay = self._out, self._bu, self._ay
        u = x
        for b, a, z0, z1 in self._sections:
            # direct form II transposed: y = b0 u + z0, z0 = b1 u - a1 y + z1, z1 = b2 u - a2 y,
            # the three products of u at once, then of y (the vector formulas' operations, in
            # their order: the same numbers)
            np.multiply(b, u, out=bu)
            np.add(bu[0], z0, out=y)
            np.multiply(a, y, out=ay)
            np.subtract(bu[1:], ay, out=bu[1:])
            np.add(bu[1], z1, out=z0)
            z1[:] = bu[2]
            u = y  # the next section filters this one's output (read into bu before y changes)
        return y

    def offline(self, values: np.ndarray) -> np.ndarray:
        """Filter a whole (N, C) sequence as :meth:`step` would, sample after sample."""
        values = np.asarray(values, dtype=np.float64)
        if self.factor == 1 or not len(values):
            return values.copy()
        zi = self._zi_unit[:, :, None] * values[0][None, None, :]
        return signal.sosfilt(self.sos, values, axis=0, zi=zi)[0]
