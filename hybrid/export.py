"""Export a trained streamable estimator for a C++ / ROS 2 node: ONNX step graph + JSON.

``export(checkpoint, out_dir)`` writes (atomically, temporary file then rename), for any model
that follows the step protocol of :mod:`hybrid.steppers` (the hybrid's causal transformer):

``hybrid_step.onnx``
    one step of the network (:func:`hybrid.steppers.step_onnx_bytes`), opset 17: inputs ``x``
    (1, F) float32 scaled features and the state tensors, outputs ``y`` (1, 3) float32 scaled
    residual, or (1, 6) for a network that predicts its variance (then columns 3..5 are the
    log-variance of the scaled residual, :mod:`hybrid.uncertainty`), and one ``<name>_out`` per
    state tensor, fed back as the next step's ``<name>``.
    The state starts at zeros and the graph advances it entirely (for the causal transformer:
    ``keys`` / ``values`` caches and the ``n_valid`` sample counter).
``hybrid.json``
    everything else the pipeline needs, in order (see its ``pipeline`` entry): the recorded
    ``raw_columns``, ``features`` (network input order), ``base_columns``, ``input_scaler`` and
    ``target_scaler`` (mean, std per column), the ``prior`` (its own JSON, from its ``save``),
    the graph's ``x``, ``y`` and ``state`` tensors (name, shape, dtype), the receptive field
    ``window`` (warm-up, samples), ``uncertainty`` (null, or what ``y``'s log-variance columns
    are and how they become a std in N), software versions and the checkpoint's provenance.

Per sample a node computes ``comp = HEX10 - prior(sample)`` (when features use ``comp_*``),
``x = (features - mean_in) / std_in``, runs the graph, and returns
``y[0:3] * std_out + mean_out + base`` (N, HEX10 frame), and with uncertainty the std
``exp(y[3:6] / 2) * std_out`` (N). :func:`run_export` does exactly that with
ONNX Runtime from the written files; tests/test_export.py checks it against the Python
:class:`hybrid.streaming.StreamingEstimator`.

Format version 2 (version 1 was the causal transformer's graph only, whose caller advanced
``n_valid`` before each step and fed no counter back). The ``uncertainty`` entry came within
version 2: it is null for every network without variance, whose files are otherwise unchanged,
and ``graph.y`` has always given ``y``'s width.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from hybrid.checkpoint import load_checkpoint
from hybrid.data import Scaler
from hybrid.inputs import HybridInputs, prior_from_json
from hybrid.steppers import (OPSET, OnnxStepper, TorchStepper, not_streamable, state_spec,
                             step_onnx_bytes)
from hybrid.uncertainty import (LOGVAR_MAX, LOGVAR_MIN, output_width, predicts_variance,
                                std_newton)
from psm_model.files import write_bytes_atomic

FORMAT = "psmforce-hybrid-export"
FORMAT_VERSION = 2
ONNX_NAME = "hybrid_step.onnx"
JSON_NAME = "hybrid.json"
_STD_FORMULA = "exp(0.5 * y[3:6]) * target_scaler.std"
"""The std in N of each axis from the graph's log-variance columns (the JSON states it)."""


class ExportError(ValueError):
    """A checkpoint that cannot be exported, or an export folder that cannot be read back."""


def export(checkpoint: str | Path, out_dir: str | Path) -> dict:
    """Write ``hybrid_step.onnx`` and ``hybrid.json`` for a hybrid checkpoint into ``out_dir``;
    check the ONNX graph against the eager step on random inputs. Returns a summary (paths,
    sizes, that check's maximum difference)."""
    ckpt = load_checkpoint(checkpoint)
    if not ckpt.recipe.streams:
        raise ExportError(f"{checkpoint}: holds a '{ckpt.model_name}' model, which does not "
                          f"stream (hybrid.recipes: streams=False), so has no step graph")
    why = not_streamable(ckpt.model)  # a recipe that claims to stream but cannot
    if why is not None:
        raise ExportError(f"{checkpoint}: the '{ckpt.model_name}' model does not follow the "
                          f"step protocol (hybrid.steppers): {why}")
    model = ckpt.model.eval()
    inputs = HybridInputs(ckpt.features, ckpt.base_columns, ckpt.input_scaler, ckpt.prior())
    onnx_bytes = step_onnx_bytes(model)
    state = state_spec(model)
    check = _check_graph(model, onnx_bytes, state)
    spec = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "onnx": ONNX_NAME, "opset": OPSET,
        **ckpt.metadata(), "window": model.window,
        "raw_columns": list(inputs.raw_columns),
        "prior": json.loads(ckpt.prior_json) if ckpt.prior_json else None,
        "graph": {"x": {"shape": [1, model.n_features], "dtype": "float32"},
                  "y": {"shape": [1, output_width(model)], "dtype": "float32"}, "state": state},
        "uncertainty": _uncertainty_spec(model),
        "pipeline": [
            "comp_{fx..tz} = HEX10 {fx..tz} - prior(sample)  (only if features use comp_*; the "
            "prior's model and inputs: its JSON and psm_model/identification/prior.py; its "
            "gravity term needs R_base_hex10(q) from the PSM kinematics)",
            "insertion_fz = prior.insertion(d, insertion_velocity) - insertion_effort  (only if "
            "features or base use it; d = third column of R_base_hex10(q); the model: "
            "psm_model/identification/insertion.py)",
            "x = (features - input_scaler.mean) / input_scaler.std  (float32, 'features' order)",
            "state = zeros for each graph.state entry (name, shape, dtype), at start only",
            "y, <name>_out per state entry = graph(x, state)  (then state <name> = <name>_out)",
            "force_hex10_N = y[0:3] * target_scaler.std + target_scaler.mean + base_columns  (per "
            "axis; an empty base entry adds nothing on that axis)",
            *([f"std_hex10_N = {_STD_FORMULA}  (only if uncertainty is not null)"]
              if predicts_variance(model) else []),
            "warming up while samples since start < window"],
        "units": "force in N, external force on the tool, HEX10 frame",
    }
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(out / ONNX_NAME, onnx_bytes)
    write_bytes_atomic(out / JSON_NAME, (json.dumps(spec, indent=2) + "\n").encode())
    return {"onnx": str(out / ONNX_NAME), "json": str(out / JSON_NAME),
            "onnx_bytes": len(onnx_bytes), "onnx_vs_torch_max_abs_diff": check}


def _uncertainty_spec(model: torch.nn.Module) -> dict | None:
    """What the JSON says about ``y``'s log-variance columns (None without them)."""
    if not predicts_variance(model):
        return None
    return {"logvar_columns": [3, 4, 5],
            "meaning": "log-variance of the standard-scaled residual per axis (x, y, z), "
                       f"soft-clamped inside the graph to ({LOGVAR_MIN}, {LOGVAR_MAX})",
            "std_hex10_N": _STD_FORMULA,
            "note": "std of the raw per-sample force estimate, HEX10 frame; a post-filter on "
                    "the force does not apply to it"}


def _check_graph(model: torch.nn.Module, onnx_bytes: bytes, state: list[dict],
                 steps: int = 64) -> float:
    """Max |ONNX - eager| over ``steps`` random scaled inputs, or more: past the receptive
    field, so every cache has wrapped and every counter has saturated."""
    rng = np.random.default_rng(0)
    onnx_step = OnnxStepper(onnx_bytes, state)
    eager = TorchStepper(model)
    worst = 0.0
    for x in rng.standard_normal((max(steps, model.window + 8),
                                  model.n_features)).astype(np.float32):
        worst = max(worst, float(np.abs(onnx_step.step(x) - eager.step(x)).max()))
    return worst


def run_export(out_dir: str | Path, frame: pd.DataFrame, *, with_std: bool = False
               ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """(N, 3) forces for a recording, computed only from the exported files with ONNX Runtime,
    sample by sample as a C++ node would (the prior through its JSON). ``with_std``: (forces,
    (N, 3) std in N) from the graph's log-variance, for an export that has one."""
    out = Path(out_dir)
    try:
        spec = json.loads((out / JSON_NAME).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise ExportError(f"{out}: no readable {JSON_NAME} ({err})") from None
    if spec.get("format") != FORMAT or spec.get("format_version") != FORMAT_VERSION:
        raise ExportError(f"{out / JSON_NAME}: not a {FORMAT} v{FORMAT_VERSION} file")
    prior = None
    if spec["prior"] is not None:
        prior = prior_from_json(json.dumps(spec["prior"]))
    inputs = HybridInputs(spec["features"], spec["base_columns"],
                          Scaler.from_dict(spec["input_scaler"]), prior)
    if with_std and spec.get("uncertainty") is None:
        raise ExportError(f"{out / JSON_NAME}: the exported network predicts no variance")
    target = Scaler.from_dict(spec["target_scaler"])
    stepper = OnnxStepper(out / spec["onnx"], spec["graph"]["state"])
    raw = frame[spec["raw_columns"]].to_numpy(np.float64)
    y = np.empty((len(raw), spec["graph"]["y"]["shape"][1]), np.float32)  # as the graph gives it
    base = np.zeros((len(raw), 3))
    for i, row in enumerate(raw):
        inputs.sample(row)
        y[i] = stepper.step(inputs.x)
        if len(inputs.base):
            base[i] = inputs.base
    forces = y[:, :3] * target.std + target.mean + base
    return (forces, std_newton(y[:, 3:], target.std)) if with_std else forces
