"""`psmforce reproduce`: the seed paper's experiments on the simulated bench, end to end.

Stages (each timed, each printed as it finishes):

1. simulate the automated benchtop protocol and the teleoperation protocol at ``scale``
   (:func:`psm_model.sim.simulate`; 1.0 = the paper's amount of data);
2. fit the internal-force prior on the automated training trials (:mod:`psm_model.identification`)
   and derive its columns, and the LSTM's Jacobian-map columns, for every trial;
3. train the four estimators on the same split (transformer, fcn, lstm, hybrid) and score them on
   the automated test set (the paper's Table III layout);
4. ablations: the hybrid without the prior, and the paper's input ablations (no HEX10, no efforts,
   no positions, no velocities, no positions+velocities) applied to the hybrid's inputs;
5. data efficiency: hybrid and paper transformer on 10 / 30 / 100 % of the training trials;
6. teleoperation: leave-one-configuration-out finetuning of the pretrained models (last decoder
   block only) and scores on seen / unseen configurations per contact condition (Table IV layout);
7. inference timing per model (batch 1, one thread, CPU);
8. ``results.md``, ``results.json`` and PNG figures in ``out``.

Compute budgets (``budget``): ``"full"`` is the paper's (100 epochs, every window each epoch,
early stopping); ``"cpu"`` caps epochs and batches per epoch so a run fits in well under an hour
on 2 CPU cores; ``"quick"`` is a smoke run for CI. The budget used is written into the results.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import torch

from hybrid.data import (Dataset, Trial, load_dataset, lstm_columns, split_validation,
                         subsample_trials)
from hybrid.evaluate import (automated_table, predict_trial, score, scored_segment, teleop_table,
                             uses_bias_correction, write_text_atomic)
from hybrid.metrics import AXES, axis_metrics
from hybrid.models import count_parameters
from hybrid.train import (MODEL_DEFAULTS, Setup, TrainConfig, finetune_model, fit_prior,
                          hybrid_feature_set, make_setup, save_setup, train_model)

BUDGETS: dict[str, dict] = {
    "full": {"pretrain": {"default": {}}, "finetune": {"default": {}}},
    "cpu": {"pretrain": {"transformer": {"max_epochs": 6, "max_batches_per_epoch": 8,
                                         "max_val_batches": 4},
                         "hybrid": {"max_epochs": 100, "max_batches_per_epoch": 32,
                                    "max_val_batches": 6},
                         "default": {"max_epochs": 10, "max_batches_per_epoch": 16,
                                     "max_val_batches": 6}},
            "finetune": {"transformer": {"max_epochs": 4, "max_batches_per_epoch": 6,
                                         "max_val_batches": 3},
                         "default": {"max_epochs": 6, "max_batches_per_epoch": 8,
                                     "max_val_batches": 4}}},
    "quick": {"pretrain": {"default": {"max_epochs": 2, "max_batches_per_epoch": 3,
                                       "max_val_batches": 2}},
              "finetune": {"default": {"max_epochs": 1, "max_batches_per_epoch": 2,
                                       "max_val_batches": 1}}},
}
"""TrainConfig overrides per budget, stage and model ("default": every other model). A window-
model batch is 256 windows (one supervised sample each, paper transformer ~5-20 ms per window
forward + backward on this CPU); a chunk-model batch is 16 chunks of 400 samples with 300
supervised each. "cpu" fits a whole run at scale 0.05 in about half an hour on 2 shared cores."""

PAPER_TRANSFORMER_NRMSE = {"Fx": 1.45, "Fy": 1.31, "Fz": 2.26}
"""Seed paper, Table III, transformer NRMSE (%) on its automated test set."""

ABLATION_GROUPS = ("no_hex10", "no_efforts", "no_positions", "no_velocities",
                   "no_positions_velocities")
DATA_FRACTIONS = (0.1, 0.3)
TELEOP_CONDITIONS = ("Rigid", "Soft", "Free")
LABELS = {"transformer": "Transformer (paper)", "fcn": "FCN", "lstm": "LSTM (Yang et al.)",
          "hybrid": "Hybrid (ours)"}


class _Log:
    def __init__(self, write: Callable[[str], None]):
        self.write, self.t0, self.stages = write, time.perf_counter(), {}

    def stage(self, name: str, since: float) -> None:
        sec = time.perf_counter() - since
        self.stages[name] = round(sec, 1)
        self.write(f"[{time.perf_counter() - self.t0:7.1f} s] {name}: {sec:.1f} s")


def _config(budget: str, stage: str, seed: int, device: str, model: str) -> TrainConfig:
    """Budget caps + the paper's per-model optimiser settings (Table S1: automated data for
    pretraining; teleoperation finetuning uses lr 1e-3, weight decay 1e-4 for every model)."""
    hparams = MODEL_DEFAULTS.get(model, {}) if stage == "pretrain" else {}
    caps = BUDGETS[budget][stage]
    return TrainConfig(**{**caps.get(model, caps["default"]), **hparams, "seed": seed,
                          "device": device, "progress": False})


def _score_models(models: dict, trials: Sequence[Trial], device: str,
                  by_condition: bool = False) -> tuple[dict, dict, dict]:
    """{label: metrics}, {label: {trial path: (post-processed pred, truth)}} and, with
    ``by_condition``, {condition: {label: metrics}} from the same predictions."""
    metrics, segments, per_cond = {}, {}, {}
    conditions = sorted({t.condition for t in trials}) if by_condition else []
    for label, (model, setup) in models.items():
        preds = {t.path: predict_trial(model, setup, t, device=device) for t in trials}
        bias = uses_bias_correction(setup.model_name)
        metrics[label] = score(preds, trials, bias=bias)
        segments[label] = {t.path: scored_segment(preds[t.path], t, bias=bias) for t in trials}
        for c in conditions:
            per_cond.setdefault(c, {})[label] = score(
                preds, [t for t in trials if t.condition == c], bias=bias)
    return metrics, segments, per_cond


def _per_trial_metrics(segments: dict, trials: Sequence[Trial]) -> list[dict]:
    """Axis metrics of each contact (non-free) test trial, for the ablation box plots."""
    return [axis_metrics(*segments[t.path]) for t in trials if t.condition != "Free"]


def _timing(models: dict, reps: int = 300) -> dict:
    """Batch-1 latency of one force estimate per model on one CPU thread (ms, Hz; mean ± std).
    Window models recompute their window; the LSTM runs one streaming step (state carried); the
    hybrid one streaming step of its numpy backend (:class:`hybrid.causal.NumpyStepper`, key /
    value cache). Network only: the prior and input scaling are not included (the real-time
    benchmark, benchmarks/streaming.py, times the whole pipeline)."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    out = {}
    try:
        for label, (model, setup) in models.items():
            model = model.to("cpu").eval()
            n_f = len(setup.features)
            with torch.no_grad():
                if model.kind == "window":
                    x = torch.randn(1, model.window, n_f)
                    call = lambda: model(x)  # noqa: E731
                    mode = "full window"
                elif setup.model_name == "hybrid":
                    from hybrid.causal import NumpyStepper
                    stepper = NumpyStepper(model)
                    x1 = np.random.default_rng(0).normal(size=n_f).astype(np.float32)
                    call = lambda: stepper.step(x1)  # noqa: E731
                    mode = "streaming step (numpy, KV cache)"
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
            out[label] = {"ms_mean": float(ms.mean()), "ms_std": float(ms.std()),
                          "ms_p99": float(np.percentile(ms, 99)),
                          "hz_mean": float(np.mean(1e3 / ms)), "hz_std": float(np.std(1e3 / ms)),
                          "mode": mode}
    finally:
        torch.set_num_threads(threads)
    return out


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


def teleop_loco(models: dict, tele: Dataset, *, budget: str, seed: int, device: str,
                log: Callable[[str], None] = print) -> tuple[dict, dict, dict]:
    """Leave-one-configuration-out finetuning (:func:`_teleop_folds`) of each pretrained
    ``{label: (model, setup)}`` (copied, last decoder block only, pretrained scalers) and its
    scores per (condition, seen/unseen) and fold. Returns (scores, unseen config_0 segments for
    plotting, trainable/total parameters per label)."""
    teleop: dict = {}
    segments: dict = {}
    params: dict = {}
    for fold in _teleop_folds(tele):
        ft_train, ft_val = split_validation(fold["train"], 0.25, seed)
        for label, (pre_model, pre_setup) in models.items():
            model = _clone(pre_model)
            rep = finetune_model(model, pre_setup, ft_train, ft_val,
                                 _config(budget, "finetune", seed, device, pre_setup.model_name),
                                 desc=f"finetune {label} ({fold['unseen']} unseen)")
            params[label] = {"trainable": rep["trainable_parameters"], "total": rep["parameters"]}
            for which in ("seen", "unseen"):
                trials = fold[f"{which}_test"]
                for cond in TELEOP_CONDITIONS:
                    group = [x for x in trials if x.condition == cond]
                    m, segs, _ = _score_models({label: (model, pre_setup)}, group, device)
                    teleop.setdefault(label, {}).setdefault(f"{cond}/{which.capitalize()}",
                                                            []).append(m[label])
                    if which == "unseen" and fold["unseen"] == "config_0":
                        segments.setdefault(label, {}).update(segs[label])
        log(f"    fold {fold['unseen']} unseen done")
    return teleop, segments, params


def teleop_from_checkpoints(checkpoints: dict, teleop_dir: str | Path, out: str | Path, *,
                            budget: str = "cpu", seed: int = 0, device: str = "cpu") -> dict:
    """The teleoperation table for trained checkpoints ``{label: path}`` on a simulated teleop
    dataset: writes ``teleop.md`` and ``teleop.json`` into ``out`` and returns the scores."""
    from hybrid.checkpoint import load_checkpoint
    from hybrid.evaluate import derive_for_checkpoint, setup_from_checkpoint
    models = {}
    tele = None
    for label, path in checkpoints.items():
        ckpt = load_checkpoint(path, device)
        tele = load_dataset(teleop_dir)
        derive_for_checkpoint(tele, ckpt)
        models[label] = (ckpt.model, setup_from_checkpoint(ckpt))
        per_model = {label: models[label]}
        scores, _, params = teleop_loco(per_model, tele, budget=budget, seed=seed, device=device)
        models[label] = {"scores": scores[label], "finetune_parameters": params[label],
                         "checkpoint": str(path)}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    result = {"teleop_dir": str(teleop_dir), "budget": budget, "seed": seed, "models": models}
    write_text_atomic(out / "teleop.json", json.dumps(result, indent=2) + "\n")
    write_text_atomic(out / "teleop.md", teleop_table({k: v["scores"] for k, v in models.items()}))
    return result


def reproduce(out: str | Path, scale: float = 0.05, device: str = "cpu", seed: int = 0, *,
              budget: str | None = None, threads: int = 2,
              log: Callable[[str], None] | None = None) -> dict:
    """Run every stage (module docstring) into the empty or new folder ``out``; return the
    results dict also written to ``out/results.json``. ``budget`` defaults to ``"full"`` on a
    CUDA device and ``"cpu"`` otherwise."""
    from psm_model import PSM
    from psm_model.sim import simulate
    from hybrid.hybrid import add_prior_columns, prior_to_json, select_base
    from hybrid.plots import (plot_ablation_boxes, plot_hex10_vs_ati, plot_scatter,
                              plot_time_series)

    budget = budget or ("full" if str(device).startswith("cuda") else "cpu")
    if budget not in BUDGETS:
        raise ValueError(f"unknown budget '{budget}'; known: {sorted(BUDGETS)}")
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise ValueError(f"{out} is not empty (refusing to mix runs)")
    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(threads)
    say = _Log(log or (lambda s: print(s, flush=True)))
    started = time.time()

    # 1. data -------------------------------------------------------------------------------
    t = time.perf_counter()
    sim = {p: simulate(p, scale=scale, seed=seed, out=out / "data" / p)
           for p in ("automated", "teleop")}
    auto, tele = load_dataset(out / "data" / "automated"), load_dataset(out / "data" / "teleop")
    say.stage("simulate + load", t)

    # 2. prior and derived columns --------------------------------------------------------
    t = time.perf_counter()
    pool = auto.select(split="train")
    train_trials, val_trials = split_validation(pool, 0.1, seed)
    test_trials = auto.select(split="test")
    psm = PSM()
    prior = fit_prior(train_trials, psm)
    for ds in (auto, tele):
        ds.add_columns(lstm_columns(psm))
        add_prior_columns(ds, prior)
    prior_json = prior_to_json(prior)
    say.stage("prior fit + derived columns", t)

    def setup_for(name: str, trials, features=None, use_prior: bool = True) -> Setup:
        if name == "hybrid":
            feats, base = hybrid_feature_set(features, use_prior)
            return make_setup("hybrid", trials, features=feats,
                              base_columns=select_base(trials, base),
                              derivation="prior" if use_prior else "none",
                              prior_json=prior_json if use_prior else None)
        return make_setup(name, trials, features=features)

    def train_one(name: str, trials, features=None, use_prior: bool = True, desc=None):
        setup = setup_for(name, trials, features, use_prior)
        model, rep = train_model(setup, trials, val_trials,
                                 _config(budget, "pretrain", seed, device, name), desc=desc)
        say.write(f"    {desc or name}: {rep['epochs_run']} epochs, "
                  f"best val {rep['best_val_loss']:.4f}, "
                  f"{rep['seconds']:.0f} s, {rep['train_windows']} train windows/chunks")
        return model, setup, rep

    # 3. the four estimators ---------------------------------------------------------------
    models, reports = {}, {}
    for name in ("transformer", "fcn", "lstm", "hybrid"):
        t = time.perf_counter()
        model, setup, rep = train_one(name, train_trials)
        models[LABELS[name]], reports[LABELS[name]] = (model, setup), rep
        say.stage(f"train {name}", t)
    for name in ("transformer", "fcn", "lstm", "hybrid"):
        model, setup = models[LABELS[name]]
        save_setup(out / "checkpoints" / f"{name}.pt", model, setup,
                   provenance={"reproduce": str(out), "seed": seed, "scale": scale,
                               "budget": budget, "train_trials": [x.path for x in train_trials],
                               "val_trials": [x.path for x in val_trials],
                               "history": reports[LABELS[name]]["history"]})
    t = time.perf_counter()
    automated, segments, by_condition = _score_models(models, test_trials, device,
                                                      by_condition=True)
    say.stage("score automated test set", t)

    # 4. ablations (hybrid) --------------------------------------------------------------------
    t = time.perf_counter()
    ablation_models = {"hybrid (all inputs, prior)": models[LABELS["hybrid"]]}
    model, setup, _ = train_one("hybrid", train_trials, use_prior=False,
                                desc="hybrid without prior")
    ablation_models["hybrid without prior (raw HEX10 inputs and base)"] = (model, setup)
    for group in ABLATION_GROUPS:
        model, setup, _ = train_one("hybrid", train_trials, features=group, desc=f"hybrid {group}")
        ablation_models[f"hybrid {group}"] = (model, setup)
    ablation, ablation_segments, _ = _score_models(ablation_models, test_trials, device)
    ablation_boxes = {k: _per_trial_metrics(v, test_trials) for k, v in ablation_segments.items()}
    say.stage("ablations", t)

    # 5. data efficiency -----------------------------------------------------------------------
    t = time.perf_counter()
    efficiency = {name: {"1.0": automated[LABELS[name]]} for name in ("transformer", "hybrid")}
    for frac in DATA_FRACTIONS:
        subset = subsample_trials(train_trials, frac, seed)
        for name in ("transformer", "hybrid"):
            model, setup, _ = train_one(name, subset, desc=f"{name} {int(frac * 100)} %")
            efficiency[name][str(frac)] = _score_models({name: (model, setup)}, test_trials,
                                                        device)[0][name]
    say.stage("data efficiency", t)

    # 6. teleoperation, leave one configuration out ---------------------------------------
    t = time.perf_counter()
    teleop, teleop_segments, finetune_params = teleop_loco(
        {LABELS[n]: models[LABELS[n]] for n in ("transformer", "lstm", "hybrid")}, tele,
        budget=budget, seed=seed, device=device, log=say.write)
    say.stage("teleoperation finetuning (3 folds)", t)

    # 7. timing ------------------------------------------------------------------------------
    t = time.perf_counter()
    timing = _timing(models)
    say.stage("inference timing", t)

    # 8. figures and results ---------------------------------------------------------------
    t = time.perf_counter()
    plot_time_series(segments, test_trials, fig_dir / "automated_time_series.png")
    plot_scatter(segments, fig_dir / "automated_scatter.png")
    plot_hex10_vs_ati(test_trials, fig_dir / "hex10_vs_ati_histograms.png")
    plot_ablation_boxes(ablation_boxes, fig_dir / "ablation_boxplots.png")
    unseen0 = [x for x in tele.trials if x.split == "config_0"]
    plot_time_series(teleop_segments, unseen0, fig_dir / "teleop_unseen_time_series.png")
    say.stage("figures", t)

    results = {
        "command": " ".join(sys.argv) if sys.argv and sys.argv[0] else None,
        "call": {"out": str(out), "scale": scale, "device": device, "seed": seed,
                 "budget": budget, "threads": threads},
        "budget": BUDGETS[budget],
        "machine": {"platform": platform.platform(), "processor": platform.processor(),
                    "cpu_count": os.cpu_count(), "torch": torch.__version__,
                    "torch_threads": threads},
        "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(started)),
        "duration_s": round(time.time() - started, 1),
        "stage_seconds": say.stages,
        "data": {p: {k: v for k, v in s.items() if k in ("rows", "minutes", "seconds")}
                 for p, s in sim.items()},
        "split": {"train_trials": len(train_trials), "val_trials": len(val_trials),
                  "test_trials": len(test_trials)},
        "training": {k: {kk: vv for kk, vv in v.items() if kk != "history"}
                     for k, v in reports.items()},
        "parameters": {k: count_parameters(m) for k, (m, _) in models.items()},
        "finetune_parameters": finetune_params,
        "automated": automated, "automated_by_condition": by_condition,
        "paper_transformer_nrmse_pct": PAPER_TRANSFORMER_NRMSE,
        "ablation": ablation, "data_efficiency": efficiency, "teleop": teleop, "timing": timing,
        "figures": sorted(str(p.relative_to(out)) for p in fig_dir.glob("*.png")),
    }
    write_text_atomic(out / "results.json", json.dumps(results, indent=2) + "\n")
    write_text_atomic(out / "results.md", _markdown(results))
    say.write(f"done in {results['duration_s']:.0f} s -> {out / 'results.md'}")
    return results


def _clone(model):
    import copy
    return copy.deepcopy(model)


def _row(metrics: dict, key: str = "nrmse_pct") -> str:
    return " | ".join(f"{metrics[a][key]:.2f}" for a in AXES)


def _markdown(r: dict) -> str:
    lines = ["# Reproduction of the seed paper on the simulated bench", "",
             f"- command: `{r['command']}`", f"- call: `{r['call']}`",
             f"- machine: {r['machine']['platform']}, {r['machine']['cpu_count']} CPU cores, "
             f"torch {r['machine']['torch']} on {r['machine']['torch_threads']} threads",
             f"- started {r['started_utc']}, duration {r['duration_s']:.0f} s; stages (s): "
             f"{r['stage_seconds']}",
             f"- budget `{r['call']['budget']}`: {r['budget']}",
             f"- data: {r['data']}", f"- split (trials): {r['split']}", "",
             "## Automated test set (paper Table III layout)", "",
             automated_table(r["automated"], "Automated test set, all conditions"), ""]
    for cond, m in r["automated_by_condition"].items():
        lines += [automated_table(m, f"{cond} test trials"), ""]
    lines += ["## Paper transformer on our bench vs the paper's figures (NRMSE %)", "",
              "| | Fx | Fy | Fz |", "|---|---|---|---|",
              "| paper (real bench) | " + " | ".join(
                  f"{r['paper_transformer_nrmse_pct'][a]:.2f}" for a in AXES) + " |",
              f"| ours (simulated bench) | {_row(r['automated'][LABELS['transformer']])} |",
              f"| hybrid (simulated bench) | {_row(r['automated'][LABELS['hybrid']])} |", "",
              "## Ablations (hybrid; automated test set; NRMSE % / R² %)", "",
              "| Variant | NRMSE Fx | NRMSE Fy | NRMSE Fz | R² Fx | R² Fy | R² Fz |",
              "|---|---|---|---|---|---|---|"]
    for k, m in r["ablation"].items():
        lines.append(f"| {k} | {_row(m)} | {_row(m, 'r2_pct')} |")
    lines += ["", "## Data efficiency (automated test set NRMSE %, Fx / Fy / Fz)", "",
              "| Model | 10 % | 30 % | 100 % |", "|---|---|---|---|"]
    for name, by_frac in r["data_efficiency"].items():
        cells = [" / ".join(f"{by_frac[f][a]['nrmse_pct']:.2f}" for a in AXES)
                 for f in ("0.1", "0.3", "1.0")]
        lines.append(f"| {LABELS[name]} | " + " | ".join(cells) + " |")
    lines += ["", "## Teleoperation after finetuning (leave one configuration out; "
              "mean ± std over "
              "3 folds; paper Table IV layout)", "", teleop_table(r["teleop"]), "",
              f"Finetuned parameters (trainable / total): {r['finetune_parameters']}", "",
              "## Inference timing (batch 1, one CPU thread)", "",
              "| Model | Device | Mode | End-to-end (ms) | End-to-end (Hz) | p99 (ms) |",
              "|---|---|---|---|---|---|"]
    for k, v in r["timing"].items():
        lines.append(f"| {k} | CPU | {v['mode']} | {v['ms_mean']:.3f} ± {v['ms_std']:.3f} | "
                     f"{v['hz_mean']:.0f} ± {v['hz_std']:.0f} | {v['ms_p99']:.3f} |")
    lines += ["", "## Training", "", "| Model | parameters | epochs | best val loss | seconds | "
              "train windows/chunks |", "|---|---|---|---|---|---|"]
    for k, v in r["training"].items():
        lines.append(f"| {k} | {r['parameters'][k]} | {v['epochs_run']} | "
                     f"{v['best_val_loss']:.4f} | "
                     f"{v['seconds']:.0f} | {v['train_windows']} |")
    lines += ["", "## Figures", ""] + [f"![{Path(f).stem}]({f})" for f in r["figures"]]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    import argparse
    parser = argparse.ArgumentParser(description="teleoperation leave-one-configuration-out "
                                     "table for trained checkpoints (LABEL=PATH ...)")
    parser.add_argument("checkpoints", nargs="+", help="LABEL=checkpoint.pt")
    parser.add_argument("--teleop", required=True, help="simulated teleoperation dataset folder")
    parser.add_argument("--out", required=True)
    parser.add_argument("--budget", default="cpu", choices=sorted(BUDGETS))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    pairs = dict(c.split("=", 1) for c in args.checkpoints)
    print(teleop_table({k: v["scores"] for k, v in teleop_from_checkpoints(
        pairs, args.teleop, args.out, budget=args.budget, seed=args.seed)["models"].items()}))
