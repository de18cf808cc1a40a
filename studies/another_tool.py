"""Another tool (issue 13, item 4): models trained on the nominal instrument, scored on tools drawn
with ``InstrumentParams.sample`` at 1x and 2x the nominal spread, as they are and after a
few-shot calibration (``psmforce calibrate``, psmforce/estimators/training/calibrate.py).

    python studies/another_tool.py --scale 0.05 --seeds 1 2 3 --json OUT.json
    python studies/another_tool.py --smoke --scale 0.01 --seeds 1 --tool-seeds 11 \
        --minutes 0.5 --test-scale 0.01 --json OUT.json        # mechanics only, not converged

Per bench seed: simulate the nominal automated bench at ``--scale`` and train each model of
``--models`` on it (the published budget: early stopping, no caps; or, with ``--checkpoints DIR``,
take ``DIR/{model}_seed{seed}.pt`` trained on that bench). Then simulate test benches at
``--test-scale`` with the same protocol seed, so they share their trajectories and differ only in
the instrument: the nominal tool (reference row) and, for every spread of ``--spreads`` and tool
seed of ``--tool-seeds``, ``simulate(..., tool_seed, tool_spread)``. Each model is scored on each
bench's test split (a) as trained and (b) after ``calibrate`` with ``--minutes`` of that bench's
calibration trials (its train split; the test split is never seen). The nominal tool is
calibrated too: calibration also shows the model more of the test bench's protocol, and the
nominal row separates that from adapting to the tool. NRMSE % per axis by the
causal metric (raw per-sample estimate, no look-ahead) and the paper's (bias + centred median),
``psmforce.estimators.evaluation.evaluate``; mean +- std over bench seeds x tool seeds (the sample
std, ddof 1).

``--pair-tools`` gives the k-th bench seed only the k-th tool seed: one drawn instrument per
bench seed, so a row's spread is over as many (bench, tool) pairs as seeds, for a third of the
cost of every pairing. The run is resumable: every training, calibration and score is kept under
``--work`` (a score as ``records/*.json``) and reused by the same command.

``--smoke`` trains and calibrates with capped batches and one epoch
(``psmforce.estimators.training.train.TrainConfig`` caps): it shows the mechanics run end to end and
its JSON says "smoke run, not converged"; its figures compare nothing.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import torch

from psmforce.estimators.training.calibrate import DEFAULT_MINUTES, calibrate
from psmforce.estimators.evaluation.evaluate import evaluate
from psmforce.estimators.evaluation.metrics import AXES
from psmforce.estimators.networks.recipes import RECIPES, recipe
from psmforce.estimators.training.train import TrainConfig, train
from psmforce.sim import simulate
from psmforce.estimators.evaluation.tables import spread_text, std_over_seeds
from psmforce.experiments.report import kept_json, shown_path, write_json

MODES = ("causal", "paper")
SMOKE = {"max_batches_per_epoch": 2, "max_val_batches": 2}
"""Batch caps of a smoke run (with one epoch): mechanics only."""


def _config(model: str | None, smoke: bool) -> TrainConfig:
    """Training's settings for ``model`` (its paper defaults), or ``psmforce calibrate``'s
    (finetuning's defaults) for None; capped for a smoke run."""
    defaults = recipe(model).optimiser if model else {}
    return TrainConfig(**defaults, progress=False, **(SMOKE if smoke else {}))


def _scores(ckpt: Path, data: Path, out: Path) -> dict:
    """{mode: {axis: NRMSE %}} on the test split, and the floor of each mode."""
    result = evaluate(ckpt, data, out, plots=False)
    modes = result["postprocessing"]
    return {"nrmse_pct": {m: {a: modes["overall"][m][a]["nrmse_pct"] for a in AXES}
                          for m in MODES},
            "floor_nrmse_pct": {m: {a: modes["floor"][m][a]["nrmse_pct"] for a in AXES}
                                for m in MODES}}


def _bench(path: Path, scale: float, seed: int, **tool) -> Path:
    if not (path / "metadata.json").is_file():   # simulate writes it last: a finished bench
        simulate("automated", scale=scale, seed=seed, out=path, **tool)
    return path


def _summary(runs: list[dict], models, rows) -> dict:
    """{model: {row: {mode: {axis: [mean, std]}}}} over every (bench seed, tool seed): std the
    sample standard deviation (ddof 1; None for one pair,
    :func:`psmforce.estimators.evaluation.tables.std_over_seeds`)."""
    table = {}
    for model in models:
        table[model] = {}
        for row in rows:
            got = [r["nrmse_pct"] for r in runs if r["model"] == model and r["row"] == row]
            table[model][row] = {m: {a: [float(np.mean([g[m][a] for g in got])),
                                         std_over_seeds([g[m][a] for g in got])] for a in AXES}
                                 for m in MODES} | {"n": len(got)}
    return table


def _print(table: dict) -> None:
    head = "| model | tool | n | " + " | ".join(f"{m} {a}" for m in MODES for a in AXES) + " |"
    print(head + "\n|" + "---|" * (3 + len(MODES) * len(AXES)))
    for model, rows in table.items():
        for row, cell in rows.items():
            print(f"| {model} | {row} | {cell['n']} | " + " | ".join(
                spread_text({"mean": cell[m][a][0], "std": cell[m][a][1]})
                for m in MODES for a in AXES) + " |")


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=0.05, help="training bench scale")
    ap.add_argument("--test-scale", type=float, default=0.1,
                    help="scale of the test benches (their train split holds the calibration "
                         "trials: at 0.1 about 10 min of Free + Traction; default 0.1)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3],
                    help="bench and initialisation seeds (default 1 2 3)")
    ap.add_argument("--tool-seeds", type=int, nargs="+", default=[11, 12, 13])
    ap.add_argument("--spreads", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--models", nargs="+", default=["hybrid", "fcn"],
                    choices=list(RECIPES))
    ap.add_argument("--minutes", type=float, default=DEFAULT_MINUTES,
                    help=f"calibration minutes (default {DEFAULT_MINUTES:g})")
    ap.add_argument("--checkpoints", type=Path,
                    help="take DIR/{model}_seed{seed}.pt (trained on the nominal bench of that "
                         "scale and seed) instead of training")
    ap.add_argument("--epochs", type=int,
                    help="epoch limit of training (default: each recipe's, as `psmforce "
                         "reproduce`; early stopping ends a run before it, and a run that "
                         "reaches it is reported not converged)")
    ap.add_argument("--calibration-epochs", type=int, default=500,
                    help="epoch limit of each calibration (default 500: a few minutes of trials "
                         "make one or two batches per epoch, and a scale-0.02 trial still "
                         "improved its validation loss at epoch 100)")
    ap.add_argument("--pair-tools", action="store_true",
                    help="the k-th bench seed meets only the k-th tool seed (module docstring)")
    ap.add_argument("--smoke", action="store_true",
                    help="one capped epoch per training and calibration: mechanics only")
    ap.add_argument("--work", type=Path, default=Path("runs/another_tool"),
                    help="benches (reused when complete), checkpoints and evaluations")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    if args.smoke:   # recorded in the JSON's settings as run
        args.epochs = args.calibration_epochs = 1
    if args.pair_tools and len(args.tool_seeds) != len(args.seeds):
        sys.exit(f"--pair-tools: {len(args.seeds)} seeds but {len(args.tool_seeds)} tool seeds")
    rows = [f"{label} {k}" for label in ["nominal"] + [f"{s:g}x" for s in args.spreads]
            for k in ("as is", "calibrated")]
    runs, started = [], time.perf_counter()
    benches = {}
    for k, seed in enumerate(args.seeds):
        work = args.work / f"seed{seed}"
        tests = {"nominal": (_bench(work / "nominal_test", args.test_scale, seed), None)}
        for spread in args.spreads:
            for tool in [args.tool_seeds[k]] if args.pair_tools else args.tool_seeds:
                tests[f"{spread:g}x tool{tool}"] = (
                    _bench(work / f"tool{tool}_x{spread:g}", args.test_scale, seed,
                           tool_seed=tool, tool_spread=spread), (tool, spread))
        benches[seed] = (_bench(work / "nominal_train", args.scale, seed), tests)
    # models outermost, the cheap ones first on the command line: a run stopped part-way has
    # whole models done, and the same command resumes it
    for model in args.models:
        for seed, (nominal, tests) in benches.items():
            work = args.work / f"seed{seed}"
            if args.checkpoints:
                ckpt = args.checkpoints / f"{model}_seed{seed}.pt"
                if not ckpt.is_file():
                    sys.exit(f"--checkpoints: {ckpt} does not exist")
                trained = {"checkpoint": shown_path(ckpt), "converged": None}
            else:
                ckpt = work / f"{model}.pt"
                epochs = args.epochs or _config(model, False).max_epochs
                report = kept_json(work / f"{model}.train.json", lambda: {
                    k: v for k, v in train(nominal, model, ckpt, epochs=epochs, seed=seed,
                                           train_config=_config(model, args.smoke)).items()
                    if k in ("converged", "epochs_run")})
                trained = {"checkpoint": shown_path(ckpt, args.work), "converged": report["converged"],
                           "epochs_run": report["epochs_run"]}
            for name, (data, tool) in tests.items():
                base = {"model": model, "seed": seed, "trained": trained,
                        "tool_seed": None if tool is None else tool[0],
                        "tool_spread": None if tool is None else tool[1]}
                label = "nominal" if tool is None else f"{tool[1]:g}x"
                key = f"{model}_{name.replace(' ', '_')}"
                runs.append(base | {"row": f"{label} as is", **kept_json(
                    work / "records" / f"{key}.json",
                    lambda: _scores(ckpt, data, work / "eval" / key))})
                cal = work / f"{key}_cal.pt"

                def calibrated():
                    record = calibrate(ckpt, data, cal, minutes=args.minutes,
                                       epochs=args.calibration_epochs, seed=seed,
                                       train_config=_config(None, args.smoke))["calibration"]
                    return {"calibration": {k: record[k] for k in (
                        "minutes_used", "minutes_by_condition", "epochs_run", "converged")},
                        **_scores(cal, data, work / "eval" / f"{key}_cal")}
                runs.append(base | {"row": f"{label} calibrated",
                                    **kept_json(work / "records" / f"{key}_cal.json", calibrated)})
                print(f"seed {seed} {model} {name}: as is / calibrated causal NRMSE % "
                      + " / ".join(f"{runs[-2]['nrmse_pct']['causal'][a]:.2f}->"
                                   f"{runs[-1]['nrmse_pct']['causal'][a]:.2f}" for a in AXES),
                      flush=True)
    table = _summary(runs, args.models, rows)
    _print(table)
    flags = [r["trained"]["converged"] for r in runs] + [
        r["calibration"]["converged"] for r in runs if "calibration" in r]
    # checkpoints from a folder carry no convergence flag: unknown, so not claimed
    converged = None if None in flags else all(flags)
    figures = {
        "label": ("smoke run, not converged: mechanics only, the figures compare nothing"
                  if args.smoke else {True: "converged", None: "training convergence unknown "
                                      "(--checkpoints)"}.get(converged,
                                                             "NOT converged: some run did not "
                                                             "early-stop")),
        "smoke": args.smoke, "converged": converged,
        "settings": {k: (shown_path(v) if isinstance(v, Path) else v) for k, v in vars(args).items()},
        "metrics": "NRMSE % per axis on each bench's test split; causal = raw per-sample "
                   "estimate; paper = bias + centred median k = 71 (psmforce.estimators.evaluation.evaluate)",
        "calibration": "psmforce/estimators/training/calibrate.py: the first --minutes of the bench's train Free + "
                       "Traction trials (interleaved by minutes); hybrid: prior refitted, every "
                       "model: last block finetuned with early stopping",
        "table": table, "runs": runs, "seconds": round(time.perf_counter() - started, 1)}
    if args.json:
        write_json(args.json, figures)
    return figures


if __name__ == "__main__":
    main()
