"""Does the internal-force prior earn its place, axis by axis? The hybrid with and without it.

Two benches, each at three bench seeds (simulator seed = split seed = initialisation seed; by
default the fresh seeds declared for this study, ``PRIOR_ABLATION_SEEDS`` in
:mod:`psmforce.experiments.seeds`: the first run chose the shipped inputs on seeds 1-3):

* ``standard``: the nominal instrument (its cable law lies in the prior's family, apart from the
  effects docs/simulator.md lists);
* ``crossing``: the same with the cables crossing the HEX10 section at
  ``--crossing-rad`` (default 0.03 rad, ``InstrumentParams.cable_crossing_angle_rad``): an
  internal lateral force the prior does not model.

Four hybrids per bench and seed, each trained to early stopping with the recipe's settings
(the same as ``psmforce reproduce --budget full``), on the same trials:

* ``weighted``: the hybrid as it ships, the prior fitted on the training trials and weighted
  per component on the validation trials (:mod:`psmforce.identification.prior_support`): the
  prior stays out of a component its law does not explain there;
* ``as_fitted``: the prior as fitted (every weight 1), the hybrid before the weights;
* ``no_prior``: the same hybrid with the prior's law switched off and nothing else
  (:func:`no_prior_inputs`): every component weight 0, so its compensated columns are the raw
  HEX10 reading and ``prior_fz`` (a constant 0) leaves the inputs; the insertion model fitted
  beside the prior stays, so the axial base is ``insertion_fz`` in both arms and "with" against
  "without" measures the prior alone. (Before issue 43 this arm was the recipe's
  ``use_prior=False`` ablation, paper inputs with the raw HEX10 force as the base on every axis:
  it dropped the insertion-effort base together with the prior, and its Fz "prior helps" mostly
  measured the insertion base.)
* ``raw_and_prior``: the weighted prior as the base where it helps, but beside the raw HEX10 reading
  among the inputs instead of subtracted from it
  (:data:`psmforce.estimators.data.hybrid_inputs.HYBRID_INPUTS_RAW_AND_PRIOR`): what the reading
  carries is not lost where the prior is wrong.

Every variant is scored on the validation trials too (the design is chosen there, not on test).

Scored on the bench's test trials by the causal metric a haptic loop gets and by the paper's offline
metric (:mod:`psmforce.estimators.evaluation.metrics`), NRMSE % per axis, mean and std over seeds
(the sample std, ddof 1).
Each (bench, seed, variant) result is cached under ``--work`` (default ``runs/prior_ablation``) so
an interrupted run resumes.

    python studies/prior_ablation.py --json results/benchmarks/prior_ablation.json
    python studies/prior_ablation.py --quick --json OUT.json   # one seed, small bench, minutes
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from psmforce.experiments.seeds import PRIOR_ABLATION_SEEDS  # noqa: E402
from psmforce.estimators.data.dataset import load_dataset, split_validation  # noqa: E402
from psmforce.estimators.evaluation.evaluate import predict_trial, score_modes  # noqa: E402
from psmforce.estimators.data.hybrid_inputs import (  # noqa: E402
    BASE_COLUMNS,
    HYBRID_FEATURES,
    HYBRID_INPUTS_RAW_AND_PRIOR,
    INSERTION_FZ,
    INSERTION_STATE,
    prior_to_json,
    select_base,
)
from psmforce.estimators.networks.recipes import DERIVATIONS, Inputs, recipe  # noqa: E402
from psmforce.estimators.evaluation.tables import (  # noqa: E402
    compare,
    spread_text,
    std_over_seeds,
)
from psmforce.estimators.training.train import (TrainConfig, fit_prior, make_setup, train_model)  # noqa: E402
from psmforce.core.files import write_text_atomic  # noqa: E402
from psmforce.sim import simulate  # noqa: E402
from psmforce.sim.params import InstrumentParams  # noqa: E402

VARIANTS = ("weighted", "as_fitted", "no_prior", "raw_and_prior")
CACHE_VERSION = 3
"""Bumped when a task's result changes shape or meaning (2: validation scores, raw_and_prior;
3: ``no_prior`` keeps the insertion-effort base)."""
AXES = ("Fx", "Fy", "Fz")
METRICS = ("causal", "paper")
NO_PRIOR_FEATURES = HYBRID_FEATURES + (INSERTION_FZ,) + INSERTION_STATE
"""The ``no_prior`` arm's inputs: the hybrid's (:data:`~psmforce.estimators.data.hybrid_inputs.
HYBRID_INPUTS`) without ``prior_fz``, which is 0 with the law switched off."""
QUICK = {"seeds": [1], "benches": ["standard"], "variants": ["weighted", "no_prior"],
         "scale": 0.02, "max_epochs": 5}
"""``--quick``: what the smoke run checks (minutes on 2 cores, not a result)."""


def law_switched_off(prior):
    """``prior`` with its law switched off (every component weight 0: its compensated columns
    are the raw HEX10 reading, ``prior_*`` 0) and its insertion model kept: the ``no_prior``
    arm's prior."""
    return prior.with_axis_weights(np.zeros(6), {"no_prior": "the law switched off, the "
                                                 "insertion model kept"})


def no_prior_inputs(train) -> Inputs:
    """The ``no_prior`` arm's inputs (:data:`NO_PRIOR_FEATURES`) and base, chosen as the
    hybrid's (``comp_fx``, ``comp_fy``, ``insertion_fz``, each kept where it helps on ``train``,
    whose columns come from :func:`law_switched_off`'s prior)."""
    return Inputs(NO_PRIOR_FEATURES, select_base(train, BASE_COLUMNS), (), "prior")


def _bench(work: Path, bench: str, seed: int, scale: float, crossing_rad: float) -> Path:
    out = work / "data" / f"{bench}_seed{seed}_scale{scale}"
    if not (out / "metadata.json").exists():
        if out.exists():  # a half-written bench from an interrupted run
            import shutil
            shutil.rmtree(out)
        angle = crossing_rad if bench == "crossing" else 0.0
        simulate("automated", scale=scale, seed=seed, out=out,
                 instrument=InstrumentParams(cable_crossing_angle_rad=angle))
    return out


def _task(work: Path, bench: str, seed: int, variant: str, scale: float,
          crossing_rad: float, max_epochs: int | None = None) -> dict:
    data = _bench(work, bench, seed, scale, crossing_rad)
    ds = load_dataset(data)
    train, val = split_validation(ds.select(split="train"), 0.1, seed)
    use_prior = variant != "no_prior"
    prior = fit_prior(train, () if variant == "as_fitted" else val)
    if variant == "no_prior":
        prior = law_switched_off(prior)
    prior_json = prior_to_json(prior)
    spec = recipe("hybrid")
    DERIVATIONS["prior"](ds, prior_json)
    inputs = None
    if variant == "raw_and_prior":
        inputs = Inputs(HYBRID_INPUTS_RAW_AND_PRIOR, select_base(train, BASE_COLUMNS), (),
                        "prior")
    elif variant == "no_prior":
        inputs = no_prior_inputs(train)
    setup = make_setup("hybrid", train, inputs=inputs, prior_json=prior_json)
    cfg = TrainConfig(**{**spec.optimiser, "seed": seed, "progress": False,
                         **({"max_epochs": max_epochs} if max_epochs else {})})
    rep = train_model(setup, train, val, cfg)
    scores, val_scores = (
        score_modes({t.path: predict_trial(setup, t) for t in trials}, trials,
                    bias=spec.bias_correction) for trials in (ds.select(split="test"), val))
    return {"bench": bench, "seed": seed, "variant": variant,
            "axis_weights": [float(w) for w in prior.axis_weights] if use_prior else None,
            "base_columns": list(setup.base_columns),
            "training": {k: rep.get(k) for k in ("epochs_run", "stopped_by", "converged",
                                                 "best_val_loss", "seconds")},
            "test": {m: {a: scores[m][a]["nrmse_pct"] for a in AXES} for m in METRICS},
            "validation": {m: {a: val_scores[m][a]["nrmse_pct"] for a in AXES} for m in METRICS}}


def _summary(tasks: list[dict]) -> dict:
    """{bench: {variant: {metric: {axis: {mean, std, seeds}}, "validation_causal": {axis: {mean,
    std}}}}} over the seeds: std the sample standard deviation (ddof 1; None for one seed,
    :func:`psmforce.estimators.evaluation.tables.std_over_seeds`)."""
    out = {}
    for bench in sorted({t["bench"] for t in tasks}):
        out[bench] = {}
        for variant in VARIANTS:
            runs = [t for t in tasks if t["bench"] == bench and t["variant"] == variant]
            if not runs:
                continue
            out[bench][variant] = {
                m: {a: {"mean": float(np.mean([r["test"][m][a] for r in runs])),
                        "std": std_over_seeds([r["test"][m][a] for r in runs]),
                        "seeds": [r["seed"] for r in runs]} for a in AXES} for m in METRICS}
            out[bench][variant]["validation_causal"] = {
                a: {"mean": float(np.mean([r["validation"]["causal"][a] for r in runs])),
                    "std": std_over_seeds([r["validation"]["causal"][a] for r in runs])}
                for a in AXES}
    return out


def _verdicts(summary: dict) -> dict:
    """Per bench, prior variant, metric and axis: the variant against the hybrid without the
    prior by the spread rule (a win needs mean + std below the other's mean - std, std the
    sample std over seeds; otherwise, or with one seed, a tie), with the ratio of means."""
    out = {}
    for bench, rows in summary.items():
        if "no_prior" not in rows:
            continue
        out[bench] = {}
        for variant in (v for v in rows if v != "no_prior"):
            out[bench][variant] = {}
            for m in METRICS:
                out[bench][variant][m] = {}
                for a in AXES:
                    w, n = rows[variant][m][a], rows["no_prior"][m][a]
                    v = {-1: "prior helps", 0: "tie", 1: "prior hurts"}[compare(w, n)]
                    out[bench][variant][m][a] = {"verdict": v, "ratio": w["mean"] / n["mean"]}
    return out


def _chosen(summary: dict) -> dict:
    """The variant with the lowest validation error relative to the hybrid without the prior
    (causal NRMSE, averaged over axes and benches, so that every axis weighs the same; the
    hybrid without the prior scores 1)."""
    scores = {}
    for variant in VARIANTS[:1] + VARIANTS[3:] + VARIANTS[1:2]:
        ratios = [rows[variant]["validation_causal"][a]["mean"]
                  / rows["no_prior"]["validation_causal"][a]["mean"]
                  for rows in summary.values() if {variant, "no_prior"} <= set(rows)
                  for a in AXES]
        if ratios:
            scores[variant] = float(np.mean(ratios))
    if scores:
        scores["no_prior"] = 1.0  # leaving the prior out is a candidate too
    best = min(scores, key=scores.get) if scores else None
    return {"variant": best, "validation_ratio_to_no_prior": scores}


def _shipped() -> str:
    """The variant the shipped hybrid recipe is (its inputs read from the recipe)."""
    raw_and_prior = tuple(recipe("hybrid").inputs(None, True).features) == tuple(
        HYBRID_INPUTS_RAW_AND_PRIOR)
    return "raw_and_prior" if raw_and_prior else "weighted"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(PRIOR_ABLATION_SEEDS),
                    help="bench seeds (default: the fresh seeds declared for this study, "
                         "psmforce/experiments/seeds.py)")
    ap.add_argument("--benches", nargs="+", default=["standard", "crossing"],
                    choices=["standard", "crossing"])
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS)
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--crossing-rad", type=float, default=0.03)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--work", type=Path, default=Path("runs/prior_ablation"))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--quick", action="store_true",
                    help="smoke run: " + ", ".join(f"{k} {v}" for k, v in QUICK.items())
                    + " (overrides those options; figures not comparable to the full run)")
    args = ap.parse_args(argv)
    max_epochs = None
    if args.quick:
        for key in ("seeds", "benches", "variants", "scale"):
            setattr(args, key, QUICK[key])
        max_epochs = QUICK["max_epochs"]
        args.work = args.work / "quick"
    if len(set(args.seeds)) != len(args.seeds):
        ap.error(f"--seeds: repeated seeds {args.seeds}")
    torch.set_num_threads(args.threads)
    cache = args.work / "cache"
    cache.mkdir(parents=True, exist_ok=True)
    started = time.time()
    tasks = []
    for bench in args.benches:
        for seed in args.seeds:
            for variant in args.variants:
                key = cache / (f"v{CACHE_VERSION}_{bench}_seed{seed}_{variant}_scale{args.scale}_"
                               f"x{args.crossing_rad}.json")
                if key.exists():
                    result = json.loads(key.read_text())
                else:
                    t0 = time.time()
                    result = _task(args.work, bench, seed, variant, args.scale,
                                   args.crossing_rad, max_epochs)
                    result["wall_s"] = time.time() - t0
                    write_text_atomic(key, json.dumps(result, indent=1))
                tasks.append(result)
                c = result["test"]["causal"]
                print(f"{bench:9s} seed {seed} {variant:10s} causal NRMSE % "
                      f"{c['Fx']:.2f} / {c['Fy']:.2f} / {c['Fz']:.2f}  "
                      f"epochs {result['training']['epochs_run']} "
                      f"({result['training']['stopped_by']})", flush=True)
    summary = _summary(tasks)
    figures = {
        "command": "python studies/prior_ablation.py " + " ".join(argv or sys.argv[1:]),
        "scale": args.scale, "crossing_rad": args.crossing_rad, "seeds": args.seeds,
        "quick": bool(args.quick), "max_epochs": max_epochs,
        "no_prior_arm": "the hybrid with the prior's law switched off (component weights 0), "
                        "the insertion-effort base kept (cache version "
                        f"{CACHE_VERSION})",
        "work": shown_path(args.work),
        "machine": {"platform": platform.platform(), "torch_threads": args.threads},
        "all_converged": all(t["training"]["converged"] for t in tasks),
        "tasks": tasks, "summary": summary, "verdicts": _verdicts(summary),
        "chosen_on_validation": _chosen(summary), "shipped": _shipped(),
        "seconds": time.time() - started}
    for bench, rows in summary.items():
        print(f"\n{bench} bench (NRMSE %, mean +- std over seeds {args.seeds})")
        for variant, r in rows.items():
            cells = "  ".join(f"{m} " + " / ".join(spread_text(r[m][a]) for a in AXES)
                              for m in METRICS)
            print(f"  {variant:10s} {cells}")
    if args.json:
        write_json(args.json, figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
