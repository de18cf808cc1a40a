"""Offline evaluation as in the seed paper: predict whole trials, post-process, score, tabulate.

Every model is scored on the same samples: from :data:`EVAL_START` (sample 99, the first with a full
100-sample window for the paper's transformer) to the end of each trial. Predictions of one trial
are post-processed on their own (:func:`psmforce.estimators.evaluation.metrics.postprocess`), then
the trials of a set are concatenated and scored per axis (RMSE, NRMSE over the set's range, R^2),
which is how the paper's tables are computed.

The bias step (subtract the mean prediction of the first 0.5 s) assumes the tool is held still in
free space then. It is skipped for models whose recipe says so (the LSTM, as in the paper,
:attr:`psmforce.estimators.networks.recipes.Recipe.bias_correction`) and for trials that do not
start in free space: traction trials (:data:`NO_FREE_START`), where the hook is attached and the
spring loaded from the first sample, so the "bias" would remove real force.

A model that predicts its variance (:mod:`psmforce.estimators.networks.uncertainty`) is scored the
same way on its mean; ``evaluate`` adds an ``uncertainty`` block
(:func:`psmforce.estimators.networks.uncertainty.uncertainty_metrics`: mean predicted std, RMSE, 1-
and 2-std coverage, Gaussian NLL per axis), overall and per condition, over the same samples from
:data:`EVAL_START` on, on the raw per-sample mean (no bias step, no filter): the std describes one
raw estimate, not a post-processed one.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import torch

from psmforce.estimators.training.checkpoint import (TrainedModel, load_checkpoint,
                                                     physics_only_problem)
from psmforce.estimators.networks.contract import ClosedFormModel, TrainableNetwork, is_chunk
from psmforce.estimators.data.dataset import Trial, base_matrix, load_dataset, sliding_windows
from psmforce.estimators.data.hybrid_inputs import physics_base
from psmforce.estimators.evaluation.metrics import POSTPROCESSING, axis_metrics, postprocess
from psmforce.estimators.evaluation.tables import automated_table, modes_table, uncertainty_table
from psmforce.estimators.networks.uncertainty import (output_width, predicts_variance, std_newton,
                                                      uncertainty_metrics)
from psmforce.core.files import locked_folder, write_text_atomic
from psmforce.io.recording import TARGETS

EVAL_START = 99
"""First scored sample of every trial (0.99 s of context for every model)."""
NO_FREE_START = frozenset({"Traction"})
"""Conditions whose trials are loaded from the start (no free-space period to take a bias from)."""
PREDICT_CHUNK = 1024
"""Chunk length for offline prediction with chunk models (overlapping by the model's window)."""


def predict_trial(setup: TrainedModel, trial: Trial, *, batch: int = 8192,
                  device: str = "cpu", with_std: bool = False
                  ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """(N, 3) force estimates in N (HEX10 frame) of ``setup.model`` for one trial (derived
    columns added, :meth:`psmforce.estimators.training.checkpoint.TrainedModel.derive`); NaN where
    the model has no estimate (the first ``window - 1`` samples for window models). Chunk models run
    over chunks of up to :data:`PREDICT_CHUNK` samples overlapping by ``model.window``: exact for a
    causal model whose receptive field is ``window``; for the LSTM a state reset every chunk, after
    a ``window``-sample warm-up, as in its training. A closed-form model
    (:class:`psmforce.estimators.networks.contract.ClosedFormModel`) predicts all full windows at
    once, in numpy. Every model's output then goes the same way: un-scaled where its
    ``output_space`` is ``"scaled"``, its base columns added (the residual left out on the
    checkpoint's ``physics_only_axes``: :func:`~psmforce.estimators.training.checkpoint.residual_gain`;
    their base from the checkpoint's prior of their own where it holds one:
    :func:`~psmforce.estimators.data.hybrid_inputs.physics_base`).

    ``with_std``: (estimates, (N, 3) standard deviation per axis in N), for a model that predicts
    its variance (:func:`psmforce.estimators.networks.uncertainty.std_newton`); refused for one that
    does not."""
    model = setup.model
    why = physics_only_problem(setup.physics_only_axes, setup.base_columns,
                               predicts_variance(model))
    if why is not None:  # save and load refuse it; a record built in memory too
        raise ValueError(why)
    if with_std and not predicts_variance(model):
        raise ValueError(f"the '{setup.model_name}' model predicts no variance (it was not "
                         f"trained with uncertainty), so it has no std")
    x = setup.input_scaler.transform(trial.matrix(setup.features))
    out = np.full((len(x), output_width(model)), np.nan, dtype=np.float64)
    if isinstance(model, ClosedFormModel):  # numpy windows in, numpy estimates out
        _predict_closed_form(model, x, out)
    else:
        _predict_network(model, x, out, batch, device)
    mean = out[:, :3]
    if model.output_space == "scaled":
        mean = setup.target_scaler.inverse(mean)
    if setup.base_columns:
        base = base_matrix(trial, setup.base_columns)
        if setup.physics_prior_json is not None:  # the physics-only axes answered by their own
            for k, column in physics_base(trial.frame, setup.physics_prior(),
                                          setup.base_columns, setup.physics_only_axes).items():
                base[:, k] = column
        mean = mean * setup.residual_gain() + base
    if with_std:
        return mean, std_newton(out[:, 3:], setup.target_scaler.std)
    return mean


def _predict_closed_form(model: ClosedFormModel, x: np.ndarray, out: np.ndarray) -> None:
    """``out[window - 1:]`` = a closed-form window model's estimates of scaled inputs ``x``."""
    if len(x) >= model.window:
        out[model.window - 1:] = model.predict(np.ascontiguousarray(
            sliding_windows(x, model.window, 1)))


def _predict_network(model: TrainableNetwork, x: np.ndarray, out: np.ndarray, batch: int,
                     device: str) -> None:
    """A network's outputs for scaled inputs ``x`` into ``out``: per window (``kind``
    ``"window"``) or over overlapping chunks (``"chunk"``); see :func:`predict_trial`."""
    n = len(x)
    model.eval()
    with torch.no_grad():
        if not is_chunk(model):
            views = sliding_windows(x, model.window, 1)
            preds = [model(torch.from_numpy(np.array(views[i:i + batch])).to(device))
                     for i in range(0, len(views), batch)]
            if preds:
                out[model.window - 1:] = torch.cat(preds).cpu().numpy()
            return
        warm = model.window
        chunk = min(PREDICT_CHUNK, n)
        step = max(1, chunk - warm)
        n_chunks = 1 if n <= chunk else int(np.ceil((n - chunk) / step)) + 1
        padded = np.concatenate([x, np.repeat(x[-1:], (n_chunks - 1) * step + chunk - n, 0)])
        chunks = torch.from_numpy(np.array(sliding_windows(padded, chunk, step)[:n_chunks]))
        per_call = max(1, batch // chunk)
        pred = torch.cat([model(chunks[i:i + per_call].to(device))
                          for i in range(0, n_chunks, per_call)]).cpu().numpy()
        out[:chunk] = pred[0]
        for k in range(1, n_chunks):
            lo, hi = k * step + warm, min(n, k * step + chunk)
            out[lo:hi] = pred[k][warm:warm + hi - lo]


def scored_segment(pred: np.ndarray, trial: Trial, *, bias: bool, rate_hz: float = 100.0,
                   mode: str = "paper") -> tuple[np.ndarray, np.ndarray]:
    """(post-processed prediction, truth) of one trial from :data:`EVAL_START` on; ``bias`` is
    the model's setting, honoured only for trials that start in free space; ``mode``: the
    post-processing of :func:`psmforce.estimators.evaluation.metrics.postprocess` (paper, causal, causal_lowpass)."""
    p = pred[EVAL_START:]
    if np.isnan(p).any():
        raise ValueError(f"{trial.path}: model gives no estimate for some samples after "
                         f"sample {EVAL_START} (window longer than {EVAL_START + 1}?)")
    bias = bias and trial.condition not in NO_FREE_START
    return (postprocess(p, rate_hz, bias=bias, mode=mode),
            trial.matrix(TARGETS, np.float64)[EVAL_START:])


def _scored_trials(trials: Sequence[Trial]) -> list[Trial]:
    scored = [t for t in trials if len(t) > EVAL_START]
    if not scored:
        raise ValueError("no trial is longer than the evaluation start")
    return scored


def score(predictions: Mapping[str, np.ndarray], trials: Sequence[Trial], *,
          bias: bool = True, mode: str = "paper") -> dict:
    """Per-axis metrics over the concatenation of the trials' post-processed predictions."""
    parts = [scored_segment(predictions[t.path], t, bias=bias, mode=mode)
             for t in _scored_trials(trials)]
    return axis_metrics(np.concatenate([p for p, _ in parts]),
                        np.concatenate([y for _, y in parts]))


def score_modes(predictions: Mapping[str, np.ndarray], trials: Sequence[Trial], *,
                bias: bool = True) -> dict:
    """{post-processing mode: per-axis metrics} over the same samples (:data:`POSTPROCESSING`)."""
    return {m: score(predictions, trials, bias=bias, mode=m) for m in POSTPROCESSING}


def score_uncertainty(predictions: Mapping[str, tuple[np.ndarray, np.ndarray]],
                      trials: Sequence[Trial]) -> dict:
    """Per-axis :func:`psmforce.estimators.networks.uncertainty.uncertainty_metrics` over the concatenation of the
    trials' raw (mean, std) from :data:`EVAL_START` on; see the module docstring."""
    parts = [(scored_segment(predictions[t.path][0], t, bias=False, mode="causal"),
              predictions[t.path][1][EVAL_START:]) for t in _scored_trials(trials)]
    return uncertainty_metrics(np.concatenate([p for (p, _), _ in parts]),
                               np.concatenate([s for _, s in parts]),
                               np.concatenate([y for (_, y), _ in parts]))


def floor_metrics(trials: Sequence[Trial]) -> dict:
    """{mode: metrics of the ground truth itself through that post-processing}: what a perfect
    estimator would score; no estimator scored that way can do much better (zero error for the
    raw causal metric)."""
    truth = {t.path: t.matrix(TARGETS, np.float64) for t in trials}
    return {m: score(truth, trials, bias=False, mode=m) for m in POSTPROCESSING}


def causal_table(result: Mapping) -> str:
    """The causal metric of an :func:`evaluate` result as a Markdown table (per axis: range,
    RMSE, NRMSE, R^2 over every scored trial): the raw per-sample estimate after the model's
    first-0.5 s tare, no filter, no look-ahead, which is what a haptic loop gets (the paper's
    metric looks 0.35 s ahead). ``psmforce evaluate`` prints it."""
    return automated_table({result["model"]: result["postprocessing"]["overall"]["causal"]},
                           f"Causal metric, {result['split'] or 'all'} trials (raw per-sample "
                           f"estimate, no look-ahead; forces in N, HEX10 frame)")


def evaluate(checkpoint: str | Path, data_dir: str | Path, out_dir: str | Path, *,
             split: str | None = "test", device: str = "cpu", plots: bool = True) -> dict:
    """Score a checkpoint on the ``split`` trials of ``data_dir`` (all trials when None), overall
    and per condition; writes metrics.json, metrics.md (the paper's metric, then the causal
    one, :func:`causal_table`) and (``plots``) PNG figures into ``out_dir``. Returns the
    metrics dict. ``out_dir`` is held for the call (:func:`psmforce.core.files.locked_folder`):
    a second evaluation into it meanwhile is refused."""
    with locked_folder(out_dir):
        return _evaluate(checkpoint, data_dir, out_dir, split=split, device=device, plots=plots)


def _evaluate(checkpoint: str | Path, data_dir: str | Path, out_dir: str | Path, *,
              split: str | None, device: str, plots: bool) -> dict:
    ckpt = load_checkpoint(checkpoint, device)
    dataset = load_dataset(data_dir)
    ckpt.derive(dataset)
    trials = dataset.select(split=split) if split else dataset.trials
    if not trials:
        raise ValueError(f"{data_dir}: no trials in split '{split}'")
    short = [t.path for t in trials if len(t) <= EVAL_START]
    if short:  # scored from EVAL_START on: refused by name, not dropped from the tables
        raise ValueError(f"{data_dir}: recordings of at most {EVAL_START} samples (the evaluation "
                         f"start) cannot be scored: {short}")
    variance = predicts_variance(ckpt.model)
    outputs = {t.path: predict_trial(ckpt, t, device=device, with_std=variance) for t in trials}
    preds = {path: out[0] for path, out in outputs.items()} if variance else outputs
    bias = ckpt.recipe.bias_correction
    conditions = sorted({t.condition for t in trials})
    result = {"checkpoint": str(checkpoint), "model": ckpt.model_name, "data_dir": str(data_dir),
              "split": split, "eval_start_sample": EVAL_START, "bias_correction": bias,
              "physics_only_axes": list(ckpt.physics_only_axes),
              "physics_only_prior": ("its own" if ckpt.physics_prior_json is not None
                                     else "the network's"),
              "overall": score(preds, trials, bias=bias),
              "by_condition": {c: score(preds, [t for t in trials if t.condition == c], bias=bias)
                               for c in conditions},
              "postprocessing": {"overall": score_modes(preds, trials, bias=bias),
                                 "floor": floor_metrics(trials)}}
    if variance:
        result["uncertainty"] = {
            "overall": score_uncertainty(outputs, trials),
            "by_condition": {c: score_uncertainty(outputs, [t for t in trials
                                                            if t.condition == c])
                             for c in conditions}}
    out = Path(out_dir)
    write_text_atomic(out / "metrics.json", json.dumps(result, indent=2) + "\n")
    md = automated_table({ckpt.model_name: result["overall"]}, f"{split or 'all'} trials")
    md += "\n" + causal_table(result)
    md += "\n" + modes_table({ckpt.model_name: result["postprocessing"]["overall"]},
                             result["postprocessing"]["floor"])
    for c, r in result["by_condition"].items():
        md += "\n" + automated_table({ckpt.model_name: r}, c)
    if variance:
        md += "\n" + uncertainty_table(result["uncertainty"])
    write_text_atomic(out / "metrics.md", md)
    if plots:
        from psmforce.estimators.evaluation.plots import plot_scatter, plot_time_series
        segments = {t.path: scored_segment(preds[t.path], t, bias=bias) for t in trials}
        plot_time_series({ckpt.model_name: segments}, trials, out / "time_series.png")
        plot_scatter({ckpt.model_name: segments}, out / "scatter.png")
    return result
