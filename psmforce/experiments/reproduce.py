"""`psmforce reproduce`: the seed paper's experiments on the simulated bench, as a comparison a
reviewer accepts.

The rules (they hold for every model, the hybrid and the baselines alike):

* **Convergence, not caps.** With the published budget (``"full"``) every model trains until its
  early stopping fires (patience 10 epochs on validation, learning rate x0.1 after 3, best
  weights kept: the paper's Table S1 protocol) or its epoch limit; each task records
  ``epochs_run``, ``stopped_by`` and ``converged``, and the learning curves. The ``"quick"`` and
  ``"cpu"`` budgets cap batches for smoke runs: their tables say "not converged".
* **Same data, inputs contract and post-processing.** One automated bench and one teleoperation
  bench per seed; validation split by trajectory family
  (:func:`psmforce.estimators.data.dataset.split_validation`); every model scored on the same
  samples, by the paper's metric (bias, centred median k = 71) and by the causal metrics a haptic
  loop gets (raw, and a causal 5 Hz low-pass), each beside its floor
  (:mod:`psmforce.estimators.evaluation.metrics`).
* **Seeds and spread.** Each seed is a new bench (simulator seed) and a new initialisation;
  tables give mean ± std over seeds (teleoperation: over seeds x folds; std the sample standard
  deviation, ddof 1, none for a single seed:
  :func:`psmforce.estimators.evaluation.tables.std_over_seeds`), and a model wins an axis only
  when its mean plus its std stays below every other model's mean minus that one's std;
  otherwise, or where one seed gives no std, the table says tie. The published run uses bench
  seeds never used while the hybrid was designed (the design used seed 0).

What it runs of each model (the label in its tables, the ablations, the data-efficiency fractions,
the published figures beside it) is the experiment plan, :data:`psmforce.experiments.plan.PLAN`.

The work is a grid of independent tasks (:mod:`psmforce.experiments.task_cache`): simulate a bench,
fit the prior, pretrain a (model, seed, variant, data fraction), finetune a (model, seed, fold).
Each is cached by its inputs under ``OUT/work/cache``, so an interrupted run resumes where it
stopped, ``OUT`` may be moved (or finished on another machine) and still resumes, and
``ray_address`` runs the same tasks on Ray. Inside a training task the loop's state is kept after
every epoch under ``OUT/work/resume`` (:mod:`psmforce.estimators.training.resume`): a run killed
mid-training resumes from its last epoch, bit-identical, and the file goes once the checkpoint is
written.

Size: the grid's tasks and their assembly into results. A task's registered name and version,
not where its function lives, make its cache key (:func:`psmforce.experiments.task_cache.task`);
each names the qualified name it had before (``formerly``), so runs cached by earlier releases
resume. The tables they feed live in :mod:`psmforce.estimators.evaluation.tables`.
"""

from __future__ import annotations

import dataclasses
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, Iterable, Sequence

import numpy as np
import torch

from psmforce.estimators.training.checkpoint import TrainedModel, load_checkpoint
from psmforce.estimators.networks.contract import is_chunk
from psmforce.estimators.data.dataset import (Dataset, Trial, load_dataset, split_validation,
                                              subsample_trials)
from psmforce.estimators.evaluation.evaluate import (EVAL_START, floor_metrics, predict_trial,
                                                     score_modes, scored_segment)
from psmforce.experiments.task_cache import (adopt_earlier_keys, cache_path, cached_result,
                                             run_grid, task)
from psmforce.estimators.evaluation.metrics import (AXES, POSTPROCESSING, axis_metrics,
                                                  lowpass_lag_samples)
from psmforce.estimators.networks.baselines import count_parameters
from psmforce.experiments.plan import plan
from psmforce.experiments.report import cpu_model
from psmforce.estimators.networks.recipes import DERIVATIONS, RECIPES, recipe
from psmforce.experiments.regimes import REGIMES, regime_settings
from psmforce.estimators.training.resume import clear_state
from psmforce.estimators.evaluation.tables import SPREAD, results_markdown, spread, verdicts
from psmforce.estimators.training.train import (TrainConfig, finetune_model, fit_prior, make_setup,
                                                train_model)
from psmforce.core.files import folder_sha256, write_bytes_atomic, write_text_atomic

BUDGETS: dict[str, dict] = {
    "full": {"pretrain": {"default": {}}, "finetune": {"default": {}}},
    "cpu": {"pretrain": {"transformer": {"max_epochs": 6, "max_batches_per_epoch": 8,
                                         "max_val_batches": 4},
                         "hybrid": {"max_epochs": 100, "max_batches_per_epoch": 32,
                                    "max_val_batches": 6},
                         "default": {"max_epochs": 10, "max_batches_per_epoch": 16,
                                     "max_val_batches": 6}},
            "finetune": {"default": {"max_epochs": 6, "max_batches_per_epoch": 8,
                                     "max_val_batches": 4}}},
    "quick": {"pretrain": {"default": {"max_epochs": 2, "max_batches_per_epoch": 3,
                                       "max_val_batches": 2}},
              "finetune": {"default": {"max_epochs": 1, "max_batches_per_epoch": 2,
                                       "max_val_batches": 1}}},
}
"""TrainConfig overrides per budget, stage and model ("default": every other model). ``full``:
the paper's protocol, trained to early stopping. ``cpu`` and ``quick`` cap batches: smoke runs,
never published as a comparison. A budget's settings are part of every task's cache key."""

DATA_FRACTIONS = (0.1, 0.3)
TELEOP_CONDITIONS = ("Rigid", "Soft", "Free")


def _config(budget: str, stage: str, seed: int, device: str, model: str,
            optimiser: dict) -> TrainConfig:
    """Budget caps + the task's optimiser settings (the model's recipe under the run's training
    regime, :func:`_recipe_params`; the paper's models' own are Table S1: automated data for
    pretraining; teleoperation finetuning uses lr 1e-3, weight decay 1e-4 for every model, and the
    LSTM keeps its 1000-sample sequences)."""
    hparams = dict(optimiser)
    if stage == "finetune":
        hparams = {k: v for k, v in hparams.items() if k not in ("lr", "weight_decay")}
    caps = BUDGETS[budget][stage]   # after the model's settings: a smoke run's caps win
    return TrainConfig(**{**hparams, **caps.get(model, caps["default"]), "seed": seed,
                          "device": device, "progress": False})


# ------------------------------------------------------------------------------ data and models

def _data_dir(run_dir: str, protocol: str, seed: int) -> Path:
    return Path(run_dir) / "data" / f"{protocol}_seed{seed}"


def _prior_path(run_dir: str, seed: int) -> Path:
    return Path(run_dir) / "data" / f"prior_seed{seed}.json"


@task("simulate", formerly=("hybrid.reproduce:_simulate_task",))
def _simulate_task(p: dict) -> dict:
    """Simulate one bench (a half-written folder from an interrupted run is removed first) and,
    for the automated one, fit the prior on its training trials and weigh it on the validation
    trials (:func:`psmforce.estimators.training.train.fit_prior`)."""
    from psmforce.sim import simulate
    out = _data_dir(p["run_dir"], p["protocol"], p["seed"])
    if out.exists():
        shutil.rmtree(out)
    from psmforce.sim.versions import Version
    summary = simulate(p["protocol"], scale=p["scale"], seed=p["seed"], out=out,
                       port=p.get("port", "none"),
                       version=Version.from_dict(p["sim"]) if "sim" in p else None)
    if p["protocol"] == "automated":
        train, val = _automated_split(load_dataset(out), p["seed"])
        prior = fit_prior(train, val)
        prior.save(_prior_path(p["run_dir"], p["seed"]))
    return {k: v for k, v in summary.items() if k in ("rows", "minutes", "seconds", "trials")
            } | {"sha256": folder_sha256(out)}


def _bench_on_disk(p: dict) -> bool:
    """Whether a simulate task's bench (and, for the automated one, its prior) is on disk."""
    return ((_data_dir(p["run_dir"], p["protocol"], p["seed"]) / "metadata.json").is_file()
            and (p["protocol"] != "automated" or _prior_path(p["run_dir"], p["seed"]).is_file()))


def _automated_split(ds: Dataset, seed: int) -> tuple[list[Trial], list[Trial]]:
    return split_validation(ds.select(split="train"), 0.1, seed)


def _load(run_dir: str, protocol: str, seed: int,
          derivations: Iterable[str] = tuple(DERIVATIONS)) -> Dataset:
    """A bench of the run with the derived columns of ``derivations`` (keys of
    :data:`psmforce.estimators.networks.recipes.DERIVATIONS`; default every one). A task asks only
    for what its models read: the LSTM's Jacobian maps, a wrench solve per sample, cost more than
    reading the recordings, so deriving them for every model slowed each task's start on a large
    bench."""
    ds = load_dataset(_data_dir(run_dir, protocol, seed))
    prior_json = _prior_path(run_dir, seed).read_text()
    for name in dict.fromkeys(derivations):
        DERIVATIONS[name](ds, prior_json)
    return ds


def _derivation(model: str, variant: str) -> str:
    """The derivation (a key of :data:`psmforce.estimators.networks.recipes.DERIVATIONS`) a variant of a model reads."""
    return recipe(model).inputs(*_request(variant)).derivation


def _request(variant: str) -> tuple[str | None, bool]:
    """(features, use_prior) of a variant: "full", "no_prior" or an input group of
    :data:`psmforce.estimators.data.dataset.FEATURE_SETS`."""
    return None if variant in ("full", "no_prior") else variant, variant != "no_prior"


def _setup(name: str, trials: Sequence[Trial], prior_json: str, variant: str) -> TrainedModel:
    features, use_prior = _request(variant)
    inputs = recipe(name).inputs(features, use_prior)
    return make_setup(name, trials, features=features, use_prior=use_prior,
                      prior_json=prior_json if inputs.uses_prior else None)


def _recipe_params(name: str, variant: str, regime: str = "own") -> dict:
    """The part of a model's recipe a training task's result depends on: the variant's inputs
    and the optimiser settings (the recipe's own, or those of a training ``regime``,
    :mod:`psmforce.experiments.regimes`). They go into the task's parameters, so a recipe
    change reruns the tasks it reaches instead of reading back what the previous recipe trained
    (a change of the model's code is not seen: rerun into a new ``out``)."""
    spec = recipe(name)
    features, use_prior = _request(variant)
    return {"inputs": dataclasses.asdict(spec.inputs(features, use_prior)),
            "optimiser": regime_settings(regime, spec)}


def task_device(model: str, device: str) -> str:
    """The device a model's tasks run on and are keyed by in a run on ``device``: a closed-form
    model fits and predicts on the CPU whatever it is given
    (:func:`psmforce.estimators.training.train.train_model`,
    :func:`psmforce.estimators.evaluation.evaluate.predict_trial`), so its tasks are the CPU's in a
    GPU run too, and the same fit is not redone under a second key."""
    return "cpu" if recipe(model).closed_form else device


def _compute_device(p: dict) -> str:
    """The device a task computes on: the run's ``finish_on`` where one is given (a run whose
    GPU is gone goes on on the CPU, its tasks keeping their keys), else the device its key
    holds. The training's history records each epoch's device."""
    return task_device(p["model"], p.get("finish_on") or p["device"])


def _regime_parameter(regime: str, model: str) -> dict:
    """A task's ``regime`` parameter: absent for ``"own"``, so that the tasks of runs made before
    regimes existed keep their keys, and for a closed-form model, which no regime changes."""
    return {} if regime == "own" or recipe(model).closed_form else {"regime": regime}


def _checkpoint(run_dir: str, p: dict) -> Path:
    regime = "" if p.get("regime", "own") == "own" else f"_{p['regime']}"
    return (Path(run_dir) / "checkpoints" / f"{p['model']}_{p['variant']}_f{p['fraction']}_"
                                            f"seed{p['seed']}_{p['budget']}_{p['device']}"
                                            f"{regime}.pt")


def _resume_path(checkpoint: Path) -> Path:
    """Where a training task keeps its loop's state between epochs (:mod:`psmforce.estimators.training.resume`), so
    that a killed run resumes inside the task, not only between tasks."""
    return checkpoint.parent.parent / "resume" / f"{checkpoint.stem}.state"


def _scores(setup: TrainedModel, trials: Sequence[Trial], device: str,
            preds: dict | None = None) -> dict:
    """Every post-processing's metrics overall and per condition, and per-trial paper metrics;
    ``preds``: the trials' estimates (trial path -> :func:`predict_trial`'s) where the caller
    has them already."""
    if preds is None:
        preds = {t.path: predict_trial(setup, t, device=device) for t in trials}
    bias = setup.recipe.bias_correction
    conditions = sorted({t.condition for t in trials})
    return {"overall": score_modes(preds, trials, bias=bias),
            "by_condition": {c: score_modes(preds, [t for t in trials if t.condition == c],
                                            bias=bias) for c in conditions},
            "per_trial": [axis_metrics(*scored_segment(preds[t.path], t, bias=bias))
                          for t in trials if t.condition != "Free" and len(t) > EVAL_START]}


def _training_summary(rep: dict) -> dict:
    keep = ("epochs_run", "stopped_by", "capped", "converged", "best_val_loss", "seconds",
            "devices", "train_windows", "val_windows", "batches_per_epoch", "chunk", "parameters")
    return {k: rep.get(k) for k in keep} | {"history": [
        {k: h[k] for k in ("epoch", "steps", "elapsed_s", "train_loss", "val_loss", "lr")}
        for h in rep["history"]]}


@task("pretrain", formerly=("hybrid.reproduce:_pretrain_task",))
def _pretrain_task(p: dict) -> dict:
    """Train one (model, seed, variant, fraction) on the automated bench, save its checkpoint,
    score it on the automated test set."""
    torch.set_num_threads(p["threads"])
    ds = _load(p["run_dir"], "automated", p["seed"], (_derivation(p["model"], p["variant"]),))
    train, val = _automated_split(ds, p["seed"])
    if p["fraction"] < 1:
        train = subsample_trials(train, p["fraction"], p["seed"])
    prior_json = _prior_path(p["run_dir"], p["seed"]).read_text()
    setup = _setup(p["model"], train, prior_json, p["variant"])
    path = _checkpoint(p["run_dir"], p)
    resume = _resume_path(path)
    rep = train_model(setup, train, val,
                      _config(p["budget"], "pretrain", p["seed"], _compute_device(p),
                              p["model"], p["recipe"]["optimiser"]),
                      desc=f"{p['model']} seed {p['seed']}", resume=resume)
    setup.provenance = {"reproduce": p, "train_trials": [t.path for t in train],
                        "val_trials": [t.path for t in val], "history": rep["history"]}
    setup.save(path)
    test = _scores(setup, ds.select(split="test"), _compute_device(p))
    clear_state(resume)  # only now: a task killed while scoring resumes its finished training
    return {"training": _training_summary(rep) | {"optimiser": p["recipe"]["optimiser"]},
            "checkpoint": str(path.relative_to(p["run_dir"])), "test": test}


def _teleop_folds(tele: Dataset) -> list[dict]:
    """Leave-one-configuration-out folds: per seen configuration and condition, demos 0 and 1
    train (one of them per condition held out for validation), demo 2 tests 'seen'; every demo
    of the left-out configuration tests 'unseen'."""
    configs = sorted({t.split for t in tele.trials})
    folds = []
    for unseen in configs:
        seen_train, seen_test = [], []
        for cfg in configs:
            if cfg == unseen:
                continue
            for cond in TELEOP_CONDITIONS:
                demos = sorted(tele.select(split=cfg, condition=cond), key=lambda t: t.path)
                seen_train += demos[:-1]
                seen_test += demos[-1:]
        folds.append({"unseen": unseen, "train": seen_train, "seen_test": seen_test,
                      "unseen_test": tele.select(split=unseen)})
    return folds


@task("finetune", formerly=("hybrid.reproduce:_finetune_task",))
def _finetune_task(p: dict) -> dict:
    """Finetune the pretrained (model, seed) on one teleoperation fold (last decoder block only,
    pretrained scalers, trained to early stopping) and score it per condition, seen and unseen."""
    torch.set_num_threads(p["threads"])
    ckpt = load_checkpoint(_checkpoint(p["run_dir"], {**p, "variant": "full", "fraction": 1.0}))
    tele = _load(p["run_dir"], "teleop", p["seed"], (ckpt.derivation,))
    fold = next(f for f in _teleop_folds(tele) if f["unseen"] == p["fold"])
    ft_train, ft_val = split_validation(fold["train"], 0.25, p["seed"])
    regime = "" if p.get("regime", "own") == "own" else f"_{p['regime']}"
    resume = Path(p["run_dir"]) / "resume" / (f"finetune_{p['model']}_{p['fold']}_seed{p['seed']}_"
                                               f"{p['budget']}_{p['device']}{regime}.state")
    rep = finetune_model(ckpt, ft_train, ft_val,
                         _config(p["budget"], "finetune", p["seed"], _compute_device(p),
                                 p["model"], p["recipe"]["optimiser"]),
                         desc=f"finetune {p['model']} {p['fold']}", resume=resume)
    scores = {}
    for which in ("seen", "unseen"):
        for cond in TELEOP_CONDITIONS:
            group = [t for t in fold[f"{which}_test"] if t.condition == cond]
            scores[f"{cond}/{which.capitalize()}"] = _scores(ckpt, group,
                                                             _compute_device(p))["overall"]
    clear_state(resume)
    return {"training": _training_summary(rep), "scores": scores,
            "parameters": {"trainable": rep["trainable_parameters"], "total": rep["parameters"]}}


@task("floor", formerly=("hybrid.reproduce:_floor_task",))
def _floor_task(p: dict) -> dict:
    """Each post-processing's floor on a bench's test trials (and teleop demos per group)."""
    auto = load_dataset(_data_dir(p["run_dir"], "automated", p["seed"]))
    test = auto.select(split="test")
    out = {"automated": floor_metrics(test),
           "automated_by_condition": {c: floor_metrics([t for t in test if t.condition == c])
                                      for c in sorted({t.condition for t in test})}}
    if p["teleop"]:
        tele = load_dataset(_data_dir(p["run_dir"], "teleop", p["seed"]))
        out["teleop"] = {c: floor_metrics(tele.select(condition=c)) for c in TELEOP_CONDITIONS}
    return out


# ------------------------------------------------------------------------------ the run

def _check_simulated_again(p: dict, result: dict, done: Path, record: bytes | None,
                           sha256: str | None, say: Callable[[str], None]) -> None:
    """A bench simulated again must be the files the run's cached tasks were computed on
    (``sha256``, from its first simulation's cached ``record`` at ``done``). When it is not
    (another machine's library versions can change a bit), the new bench and prior are removed
    and the first record put back, so every later call refuses the same way."""
    what = f"bench {p['protocol']} seed {p['seed']}"
    if record is None:
        return
    if sha256 is None:
        say(f"{what}: not checked against its first simulation (which recorded no digest)")
        return
    if result["sha256"] == sha256:
        return
    shutil.rmtree(_data_dir(p["run_dir"], p["protocol"], p["seed"]))
    if p["protocol"] == "automated":   # fitted on the new bench
        _prior_path(p["run_dir"], p["seed"]).unlink()
    write_bytes_atomic(done, record)
    raise ValueError(f"{what} simulated again in {p['run_dir']} differs from the one this run's "
                     "cached results were computed on (SHA-256 of its files; other library "
                     "versions?): they do not hold for it. Bring the run's work/data along, or "
                     "finish it where its benches simulate the same.")


def prepare_benches(out: str | Path, scale: float, seeds: Sequence[int], *, teleop: bool = True,
                    port: str = "none", sim_version=None, ray_address: str | None = None,
                    log: Callable[[str], None] | None = None) -> list[dict]:
    """Simulate (or find cached) each seed's benches of a run in ``out`` (the automated one with
    its fitted prior, and the teleoperation one when ``teleop``) and score their evaluation
    floors, the first stage of :func:`reproduce`; returns the floors per seed. With no seeds,
    only claims ``out`` for the bench (scale, port), so calls for different seeds may then run
    at once; one seed must not be prepared by two calls at once (both would write its bench).
    A run folder moved without its benches (``work/data``, nearly all of its bytes) to another
    machine gets them simulated again from their seeds, so an unfinished run travels light; a
    bench that comes back other files than its first simulation's is refused (ValueError), since
    the run's cached results were computed on those. ``sim_version``: the simulator version of
    the benches (:func:`psmforce.sim.versions.version`: a name, a ``Version`` or None, the
    default), like the scale a property of the run; a version other than the default keys the
    benches by its whole definition (``"sim"``), so a changed definition simulates anew."""
    from psmforce.sim import versions
    from psmforce.sim.dataset import check_scale_and_seed
    from psmforce.sim.port import port_by_name
    say = log or (lambda s: print(s, flush=True))
    port_by_name(port)
    sim = versions.version(sim_version)
    for s in seeds:  # before anything is written: a bad value must leave no OUT/work behind
        check_scale_and_seed(scale, s, "seeds")
    out = Path(out)
    # Every task is cached by all it depends on; only the benches (scale, port) are shared by
    # name. Without a port the file and the task parameters are those of runs made before the
    # port existed, so their caches stay valid.
    bench = ({"scale": scale} | ({} if port == "none" else {"port": port})
             | ({} if sim == versions.version() else {"sim": sim.to_dict()}))
    call_file = out / "work" / "scale.json"
    if out.exists() and any(out.iterdir()):
        if not call_file.exists() or json.loads(call_file.read_text()) != bench:
            raise ValueError(f"{out} holds another run or a run on another bench (scale, port) "
                             f"(refusing to mix benches; see {call_file})")
    call_file.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(call_file, json.dumps(bench))
    run_dir, cache = str((out / "work").resolve()), out / "work" / "cache"
    benches = [(_simulate_task, {"run_dir": run_dir, "protocol": proto, "seed": s, **bench})
               for s in seeds for proto in ("automated",) + (("teleop",) if teleop else ())]
    adopt_earlier_keys(cache, benches, say)  # a run cached by an earlier release: its names first
    first = {}   # a run moved without its benches: the seeds simulate them again
    for task, p in benches:
        done = cache_path(cache, task, p)
        if done.exists() and not _bench_on_disk(p):
            say(f"bench {p['protocol']} seed {p['seed']} is not in {run_dir}: simulating it again")
            first[done] = (done.read_bytes(), (cached_result(cache, task, p) or {}).get("sha256"))
            done.unlink()
    results = run_grid(benches, cache, ray_address=ray_address, log=say, adopt=False)
    for (task, p), result in zip(benches, results, strict=True):
        done = cache_path(cache, task, p)
        _check_simulated_again(p, result, done, *first.get(done, (None, None)), say)
    return run_grid([(_floor_task, {"run_dir": run_dir, "seed": s, "teleop": teleop})
                     for s in seeds], cache, log=say)


def reproduce(out: str | Path, scale: float = 0.1, seeds: Sequence[int] = (1, 2, 3),
              device: str = "cpu", *, budget: str = "full", threads: int = 2,
              finish_on: str | None = None, models: Sequence[str] | None = None,
              ablations: bool = True, efficiency: bool = True, teleop: bool = True,
              port: str = "none", regime: str = "own", sim_version=None,
              ray_address: str | None = None,
              log: Callable[[str], None] | None = None) -> dict:
    """Run (or resume) the grid into ``out`` and write ``results.md``, ``results.json``,
    ``learning_curves.json`` and figures there. ``out`` must be new, empty, or hold a previous run
    at the same scale: its finished tasks are reused, so a run resumes, and a later call with more
    seeds, models or parts adds only what is missing. ``models``: names of
    :data:`psmforce.estimators.networks.recipes.RECIPES` (default: all, in the table's order).
    ``port``: the cannula the shaft passes through on every bench of the run
    (:data:`psmforce.sim.port.PORT_NAMES`; ``"none"``, the paper's benchtop), like the scale a
    property of the run: one ``out`` per port. ``finish_on``: the device the tasks still to compute
    run on, when not ``device``: a run started on a GPU whose machine is gone finishes on the CPU,
    every task keeping the key of ``device`` and a training resuming its saved state
    (:mod:`psmforce.estimators.training.resume`); each training records the devices it ran on.
    ``regime``: the training regime of every network of the call
    (:data:`psmforce.experiments.regimes.REGIMES`; ``"own"``: each recipe's settings),
    which keys its tasks and names its checkpoints, so regimes share one ``out`` and its benches;
    ``results.json`` is the last call's. ``sim_version``: the simulator version of the run's
    benches (:func:`prepare_benches`; None: the default), one ``out`` per version."""
    say = log or (lambda s: print(s, flush=True))
    if budget not in BUDGETS:
        raise ValueError(f"unknown budget '{budget}'; known: {sorted(BUDGETS)}")
    if regime not in REGIMES:
        raise ValueError(f"unknown training regime '{regime}'; known: {list(REGIMES)}")
    models = tuple(RECIPES) if models is None else tuple(models)
    if set(models) - set(RECIPES) or not models:
        raise ValueError(f"models must be among {list(RECIPES)}, got {list(models)}")
    if not seeds:
        raise ValueError("at least one seed")
    repeated = sorted({s for s in seeds if list(seeds).count(s) > 1})
    if repeated:  # one seed twice would be averaged as two and show a spread of 0
        raise ValueError(f"seeds: {repeated[0]} given more than once; each seed is one "
                         f"independent bench and initialisation")
    out = Path(out)
    call = {"scale": scale, "seeds": list(seeds), "device": device, "finish_on": finish_on,
            "budget": budget, "models": list(models), "ablations": ablations,
            "efficiency": efficiency, "teleop": teleop, "port": port, "regime": regime}
    if sim_version is not None:
        from psmforce.sim.versions import version
        call["sim_version"] = version(sim_version).to_dict()
    floors = prepare_benches(out, scale, seeds, teleop=teleop, port=port,
                             sim_version=sim_version, ray_address=ray_address, log=say)
    run_dir, cache = str((out / "work").resolve()), out / "work" / "cache"
    common = {"run_dir": run_dir, "budget": budget, "budget_settings": BUDGETS[budget],
              "device": device, "finish_on": finish_on, "threads": threads}
    started = time.time()

    variants = [(m, "full", 1.0) for m in models]
    if ablations:
        variants += [(m, v, 1.0) for m in models for v in plan(m).ablations]
    if efficiency:
        variants += [(m, "full", f) for f in DATA_FRACTIONS for m in models
                     if plan(m).data_efficiency]
    # Main models over every seed first: an interrupted run has the headline comparison soonest.
    pre_specs = [(_pretrain_task, {**common, "device": task_device(m, device), "seed": s,
                                   "model": m, "variant": v, "fraction": f,
                                   "recipe": _recipe_params(m, v, regime),
                                   **_regime_parameter(regime, m)})
                 for m, v, f in variants for s in seeds]
    pre = run_grid(pre_specs, cache, ray_address=ray_address, log=say)
    pre_by = {(p["model"], p["variant"], p["fraction"], p["seed"]): r
              for (_, p), r in zip(pre_specs, pre)}
    # from the parameters, not the result: a result cached before the run folder moved names
    # the checkpoint where it was then
    checkpoints = {(p["model"], p["variant"], p["fraction"], p["seed"]): _checkpoint(run_dir, p)
                   for _, p in pre_specs}
    ft_specs = []
    if teleop:
        folds = [f"config_{k}" for k in range(3)]
        ft_specs = [(_finetune_task, {**common, "device": task_device(m, device), "seed": s,
                                      "model": m, "fold": f,
                                      "recipe": _recipe_params(m, "full", regime),
                                      **_regime_parameter(regime, m)})
                    for s in seeds for m in models for f in folds]
    ft = run_grid(ft_specs, cache, ray_address=ray_address, log=say)

    results = _collect(call, seeds, models, variants, pre_by, ft_specs, ft, floors,
                       started, out, ray_address)
    # a closed-form model (MultiRocket-Hydra) is left out of the timing and the figures of
    # trained networks: it has no learning curve, and its batch-1 latency is not a network's
    torch_models = [m for m in models if not recipe(m).closed_form]
    results["timing"] = _timing({plan(m).label: checkpoints[(m, "full", 1.0, seeds[0])]
                                 for m in torch_models})
    results["figures"] = _figures(out, run_dir, seeds[0], torch_models, pre_by, checkpoints,
                                  finish_on or device)
    write_text_atomic(out / "results.json", json.dumps(results, indent=1) + "\n")
    write_text_atomic(out / "learning_curves.json", json.dumps(_curves(pre_specs, pre), indent=1))
    write_text_atomic(out / "results.md", results_markdown(results))
    say(f"done -> {out / 'results.md'}")
    return results


def _code_version() -> dict:
    """The package version and, in a git checkout, the commit of the code rendering the tables
    (cached tasks keep what the code that ran them computed)."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        ours = version("psmforce")
    except PackageNotFoundError:
        ours = "unknown"
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, cwd=Path(__file__).parent, timeout=10,
                                check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = None
    return {"psmforce": ours, "git_commit": commit}


def _machine() -> dict:
    """What a training's floats depend on besides the code, its inputs and its seed: the
    processor, the instruction set torch dispatches its CPU kernels to (MKL and torch choose
    kernels per processor, so a training on one seed may end a few rounding errors apart on
    another machine, and one stopped by patience at another epoch), torch and its threads."""
    return {"platform": platform.platform(), "cpu": cpu_model(),
            "cpu_capability": torch.backends.cpu.get_cpu_capability(),
            "cpu_count": os.cpu_count(), "torch": torch.__version__,
            "torch_threads": torch.get_num_threads()}


def _bench_versions(run_dir: Path, seeds: Sequence[int], teleop: bool) -> dict:
    """{bench: simulator version} from each simulated bench's metadata.json."""
    protocols = ("automated",) + (("teleop",) if teleop else ())
    return {f"{proto} seed {s}": json.loads((_data_dir(str(run_dir), proto, s) / "metadata.json")
                                            .read_text()).get("simulator_version")
            for proto in protocols for s in seeds}


def _collect(call, seeds, models, variants, pre_by, ft_specs, ft, floors, started, out,
             ray_address) -> dict:
    main = {plan(m).label: [pre_by[(m, "full", 1.0, s)] for s in seeds] for m in models}
    automated = {mode: {lab: spread([r["test"]["overall"][mode] for r in rs])
                        for lab, rs in main.items()} for mode in POSTPROCESSING}
    # per seed, in the order of call["seeds"]: what a paired comparison reads
    per_seed = {mode: {lab: [{a: r["test"]["overall"][mode][a]["nrmse_pct"] for a in AXES}
                             for r in rs] for lab, rs in main.items()} for mode in POSTPROCESSING}
    conditions = sorted(next(iter(main.values()))[0]["test"]["by_condition"])
    by_condition = {c: {mode: {lab: spread([r["test"]["by_condition"][c][mode] for r in rs])
                               for lab, rs in main.items()} for mode in POSTPROCESSING}
                    for c in conditions}
    training = {f"{m} {v} {f} seed {s}": {k: vv for k, vv in pre_by[(m, v, f, s)][
        "training"].items() if k != "history"} for m, v, f in variants for s in seeds}
    ablation = {f"{m} {v}": {mode: spread([pre_by[(m, v, 1.0, s)]["test"]["overall"][mode]
                                            for s in seeds]) for mode in POSTPROCESSING}
                for m, v, f in variants if v != "full"}
    efficiency = {}
    for m, v, f in variants:
        if f < 1:
            for frac in (f, 1.0):
                efficiency.setdefault(plan(m).label, {})[str(frac)] = {
                    mode: spread([pre_by[(m, v, frac, s)]["test"]["overall"][mode]
                                   for s in seeds]) for mode in POSTPROCESSING}
    teleop, ft_training = {}, {}
    for (_, p), r in zip(ft_specs, ft):
        for group, by_mode in r["scores"].items():
            teleop.setdefault(group, {}).setdefault(plan(p["model"]).label, []).append(by_mode)
        ft_training[f"{p['model']} {p['fold']} seed {p['seed']}"] = {
            k: v for k, v in r["training"].items() if k != "history"}
    teleop = {g: {mode: {lab: spread([x[mode] for x in runs]) for lab, runs in labs.items()}
                  for mode in POSTPROCESSING} for g, labs in teleop.items()}
    floor = {"automated": {mode: spread([f["automated"][mode] for f in floors])
                           for mode in POSTPROCESSING},
             "teleop": {c: {mode: spread([f["teleop"][c][mode] for f in floors])
                            for mode in POSTPROCESSING} for c in TELEOP_CONDITIONS}
             if call["teleop"] else {}}
    return {
        "command": " ".join(sys.argv) if sys.argv and sys.argv[0] else None, "call": call,
        "code": _code_version(), "benches": _bench_versions(out / "work", seeds, call["teleop"]),
        "budget": BUDGETS[call["budget"]], "executor": f"ray {ray_address}" if ray_address
        else "in-process",
        "machine": _machine(),
        "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(started)),
        "duration_s": round(time.time() - started, 1),
        "all_converged": all(t["converged"] for t in training.values())
        and all(t["converged"] for t in ft_training.values()),
        "training": training, "finetune_training": ft_training,
        "causal_lowpass_lag_ms": lowpass_lag_samples() * 10.0,
        "spread": SPREAD, "automated": automated, "automated_nrmse_pct_per_seed": per_seed,
        "automated_by_condition": by_condition, "floor": floor,
        "published_nrmse_pct": {plan(m).label: plan(m).published_nrmse_pct for m in models
                                if plan(m).published_nrmse_pct},
        "ablation": ablation,
        "data_efficiency": efficiency, "teleop": teleop,
        "verdicts": {mode: verdicts(automated[mode]) for mode in POSTPROCESSING},
    }


def _curves(specs, results) -> dict:
    return {f"{p['model']} {p['variant']} {p['fraction']} seed {p['seed']}":
            r["training"]["history"] for (_, p), r in zip(specs, results)}


def _timing(checkpoints: dict, reps: int = 300) -> dict:
    """Batch-1 latency of one force estimate per model on one CPU thread (ms over ``reps``
    calls: mean, sample std with ddof 1, p99).
    Window models recompute their window; a streaming model runs one step of its numpy backend
    where it has one (the hybrid: key / value cache), else of the torch one; the LSTM one
    recurrent step (state carried). Network only."""
    from psmforce.estimators.runtime.steppers import has_numpy_path, make_backend
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    out = {}
    try:
        for label, path in checkpoints.items():
            ckpt = load_checkpoint(path)
            model, n_f = ckpt.model.eval(), len(ckpt.features)
            with torch.no_grad():
                if not is_chunk(model):
                    x = torch.randn(1, model.window, n_f)
                    call, mode = (lambda: model(x)), "full window"
                elif ckpt.recipe.streams:
                    stepper = make_backend(model, "numpy" if has_numpy_path(model) else "torch")
                    x1 = np.random.default_rng(0).normal(size=n_f).astype(np.float32)
                    call, mode = (lambda: stepper.step(x1)), f"streaming step ({stepper.backend})"
                else:
                    x1 = torch.randn(1, n_f)
                    state = [model.step(x1)[1]]

                    def call():
                        _, state[0] = model.step(x1, state[0])
                    mode = "streaming step (LSTM state)"
                for _ in range(30):
                    call()
                times = []
                for _ in range(reps):
                    t0 = time.perf_counter()
                    call()
                    times.append(time.perf_counter() - t0)
            ms = np.array(times) * 1e3
            out[label] = {"ms_mean": float(ms.mean()), "ms_std": float(ms.std(ddof=1)),
                          "ms_p99": float(np.percentile(ms, 99)), "mode": mode,
                          "parameters": count_parameters(model)}
    finally:
        torch.set_num_threads(threads)
    return out


def _figures(out: Path, run_dir: str, seed: int, models, pre_by, checkpoints,
             device: str = "cpu") -> list[str]:
    """Time series, scatter and histogram of the first seed's models on its automated test set,
    and the learning curves of every pretraining (``models``: the trained networks; a run of
    closed-form models alone gets the sensor histogram only). The networks predict on the run's
    ``device``: the paper transformer over a paper-scale test set is minutes on a CPU."""
    from psmforce.estimators.evaluation.plots import (plot_ablation_boxes, plot_hex10_vs_ati,
                                                      plot_learning_curves, plot_scatter,
                                                      plot_time_series)
    fig_dir = out / "figures"
    ckpts = {m: load_checkpoint(checkpoints[(m, "full", 1.0, seed)], task_device(m, device))
             for m in models}
    test = _load(run_dir, "automated", seed,
                 [c.derivation for c in ckpts.values()]).select(split="test")
    plot_hex10_vs_ati(test, fig_dir / "hex10_vs_ati_histograms.png")
    if models:
        segments = {}
        for m, ckpt in ckpts.items():
            bias = ckpt.recipe.bias_correction
            on = task_device(m, device)
            segments[plan(m).label] = {t.path: scored_segment(predict_trial(ckpt, t, device=on),
                                                              t, bias=bias) for t in test}
        plot_time_series(segments, test, fig_dir / "automated_time_series.png")
        plot_scatter(segments, fig_dir / "automated_scatter.png")
        curves = {plan(m).label: [pre_by[k]["training"]["history"] for k in pre_by
                                  if k[0] == m and k[1] == "full" and k[2] == 1.0] for m in models}
        plot_learning_curves(curves, fig_dir / "learning_curves.png")
    for m in models:  # one box plot per model with ablations: its variants side by side
        boxes = {f"{m} {k[1]}": [] for k in pre_by if k[0] == m and k[2] == 1.0}
        for k, r in pre_by.items():
            if k[0] == m and k[2] == 1.0:
                boxes[f"{m} {k[1]}"] += r["test"]["per_trial"]
        if len(boxes) > 1:
            plot_ablation_boxes(boxes, fig_dir / f"ablation_boxplots_{m}.png")
    return sorted(str(p.relative_to(out)) for p in fig_dir.glob("*.png"))
