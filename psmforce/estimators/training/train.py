"""Training and finetuning for every estimator, on one loop (seed paper, training section).

The models are read through their protocols (:mod:`psmforce.estimators.networks.contract`): a
:class:`psmforce.estimators.networks.contract.TrainableNetwork` is fitted by the loop below, a
:class:`psmforce.estimators.networks.contract.ClosedFormModel` by its own ``fit`` on the same
windows.

Adam with L2 weight decay, MSE on standard-scaled targets, validation every epoch, learning rate
x0.1 after ``lr_patience`` (3) epochs without improvement, early stop after ``patience`` (10),
the best-validation weights kept. Window models see (B, L, F) windows and predict their last
sample; chunk models see (B, T, F) chunks and are scored on every sample after a warm-up of
``model.window`` samples (chunks overlap by that warm-up, so every sample past a trial's first
``window`` is supervised once per epoch). Models whose output is a force in N
(``output_space = "newton"``) are scored after the same target scaling, so every axis weighs the
same in every loss.

A model that predicts its variance (``predicts_variance``,
:mod:`psmforce.estimators.networks.uncertainty`: 6 output channels, mean and log-variance of the
scaled target) is trained and early-stopped on the beta-NLL of Seitzer et al. 2022 (beta 0.5) over
the same supervised samples, not the MSE: the plain Gaussian NLL would let the mean under-fit where
the predicted variance is high (each sample's error weighs 1 / variance), which beta = 0.5 partly
undoes. Its losses in the history are that NLL (it can be negative). Finetuning trains the decoder,
mean and variance together.

A "base" (three columns added to the network output, e.g. the HEX10 force minus the prior's
internal force for the hybrid) turns the target into the residual ``ATI - base``; the network
learns that residual and :func:`predict_trial` adds the base back.

Deterministic given ``seed`` on one device and thread count.

Size: the loop, its closed-form counterpart and the file-level API (:func:`train`,
:func:`finetune`) share :class:`TrainConfig`, the window sets and the fit report; kept together
they read top to bottom as one pipeline, and no part is used without the others.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

from psmforce.io.recording import TIME
from psmforce.estimators.data.rates import RATE_TOLERANCE, training_rate_hz
from psmforce.estimators.training.checkpoint import TrainedModel, load_checkpoint
from psmforce.estimators.networks.contract import ClosedFormModel, is_chunk
from psmforce.estimators.data.dataset import (DatasetError, Scaler, Trial, WindowSet, fit_scalers,
                                              load_dataset, split_validation)
from psmforce.estimators.data.hybrid_inputs import prior_to_json, select_base
from psmforce.estimators.networks.baselines import count_parameters, freeze_for_finetuning
from psmforce.estimators.networks.recipes import DERIVATIONS, Features, Inputs, build_model, recipe
from psmforce.estimators.training.resume import clear_state, fingerprint, load_state, save_state
from psmforce.estimators.networks.uncertainty import beta_nll, predicts_variance

DEFAULT_CHUNK = 400
"""Chunk length (samples) for chunk models: 4 s at 100 Hz, 3 s of it supervised with window 100."""


@dataclass
class TrainConfig:
    """Optimiser, schedule and data-budget settings (paper defaults; budgets off)."""

    lr: float = 1e-3
    weight_decay: float = 1e-4
    batch_size: int = 256
    """Windows per batch (window models)."""
    chunk_batch_size: int = 16
    """Chunks per batch (chunk models): 16 x 300 supervised samples."""
    max_epochs: int = 100
    patience: int = 10
    lr_patience: int = 3
    lr_factor: float = 0.1
    stride: int = 5
    """Samples between consecutive training windows (x4 for free-space trials)."""
    chunk: int = DEFAULT_CHUNK
    """Chunk length of chunk models; shortened to the shortest trial when one is shorter."""
    chunk_supervised: int | None = None
    """When set, chunks are the model's warm-up window plus this many supervised samples, whatever
    the window (``chunk`` is then not read): a setting that holds when the model's receptive
    field changes."""
    chunk_stride: int | None = None
    """Samples between consecutive training chunks of a chunk model (None: the supervised part's
    length, so every supervised sample is trained on once per epoch). With ``chunk_supervised``
    1 and stride 5 a chunk model sees the window models' training targets: one every fifth sample
    (:mod:`psmforce.experiments.regimes`, the paper's regime)."""
    max_batches_per_epoch: int | None = None
    """Smoke-run cap: a seeded random subset of this many batches per epoch (None: all). A run
    with a cap is not converged, whatever its early stopping did."""
    max_val_batches: int | None = None
    """Smoke-run cap: evenly spaced validation batches (None: all)."""
    compile: bool = False
    """Train window models through :func:`torch.compile` (the same function). Off by default:
    on a 2-core CPU the compiled paper transformer's steps were slower than its eager path
    (``benchmarks/training.py``); it may pay on other hardware."""
    bf16: bool = False
    """Training forward passes and losses under autocast to bfloat16 (weights, optimiser and
    validation stay float32). Off by default: ``benchmarks/training.py --speed-options``
    measures what it buys per step; converged accuracy with it has not been shown yet."""
    seed: int = 0
    device: str = "cpu"
    progress: bool = True

    def to_dict(self) -> dict:
        return asdict(self)


class TrainingError(ValueError):
    """A training request that cannot run as asked; the message says why."""


def _loss(model: nn.Module, x: torch.Tensor, y: torch.Tensor,
          target_scaler: Scaler, forward=None) -> torch.Tensor:
    pred = (model if forward is None else forward)(x)
    if model.output_space == "newton":
        pred = (pred - torch.as_tensor(target_scaler.mean, device=pred.device)) / torch.as_tensor(
            target_scaler.std, device=pred.device)
    if is_chunk(model):
        pred, y = pred[:, model.window:], y[:, model.window:]
    if predicts_variance(model):
        return beta_nll(pred[..., :3], pred[..., 3:], y)
    return torch.mean((pred - y) ** 2)


def chunk_length(model: nn.Module, cfg: TrainConfig) -> int:
    """Samples per training chunk of chunk model ``model`` under ``cfg``: ``chunk``, or the
    warm-up window plus ``chunk_supervised`` when that is set."""
    if cfg.chunk_supervised is not None:
        if isinstance(cfg.chunk_supervised, bool) or not isinstance(cfg.chunk_supervised, int) \
                or cfg.chunk_supervised < 1:
            raise TrainingError(f"chunk_supervised must be a positive integer, "
                                f"got {cfg.chunk_supervised!r}")
        return model.window + cfg.chunk_supervised
    if cfg.chunk <= model.window:
        raise TrainingError(f"chunk ({cfg.chunk}) must exceed the warm-up window "
                            f"({model.window})")
    return cfg.chunk


def _chunk_length(model: nn.Module, trials: Sequence[Trial], cfg: TrainConfig) -> int:
    """:func:`chunk_length`, or the shortest trial's length when shorter: every trial is
    trained on, none dropped for being short. Trials too short to supervise are refused."""
    length = chunk_length(model, cfg)
    short = [t.path for t in trials if len(t) <= model.window]
    if short:
        raise TrainingError(f"recordings of at most {model.window} samples (the model's warm-up) "
                            f"cannot be trained on: {short}")
    return min(length, min(len(t) for t in trials))


def _window_set(model: nn.Module, trials: Sequence[Trial], setup: TrainedModel, cfg: TrainConfig,
                stride: int | None = None) -> WindowSet:
    if is_chunk(model):
        chunk = _chunk_length(model, trials, cfg)
        if cfg.chunk_stride is not None and (isinstance(cfg.chunk_stride, bool) or not isinstance(
                cfg.chunk_stride, int) or cfg.chunk_stride < 1):
            raise TrainingError(f"chunk_stride must be a positive integer, "
                                f"got {cfg.chunk_stride!r}")
        return WindowSet(trials, setup.features, setup.input_scaler, setup.target_scaler,
                         chunk, stride or cfg.chunk_stride or chunk - model.window, targets="all",
                         downsample_free=True, base_columns=setup.base_columns)
    short = [t.path for t in trials if len(t) < model.window]
    if short:
        raise TrainingError(f"recordings shorter than the model's window ({model.window} "
                            f"samples) cannot be trained on: {short}")
    return WindowSet(trials, setup.features, setup.input_scaler, setup.target_scaler,
                     model.window, stride or cfg.stride, targets="last", downsample_free=True,
                     base_columns=setup.base_columns)


def _evaluate_loss(model, data, setup: TrainedModel, cfg: TrainConfig, batch: int) -> float:
    model.eval()
    n_batches = math.ceil(len(data) / batch)
    chosen = range(n_batches)
    if cfg.max_val_batches is not None and n_batches > cfg.max_val_batches:
        chosen = np.linspace(0, n_batches - 1, cfg.max_val_batches).round().astype(int)
    total, count = 0.0, 0
    with torch.no_grad():
        for b in chosen:
            idx = torch.arange(b * batch, min((b + 1) * batch, len(data)))
            x, y = data.batch(idx)
            total += float(_loss(model, x.to(cfg.device), y.to(cfg.device),
                                 setup.target_scaler)) * len(idx)
            count += len(idx)
    return total / count


class _Features:
    """Window features precomputed by a frozen trunk, paired with their targets (finetuning)."""

    def __init__(self, model: nn.Module, data: WindowSet, device: str, batch: int = 2048):
        model.eval()
        feats = []
        with torch.no_grad():
            for i in range(0, len(data), batch):
                x, _ = data.batch(torch.arange(i, min(i + batch, len(data))))
                feats.append(model.features(x.to(device)))
        self.features = torch.cat(feats)
        self.targets = data.targets[data.starts + data.window - 1].to(device)

    def __len__(self) -> int:
        return len(self.features)

    def batch(self, index: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.features[index], self.targets[index]


class _Head(nn.Module):
    """A window model's decoder seen as a model of its precomputed features."""

    kind = "window"

    def __init__(self, model: nn.Module):
        super().__init__()
        self.model, self.output_space = model, model.output_space

    def forward(self, features: torch.Tensor) -> torch.Tensor:
        return self.model.decode(features)


def fit(model: nn.Module, train_trials: Sequence[Trial], val_trials: Sequence[Trial],
        setup: TrainedModel, cfg: TrainConfig, *, desc: str = "train",
        frozen_in_eval: bool = False, resume: str | Path | None = None) -> dict:
    """Train ``model`` in place and leave it holding its best-validation weights.

    ``resume``: a file for the loop's state (:mod:`psmforce.estimators.training.resume`), written
    after every epoch; when it exists the training continues from it and ends bit-identical to an
    uninterrupted run. The file is left in place (a finished state resumes to the same result at
    once); the caller removes it once the result is saved
    (:func:`psmforce.estimators.training.resume.clear_state`).

    ``frozen_in_eval``: modules without trainable parameters stay in eval mode (finetuning).
    A window model whose only trainable part is its decoder (``features`` / ``decode``) is then
    trained on features computed once: the same function, without re-running the frozen trunk
    every epoch.

    Returns the fit report: the history (per epoch: train and validation loss, learning rate,
    seconds, cumulative optimiser steps, wall-clock and device), ``devices`` (those the epochs
    ran on, in order: more than one when a resumed training moved), ``epochs_run``, ``stopped_by``
    ("patience": early stopping fired; "epoch_limit") and ``converged`` (early stopping fired and
    no batch cap thinned the epochs).
    """
    if not val_trials:
        raise TrainingError("no validation trials: early stopping needs a validation set")
    torch.manual_seed(cfg.seed)
    model.to(cfg.device)
    train_set = _window_set(model, train_trials, setup, cfg)
    val_set = _window_set(model, val_trials, setup, cfg)
    batch = cfg.chunk_batch_size if is_chunk(model) else cfg.batch_size
    params = [p for p in model.parameters() if p.requires_grad]
    if not params:
        raise TrainingError("the model has no trainable parameters")
    net, frozen = model, []
    if frozen_in_eval:
        head = {id(p) for m in model.finetune_modules() for p in m.parameters()}
        if (not is_chunk(model) and hasattr(model, "features")
                and {id(p) for p in params} <= head):
            net = _Head(model)
            train_set = _Features(model, train_set, cfg.device)
            val_set = _Features(model, val_set, cfg.device)
        else:
            frozen = [m for m in model.modules()
                      if not any(p.requires_grad for p in m.parameters())]
    forward = torch.compile(net) if cfg.compile and net is model and not is_chunk(model) \
        else None
    opt = torch.optim.Adam(params, lr=cfg.lr, weight_decay=cfg.weight_decay)
    sched = torch.optim.lr_scheduler.ReduceLROnPlateau(opt, mode="min", factor=cfg.lr_factor,
                                                       patience=cfg.lr_patience)
    gen = torch.Generator().manual_seed(cfg.seed)
    best, best_state, stale, history = math.inf, None, 0, []
    steps, elapsed = 0, 0.0
    key = _resume_key(model, setup, cfg, len(train_set), len(val_set), frozen_in_eval)
    state = load_state(resume, key) if resume is not None else None
    if state is not None:
        model.load_state_dict(state["model"])
        opt.load_state_dict(state["optimizer"])
        sched.load_state_dict(state["scheduler"])
        gen.set_state(state["generator"])
        torch.set_rng_state(state["torch_rng"])
        if "cuda_rng" in state and str(cfg.device).startswith("cuda"):
            torch.cuda.set_rng_state_all(state["cuda_rng"])
        best, best_state, stale = state["best"], state["best_state"], state["stale"]
        history, steps, elapsed = state["history"], state["steps"], state["elapsed_s"]
    full_batches = math.ceil(len(train_set) / batch)
    n_batches = full_batches
    if cfg.max_batches_per_epoch is not None:
        n_batches = min(n_batches, cfg.max_batches_per_epoch)
    capped = n_batches < full_batches or (
        cfg.max_val_batches is not None and math.ceil(len(val_set) / batch) > cfg.max_val_batches)
    first = len(history) if stale < cfg.patience else cfg.max_epochs
    bar = tqdm(range(first, cfg.max_epochs), desc=desc, disable=not cfg.progress,
               mininterval=5.0, leave=False)
    started = time.perf_counter() - elapsed
    for epoch in bar:
        t0 = time.perf_counter()
        net.train()
        for m in frozen:
            m.eval()
        order = torch.randperm(len(train_set), generator=gen)
        running = 0.0
        for b in range(n_batches):
            x, y = train_set.batch(order[b * batch:(b + 1) * batch])
            opt.zero_grad(set_to_none=True)
            with torch.autocast(torch.device(cfg.device).type, dtype=torch.bfloat16,
                                enabled=cfg.bf16):
                loss = _loss(net, x.to(cfg.device), y.to(cfg.device), setup.target_scaler,
                             forward)
            loss.backward()
            opt.step()
            running += loss.item()
        steps += n_batches
        val = _evaluate_loss(net, val_set, setup, cfg, batch)
        lr = opt.param_groups[0]["lr"]
        sched.step(val)
        history.append({"epoch": epoch + 1, "train_loss": running / n_batches, "val_loss": val,
                        "lr": lr, "seconds": time.perf_counter() - t0, "steps": steps,
                        "elapsed_s": time.perf_counter() - started, "device": str(cfg.device)})
        bar.set_postfix(train=f"{running / n_batches:.4f}", val=f"{val:.4f}", lr=f"{lr:.0e}")
        if val < best:
            best, best_state, stale = val, copy.deepcopy(model.state_dict()), 0
        else:
            stale += 1
        if resume is not None:
            save_state(resume, key, {
                "model": model.state_dict(), "optimizer": opt.state_dict(),
                "scheduler": sched.state_dict(), "generator": gen.get_state(),
                "torch_rng": torch.get_rng_state(), "best": best, "best_state": best_state,
                "stale": stale, "history": history, "steps": steps,
                "elapsed_s": time.perf_counter() - started,
                **({"cuda_rng": torch.cuda.get_rng_state_all()}
                   if str(cfg.device).startswith("cuda") else {})})
        if stale >= cfg.patience:
            break
    bar.close()
    model.load_state_dict(best_state)
    model.eval()
    stopped_by = "patience" if stale >= cfg.patience else "epoch_limit"
    return {"history": history, "best_val_loss": best, "epochs_run": len(history),
            "stopped_by": stopped_by, "capped": capped,
            "converged": stopped_by == "patience" and not capped,
            "devices": list(dict.fromkeys(h.get("device", "not recorded") for h in history)),
            "train_windows": len(train_set), "val_windows": len(val_set),
            "batches_per_epoch": n_batches, "chunk": getattr(train_set, "window", None)
            if is_chunk(model) else None}


def _resume_key(model: nn.Module, setup: TrainedModel, cfg: TrainConfig, n_train: int,
                n_val: int, finetuning: bool) -> str:
    """What a saved training state must have been written by (:mod:`psmforce.estimators.training.resume`). The device
    is left out: a state moves between devices (a training started on a GPU that is lost goes
    on on the CPU), and its history records each epoch's."""
    return fingerprint({
        "config": {k: v for k, v in cfg.to_dict().items() if k not in ("progress", "device")},
        "model": setup.model_name, "model_config": setup.config,
        "features": list(setup.features), "base": list(setup.base_columns),
        "windows": [n_train, n_val], "finetuning": finetuning,
        "parameters": [[k, list(v.shape)] for k, v in model.state_dict().items()]})


def make_setup(model_name: str, train_trials: Sequence[Trial], *, features: Features = None,
               use_prior: bool = True, prior_json: str | None = None, config: dict | None = None,
               inputs: Inputs | None = None) -> TrainedModel:
    """The untrained record of a model: its recipe's inputs for ``features`` / ``use_prior``,
    their base kept only on axes where it helps
    (:func:`psmforce.estimators.data.hybrid_inputs.select_base`), and the scalers fitted on the
    training trials only. ``inputs`` replaces the recipe's, base as given (design studies). The
    trials must hold the derived columns (:data:`psmforce.estimators.networks.recipes.DERIVATIONS`);
    ``prior_json`` goes with derivation ``"prior"``."""
    if inputs is None:
        inputs = recipe(model_name).inputs(features, use_prior)
        if inputs.base:
            inputs = replace(inputs, base=select_base(train_trials, inputs.base))
    if inputs.uses_prior != (prior_json is not None):
        raise TrainingError(f"derivation '{inputs.derivation}' and "
                            f"{'a' if prior_json else 'no'} prior do not go together")
    timed = all(TIME in t.frame.columns for t in train_trials)  # recordings always are
    rate_hz = training_rate_hz(train_trials) if timed else None  # every stream meets it
    x_scaler, y_scaler = fit_scalers(train_trials, inputs.features, raw_columns=inputs.raw,
                                     base_columns=inputs.base)
    return TrainedModel(model_name, dict(config or {}), inputs.features, x_scaler, y_scaler,
                        inputs.base, inputs.derivation, prior_json, sample_rate_hz=rate_hz)


def _closed_form_windows(model, trials: Sequence[Trial], setup: TrainedModel, cfg: TrainConfig,
                    stream: int) -> tuple[np.ndarray, np.ndarray]:
    """The window models' training windows (stride ``cfg.stride``, free space 4x sparser) as
    arrays, only the seeded subsample the regressor keeps gathered."""
    data = _window_set(model, trials, setup, cfg)
    x, y = data.batch(torch.from_numpy(model.subsample_indices(len(data), stream)))
    return x.numpy(), y.numpy()


def _closed_form_report(model, fit_report: dict, n_train: int, n_val: int) -> dict:
    """A closed-form fit in the shape of :func:`fit`'s report: no epochs, converged by
    construction; ``best_val_loss`` is the validation MSE (scaled units) at the chosen penalty."""
    n = model.n_parameters()
    return {"history": [], "best_val_loss": fit_report["criterion_rmse"] ** 2, "epochs_run": 1,
            "stopped_by": "closed form", "capped": False, "converged": True,
            "train_windows": n_train, "val_windows": n_val, "batches_per_epoch": None,
            "chunk": None, "parameters": n, "trainable_parameters": n, "fit": fit_report}


def _fit_closed_form(setup: TrainedModel, train_trials: Sequence[Trial],
                     val_trials: Sequence[Trial], cfg: TrainConfig,
                     head_of=None) -> tuple[object, dict]:
    """A closed-form window model (MultiRocket-Hydra, :mod:`psmforce.estimators.networks.rocket`) on the same windows
    as the networks, its penalty chosen on the validation trials. ``head_of``: a fitted model
    whose features stay and whose head (the ridge) is refitted (finetuning)."""
    if not val_trials:
        raise TrainingError("no validation trials: the penalty is chosen on them")
    t0 = time.perf_counter()
    model = head_of
    if model is None:
        model = build_model(setup.model_name, len(setup.features), {
            **setup.config, "seed": cfg.seed, "threads": torch.get_num_threads()})
        setup.config = model.config()  # every constructor argument, for the checkpoint
    (x, y), (xv, yv) = (_closed_form_windows(model, trials, setup, cfg, stream)
                        for stream, trials in ((0, train_trials), (1, val_trials)))
    fit_report = (model.refit_head if head_of is not None else model.fit)(x, y, xv, yv)
    report = _closed_form_report(model, fit_report, len(x), len(xv))
    report["seconds"] = time.perf_counter() - t0
    return model, report


def train_model(setup: TrainedModel, train_trials: Sequence[Trial],
                val_trials: Sequence[Trial], cfg: TrainConfig, *, desc: str | None = None,
                resume: str | Path | None = None) -> dict:
    """Build the model of ``setup``, train it, leave it with its best weights in
    ``setup.model``; return the fit report. A closed-form recipe is fitted by its own ``fit``
    (its config gains the seed and thread count; nothing to resume). ``resume``: :func:`fit`'s."""
    if recipe(setup.model_name).closed_form:  # derived from its model (psmforce.estimators.networks.contract)
        setup.model, report = _fit_closed_form(setup, train_trials, val_trials, cfg)
        return report
    torch.manual_seed(cfg.seed)
    setup.model = build_model(setup.model_name, len(setup.features), setup.config)
    t0 = time.perf_counter()
    report = fit(setup.model, train_trials, val_trials, setup, cfg,
                 desc=desc or setup.model_name, resume=resume)
    # a resumed run's earlier processes count: the history's clock runs across resumes
    report["seconds"] = max(time.perf_counter() - t0, report["history"][-1]["elapsed_s"]
                            if report["history"] else 0.0)
    report["parameters"] = count_parameters(setup.model)
    return report


def finetune_model(setup: TrainedModel, train_trials: Sequence[Trial],
                   val_trials: Sequence[Trial], cfg: TrainConfig, *,
                   desc: str = "finetune", resume: str | Path | None = None) -> dict:
    """Freeze all but the last decoder block of ``setup.model``, train that on new data with the
    pretrained scalers (the paper's transfer protocol). Frozen parts run in eval mode (no
    dropout): they act as a fixed feature extractor; a closed-form model keeps its features and
    refits its head. Returns the fit report with trainable/total parameter counts. ``resume``:
    :func:`fit`'s."""
    if isinstance(setup.model, ClosedFormModel):
        return _fit_closed_form(setup, train_trials, val_trials, cfg, head_of=setup.model)[1]
    trainable, total = freeze_for_finetuning(setup.model)
    t0 = time.perf_counter()
    report = fit(setup.model, train_trials, val_trials, setup, cfg, desc=desc,
                 frozen_in_eval=True, resume=resume)
    report.update(seconds=time.perf_counter() - t0, trainable_parameters=trainable,
                  parameters=total)
    return report


# --------------------------------------------------------------------------- file-level API

def fit_prior(train_trials: Sequence[Trial], validation_trials: Sequence[Trial] = (), psm=None,
              crosstalk: bool = False):
    """The internal-force prior fitted on training trials (all conditions: the fit removes the
    known ATI force from the HEX10 reading), :mod:`psmforce.identification.prior`; with
    ``validation_trials``, weighted per component by what they support
    (:mod:`psmforce.identification.prior_support`: the prior stays out of a component whose
    held-out internal wrench its law does not explain). ``crosstalk``: the law also fits the
    HEX10's cross-talk of fz into the other channels (``prior_law.CROSSTALK``), which the
    efforts reading otherwise holds at 0."""
    from psmforce.identification import InternalForcePrior
    from psmforce.identification.prior_support import weigh_prior
    prior = InternalForcePrior.fit([t.frame for t in train_trials], psm=psm, crosstalk=crosstalk,
                                   provenance={"trials": [t.path for t in train_trials]})
    if validation_trials:
        prior = weigh_prior(prior, [t.frame for t in validation_trials], psm)
    return prior


def _load_prior(prior):
    if prior is None or not isinstance(prior, (str, Path)):
        return prior
    from psmforce.identification import InternalForcePrior
    return InternalForcePrior.load(prior)


def _epochs(epochs) -> None:
    if isinstance(epochs, bool) or not isinstance(epochs, int) or epochs < 1:
        raise TrainingError(f"epochs must be an integer >= 1, got {epochs!r}")


def check_config(model: str, config: dict | None, features: Features = None,
                 use_prior: bool = True) -> None:
    """Refuse, before any data is read, a constructor ``config`` that does not build ``model``
    (unknown or ill-typed arguments): the model is built once, untrained, on the recipe's
    input count."""
    if config is None:
        return
    if not isinstance(config, dict):
        raise TrainingError(f"config must be a dict of the '{model}' model's constructor "
                            f"arguments, got {type(config).__name__}")
    n_features = len(recipe(model).inputs(features, use_prior).features)
    try:
        build_model(model, n_features, config)
    except (TypeError, ValueError) as err:
        raise TrainingError(f"config {config} does not build a '{model}' model: {err}") from None


def train(data_dir: str | Path, model: str, out_checkpoint: str | Path, *,
          features: Features = None, epochs: int = 100, seed: int = 0, device: str = "cpu",
          prior=None, use_prior: bool = True, config: dict | None = None,
          train_config: TrainConfig | None = None, resume: str | Path | None = None,
          prior_crosstalk: bool = False) -> dict:
    """Train ``model`` (a name of :data:`psmforce.estimators.networks.recipes.RECIPES`) on the ``train`` split of the
    dataset in ``data_dir`` (10 % of its trials per condition held out for validation, seeded) and
    write a checkpoint. ``features``: a name of
    :data:`psmforce.estimators.data.dataset.FEATURE_SETS` or a column list (the LSTM's inputs are
    fixed). Models whose recipe uses the prior: ``prior`` is an InternalForcePrior or the path of
    its JSON, fitted on the training trials when None; ``use_prior=False`` trains the "without the
    prior" ablation. ``config``: the model constructor's keyword arguments (e.g. ``{"uncertainty":
    True}`` for a hybrid that predicts its variance,
    :mod:`psmforce.estimators.networks.uncertainty`), checked before the data is read
    (:func:`check_config`). ``train_config`` defaults to the recipe's optimiser settings.
    ``resume``: a file for the loop's state (:func:`fit`), removed once the checkpoint is written.
    ``prior_crosstalk``: the fitted prior also fits the HEX10's cross-talk (:func:`fit_prior`).
    Returns a summary (losses, epochs, windows, seconds, checkpoint path)."""
    spec = recipe(model)
    _epochs(epochs)
    check_config(model, config, features, use_prior)
    inputs = spec.inputs(features, use_prior)
    if prior is not None and not inputs.uses_prior:
        raise TrainingError(f"a prior was given, but the '{model}' model "
                            f"{'is trained without one' if spec.uses_prior else 'uses none'}")
    if prior_crosstalk and (prior is not None or not inputs.uses_prior):
        raise TrainingError(f"prior_crosstalk (--prior-crosstalk): the prior is fitted here "
                            f"only for a model that uses one and when no prior is given "
                            f"('{model}'" + (", with a prior given)" if prior is not None
                                             else ", which is trained without a prior)"))
    cfg = train_config or TrainConfig(**spec.optimiser)
    cfg = TrainConfig(**{**cfg.to_dict(), "max_epochs": epochs, "seed": seed, "device": device})
    given_prior = _load_prior(prior) if inputs.uses_prior else None  # before the data is read
    dataset = load_dataset(data_dir)
    trials = dataset.select(split="train")
    if not trials:
        raise DatasetError(f"{data_dir}: no trials in a 'train' split")
    training_rate_hz(trials, root=dataset.root)  # one rate, in seconds, named by file
    train_trials, val_trials = split_validation(trials, 0.1, seed)
    prior_json = None
    if inputs.uses_prior:
        prior_json = prior_to_json(given_prior or fit_prior(train_trials, val_trials,
                                                            crosstalk=prior_crosstalk))
    DERIVATIONS[inputs.derivation](dataset, prior_json)
    setup = make_setup(model, train_trials, features=features, use_prior=use_prior,
                       prior_json=prior_json, config=config)
    report = train_model(setup, train_trials, val_trials, cfg, resume=resume)
    setup.provenance = {
        "data_dir": str(data_dir), "train_trials": [t.path for t in train_trials],
        "val_trials": [t.path for t in val_trials], "train_config": cfg.to_dict(),
        "best_val_loss": report["best_val_loss"], "epochs_run": report["epochs_run"],
        "seconds": report["seconds"], "history": report["history"]}
    setup.save(out_checkpoint)
    clear_state(resume)
    return {k: v for k, v in report.items() if k != "history"} | {"checkpoint": str(out_checkpoint)}


def finetune(checkpoint: str | Path, data_dir: str | Path, out: str | Path, *, epochs: int = 100,
             seed: int = 0, device: str = "cpu", splits: Sequence[str] | None = None,
             train_config: TrainConfig | None = None) -> dict:
    """Finetune a checkpoint's last decoder block on the trials of ``data_dir`` (``splits``: which
    split folders, default all but ``test``), 10 % held out for validation; writes ``out``."""
    _epochs(epochs)
    record = load_checkpoint(checkpoint, device)
    dataset = load_dataset(data_dir)
    record.derive(dataset)
    trials = (dataset.select(split=splits) if splits else
              [t for t in dataset.trials if t.split != "test"])
    if not trials:
        raise DatasetError(f"{data_dir}: no trials to finetune on (splits {splits})")
    cfg = train_config or TrainConfig()
    cfg = TrainConfig(**{**cfg.to_dict(), "max_epochs": epochs, "seed": seed, "device": device})
    rate_hz = training_rate_hz(trials, root=dataset.root)
    if abs(rate_hz - record.sample_rate_hz) > RATE_TOLERANCE * record.sample_rate_hz:
        raise DatasetError(f"{data_dir}: sampled at {rate_hz:.4g} Hz, but {checkpoint} was "
                           f"trained at {record.sample_rate_hz:.4g} Hz; a model is finetuned at "
                           f"its own rate")
    train_trials, val_trials = split_validation(trials, 0.1, seed)
    report = finetune_model(record, train_trials, val_trials, cfg)
    record.provenance = {
        **record.provenance, "finetuned_from": str(checkpoint),
        "finetune_data_dir": str(data_dir), "finetune_trials": [t.path for t in train_trials],
        "finetune_config": cfg.to_dict(), "trainable_parameters": report["trainable_parameters"]}
    record.save(out)
    return {k: v for k, v in report.items() if k != "history"} | {"checkpoint": str(out)}
