"""Export a trained streamable estimator for a C++ / ROS 2 node: ONNX step graph + JSON.

``export(checkpoint, out_dir)`` writes (atomically, temporary file then rename), for any model that
follows the step protocol of :mod:`psmforce.estimators.runtime.steppers` (the hybrid's causal
transformer), or is a trainable window network (the paper's transformer, the FCN), whose state is
its last ``window`` inputs (:mod:`psmforce.estimators.runtime.window_stream`):

``hybrid_step.onnx``
    one step of the network (:func:`psmforce.estimators.runtime.steppers.step_onnx_bytes`), opset
    17: inputs ``x`` (1, F) float32 scaled features and the state tensors, outputs ``y`` (1, 3)
    float32 scaled residual, or (1, 6) for a network that predicts its variance (then columns 3..5
    are the log-variance of the scaled residual, :mod:`psmforce.estimators.networks.uncertainty`),
    and one ``<name>_out`` per state tensor, fed back as the next step's ``<name>``. The state
    starts at zeros and the graph advances it entirely (for the causal transformer: ``keys`` /
    ``values`` caches and the ``n_valid`` sample counter; for a window network: ``window_inputs``).
``hybrid.json``
    everything else the pipeline needs, in order (see its ``pipeline`` entry): the recorded
    ``raw_columns``, ``features`` (network input order), ``base_columns``, ``input_scaler`` and
    ``target_scaler`` (mean, std per column), the ``prior`` (its own JSON, from its ``save``), the
    ``physics_prior`` (null, or the physics-only axes' own prior, the same JSON), the
    graph's ``x``, ``y`` and ``state`` tensors (name, shape, dtype), the receptive field ``window``
    (warm-up, samples), ``sample_rate_hz`` (the rate the model was trained at and must be stepped
    at, Hz; 100 for a checkpoint that does not record it, :mod:`psmforce.estimators.data.rates`),
    ``uncertainty`` (null, or what ``y``'s log-variance columns are and how they become a std in N),
    software versions and the checkpoint's provenance.

Per sample a node computes ``comp = HEX10 - prior(sample)`` (when features use ``comp_*``),
``x = (features - mean_in) / std_in``, runs the graph, and returns
``y[0:3] * std_out + mean_out + base`` (N, HEX10 frame; the base alone on the checkpoint's
``physics_only_axes``, computed with ``physics_prior`` where the JSON holds one), and with
uncertainty the std
``exp(y[3:6] / 2) * std_out`` (N). :func:`run_export` does exactly that with
ONNX Runtime from the written files; tests/estimators/test_export.py checks it against the Python
:class:`psmforce.estimators.runtime.streaming.StreamingEstimator`.

Format version 3: the JSON carries ``onnx_sha256`` (the graph file's SHA-256) and the integrity
envelope ``sha256`` over every entry (:mod:`psmforce.core.integrity`); the version must be an
``int``. Version 2 exports (no envelope) are refused with a message to export again: an export is
rewritten from its checkpoint in seconds. (Version 1 was the causal transformer's graph only, whose
caller advanced ``n_valid`` before each step and fed no counter back.)

:func:`run_export` trusts the folder no more than the stream trusts its samples: it refuses, in one
line naming the file, an export whose JSON or graph does not match its envelope, whose ``onnx``
entry names anything but a file inside the export folder (a path, ``..``, a link leading out), whose
scalers are not finite with std > 0 of the features' width, whose state tensors are not those the
graph takes; and a recording with no rows, lacking a raw column or holding one twice, with a column
that is not real numbers (text, bool, complex, which numpy would cast without a word), or with a
value that is NaN, infinite or beyond its physical bound
(:func:`psmforce.estimators.data.bounds.physical_bounds`, the stream's ``INVALID_INPUT``), naming
the column and row. An output that is not finite is refused too.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from psmforce.estimators.data.bounds import physical_bounds
from psmforce.estimators.training.checkpoint import (load_checkpoint, physics_only_problem,
                                                     residual_gain)
from psmforce.estimators.data.dataset import Scaler
from psmforce.io.recording import TIME
from psmforce.core.integrity import check_version, seal, sha256_bytes, verify
from psmforce.estimators.networks.recipes import MAX_STATE_FLOATS
from psmforce.estimators.data.hybrid_inputs import (HybridInputs, physics_base_problem,
                                                    prior_from_json)
from psmforce.estimators.runtime.steppers import (OPSET, OnnxStepper, StreamingError,
                                                  TorchStepper, not_streamable, state_spec,
                                                  step_onnx_bytes)
from psmforce.estimators.runtime.window_stream import as_streamable
from psmforce.estimators.networks.uncertainty import (LOGVAR_MAX, LOGVAR_MIN, output_width,
                                                      predicts_variance, std_newton)
from psmforce.core.files import (MAX_JSON_BYTES, locked_folder, read_input_text,
                                 write_bytes_atomic)

FORMAT = "psmforce-hybrid-export"
FORMAT_VERSION = 3
ONNX_NAME = "hybrid_step.onnx"
JSON_NAME = "hybrid.json"
_STD_FORMULA = "exp(0.5 * y[3:6]) * target_scaler.std"
"""The std in N of each axis from the graph's log-variance columns (the JSON states it)."""


class ExportError(ValueError):
    """A checkpoint that cannot be exported, or an export folder that cannot be read back."""


def export(checkpoint: str | Path, out_dir: str | Path) -> dict:
    """Write ``hybrid_step.onnx`` and ``hybrid.json`` for a checkpoint of a model that streams
    into ``out_dir`` (the names and the format are the hybrid's, whichever model it is);
    check the ONNX graph against the eager step on random inputs. Returns a summary (paths,
    sizes, that check's maximum difference). ``out_dir`` is held for the call
    (:func:`psmforce.core.files.locked_folder`): a second export into it meanwhile is refused."""
    with locked_folder(out_dir):
        return _export(checkpoint, out_dir)


def _export(checkpoint: str | Path, out_dir: str | Path) -> dict:
    ckpt = load_checkpoint(checkpoint)
    if not ckpt.recipe.streams:
        raise ExportError(f"{checkpoint}: holds a '{ckpt.model_name}' model, which does not "
                          f"stream (psmforce.estimators.networks.recipes: streams=False), so has no step graph")
    try:
        model = as_streamable(ckpt.model, len(ckpt.features))
    except StreamingError as err:
        raise ExportError(f"{checkpoint}: {err}") from None
    why = not_streamable(model)  # a recipe that claims to stream but cannot
    if why is not None:
        raise ExportError(f"{checkpoint}: the '{ckpt.model_name}' model does not follow the "
                          f"step protocol (psmforce.estimators.runtime.steppers): {why}")
    model = model.eval()
    inputs = HybridInputs(ckpt.features, ckpt.base_columns, ckpt.input_scaler, ckpt.prior(),
                          physics_prior=ckpt.physics_prior(),
                          physics_axes=ckpt.physics_only_axes)
    state = state_spec(model)
    for entry in state:   # what run_export would refuse to read back is never written
        if math.prod(entry["shape"]) > MAX_STATE_FLOATS:
            raise ExportError(f"{checkpoint}: the step state {entry['name']} {entry['shape']} "
                              f"holds more than {MAX_STATE_FLOATS} values (psmforce.estimators."
                              f"networks.recipes.MAX_STATE_FLOATS)")
    onnx_bytes = step_onnx_bytes(model)
    check = _check_graph(model, onnx_bytes, state)
    spec = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "onnx": ONNX_NAME, "opset": OPSET,
        **ckpt.metadata(), "window": model.window,
        "raw_columns": list(inputs.raw_columns),
        "prior": json.loads(ckpt.prior_json) if ckpt.prior_json else None,
        "physics_prior": (json.loads(ckpt.physics_prior_json) if ckpt.physics_prior_json
                          else None),
        "graph": {"x": {"shape": [1, model.n_features], "dtype": "float32"},
                  "y": {"shape": [1, output_width(model)], "dtype": "float32"}, "state": state},
        "uncertainty": _uncertainty_spec(model),
        "pipeline": [
            "comp_{fx..tz} = HEX10 {fx..tz} - prior(sample)  (only if features use comp_*; the "
            "prior's model and inputs: its JSON and psmforce/identification/prior.py; its "
            "gravity term needs R_base_hex10(q) from the PSM kinematics)",
            "insertion_fz = prior.insertion(d, insertion_velocity) - insertion_effort  (only if "
            "features or base use it; d = third column of R_base_hex10(q); the model: "
            "psmforce/identification/insertion.py)",
            "x = (features - input_scaler.mean) / input_scaler.std  (float32, 'features' order)",
            "state = zeros for each graph.state entry (name, shape, dtype), at start only",
            "y, <name>_out per state entry = graph(x, state)  (then state <name> = <name>_out)",
            "force_hex10_N = y[0:3] * target_scaler.std + target_scaler.mean + base_columns  (per "
            "axis; an empty base entry adds nothing on that axis; on each axis of "
            "physics_only_axes, Fx Fy Fz = columns 0 1 2, base_columns alone)",
            *(["base_columns on physics_only_axes = the same columns computed with "
               "physics_prior in place of prior (its own state, stepped every sample)"]
              if ckpt.physics_prior_json else []),
            *([f"std_hex10_N = {_STD_FORMULA}  (only if uncertainty is not null)"]
              if predicts_variance(model) else []),
            "warming up while samples since start < window",
            "step at sample_rate_hz; a faster stream (a whole multiple D of it) is low-passed "
            "causally and every D-th sample stepped (psmforce/estimators/data/rates.py)"],
        "units": "force in N, external force on the tool, HEX10 frame",
    }
    spec = seal({**spec, "onnx_sha256": sha256_bytes(onnx_bytes)})
    out = Path(out_dir)
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
    spec, onnx_bytes = read_export(out)
    where = out / JSON_NAME
    try:
        prior, physics = None, None
        if spec["prior"] is not None:
            prior = prior_from_json(json.dumps(spec["prior"]))
        if spec.get("physics_prior") is not None:
            physics = prior_from_json(json.dumps(spec["physics_prior"]))
        inputs = HybridInputs(spec["features"], spec["base_columns"],
                              Scaler.from_dict(spec["input_scaler"]), prior,
                              physics_prior=physics,
                              physics_axes=spec.get("physics_only_axes", []))
    except (TypeError, KeyError, ValueError) as err:
        raise ExportError(f"{where}: cannot set up its inputs ({type(err).__name__}: "
                          f"{str(err)[:200]})") from None
    if with_std and spec.get("uncertainty") is None:
        raise ExportError(f"{where}: the exported network predicts no variance")
    target = Scaler.from_dict(spec["target_scaler"])
    try:
        stepper = OnnxStepper(onnx_bytes, spec["graph"]["state"],
                              x_width=len(spec["features"]), y_width=spec["graph"]["y"]["shape"][1])
    except Exception as err:  # noqa: BLE001 - ONNX Runtime raises its own types
        raise ExportError(f"{out / spec['onnx']}: ONNX Runtime cannot run it with the JSON's "
                          f"state ({type(err).__name__}: {str(err).strip()[:160]})") from None
    raw = _raw_matrix(frame, spec["raw_columns"], where)
    y = np.empty((len(raw), spec["graph"]["y"]["shape"][1]), np.float32)  # as the graph gives it
    base = np.zeros((len(raw), 3))
    for i, row in enumerate(raw):
        inputs.sample(row)
        if not np.isfinite(inputs.x).all():
            raise ExportError(f"row {i}: the inputs are not finite after the prior and scaling "
                              f"of {where}")
        y[i] = stepper.step(inputs.x)
        if len(inputs.base):
            base[i] = inputs.base
    forces = (y[:, :3] * target.std + target.mean) * residual_gain(
        spec.get("physics_only_axes", [])) + base
    if not np.isfinite(forces).all():
        row = int(np.argmax(~np.isfinite(forces).all(axis=1)))
        raise ExportError(f"row {row}: the graph of {where} gave a force that is not finite")
    return (forces, std_newton(y[:, 3:], target.std)) if with_std else forces


def read_export(out_dir: str | Path) -> tuple[dict, bytes]:
    """(the JSON, the ONNX graph's bytes) of an export folder, both checked: format, integer
    version, envelope, the graph file confined to the folder and matching its digest, scalers
    and state of sense (module docstring). Raises :class:`ExportError` naming the file."""
    out = Path(out_dir)
    where = out / JSON_NAME
    try:
        spec = json.loads(read_input_text(where, MAX_JSON_BYTES, "export JSON"))
    except (OSError, ValueError) as err:  # missing, not a file, too large, not JSON
        raise ExportError(f"{where}: no readable {JSON_NAME} ({err})") from None
    if not isinstance(spec, dict) or spec.get("format") != FORMAT:
        raise ExportError(f"{where}: not a {FORMAT} file")
    if spec.get("format_version") == 2 and type(spec.get("format_version")) is int:  # noqa: E721
        raise ExportError(f"{where}: export format version 2 carries no integrity envelope; "
                          f"export the checkpoint again (psmforce export)")
    check_version(spec.get("format_version"), (FORMAT_VERSION,), str(where), "export",
                  ExportError)
    verify(spec, str(where), "export", ExportError)
    name = spec.get("onnx")
    if not isinstance(name, str) or not name or Path(name).name != name or name in (".", ".."):
        raise ExportError(f"{where}: 'onnx' must name a file inside the export folder, got "
                          f"{name!r:.120}")
    graph = out / name
    try:
        inside = graph.resolve().parent == out.resolve()
    except (OSError, RuntimeError):  # a link loop
        inside = False
    if not inside:
        raise ExportError(f"{where}: 'onnx' {name!r} leads outside the export folder")
    try:
        onnx_bytes = graph.read_bytes()
    except OSError as err:
        raise ExportError(f"{graph}: cannot read the export's graph ({err.strerror})") from None
    if sha256_bytes(onnx_bytes) != spec.get("onnx_sha256"):
        raise ExportError(f"{graph}: the graph does not match the SHA-256 its JSON records "
                          f"(edited or corrupted)")
    _check_spec(spec, where)
    return spec, onnx_bytes


def _check_spec(spec: dict, where: Path) -> None:
    def bad(text: str) -> ExportError:
        return ExportError(f"{where}: {text}")
    try:
        features, raw = list(spec["features"]), list(spec["raw_columns"])
        width = spec["graph"]["y"]["shape"][1]
        state = spec["graph"]["state"]
        scalers = [(np.asarray(spec[k]["mean"], np.float64), np.asarray(spec[k]["std"],
                                                                        np.float64), n)
                   for k, n in (("input_scaler", len(features)), ("target_scaler", 3))]
    except (TypeError, KeyError, IndexError, ValueError) as err:
        raise bad(f"malformed ({type(err).__name__}: {str(err)[:120]})") from None
    if not all(isinstance(c, str) for c in features + raw) or not features:
        raise bad("features and raw_columns must be column names")
    if width not in (3, 6):
        raise bad(f"graph.y must have 3 or 6 columns, got {width!r}")
    for mean, std, n in scalers:
        with np.errstate(over="ignore"):  # checked in float32, the dtype the runner uses
            mean, std = mean.astype(np.float32), std.astype(np.float32)
        if mean.shape != (n,) or std.shape != (n,) or not (
                np.isfinite(mean).all() and np.isfinite(std).all()
                and (std >= Scaler.MIN_STD).all()):
            raise bad(f"a scaler is not {n} means and stds >= {Scaler.MIN_STD:g}, finite in "
                      f"float32")
    why = physics_only_problem(spec.get("physics_only_axes", []), spec.get("base_columns", []),
                               width == 6)
    if why is None and spec.get("physics_prior") is not None:
        why = physics_base_problem(spec.get("base_columns", []),
                                   spec.get("physics_only_axes", []))
    if why is not None:
        raise bad(why)
    if not isinstance(state, list):
        raise bad("graph.state must be a list")
    for entry in state:
        try:
            shape, size = entry["shape"], 1
            ok = isinstance(entry["name"], str) and entry["dtype"] in ("float32", "int64") \
                and isinstance(shape, list) and all(
                    isinstance(d, int) and not isinstance(d, bool) and d >= 1 for d in shape)
            for d in shape:
                size *= d
        except (TypeError, KeyError):
            ok = False
        if not ok or size > MAX_STATE_FLOATS:
            raise bad(f"graph.state entry {entry!r:.100} is not a name, a dtype (float32, "
                      f"int64) and a shape of at most {MAX_STATE_FLOATS} values")


def _raw_matrix(frame: pd.DataFrame, columns: list[str], where: Path) -> np.ndarray:
    """The recording's raw columns as float64, every value finite and inside its physical
    bound (the stream's INVALID_INPUT), else :class:`ExportError` naming the column and row."""
    if not isinstance(frame, pd.DataFrame):
        raise ExportError(f"the recording must be a pandas DataFrame, got "
                          f"{type(frame).__name__}")
    missing = [c for c in columns if c not in frame.columns]
    if missing:
        raise ExportError(f"the recording lacks the columns {missing} that {where} reads")
    twice = sorted({c for c in frame.columns[frame.columns.duplicated()] if c in columns})
    if twice:  # which of the two would be the signal?
        raise ExportError(f"column {twice[0]}: appears more than once in the recording")
    if len(frame) == 0:
        raise ExportError(f"the recording has no rows (the columns {where} reads are empty)")
    for c in columns:
        kind = frame[c].dtype
        if (not pd.api.types.is_numeric_dtype(kind) or pd.api.types.is_bool_dtype(kind)
                or pd.api.types.is_complex_dtype(kind)):
            raise ExportError(f"column {c}: not numeric ({kind}; real numbers only), as "
                              f"{where} reads it")
    raw = frame[columns].to_numpy(np.float64)
    if TIME in frame.columns:  # the stream flags a step back in time; a batch refuses it
        step = np.diff(pd.to_numeric(frame[TIME], errors="coerce").to_numpy(np.float64))
        if not (step > 0).all():
            row = int(np.argmin(step > 0)) + 1
            raise ExportError(f"column {TIME} row {row}: time does not increase (the recording "
                              f"runs backwards or repeats a stamp)")
    bounds = physical_bounds()
    for k, c in enumerate(columns):
        low, high = bounds.get(c, (-np.inf, np.inf))
        ok = np.isfinite(raw[:, k]) & (raw[:, k] >= low) & (raw[:, k] <= high)
        if not ok.all():
            row = int(np.argmin(ok))
            raise ExportError(f"column {c} row {row}: {raw[row, k]!r} is not finite or outside "
                              f"its physical range [{low:.4g}, {high:.4g}]")
    return raw
