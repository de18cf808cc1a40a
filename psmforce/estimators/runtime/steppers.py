"""Running a streamable network one sample at a time: the step protocol and its backends.

The step protocol (:class:`psmforce.estimators.networks.contract.StepModel`; a model the recipe
table builds that follows it is a :class:`psmforce.estimators.networks.contract.StreamableModel`). A
streamable model is a ``torch.nn.Module`` with

* ``kind = "chunk"``: causal, ``forward(x: (B, T, F)) -> (B, T, C)``, C = 3 channels (the scaled
  mean) or, where ``predicts_variance`` is true, 6 (then the log-variance of each axis,
  :mod:`psmforce.estimators.networks.uncertainty`; ``predicts_variance`` may be absent, meaning
  false);
* ``window``: its receptive field, samples (the streaming warm-up);
* ``n_features``: F;
* ``state_names``: one name per state tensor (the step graph's input names; its outputs are
  ``<name>_out``);
* ``stream_state(batch=1) -> tuple[torch.Tensor, ...]``: the state before the first sample,
  all zeros (caches, sample counters), so that an exported graph's user can build it from the
  names, shapes and dtypes alone;
* ``stream_step(x: (B, F), *state) -> (y: (B, C), *new_state)``: one sample, a pure tensor
  function that ONNX can export; any counter lives in the state and is advanced inside, so a
  caller only feeds the new state back;
* ``predict_sequence(x: np.ndarray (T, F)) -> (T, C)``: offline, the same function as stepping
  from ``stream_state()``.

:func:`not_streamable` checks it (:class:`psmforce.estimators.networks.causal.CausalTransformer`
follows it). The backends, each a batch-1 runner with ``reset()``, ``step(x (F,) float32) -> (C,)``
(an internal buffer: copy to keep) and ``backend`` (its name), agree within float32 rounding
(tests/estimators/test_streaming.py); their speed is in ``benchmarks/streaming.py``
(``results/benchmarks/streaming.json``). Every backend and the ONNX export run on weights with
subnormal floats flushed to zero (:func:`flush_subnormal`): a CPU computes with those in microcode,
and GPU trainings leave them behind (``benchmarks/subnormal_weights.py``):

* :class:`TorchStepper`: eager PyTorch on any streamable model, the reference;
* :class:`OnnxStepper`: ONNX Runtime on the step graph of :func:`step_onnx_bytes`, any
  streamable model, allocation-free; also what :mod:`psmforce.estimators.runtime.export` runs back;
* :class:`NumpyStepper`: :class:`psmforce.estimators.networks.causal.CausalTransformer` only,
  hand-vectorised numpy, allocation-free; needs nothing but numpy.

:func:`make_backend` picks one (``"auto"``: onnx when onnxruntime is installed, else numpy where the
model has a numpy path, else torch) and raises :class:`StreamingError`, the error of every streaming
request that cannot be served (:mod:`psmforce.estimators.runtime.streaming` raises it too).

Size: the three backends stay together because they answer one contract and are tested
against each other; splitting them would scatter the protocol's one description.
"""

from __future__ import annotations

import copy
import io
import itertools
import math
import warnings
from pathlib import Path
from typing import Sequence

import numpy as np
import torch

from psmforce.estimators.networks.causal import CausalTransformer
from psmforce.estimators.networks.contract import StepModel, is_chunk, members, missing
from psmforce.estimators.networks.uncertainty import LOGVAR_HALF, LOGVAR_MID

BACKENDS = ("numpy", "onnx", "torch")
OPSET = 17
PROTOCOL = members(StepModel)
"""The members a streamable model has (see the module docstring), those of
:class:`psmforce.estimators.networks.contract.StepModel`."""


class StreamingError(ValueError):
    """A streaming request that cannot be served; the message says why."""


def not_streamable(model) -> str | None:
    """Why ``model`` does not follow the step protocol, or None when it does."""
    name = type(model).__name__
    if not isinstance(model, torch.nn.Module):
        return f"{name} is not a torch module"
    lacks = missing(model, StepModel)
    if lacks:
        return f"{name} lacks {', '.join(lacks)}"
    if not is_chunk(model):
        return f"{name} is a '{model.kind}' model, not a causal 'chunk' model"
    state = model.stream_state(1)
    if len(state) != len(model.state_names):
        return (f"{name}.stream_state gives {len(state)} tensors for {len(model.state_names)} "
                f"state_names")
    if any(not isinstance(t, torch.Tensor) or t.any() for t in state):
        return f"{name}.stream_state is not a tuple of zero tensors"
    return None


def subnormal_count(model: torch.nn.Module) -> int:
    """How many float32 parameters and buffers of ``model`` are subnormal (nonzero, below
    ``finfo(float32).tiny`` = 1.2e-38 in magnitude)."""
    tiny = torch.finfo(torch.float32).tiny
    return sum(int(((t != 0) & (t.abs() < tiny)).sum())
               for t in itertools.chain(model.parameters(), model.buffers())
               if t.dtype == torch.float32)


def flush_subnormal(model: torch.nn.Module) -> tuple[torch.nn.Module, int]:
    """``model`` with its subnormal float32 weights set to zero, and how many there were: a copy
    when there are any (the caller's model is left as it is), else ``model`` itself. Each value
    flushed changes by less than 1.2e-38, below float32's resolution of any normal number a
    network adds it to, so outputs are unchanged to float32 rounding (tested); on x86 a step no
    longer runs through the slow microcode path."""
    count = subnormal_count(model)
    if not count:
        return model, 0
    model = copy.deepcopy(model)
    tiny = torch.finfo(torch.float32).tiny
    with torch.no_grad():
        for t in itertools.chain(model.parameters(), model.buffers()):
            if t.dtype == torch.float32:
                t.masked_fill_(t.abs() < tiny, 0.0)
    return model, count


def state_spec(model) -> list[dict]:
    """The state tensors of a streamable ``model`` at batch 1: ``name``, ``shape``, ``dtype``
    (numpy's name), in ``stream_step`` order; what :class:`OnnxStepper` and an export need."""
    return [{"name": name, "shape": list(t.shape), "dtype": t.detach().cpu().numpy().dtype.name}
            for name, t in zip(model.state_names, model.stream_state(1))]


class TorchStepper:
    """Eager PyTorch reference backend: ``model.stream_step`` with its state fed back."""

    backend = "torch"

    def __init__(self, model: torch.nn.Module):
        self.model = model.eval()
        self.reset()

    def reset(self) -> None:
        self._state = self.model.stream_state(1)

    def step(self, x: np.ndarray) -> np.ndarray:
        # a copy: a state may keep x itself, and callers reuse their input buffer
        with torch.inference_mode():
            y, *self._state = self.model.stream_step(torch.tensor(x)[None], *self._state)
        return y[0].numpy()


class _StepGraph(torch.nn.Module):
    """``stream_step`` as a module's ``forward``, which is what the ONNX exporter traces."""

    def __init__(self, model: torch.nn.Module):
        super().__init__()
        self.model = model

    def forward(self, x, *state):
        return self.model.stream_step(x, *state)


def step_onnx_bytes(model: torch.nn.Module, *, flush: bool = True) -> bytes:
    """The ONNX step graph of a streamable ``model``, opset :data:`OPSET`, batch 1: inputs ``x``
    (1, F) float32 and the state tensors under ``model.state_names``; outputs ``y`` (1, C) and
    ``<name>_out`` per state tensor (the next step's state); subnormal weights flushed
    (:func:`flush_subnormal`) unless ``flush=False``."""
    model = (flush_subnormal(model)[0] if flush else model).eval()
    names = list(model.state_names)
    example = (torch.zeros(1, model.n_features), *model.stream_state(1))
    buffer = io.BytesIO()
    # the legacy (TorchScript) exporter: the newer one needs onnxscript, not a dependency here.
    # The wrapper in eval mode: the exporter restores the wrapper's mode on the whole tree
    # afterwards, and a fresh module is in training mode (it left ``model`` with dropout on).
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        # the step graph is traced at batch 1 with the state's fixed shapes, so a branch on a
        # shape (a window network's length check, for one) is constant there by design
        warnings.simplefilter("ignore", torch.jit.TracerWarning)
        torch.onnx.export(_StepGraph(model).eval(), example, buffer, dynamo=False,
                          opset_version=OPSET, input_names=["x", *names],
                          output_names=["y", *(f"{n}_out" for n in names)])
    return buffer.getvalue()


class OnnxStepper:
    """Batch-1 step runner on ONNX Runtime (one intra-op thread) for a graph of
    :func:`step_onnx_bytes`; ``state``: its :func:`state_spec` (as an export's JSON holds it).

    Inputs and outputs are bound once to preallocated arrays (I/O binding); the state tensors
    alternate between two buffer sets, each step reading one and writing the other, so a step
    allocates no arrays in Python and copies no state."""

    backend = "onnx"

    def __init__(self, onnx_model: bytes | str | Path, state: Sequence[dict], *,
                 x_width: int | None = None, y_width: int | None = None):
        import onnxruntime as ort
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        source = str(onnx_model) if isinstance(onnx_model, Path) else onnx_model
        self._session = ort.InferenceSession(source, options, providers=["CPUExecutionProvider"])
        _check_signature(self._session, state, x_width, y_width)
        inputs = {i.name: i for i in self._session.get_inputs()}
        self._x = np.zeros((1, inputs["x"].shape[1]), np.float32)
        outputs = {o.name: o for o in self._session.get_outputs()}
        self._y = np.zeros(outputs["y"].shape, np.float32)  # (1, C): 3 or 6 channels
        self._states = [[np.zeros(s["shape"], s["dtype"]) for s in state] for _ in range(2)]
        self._bindings = []
        for phase in range(2):
            binding = self._session.io_binding()
            for name, arr in (("x", self._x), *zip((s["name"] for s in state),
                                                    self._states[phase])):
                binding.bind_input(name, "cpu", 0, arr.dtype, arr.shape, arr.ctypes.data)
            for name, arr in (("y", self._y), *zip((f"{s['name']}_out" for s in state),
                                                    self._states[1 - phase])):
                binding.bind_output(name, "cpu", 0, arr.dtype, arr.shape, arr.ctypes.data)
            self._bindings.append(binding)
        self.reset()

    def reset(self) -> None:
        for buffers in self._states:
            for arr in buffers:
                arr.fill(0)
        self._phase = 0

    def step(self, x: np.ndarray) -> np.ndarray:
        self._x[0] = x
        self._session.run_with_iobinding(self._bindings[self._phase])
        self._phase = 1 - self._phase
        return self._y[0]


_ONNX_TYPES = {"float32": "tensor(float)", "int64": "tensor(int64)"}


def _check_signature(session, state: Sequence[dict], x_width: int | None,
                     y_width: int | None) -> None:
    """Refuse (ValueError, one line) a graph whose inputs and outputs are not those the step
    protocol and ``state`` (with ``x_width`` features, ``y_width`` outputs, where given) say:
    the same names, shapes and dtypes, so a graph replaced under an export is never run."""
    want_in = {"x": ([1, x_width] if x_width else None, "tensor(float)")}
    want_out = {"y": ([1, y_width] if y_width else None, "tensor(float)")}
    for entry in state:
        kind = _ONNX_TYPES.get(entry["dtype"])
        want_in[entry["name"]] = (list(entry["shape"]), kind)
        want_out[f"{entry['name']}_out"] = (list(entry["shape"]), kind)
    for side, args, want in (("inputs", session.get_inputs(), want_in),
                             ("outputs", session.get_outputs(), want_out)):
        got = {a.name: (list(a.shape), a.type) for a in args}
        if set(got) != set(want):
            raise ValueError(f"the graph's {side} are {sorted(got)}, the export says "
                             f"{sorted(want)}")
        for name, (shape, kind) in want.items():
            if kind != got[name][1] or (shape is not None and shape != got[name][0]):
                raise ValueError(f"the graph's {side[:-1]} {name} is {got[name][1]} "
                                 f"{got[name][0]}, the export says {kind} {shape}")


class NumpyStepper:
    """Batch-1 incremental inference of a :class:`psmforce.estimators.networks.causal.CausalTransformer` in float32
    numpy.

    Weights are copied out of the module once; every intermediate lives in a buffer allocated
    here, written with ``out=``. Keys and values sit in a ring of length 2W where each token is
    written twice (slots ``p`` and ``p + W``), so the last W tokens are always the contiguous,
    oldest-first slice ``[p + 1, p + 1 + W)``: no shifting and no gather per step. The lag bias
    with the not-yet-filled slots masked is precomputed for every fill level. A model with
    ``predicts_variance`` gets its log-variance channels soft-clamped as
    :func:`psmforce.estimators.networks.uncertainty.soft_clamp_logvar` does, in place.
    """

    backend = "numpy"

    def __init__(self, model: CausalTransformer):
        f32 = np.float32

        def arr(t: torch.Tensor) -> np.ndarray:
            return np.ascontiguousarray(t.detach().cpu().numpy(), dtype=f32)

        d, w_len = model.d_model, model.attention_window
        blocks = list(model.blocks)
        self._d, self._span, self._eps = d, w_len, model.norm.eps
        n_heads, head_dim = blocks[0].n_heads, blocks[0].head_dim
        self._embed = (arr(model.embed.weight), arr(model.embed.bias))
        # head_mask[c, h] = 1 where feature c belongs to head h: turns per-head dot products into
        # one (W, d) @ (d, H) product and back.
        head_mask = np.repeat(np.eye(n_heads, dtype=f32), head_dim, axis=0)
        self._head_mask, self._head_mask_t = head_mask, np.ascontiguousarray(head_mask.T)
        scale = f32(1.0 / math.sqrt(head_dim))
        self._layers = []
        fill = np.arange(w_len)[None, :] < (w_len - np.arange(w_len + 1))[:, None]  # (W+1, W)
        for b in blocks:
            bias = arr(b.lag_bias).T  # (W, H)
            masked = np.where(fill[:, :, None], f32(-np.inf), bias[None]).astype(f32)
            self._layers.append({
                "ln1": (arr(b.norm_attn.weight), arr(b.norm_attn.bias)),
                "qkv": (arr(b.qkv.weight), arr(b.qkv.bias)),
                "out": (arr(b.out.weight), arr(b.out.bias)),
                "ln2": (arr(b.norm_ff.weight), arr(b.norm_ff.bias)),
                "ff_in": (arr(b.ff_in.weight), arr(b.ff_in.bias)),
                "ff_out": (arr(b.ff_out.weight), arr(b.ff_out.bias)),
                "bias": masked,  # (W+1, W, H): row c = c samples valid
                "keys": np.zeros((2 * w_len, d), f32), "values": np.zeros((2 * w_len, d), f32),
            })
        self._scale = scale
        self._norm = (arr(model.norm.weight), arr(model.norm.bias))
        dec = model.decoder
        self._dec = (arr(dec[0].weight), arr(dec[0].bias), arr(dec[2].weight), arr(dec[2].bias))
        d_ff = blocks[0].ff_in.out_features
        self._h = np.zeros(d, f32)
        self._a = np.zeros(d, f32)
        self._tmp = np.zeros(d, f32)
        self._qkv = np.zeros(3 * d, f32)
        self._qh = np.zeros((d, n_heads), f32)
        self._scores = np.zeros((w_len, n_heads), f32)
        self._colmax = np.zeros((1, n_heads), f32)
        self._colsum = np.zeros((1, n_heads), f32)
        self._mix = np.zeros((n_heads, d), f32)
        self._ff = np.zeros(d_ff, f32)
        self._dec_h = np.zeros(d, f32)
        self._y = np.zeros(dec[2].out_features, f32)
        # the log-variance channels (a view; empty without them), clamped in place
        self._logvar = self._y[3:]
        self.reset()

    def reset(self) -> None:
        """Forget the history (the next sample starts a new sequence)."""
        self._pos, self._count = 0, 0

    def _layer_norm(self, x: np.ndarray, params, out: np.ndarray) -> np.ndarray:
        np.subtract(x, x.mean(), out=out)
        np.multiply(out, out, out=self._tmp)
        denom = np.sqrt(self._tmp.mean() + self._eps)
        np.divide(out, denom, out=out)
        np.multiply(out, params[0], out=out)
        np.add(out, params[1], out=out)
        return out

    def step(self, x: np.ndarray) -> np.ndarray:
        """x (F,) scaled inputs -> (C,) scaled output. Returns an internal buffer: copy to keep."""
        d, span = self._d, self._span
        h, a = self._h, self._a
        np.matmul(self._embed[0], x, out=h)
        np.add(h, self._embed[1], out=h)
        self._count = min(self._count + 1, span)
        pos = self._pos
        for layer in self._layers:
            self._layer_norm(h, layer["ln1"], a)
            qkv = np.matmul(layer["qkv"][0], a, out=self._qkv)
            np.add(qkv, layer["qkv"][1], out=qkv)
            keys, values = layer["keys"], layer["values"]
            keys[pos] = qkv[d:2 * d]
            keys[pos + span] = qkv[d:2 * d]
            values[pos] = qkv[2 * d:]
            values[pos + span] = qkv[2 * d:]
            # block-diagonal query (d, H): column h holds head h's query, scaled
            np.multiply(self._head_mask, qkv[:d, None], out=self._qh)
            np.multiply(self._qh, self._scale, out=self._qh)
            scores = np.matmul(keys[pos + 1:pos + 1 + span], self._qh, out=self._scores)
            np.add(scores, layer["bias"][self._count], out=scores)
            np.max(scores, axis=0, keepdims=True, out=self._colmax)
            np.subtract(scores, self._colmax, out=scores)
            np.exp(scores, out=scores)
            np.sum(scores, axis=0, keepdims=True, out=self._colsum)
            np.divide(scores, self._colsum, out=scores)
            # (H, W) @ (W, d) mixes every head's weights with every feature; keep each head's own
            mix = np.matmul(scores.T, values[pos + 1:pos + 1 + span], out=self._mix)
            np.multiply(mix, self._head_mask_t, out=mix)
            np.sum(mix, axis=0, out=a)
            np.matmul(layer["out"][0], a, out=self._tmp)
            np.add(h, self._tmp, out=h)
            np.add(h, layer["out"][1], out=h)
            self._layer_norm(h, layer["ln2"], a)
            np.matmul(layer["ff_in"][0], a, out=self._ff)
            np.add(self._ff, layer["ff_in"][1], out=self._ff)
            np.maximum(self._ff, 0, out=self._ff)
            np.matmul(layer["ff_out"][0], self._ff, out=self._tmp)
            np.add(h, self._tmp, out=h)
            np.add(h, layer["ff_out"][1], out=h)
        self._pos = (pos + 1) % span
        self._layer_norm(h, self._norm, a)
        np.matmul(self._dec[0], a, out=self._dec_h)
        np.add(self._dec_h, self._dec[1], out=self._dec_h)
        np.maximum(self._dec_h, 0, out=self._dec_h)
        np.matmul(self._dec[2], self._dec_h, out=self._y)
        np.add(self._y, self._dec[3], out=self._y)
        if self._logvar.size:
            v, mid, half = self._logvar, np.float32(LOGVAR_MID), np.float32(LOGVAR_HALF)
            np.subtract(v, mid, out=v)
            np.divide(v, half, out=v)
            np.tanh(v, out=v)
            np.multiply(v, half, out=v)
            np.add(v, mid, out=v)
        return self._y


def _onnxruntime_installed() -> bool:
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        return False
    return True


def has_numpy_path(model) -> bool:
    """Whether :class:`NumpyStepper` runs ``model`` (it is written for the hybrid's network)."""
    return isinstance(model, CausalTransformer)


def make_backend(model: torch.nn.Module, backend: str = "auto", *, flush: bool = True):
    """A batch-1 step runner for a streamable ``model`` (see the module docstring), on its
    weights with subnormals flushed (``flush=False``: as saved, for measuring what they cost);
    raises :class:`StreamingError` for an unknown backend or one the model has no path for."""
    if backend not in ("auto", *BACKENDS):
        raise StreamingError(f"unknown backend {backend!r}; known: {['auto', *BACKENDS]}")
    if backend == "auto":
        backend = ("onnx" if _onnxruntime_installed() else "numpy" if has_numpy_path(model)
                   else "torch")
    if flush:
        model = flush_subnormal(model)[0]
    if backend == "numpy":
        if not has_numpy_path(model):
            raise StreamingError(f"backend 'numpy' runs psmforce.estimators.networks.causal.CausalTransformer only, "
                                 f"not {type(model).__name__}; use 'onnx' or 'torch'")
        return NumpyStepper(model)
    if backend == "torch":
        return TorchStepper(model)
    return OnnxStepper(step_onnx_bytes(model, flush=flush), state_spec(model))
