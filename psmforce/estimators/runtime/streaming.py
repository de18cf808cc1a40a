"""Streaming force estimation, one sample at a time, for a 1 kHz haptic loop on one CPU core.

:class:`StreamingEstimator` runs the hybrid pipeline per sample: recorded signals -> prior ->
compensated HEX10 -> scaled inputs (:class:`psmforce.estimators.data.hybrid_inputs.HybridInputs`) ->
one incremental step of the network (any model that follows the step protocol of
:mod:`psmforce.estimators.runtime.steppers`, such as the causal transformer of
:mod:`psmforce.estimators.networks.causal`: keys/values cached, one token per layer; or a window
network, its last ``window`` inputs as the state,
:mod:`psmforce.estimators.runtime.window_stream`) -> un-scaled
residual + base -> optional causal post-filter. Output: the external force ON the tool in the HEX10
frame (N), and on request in the PSM base frame (rotated by R_base_hex10(q),
:class:`psmforce.estimators.data.hybrid_inputs.HexRotation`). All buffers are allocated at
construction; memory is constant.

Per-sample :class:`Flags` (bit mask, several may be set):

``WARMING_UP``      fewer than ``model.window`` samples since the start or the last reset: the
                    estimate exists but has seen less history than in training.
``OVERLOAD``        the sample's ``hex10_overload`` signal is set (the reading is clipped).
``INVALID_INPUT``   the sample is not used and the state is untouched: a NaN / inf value, a
                    value beyond its physical bound
                    (:func:`psmforce.estimators.data.bounds.physical_bounds`: joint limits with a
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
                    :meth:`psmforce.estimators.runtime.postfilter.CausalFilter.memory_samples`):
                    beyond ``input_range`` (raw units) when given, else more than
                    ``extrapolation_z`` training standard deviations from the training mean.
``HELD``            no new estimate: the returned force is the last one (NaN before the first).
``RESET``           the network's output or the filter's state was not finite: both were
                    reset, the last good estimate is held and a new warm-up starts.
``IMPLAUSIBLE``     the estimate exceeds :data:`psmforce.estimators.data.bounds.MAX_FORCE_N` on an
axis, more
                    than the shaft sensor can carry: returned, but not a force to act on.

A sample that is not used never touches the state, so the estimator recovers by itself: up to
``max_gap_samples`` dropped samples are bridged (the network sees the next good sample as the next
one), longer gaps restart the warm-up. No sample, however malformed, raises: every estimate after
the first is finite (``tests/estimators/test_streaming.py`` drives adversarial streams;
``tests/robustness/adversarial_stream.py`` 10^6 samples).

Backends for the network step (identical outputs within 1e-5, tests/estimators/test_streaming.py):
``"onnx"`` (ONNX Runtime, one thread, on the model's step graph), ``"numpy"`` (the causal
transformer only), ``"torch"`` (eager reference); :mod:`psmforce.estimators.runtime.steppers` holds
them. ``backend="auto"`` picks onnx when onnxruntime is installed, else numpy where the model has a
numpy path, else torch: their order of speed in ``benchmarks/streaming.py``
(``results/benchmarks/streaming.json``).

Post-filters (the paper's bidirectional median, k = 71, cannot run online): ``"none"``, ``"median"``
(trailing), ``"lowpass"`` (Butterworth); :mod:`psmforce.estimators.runtime.postfilter` holds them.
They run at the input rate, on every answer.

Rates (:mod:`psmforce.estimators.data.rates`). The network runs at ``rate_hz``, the rate it was
trained at (the checkpoint's ``sample_rate_hz``). Samples may arrive faster, at ``input_rate_hz`` =
``D`` x ``rate_hz`` (an integer ``D``, e.g. a 1 kHz robot and a 100 Hz model: ``D`` = 10); any other
input rate is refused at construction with one line. Every accepted sample passes the causal
anti-alias low-pass (:class:`psmforce.estimators.data.rates.AntiAlias`); the network steps on the
first accepted sample after a (re)start and then on every ``D``-th, on the filtered sample. Every
sample is answered: force = the latest network residual + the physics base (prior-compensated HEX10,
insertion force) of the current filtered sample. Lag of an answer at ``D`` > 1: the anti-alias
filter's group delay (:meth:`StreamingEstimator.lag_s`, 5.6 ms for a 100 Hz model) for the base,
plus up to ``D - 1`` input periods for the residual (9 ms at 1 kHz / 100 Hz); ``D`` = 1 adds none.
``max_gap_samples``, the gap check and the post-filter count input samples; ``window`` and
``WARMING_UP`` count network steps.

The network after the answer (``network_after_answer=True``, at ``D`` > 1). A node's answer need
not wait for the network: the sample on which the network is due is answered with the residual
of the step before, and its own step runs afterwards, in the ``D - 1`` input periods before the
residual is next needed (:meth:`StreamingEstimator.advance`, which a node calls once its answer
is written; :meth:`StreamingEstimator.step` runs a step still owed before it reads its sample,
so the estimates never depend on whether or when ``advance`` is called). The residual's hold
becomes 1 to ``D`` input periods instead of 0 to ``D - 1``: one input period more of lag on the
residual (1 ms at 1 kHz), none on the base; the first sample after a (re)start still steps
before its answer, having no residual to hold. At ``D`` = 1 every answer needs its own step, so
the option changes nothing there.

Uncertainty: a network that predicts its variance (:mod:`psmforce.estimators.networks.uncertainty`,
the hybrid trained with ``{"uncertainty": true}``) gives each :class:`Estimate` a ``std_hex10``, the
standard deviation of the force estimate per axis in N, ``exp(logvar / 2) * target_scaler.std``: the
spread the network expects of the true force around its raw estimate, learned with the beta-NLL on
the training data. It belongs to the raw per-sample estimate: the post-filter smooths the force
only, not the std, and a HELD estimate keeps the std of the estimate it holds. It is given in the
HEX10 frame only (``force_base`` is a rotation of the force; the per-axis std of a rotated vector is
not a rotation of the per-axis std, which would need the covariance). During warm-up it is as little
trained as the force (training never scored a truncated history). ``std_hex10`` is None for a
network without variance.

Size: one class, because :meth:`StreamingEstimator.step` is the whole per-sample pipeline
(validation, clocks, decimation, network, filter, flags) and reads best in one place.

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

from psmforce.estimators.data.bounds import MAX_FORCE_N, physical_bounds
from psmforce.estimators.training.checkpoint import (load_checkpoint, physics_only_problem,
                                                     residual_gain)
from psmforce.estimators.data.hybrid_inputs import HexRotation, HybridInputs
from psmforce.estimators.runtime.postfilter import CausalFilter
from psmforce.estimators.data.rates import AntiAlias, RateError, check_rate, decimation_factor
from psmforce.estimators.runtime.steppers import StreamingError, make_backend, not_streamable
from psmforce.estimators.runtime.window_stream import as_streamable
from psmforce.estimators.networks.uncertainty import predicts_variance, std_newton
from psmforce.io.recording import JOINT_POSITIONS, OVERLOAD

CHAIN_POSITIONS = JOINT_POSITIONS
"""Joint positions the base-frame rotation reads (dVRK order, jaw last)."""


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


def _finite(values: np.ndarray) -> bool:
    """Every entry of a small array is finite. On Python floats: for the few values the
    estimator checks per sample this is several times faster than ``np.isfinite(v).all()``."""
    return all(map(math.isfinite, values.tolist()))


class Estimate(NamedTuple):
    force_hex10: np.ndarray
    """(3,) external force on the tool, N, HEX10 frame (a copy)."""
    flags: int
    """:class:`Flags` bits as an int (``Flags(flags)`` names them)."""
    force_base: np.ndarray | None = None
    """(3,) the same force in the PSM base frame, when asked for."""
    std_hex10: np.ndarray | None = None
    """(3,) standard deviation of the raw (unfiltered) force estimate per axis, N, HEX10 frame
    (a copy), for a network that predicts its variance; None otherwise (module docstring)."""


class StreamingEstimator:
    """Per-sample force estimator (the hybrid's pipeline, any model that streams); see the
    module docstring.

    ``model``: a streamable network (:mod:`psmforce.estimators.runtime.steppers`; the hybrid's is a
    :class:`psmforce.estimators.networks.causal.CausalTransformer`) or a trainable window network
    (streamed by :func:`psmforce.estimators.runtime.window_stream.as_streamable`); ``features``,
    ``input_scaler``, ``target_scaler``, ``base_columns``, ``prior``: as stored in the checkpoint
    (:meth:`from_checkpoint`). ``rate_hz``: the rate the network was trained at (Hz).
    ``physics_only_axes``: axes answered by the base alone
    (:func:`psmforce.estimators.training.checkpoint.residual_gain`); ``physics_prior``: their
    own prior, else None (``prior`` answers them: :mod:`psmforce.estimators.data.hybrid_inputs`,
    "A prior of the physics-only axes' own").
    ``input_rate_hz``: the rate samples arrive at, a whole multiple of ``rate_hz`` (default:
    ``rate_hz``; module docstring, Rates). ``psm``: a ``psmforce.robot.PSM`` for base-frame output
    (``step(..., base_frame=True)``). ``network_after_answer``: at a decimation above 1, the
    network steps after the answer it is due for (module docstring; :meth:`advance`).
    """

    def __init__(self, model: torch.nn.Module, features: Sequence[str], input_scaler,
                 target_scaler, base_columns: Sequence[str] = (), prior=None, *,
                 rate_hz: float = 100.0, input_rate_hz: float | None = None,
                 max_gap_samples: int = 5, backend: str = "auto",
                 post_filter: str = "none", median_kernel: int = 11, lowpass_hz: float = 5.0,
                 lowpass_order: int = 2, extrapolation_z: float = 5.0,
                 input_range: tuple[Sequence[float], Sequence[float]] | None = None, psm=None,
                 network_after_answer: bool = False, physics_only_axes: Sequence[str] = (),
                 physics_prior=None):
        model = as_streamable(model, len(features))
        why = not_streamable(model)
        if why is not None:
            raise StreamingError(f"streaming needs a streamable model (psmforce.estimators.runtime.steppers): {why}")
        if model.n_features != len(features):
            raise StreamingError(f"the model takes {model.n_features} features, "
                                 f"{len(features)} given")
        if len(base_columns) not in (0, 3):
            raise StreamingError(f"base needs 0 or 3 columns, got {list(base_columns)}")
        why = physics_only_problem(physics_only_axes, base_columns, predicts_variance(model))
        if why is not None:
            raise StreamingError(why)
        try:
            rate_hz = check_rate(rate_hz)
        except RateError as err:
            raise StreamingError(str(err)) from None
        if isinstance(max_gap_samples, bool) or not isinstance(max_gap_samples, int) \
                or max_gap_samples < 0:
            raise StreamingError(f"max_gap_samples must be an integer >= 0, got "
                                 f"{max_gap_samples!r}")
        self.model = model.eval()
        self.inputs = HybridInputs(features, base_columns, input_scaler, prior,
                                   extra_columns=CHAIN_POSITIONS if psm is not None else (),
                                   psm=psm, physics_prior=physics_prior,
                                   physics_axes=physics_only_axes)
        self.columns = self.inputs.raw_columns
        """The recorded signals :meth:`step` reads, in the order an array sample must follow."""
        self.rate_hz = rate_hz
        """The rate the network runs at (Hz): the rate it was trained at."""
        self.max_gap_samples = max_gap_samples
        self.network_after_answer = bool(network_after_answer)
        """Whether, at a decimation above 1, the network steps after its answer (module
        docstring)."""
        self.window = model.window
        self._filter_options = {"kind": post_filter, "median_kernel": median_kernel,
                                "lowpass_hz": lowpass_hz, "lowpass_order": lowpass_order}
        self._set_rates(rate_hz if input_rate_hz is None else input_rate_hz)
        self._net = make_backend(model, backend)
        self.backend_name = self._net.backend
        # the residual's un-scaling, zeroed on the physics-only axes: those answer the base alone
        gain = residual_gain(physics_only_axes)
        self._y_mean = np.asarray(target_scaler.mean, np.float64) * gain
        self._y_std = np.asarray(target_scaler.std, np.float64) * gain
        self.physics_only_axes = tuple(physics_only_axes)
        """Axes answered by the base alone (the checkpoint's ``physics_only_axes``)."""
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
        # as Python floats: _read compares a sample's values with them one by one
        self._raw_lo = [float(bounds.get(c, (-finite, finite))[0]) for c in self.columns]
        self._raw_hi = [float(bounds.get(c, (-finite, finite))[1]) for c in self.columns]
        if psm is not None:
            self._hex_rotation = HexRotation(psm)
            self._q_index = np.array([self.columns.index(c) for c in CHAIN_POSITIONS])
        self._raw = np.zeros(len(self.columns))
        self._force = np.zeros(3)
        self._residual = np.zeros(3)
        self._held = np.full(3, np.nan)
        self._variance = predicts_variance(model)
        self._std = np.zeros(3)
        self._held_std = np.full(3, np.nan)
        self._outside = np.zeros(n_feat, bool)
        self._owed_x = np.zeros(n_feat, np.float32)  # the inputs of a step owed (advance)
        self.reset()

    @classmethod
    def from_checkpoint(cls, path: str | Path, **options) -> "StreamingEstimator":
        """An estimator for a checkpoint written by :mod:`psmforce.estimators.training.train` of a
        model that streams (its recipe's ``streams``), its network
        run at the checkpoint's ``sample_rate_hz`` (``options``: the keyword arguments of the
        constructor; ``input_rate_hz`` for a faster stream; a ``rate_hz`` other than the
        checkpoint's is refused)."""
        ckpt = load_checkpoint(path)
        if not ckpt.recipe.streams:
            raise StreamingError(f"{path}: holds a '{ckpt.model_name}' model, which does not "
                                 f"stream (psmforce.estimators.networks.recipes: streams=False)")
        rate = options.pop("rate_hz", ckpt.sample_rate_hz)
        if rate != ckpt.sample_rate_hz:
            raise StreamingError(f"{path}: the model was trained at {ckpt.sample_rate_hz:g} Hz "
                                 f"and runs at that rate, not {rate!r}; give the stream's rate "
                                 f"as input_rate_hz")
        return cls(ckpt.model, ckpt.features, ckpt.input_scaler, ckpt.target_scaler,
                   ckpt.base_columns, ckpt.prior(), rate_hz=ckpt.sample_rate_hz,
                   physics_only_axes=ckpt.physics_only_axes,
                   physics_prior=ckpt.physics_prior(), **options)

    def _set_rates(self, input_rate_hz: float) -> None:
        try:
            input_rate_hz = check_rate(input_rate_hz, "input_rate_hz")
            decimation = decimation_factor(input_rate_hz, self.rate_hz)
        except RateError as err:
            raise StreamingError(str(err)) from None
        self.input_rate_hz = input_rate_hz
        """The rate samples arrive and are answered at (Hz)."""
        self.decimation = decimation
        """Input samples per network step."""
        self.anti_alias = AntiAlias(len(self.columns), decimation, self.rate_hz)
        self.filter = CausalFilter(rate_hz=input_rate_hz, **self._filter_options)
        self._memory = self.window * decimation + self.filter.memory_samples() - 1

    def set_input_rate(self, input_rate_hz: float) -> None:
        """Answer samples arriving at ``input_rate_hz`` from now on (a whole multiple of
        :attr:`rate_hz`, else :class:`StreamingError`): the decimation, the anti-alias filter
        and the post-filter are rebuilt and the stream starts over (:meth:`reset`); the
        network's backend, the slow part to build, is kept. For a node that builds its
        estimator before its first messages tell the rate (``psmforce serve``)."""
        self._set_rates(input_rate_hz)
        self.reset()

    def lag_s(self) -> float:
        """Lag (s) the decimation adds to an answer: the anti-alias filter's group delay at
        0 Hz, plus the mean hold of the network's residual, ``(D - 1) / 2`` input periods
        (at most ``D - 1``), one period more with ``network_after_answer``; 0 when the input
        rate is the model's. The post-filter's own lag
        is :meth:`psmforce.estimators.runtime.postfilter.CausalFilter.lag_samples`."""
        return self.anti_alias.lag_s() + ((self.decimation - 1) / 2 + self._deferring()) \
            / self.input_rate_hz

    def _deferring(self) -> bool:
        return self.network_after_answer and self.decimation > 1

    def advance(self) -> None:
        """Run the network step the last answer deferred (``network_after_answer``; module
        docstring); nothing when none is owed. A node calls it once the answer is written, so
        the step runs in the time before the next sample; :meth:`step` runs it otherwise."""
        if self._owed:
            self._owed = False
            self._network_step(self._owed_x)

    def _network_step(self, x: np.ndarray) -> None:
        self._seen += 1  # steps the residual has seen: WARMING_UP until the window's worth
        y = self._net.step(x)
        np.multiply(y[:3], self._y_std, out=self._residual)
        np.add(self._residual, self._y_mean, out=self._residual)
        if self._variance:
            std_newton(y[3:], self._y_std, out=self._std)

    def reset(self) -> None:
        """Forget all history (network cache, filter, timestamps): the next sample starts over."""
        self._restart()
        self._last_time: float | None = None
        self._behind = 0
        self._held[:] = np.nan
        self._held_std[:] = np.nan

    def _restart(self) -> None:
        self._net.reset()
        self.filter.reset()
        self.anti_alias.reset()
        self._phase = 0  # input samples since the last network step, modulo the decimation
        self._owed = False  # a network step deferred past its answer (advance)
        self._fresh = True  # no residual yet: the first step is never deferred
        self._seen = 0
        self._tainted = 0  # outputs left that remember an extrapolating input

    def _held_estimate(self, flags: int, base_frame: bool) -> Estimate:
        flags |= Flags.HELD
        if self._seen < self.window:
            flags |= Flags.WARMING_UP
        base = np.full(3, np.nan) if base_frame else None
        if base_frame and not np.isnan(self._held).any():
            base = self._rotation() @ self._held
        return Estimate(self._held.copy(), int(flags), base,
                        self._held_std.copy() if self._variance else None)

    def _rotation(self) -> np.ndarray:
        return self._hex_rotation(self._raw[self._q_index])

    def base_rotation(self) -> np.ndarray:
        """R_base_hex10 (3x3) of the last sample stepped: the rotation its ``force_base`` used
        (``force_base = R @ force_hex10``). Needs the PSM model, as ``base_frame`` does."""
        if not hasattr(self, "_hex_rotation"):
            raise StreamingError("the base rotation needs the PSM model: construct the "
                                 "estimator with psm=psmforce.robot.PSM()")
        return self._rotation().copy()

    def _read(self, sample, time, overload) -> tuple[float, bool] | None:
        """Sample -> :attr:`_raw`, (time s, overload); None for a sample that cannot be used
        (malformed, non-finite, beyond its physical bounds)."""
        try:
            if isinstance(sample, np.ndarray):
                # real numbers only: numpy would cast complex (dropping the imaginary part),
                # text and bools into the float buffer without a word
                if sample.shape != self._raw.shape or sample.dtype.kind not in "iuf":
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
        # one comparison per bound also refuses NaN (every comparison with NaN is false); on
        # Python floats, faster than numpy's comparisons and reductions for one sample
        values = self._raw.tolist()
        if not (all(map(operator.le, self._raw_lo, values))
                and all(map(operator.le, values, self._raw_hi))) or not math.isfinite(time):
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
                                 "with psm=psmforce.robot.PSM()")
        self.advance()  # a step the last answer deferred comes before this sample
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
            elif not math.isfinite(gap := (time - last) * self.input_rate_hz) \
                    or round(gap) - 1 > self.max_gap_samples:  # a 1e307 s gap: inf samples
                flags |= Flags.GAP
                self._restart()

        inputs = self.inputs
        # at D > 1 the anti-alias filter (restarted with the network) sees every accepted sample
        inputs.sample(self._raw if self.decimation == 1 else self.anti_alias.step(self._raw))
        if not (_finite(inputs.x) and _finite(inputs.base)):
            return self._held_estimate(flags | Flags.INVALID_INPUT, base_frame)
        self._last_time = time
        self._behind = 0
        tick = self._phase == 0
        self._phase = (self._phase + 1) % self.decimation
        extrapolating = False
        residual, std = self._residual, self._std
        if tick:
            np.less(inputs.x, self._lo, out=self._outside)
            extrapolating = self._outside.any()
            if not extrapolating:
                np.greater(inputs.x, self._hi, out=self._outside)
                extrapolating = self._outside.any()
            if self._fresh or not self._deferring():
                self._network_step(inputs.x)
            else:  # answered with the step before's residual; this one's step runs after
                np.copyto(self._owed_x, inputs.x)
                self._owed = True
            self._fresh = False
        force = self._force
        if len(inputs.base):
            np.add(residual, inputs.base, out=force)
        else:
            force[:] = residual
        if not (_finite(force) and _finite(std)):
            self._restart()
            return self._held_estimate(flags | Flags.RESET, base_frame)
        filtered = self.filter.step(force)
        filtered_values = filtered.tolist()
        if not all(map(math.isfinite, filtered_values)):
            self._restart()
            return self._held_estimate(flags | Flags.RESET, base_frame)
        if extrapolating:
            self._tainted = self._memory
        if self._tainted > 0:
            flags |= Flags.EXTRAPOLATION
            self._tainted -= 1
        if self._seen < self.window:
            flags |= Flags.WARMING_UP
        if max(map(abs, filtered_values)) > MAX_FORCE_N:
            flags |= Flags.IMPLAUSIBLE
        self._held[:] = filtered
        self._held_std[:] = std
        base = self._rotation() @ filtered if base_frame else None
        return Estimate(filtered.copy(), int(flags), base, std.copy() if self._variance else None)

    def predict_recording(self, frame: pd.DataFrame, *, with_std: bool = False
                          ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Offline batch path: (N, 3) force estimates (N, HEX10 frame) for a whole recording
        at the input rate, as if streamed from its first sample (same weights, decimation and
        post-filter), without flags.
        The recording must be valid (:func:`psmforce.io.recording.read_recording` checks it).
        ``with_std``: (estimates, (N, 3) std per axis in N, unfiltered) for a network that
        predicts its variance; refused for one that does not."""
        if with_std and not self._variance:
            raise StreamingError("this network predicts no variance, so it has no std")
        if self.decimation > 1:
            frame = frame.copy()
            columns = list(self.columns)
            frame[columns] = self.anti_alias.offline(frame[columns].to_numpy(np.float64))
        x, base = self.inputs.frame(frame)
        y = self.model.predict_sequence(x[::self.decimation]).astype(np.float64)
        y = np.repeat(y, self.decimation, axis=0)[:len(x)]  # each answer: the latest step
        if self._deferring():  # each answer after the first: the step before its sample's
            y = np.concatenate([y[:1], y[:-1]])
        force = y[:, :3] * self._y_std + self._y_mean
        if base.shape[1]:
            force = force + base
        force = CausalFilter(self.filter.kind, rate_hz=self.input_rate_hz,
                             median_kernel=self.filter.median_kernel,
                             lowpass_hz=self.filter.lowpass_hz,
                             lowpass_order=self.filter.lowpass_order).offline(force)
        return (force, std_newton(y[:, 3:], self._y_std)) if with_std else force
