"""Streaming force estimation, one sample at a time, for a 1 kHz haptic loop on one CPU core.

:class:`StreamingEstimator` runs the hybrid pipeline per sample: recorded signals -> prior ->
compensated HEX10 -> scaled inputs (:class:`hybrid.inputs.HybridInputs`) -> one incremental step
of the causal transformer (:mod:`hybrid.causal`; keys/values cached, one token per layer) ->
un-scaled residual + base -> optional causal post-filter. Output: the external force ON the tool
in the HEX10 frame (N), and on request in the PSM base frame (rotated by R_base_hex10(q),
:class:`hybrid.inputs.HexRotation`).
All buffers are allocated at construction; memory is constant.

Per-sample :class:`Flags` (bit mask, several may be set):

``WARMING_UP``      fewer than ``model.window`` samples since the start or the last reset: the
                    estimate exists but has seen less history than in training.
``OVERLOAD``        the sample's ``hex10_overload`` signal is set (the reading is clipped).
``INVALID_INPUT``   the sample is not used and the state is untouched: a NaN / inf value, a
                    value beyond its physical bound (:func:`physical_bounds`: joint limits with a
                    margin, effort and velocity limits, the HEX10 overload), a missing or
                    non-numeric field (the overload signal included), a wrongly shaped array, a
                    missing or non-finite timestamp.
``TIME_BACKWARDS``  timestamp not after the last accepted one: the sample is not used. A clock
                    that stays behind for more than ``max_gap_samples`` samples in a row is a
                    restarted clock: it is accepted as a ``GAP`` (one bad future timestamp cannot
                    lock the estimator out).
``GAP``             more than ``max_gap_samples`` samples missing since the last accepted one
                    (from the timestamps): the history is discontinuous, so the network and
                    filter state are reset and this sample starts a new warm-up.
``EXTRAPOLATION``   an input lies outside the training range, in this sample or in one the
                    estimate still remembers (the network's ``window`` plus the post-filter's
                    :meth:`CausalFilter.memory_samples`): beyond ``input_range`` (raw units)
                    when given, else more than ``extrapolation_z`` training standard deviations
                    from the training mean.
``HELD``            no new estimate: the returned force is the last one (NaN before the first).
``RESET``           the network's output or the filter's state was not finite: both were
                    reset, the last good estimate is held and a new warm-up starts.
``IMPLAUSIBLE``     the estimate exceeds :data:`MAX_FORCE_N` on an axis, more than the shaft
                    sensor can carry: returned, but not a force to act on.

A sample that is not used never touches the state, so the estimator recovers by itself: up to
``max_gap_samples`` dropped samples are bridged (the network sees the next good sample as the
next one), longer gaps restart the warm-up. No sample, however malformed, raises: every
estimate after the first is finite (``tests/test_streaming.py`` drives adversarial streams;
``benchmarks/streaming_fuzz.py`` 10^6 samples).

Backends for the network step (identical outputs within 1e-5, tests/test_streaming.py):
``"onnx"`` (ONNX Runtime, one thread, on the step graph of :mod:`hybrid.export`), ``"numpy"``
(:class:`hybrid.causal.NumpyStepper`), ``"torch"`` (eager reference). ``backend="auto"`` picks
onnx when onnxruntime is installed, else numpy: that is their order of speed in
``benchmarks/streaming.py`` (network step median on this CPU: onnx ~0.06 ms, numpy ~0.12 ms,
torch ~0.32 ms).

Post-filters (the paper's bidirectional median, k = 71, cannot run online): ``"none"``;
``"median"``: trailing median over the last ``median_kernel`` estimates (lag (k - 1) / 2
samples on a ramp); ``"lowpass"``: Butterworth of ``lowpass_order`` at ``lowpass_hz`` as
second-order sections (lag = its group delay at 0 Hz, :meth:`CausalFilter.lag_samples`). The
benchmark reports each one's lag and accuracy next to the paper's filter.

:meth:`StreamingEstimator.predict_recording` is the offline batch path (whole recordings,
same weights, same filter, vectorised): it equals stepping through the recording sample by
sample within float32 rounding.
"""

from __future__ import annotations

import enum
import math
import operator
from pathlib import Path
from typing import NamedTuple, Sequence

import numpy as np
import pandas as pd
import torch
from scipy import signal

from hybrid.causal import CausalTransformer, NumpyStepper, predict_sequence
from hybrid.inputs import HexRotation, HybridInputs
from hybrid.metrics import lowpass_causal
from psm_model.recording import (HEX10_FORCE, HEX10_TORQUE, JOINT_EFFORTS, JOINT_POSITIONS,
                                  JOINT_VELOCITIES, JOINTS, OVERLOAD)
from psm_model.sim.params import InstrumentParams

CHAIN_POSITIONS = JOINT_POSITIONS
"""Joint positions the base-frame rotation reads (dVRK order, jaw last)."""
BACKENDS = ("numpy", "onnx", "torch")

POSITION_MARGIN = 0.1
"""Joint positions may pass the URDF limits by this fraction of each joint's range: the dVRK's
limits are software limits that a backdriven or homing arm overshoots by a few degrees; beyond
that a value is not a pose but a corrupt sample."""
VELOCITY_FACTOR = 10.0
"""Joint velocities may reach this multiple of the URDF velocity limit: they are encoder
differences that spike on quantisation and impacts (the simulated bench reaches 3.8x on roll)."""
EFFORT_FACTOR = 3.0
"""Joint efforts may reach this multiple of the URDF effort limit (max current x torque constant x
gear ratio): joint efforts are coupled sums of saturated actuator currents (the bench: 1.04x)."""
HEX10_FACTOR = 1.5
"""HEX10 channels may reach this multiple of the sensor's overload range (clipped there), which
leaves room for a re-tared offset; a larger reading cannot come from the sensor."""
_HEX10 = InstrumentParams()  # the HEX10's data-sheet ranges, stated once with the simulated sensor
MAX_FORCE_N = HEX10_FACTOR * _HEX10.hex10_overload_n
"""An estimated force beyond this on an axis (N) cannot be carried through the shaft sensor: the
estimate is flagged ``IMPLAUSIBLE``."""
_FILTER_SETTLED = 1e-4
"""The post-filter has forgotten a sample once its impulse response is below this (a
:data:`MAX_FORCE_N` spike then contributes < 0.02 N)."""


def physical_bounds(psm=None) -> dict[str, tuple[float, float]]:
    """Per recorded column, the (low, high) range a real sample can take (units of
    :mod:`psm_model.recording`): the URDF's joint, velocity and effort limits of ``psm`` (default
    the bundled PSM) widened by :data:`POSITION_MARGIN`, :data:`VELOCITY_FACTOR`,
    :data:`EFFORT_FACTOR`, and the HEX10's overload times :data:`HEX10_FACTOR`."""
    if psm is None:
        from psm_model import PSM
        psm = PSM()
    model = psm.model
    idx_v = [model.joints[model.getJointId(j)].idx_v for j in JOINTS]
    low, high = np.asarray(psm.lower_limits, float), np.asarray(psm.upper_limits, float)
    margin = POSITION_MARGIN * (high - low)
    velocity = VELOCITY_FACTOR * np.asarray(model.velocityLimit)[idx_v]
    effort = EFFORT_FACTOR * np.asarray(model.effortLimit)[idx_v]
    bounds = {}
    for k in range(len(JOINTS)):
        bounds[JOINT_POSITIONS[k]] = (low[k] - margin[k], high[k] + margin[k])
        bounds[JOINT_VELOCITIES[k]] = (-velocity[k], velocity[k])
        bounds[JOINT_EFFORTS[k]] = (-effort[k], effort[k])
    for names, limit in ((HEX10_FORCE, _HEX10.hex10_overload_n),
                         (HEX10_TORQUE, _HEX10.hex10_overload_moment_nm)):
        for c in names:
            bounds[c] = (-HEX10_FACTOR * limit, HEX10_FACTOR * limit)
    return bounds


class StreamingError(ValueError):
    """A streaming request that cannot be served; the message says why."""


class Flags(enum.IntFlag):
    """Per-sample status bits; see the module docstring."""

    NONE = 0
    WARMING_UP = 1
    OVERLOAD = 2
    INVALID_INPUT = 4
    TIME_BACKWARDS = 8
    GAP = 16
    EXTRAPOLATION = 32
    HELD = 64
    RESET = 128
    IMPLAUSIBLE = 256


class Estimate(NamedTuple):
    force_hex10: np.ndarray
    """(3,) external force on the tool, N, HEX10 frame (a copy)."""
    flags: int
    """:class:`Flags` bits as an int (``Flags(flags)`` names them)."""
    force_base: np.ndarray | None = None
    """(3,) the same force in the PSM base frame, when asked for."""


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


class TorchStepper:
    """Eager PyTorch reference backend: :meth:`CausalTransformer.step` with its caches."""

    def __init__(self, model: CausalTransformer):
        self.model = model.eval()
        self.reset()

    def reset(self) -> None:
        self._keys, self._values, self._n_valid = self.model.init_cache(1)

    def step(self, x: np.ndarray) -> np.ndarray:
        with torch.inference_mode():
            self._n_valid = torch.clamp(self._n_valid + 1, max=self.model.attention_window)
            y, self._keys, self._values = self.model.step(torch.from_numpy(x)[None],
                                                          self._keys, self._values,
                                                          self._n_valid)
        return y[0].numpy()


def _auto_backend() -> str:
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        return "numpy"
    return "onnx"


def make_backend(model: CausalTransformer, backend: str = "auto"):
    """A batch-1 step runner with ``reset()`` and ``step(x (F,) float32) -> (3,)``."""
    if backend == "auto":
        backend = _auto_backend()
    if backend == "numpy":
        return NumpyStepper(model)
    if backend == "torch":
        return TorchStepper(model)
    if backend == "onnx":
        from hybrid.export import OnnxStepper
        return OnnxStepper.from_model(model)
    raise StreamingError(f"unknown backend {backend!r}; known: {['auto', *BACKENDS]}")


class StreamingEstimator:
    """Per-sample hybrid force estimator; see the module docstring.

    ``model``: a :class:`hybrid.causal.CausalTransformer`; ``features``, ``input_scaler``,
    ``target_scaler``, ``base_columns``, ``prior``: as stored in the checkpoint
    (:meth:`from_checkpoint`). ``rate_hz``: the recordings' sample rate. ``psm``: a
    ``psm_model.PSM`` for base-frame output (``step(..., base_frame=True)``).
    """

    def __init__(self, model: CausalTransformer, features: Sequence[str], input_scaler,
                 target_scaler, base_columns: Sequence[str] = (), prior=None, *,
                 rate_hz: float = 100.0, max_gap_samples: int = 5, backend: str = "auto",
                 post_filter: str = "none", median_kernel: int = 11, lowpass_hz: float = 5.0,
                 lowpass_order: int = 2, extrapolation_z: float = 5.0,
                 input_range: tuple[Sequence[float], Sequence[float]] | None = None, psm=None):
        if not isinstance(model, CausalTransformer):
            raise StreamingError(f"streaming needs a hybrid.causal.CausalTransformer, got "
                                 f"{type(model).__name__}")
        if len(base_columns) not in (0, 3):
            raise StreamingError(f"base needs 0 or 3 columns, got {list(base_columns)}")
        if not (isinstance(rate_hz, (int, float)) and math.isfinite(rate_hz) and rate_hz > 0):
            raise StreamingError(f"rate_hz must be a finite number > 0 (Hz), got {rate_hz!r}")
        if isinstance(max_gap_samples, bool) or not isinstance(max_gap_samples, int) \
                or max_gap_samples < 0:
            raise StreamingError(f"max_gap_samples must be an integer >= 0, got "
                                 f"{max_gap_samples!r}")
        self.model = model.eval()
        self.inputs = HybridInputs(features, base_columns, input_scaler, prior,
                                   extra_columns=CHAIN_POSITIONS if psm is not None else (),
                                   psm=psm)
        self.columns = self.inputs.raw_columns
        """The recorded signals :meth:`step` reads, in the order an array sample must follow."""
        self.rate_hz = rate_hz
        self.max_gap_samples = max_gap_samples
        self.window = model.window
        self.backend_name = _auto_backend() if backend == "auto" else backend
        self._net = make_backend(model, backend)
        self.filter = CausalFilter(post_filter, rate_hz=rate_hz, median_kernel=median_kernel,
                                   lowpass_hz=lowpass_hz, lowpass_order=lowpass_order)
        self._y_mean = np.asarray(target_scaler.mean, np.float64)
        self._y_std = np.asarray(target_scaler.std, np.float64)
        n_feat = len(self.inputs.features)
        if input_range is not None:
            lo, hi = (np.asarray(v, np.float64) for v in input_range)
            if lo.shape != (n_feat,) or hi.shape != (n_feat,):
                raise StreamingError(f"input_range needs two arrays of {n_feat} values")
            self._lo = ((lo - input_scaler.mean) / input_scaler.std).astype(np.float32)
            self._hi = ((hi - input_scaler.mean) / input_scaler.std).astype(np.float32)
        else:
            self._lo = np.full(n_feat, -extrapolation_z, np.float32)
            self._hi = np.full(n_feat, extrapolation_z, np.float32)
        self._get = operator.itemgetter(*self.columns)
        bounds = physical_bounds(psm)
        finite = np.finfo(np.float64).max  # a column without a physical bound: finite is enough
        self._raw_lo = np.array([bounds.get(c, (-finite, finite))[0] for c in self.columns])
        self._raw_hi = np.array([bounds.get(c, (-finite, finite))[1] for c in self.columns])
        self._memory = self.window + self.filter.memory_samples() - 1
        if psm is not None:
            self._hex_rotation = HexRotation(psm)
            self._q_index = np.array([self.columns.index(c) for c in CHAIN_POSITIONS])
        self._raw = np.zeros(len(self.columns))
        self._force = np.zeros(3)
        self._held = np.full(3, np.nan)
        self._outside = np.zeros(n_feat, bool)
        self._in_bounds = np.zeros(len(self.columns), bool)
        self.reset()

    @classmethod
    def from_checkpoint(cls, path: str | Path, **options) -> "StreamingEstimator":
        """An estimator for a hybrid checkpoint written by :mod:`hybrid.train`
        (``options``: the keyword arguments of the constructor)."""
        from hybrid.checkpoint import load_checkpoint
        ckpt = load_checkpoint(path)
        if not ckpt.recipe.streams:
            raise StreamingError(f"{path}: holds a '{ckpt.model_name}' model, which does not "
                                 f"stream (hybrid.recipes: streams=False)")
        return cls(ckpt.model, ckpt.features, ckpt.input_scaler, ckpt.target_scaler,
                   ckpt.base_columns, ckpt.prior(), **options)

    def reset(self) -> None:
        """Forget all history (network cache, filter, timestamps): the next sample starts over."""
        self._restart()
        self._last_time: float | None = None
        self._behind = 0
        self._held[:] = np.nan

    def _restart(self) -> None:
        self._net.reset()
        self.filter.reset()
        self._seen = 0
        self._tainted = 0  # outputs left that remember an extrapolating input

    def _held_estimate(self, flags: int, base_frame: bool) -> Estimate:
        flags |= Flags.HELD
        if self._seen < self.window:
            flags |= Flags.WARMING_UP
        base = np.full(3, np.nan) if base_frame else None
        if base_frame and not np.isnan(self._held).any():
            base = self._rotation() @ self._held
        return Estimate(self._held.copy(), int(flags), base)

    def _rotation(self) -> np.ndarray:
        return self._hex_rotation(self._raw[self._q_index])

    def _read(self, sample, time, overload) -> tuple[float, bool] | None:
        """Sample -> :attr:`_raw`, (time s, overload); None for a sample that cannot be used
        (malformed, non-finite, beyond its physical bounds)."""
        try:
            if isinstance(sample, np.ndarray):
                if sample.shape != self._raw.shape:
                    return None
                self._raw[:] = sample
            else:
                self._raw[:] = self._get(sample)
                if time is None:
                    time = sample.get("time")
                if overload is None:
                    overload = sample.get(OVERLOAD, 0)
            time = float(time)
            # a number (0 / 1, as recorded) or a bool: float() refuses text, whose truth value
            # ('no' is true) says nothing about the sensor
            overload = 0.0 if overload is None else float(overload)  # None: array, no signal
        except (KeyError, TypeError, ValueError, AttributeError, OverflowError):
            return None
        if not math.isfinite(overload):
            return None
        overload = overload != 0
        # one comparison per bound also refuses NaN (every comparison with NaN is false)
        np.less_equal(self._raw_lo, self._raw, out=self._in_bounds)
        if not self._in_bounds.all():
            return None
        np.less_equal(self._raw, self._raw_hi, out=self._in_bounds)
        if not self._in_bounds.all() or not math.isfinite(time):
            return None
        return time, overload

    def step(self, sample, time: float | None = None, *, overload: bool | None = None,
             base_frame: bool = False) -> Estimate:
        """Feed one sample; return its :class:`Estimate`.

        ``sample``: a mapping with every name of :attr:`columns` (plus optionally ``time`` and
        ``hex10_overload``), or a 1-D array in :attr:`columns` order. ``time`` (s) overrides
        the mapping's ``time``. ``overload``: the sensor's overload signal for array samples.
        Bad samples (anything :class:`Flags` lists) are flagged, never raised; only asking for
        ``base_frame`` without a PSM model raises :class:`StreamingError`.
        """
        if base_frame and not hasattr(self, "_hex_rotation"):
            raise StreamingError("base-frame output needs the PSM model: construct the estimator "
                                 "with psm=psm_model.PSM()")
        read = self._read(sample, time, overload)
        if read is None:
            return self._held_estimate(Flags.INVALID_INPUT, base_frame)
        time, overload = read
        flags = Flags.OVERLOAD if overload else 0
        last = self._last_time
        if last is not None:
            if time <= last:
                self._behind += 1
                if self._behind <= self.max_gap_samples:
                    return self._held_estimate(flags | Flags.TIME_BACKWARDS, base_frame)
                flags |= Flags.TIME_BACKWARDS | Flags.GAP  # the clock restarted: so do we
                self._restart()
            elif round((time - last) * self.rate_hz) - 1 > self.max_gap_samples:
                flags |= Flags.GAP
                self._restart()

        inputs = self.inputs
        inputs.sample(self._raw)
        if not (np.isfinite(inputs.x).all() and np.isfinite(inputs.base).all()):
            return self._held_estimate(flags | Flags.INVALID_INPUT, base_frame)
        self._last_time = time
        self._behind = 0
        np.less(inputs.x, self._lo, out=self._outside)
        extrapolating = self._outside.any()
        if not extrapolating:
            np.greater(inputs.x, self._hi, out=self._outside)
            extrapolating = self._outside.any()
        y = self._net.step(inputs.x)
        force = self._force
        np.multiply(y, self._y_std, out=force)
        np.add(force, self._y_mean, out=force)
        if len(inputs.base):
            np.add(force, inputs.base, out=force)
        if not np.isfinite(force).all():
            self._restart()
            return self._held_estimate(flags | Flags.RESET, base_frame)
        filtered = self.filter.step(force)
        if not np.isfinite(filtered).all():
            self._restart()
            return self._held_estimate(flags | Flags.RESET, base_frame)
        self._seen += 1
        if extrapolating:
            self._tainted = self._memory
        if self._tainted > 0:
            flags |= Flags.EXTRAPOLATION
            self._tainted -= 1
        if self._seen < self.window:
            flags |= Flags.WARMING_UP
        if (np.abs(filtered) > MAX_FORCE_N).any():
            flags |= Flags.IMPLAUSIBLE
        self._held[:] = filtered
        base = self._rotation() @ filtered if base_frame else None
        return Estimate(filtered.copy(), int(flags), base)

    def predict_recording(self, frame: pd.DataFrame) -> np.ndarray:
        """Offline batch path: (N, 3) force estimates (N, HEX10 frame) for a whole recording,
        as if streamed from its first sample (same weights and post-filter), without flags.
        The recording must be valid (:func:`psm_model.recording.read_recording` checks it)."""
        x, base = self.inputs.frame(frame)
        y = predict_sequence(self.model, x).astype(np.float64)
        force = y * self._y_std + self._y_mean
        if base.shape[1]:
            force = force + base
        return CausalFilter(self.filter.kind, rate_hz=self.rate_hz,
                            median_kernel=self.filter.median_kernel,
                            lowpass_hz=self.filter.lowpass_hz,
                            lowpass_order=self.filter.lowpass_order).offline(force)
