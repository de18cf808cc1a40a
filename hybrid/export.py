"""Export a trained hybrid estimator for a C++ / ROS 2 node: ONNX step graph + JSON.

``export(checkpoint, out_dir)`` writes (atomically, temporary file then rename):

``hybrid_step.onnx``
    one incremental step of :class:`hybrid.causal.CausalTransformer`, opset 17, float32:
    inputs ``x`` (1, F) scaled features, ``keys`` / ``values`` (n_layers, 1, W, d_model)
    caches (oldest sample first; zeros at start), ``n_valid`` (1,) int64 = min(samples since
    start including this one, W); outputs ``y`` (1, 3) scaled residual, ``keys_out`` /
    ``values_out`` (feed back as the next step's caches).
``hybrid.json``
    everything else the pipeline needs, in order (see its ``pipeline`` entry): the recorded
    ``raw_columns``, ``features`` (network input order), ``base_columns``, ``input_scaler`` and
    ``target_scaler`` (mean, std per column), the ``prior`` (its own JSON, from its ``save``),
    the graph's tensor names and shapes, the receptive field ``window`` (warm-up, samples),
    software versions and the checkpoint's provenance.

Per sample a node computes ``comp = HEX10 - prior(sample)`` (when features use ``comp_*``),
``x = (features - mean_in) / std_in``, runs the graph, and returns
``y * std_out + mean_out + base`` (N, HEX10 frame). :func:`run_export` does exactly that with
ONNX Runtime from the written files; tests/test_export.py checks it against the Python
:class:`hybrid.streaming.StreamingEstimator`.
"""

from __future__ import annotations

import io
import json
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from hybrid.causal import CausalTransformer
from hybrid.data import Scaler
from hybrid.inputs import HybridInputs
from psm_model.files import write_bytes_atomic

FORMAT = "psmforce-hybrid-export"
FORMAT_VERSION = 1
ONNX_NAME = "hybrid_step.onnx"
JSON_NAME = "hybrid.json"
OPSET = 17


class ExportError(ValueError):
    """A checkpoint that cannot be exported, or an export folder that cannot be read back."""


class _StepGraph(torch.nn.Module):
    def __init__(self, model: CausalTransformer):
        super().__init__()
        self.model = model

    def forward(self, x, keys, values, n_valid):
        return self.model.step(x, keys, values, n_valid)


def step_onnx_bytes(model: CausalTransformer) -> bytes:
    """The ONNX step graph of ``model`` (see the module docstring for its signature)."""
    model = model.eval()
    keys, values, _ = model.init_cache(1)
    example = (torch.zeros(1, model.n_features), keys, values, torch.ones(1, dtype=torch.int64))
    buffer = io.BytesIO()
    # the legacy (TorchScript) exporter: the newer one needs onnxscript, not a dependency here
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.onnx.export(_StepGraph(model), example, buffer, dynamo=False, opset_version=OPSET,
                          input_names=["x", "keys", "values", "n_valid"],
                          output_names=["y", "keys_out", "values_out"])
    return buffer.getvalue()


class OnnxStepper:
    """Batch-1 step runner on ONNX Runtime (one intra-op thread), same interface as
    :class:`hybrid.causal.NumpyStepper`: ``reset()``, ``step(x (F,)) -> (3,)``.

    Inputs and outputs are bound once to preallocated arrays (I/O binding); the caches
    alternate between two buffer pairs, each step reading one and writing the other, so a step
    allocates no arrays in Python and copies no cache."""

    def __init__(self, onnx_model: bytes | str | Path, n_layers: int, attention_window: int,
                 d_model: int):
        import onnxruntime as ort
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        source = str(onnx_model) if isinstance(onnx_model, Path) else onnx_model
        self._session = ort.InferenceSession(source, options, providers=["CPUExecutionProvider"])
        self._span = attention_window
        shape = (n_layers, 1, attention_window, d_model)
        n_features = self._session.get_inputs()[0].shape[1]
        self._x = np.zeros((1, n_features), np.float32)
        self._n_valid = np.zeros(1, np.int64)
        self._y = np.zeros((1, 3), np.float32)
        self._caches = [(np.zeros(shape, np.float32), np.zeros(shape, np.float32))
                        for _ in range(2)]
        self._bindings = []
        for phase in range(2):
            binding = self._session.io_binding()
            for name, arr in (("x", self._x), ("n_valid", self._n_valid),
                              ("keys", self._caches[phase][0]),
                              ("values", self._caches[phase][1])):
                binding.bind_input(name, "cpu", 0, arr.dtype, arr.shape, arr.ctypes.data)
            for name, arr in (("y", self._y), ("keys_out", self._caches[1 - phase][0]),
                              ("values_out", self._caches[1 - phase][1])):
                binding.bind_output(name, "cpu", 0, arr.dtype, arr.shape, arr.ctypes.data)
            self._bindings.append(binding)
        self.reset()

    @classmethod
    def from_model(cls, model: CausalTransformer) -> "OnnxStepper":
        return cls(step_onnx_bytes(model), model.n_layers, model.attention_window, model.d_model)

    def reset(self) -> None:
        for keys, values in self._caches:
            keys.fill(0.0)
            values.fill(0.0)
        self._n_valid[0] = 0
        self._phase = 0

    def step(self, x: np.ndarray) -> np.ndarray:
        self._x[0] = x
        self._n_valid[0] = min(self._n_valid[0] + 1, self._span)
        self._session.run_with_iobinding(self._bindings[self._phase])
        self._phase = 1 - self._phase
        return self._y[0]


def export(checkpoint: str | Path, out_dir: str | Path) -> dict:
    """Write ``hybrid_step.onnx`` and ``hybrid.json`` for a hybrid checkpoint into ``out_dir``;
    check the ONNX graph against the eager step on random inputs. Returns a summary (paths,
    sizes, that check's maximum difference)."""
    from hybrid.checkpoint import load_checkpoint
    ckpt = load_checkpoint(checkpoint)
    if not ckpt.recipe.streams:
        raise ExportError(f"{checkpoint}: holds a '{ckpt.model_name}' model, which does not "
                          f"stream (hybrid.recipes: streams=False), so has no step graph")
    model = ckpt.model.eval()
    inputs = HybridInputs(ckpt.features, ckpt.base_columns, ckpt.input_scaler, ckpt.prior())
    onnx_bytes = step_onnx_bytes(model)
    check = _check_graph(model, onnx_bytes)
    shape = [model.n_layers, 1, model.attention_window, model.d_model]
    spec = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "onnx": ONNX_NAME, "opset": OPSET,
        **ckpt.metadata(), "window": model.window,
        "attention_window": model.attention_window, "n_layers": model.n_layers,
        "d_model": model.d_model,
        "raw_columns": list(inputs.raw_columns),
        "prior": json.loads(ckpt.prior_json) if ckpt.prior_json else None,
        "graph": {"inputs": {"x": [1, len(ckpt.features)], "keys": shape, "values": shape,
                             "n_valid": [1]},
                  "outputs": {"y": [1, 3], "keys_out": shape, "values_out": shape}},
        "pipeline": [
            "comp_{fx..tz} = HEX10 {fx..tz} - prior(sample)  (only if features use comp_*; the "
            "prior's model and inputs: its JSON and psm_model/identification/prior.py; its "
            "gravity term needs R_base_hex10(q) from the PSM kinematics)",
            "insertion_fz = prior.insertion(d, insertion_velocity) - insertion_effort  (only if "
            "features or base use it; d = third column of R_base_hex10(q); the model: "
            "psm_model/identification/insertion.py)",
            "x = (features - input_scaler.mean) / input_scaler.std  (float32, 'features' order)",
            "n_valid = min(samples since start including this one, attention_window)",
            "y, keys, values = graph(x, keys, values, n_valid)  (caches start at zeros)",
            "force_hex10_N = y * target_scaler.std + target_scaler.mean + base_columns  (per axis; "
            "an empty base entry adds nothing on that axis)",
            "warming up while samples since start < window"],
        "units": "force in N, external force on the tool, HEX10 frame",
    }
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(out / ONNX_NAME, onnx_bytes)
    write_bytes_atomic(out / JSON_NAME, (json.dumps(spec, indent=2) + "\n").encode())
    return {"onnx": str(out / ONNX_NAME), "json": str(out / JSON_NAME),
            "onnx_bytes": len(onnx_bytes), "onnx_vs_torch_max_abs_diff": check}


def _check_graph(model: CausalTransformer, onnx_bytes: bytes, steps: int = 64) -> float:
    """Max |ONNX - eager| over ``steps`` random scaled inputs (more than W, so the cache wraps)."""
    from hybrid.streaming import TorchStepper
    rng = np.random.default_rng(0)
    onnx_step = OnnxStepper(onnx_bytes, model.n_layers, model.attention_window, model.d_model)
    eager = TorchStepper(model)
    worst = 0.0
    for x in rng.standard_normal((max(steps, model.attention_window + 8),
                                  model.n_features)).astype(np.float32):
        worst = max(worst, float(np.abs(onnx_step.step(x) - eager.step(x)).max()))
    return worst


def run_export(out_dir: str | Path, frame: pd.DataFrame) -> np.ndarray:
    """(N, 3) forces for a recording, computed only from the exported files with ONNX Runtime,
    sample by sample as a C++ node would (the prior through its JSON)."""
    out = Path(out_dir)
    try:
        spec = json.loads((out / JSON_NAME).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ExportError(f"{out}: no readable {JSON_NAME} ({err})") from None
    if spec.get("format") != FORMAT or spec.get("format_version") != FORMAT_VERSION:
        raise ExportError(f"{out / JSON_NAME}: not a {FORMAT} v{FORMAT_VERSION} file")
    prior = None
    if spec["prior"] is not None:
        from hybrid.inputs import prior_from_json
        prior = prior_from_json(json.dumps(spec["prior"]))
    inputs = HybridInputs(spec["features"], spec["base_columns"],
                          Scaler.from_dict(spec["input_scaler"]), prior)
    target = Scaler.from_dict(spec["target_scaler"])
    stepper = OnnxStepper(out / spec["onnx"], spec["n_layers"], spec["attention_window"],
                          spec["d_model"])
    raw = frame[spec["raw_columns"]].to_numpy(np.float64)
    forces = np.empty((len(raw), 3))
    for i, row in enumerate(raw):
        inputs.sample(row)
        forces[i] = stepper.step(inputs.x) * target.std + target.mean
        if len(inputs.base):
            forces[i] += inputs.base
    return forces
