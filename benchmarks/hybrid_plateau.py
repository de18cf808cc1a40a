"""Why the hybrid's lateral error stops improving with more data: variants on one learning-curve bench.

    python benchmarks/hybrid_plateau.py --scale 0.5 --seed 1 --variants default wide_64 \
        --json results/benchmarks/hybrid_plateau.json

Reads a finished learning-curve run (``benchmarks/learning_curve.py``) under ``--work``: its bench
of ``--seed`` (prior and derived columns included) and its checkpoints. Each variant is a hybrid
trained with the run's own settings (the full budget, early stopping, one thread) but one change
(:data:`VARIANTS`: its width, dropout, attention span, batch, inputs or base), or one of the run's
own checkpoints scored again (``existing_*``). Each is scored by the causal NRMSE % per axis on the
validation trials (the selection criterion) and, for information only, on the test trials. A
variant already in ``--json`` is kept, not retrained, so the script resumes variant by variant.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import torch  # noqa: E402

from benchmarks._report import write_json  # noqa: E402
from benchmarks.learning_curve import AXES, run_dir  # noqa: E402
from hybrid.checkpoint import load_checkpoint  # noqa: E402
from hybrid.data import NO_BASE  # noqa: E402
from hybrid.recipes import recipe  # noqa: E402
from hybrid.reproduce import (  # noqa: E402
    _automated_split,
    _checkpoint,
    _config,
    _load,
    _prior_path,
    _scores,
)
from hybrid.train import make_setup, train_model  # noqa: E402

RAW_HEX10 = ("fx", "fy", "fz", "tx", "ty", "tz")
INSERTION_STATE = ("insertion_velocity", "insertion_position")
VARIANTS = {
    # name: (model config, training overrides, inputs change)
    "default": ({}, {}, {}),
    "wide_64": ({"d_model": 64, "d_ff": 128}, {}, {}),
    "dropout_0": ({"dropout": 0.0}, {}, {}),
    "attention_window_1": ({"attention_window": 1}, {}, {}),
    "batch_4_chunks": ({}, {"chunk_batch_size": 4}, {}),
    "no_lateral_base": ({}, {}, {"base": (NO_BASE, NO_BASE, "insertion_fz")}),
    "plus_raw_hex10": ({}, {}, {"add": RAW_HEX10}),
    "no_insertion_state": ({}, {}, {"drop": INSERTION_STATE}),
}
"""One change each from the hybrid the learning curve trains."""
EXISTING = ("existing_hybrid", "existing_fcn", "existing_transformer")
"""The run's own checkpoints, scored on the same trials."""


def _inputs(change: dict):
    if not change:
        return None
    inputs = recipe("hybrid").inputs(None, True)
    features = tuple(f for f in inputs.features if f not in change.get("drop", ()))
    return dataclasses.replace(inputs, features=features + tuple(change.get("add", ())),
                               base=tuple(change.get("base", inputs.base)))


def _causal(setup, trials) -> list[float]:
    c = _scores(setup, trials, "cpu")["overall"]["causal"]
    return [round(c[a]["nrmse_pct"], 3) for a in AXES]


def variant(work: Path, scale: float, seed: int, name: str) -> dict:
    run = str(run_dir(work, scale) / "work")
    ds = _load(run, "automated", seed)
    train, val = _automated_split(ds, seed)
    result = {"name": name, "scale": scale, "seed": seed}
    if name in EXISTING:
        model = name.removeprefix("existing_")
        path = _checkpoint(run, {"model": model, "variant": "full", "fraction": 1.0, "seed": seed,
                                 "budget": "full", "device": "cpu"})
        if not path.is_file():
            raise SystemExit(f"{name}: the run has not trained {model} seed {seed} yet ({path})")
        setup = load_checkpoint(path)
    else:
        config, overrides, change = VARIANTS[name]
        setup = make_setup("hybrid", train, prior_json=_prior_path(run, seed).read_text(),
                           config=config, inputs=_inputs(change))
        cfg = dataclasses.replace(_config("full", "pretrain", seed, "cpu", "hybrid"), **overrides)
        started = time.time()
        rep = train_model(setup, train, val, cfg, desc=name)
        result |= {"config": config, "training": overrides,
                   "inputs": {k: list(v) for k, v in change.items()},
                   **{k: rep.get(k) for k in ("epochs_run", "stopped_by", "converged", "parameters")},
                   "seconds": round(time.time() - started)}
    return result | {"validation": _causal(setup, val), "test": _causal(setup, ds.select(split="test"))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "learning_curve")
    ap.add_argument("--scale", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--variants", nargs="+", default=list(EXISTING) + list(VARIANTS),
                    choices=list(EXISTING) + list(VARIANTS))
    ap.add_argument("--json", type=Path, default=ROOT / "results" / "benchmarks" / "hybrid_plateau.json")
    args = ap.parse_args(argv)
    if not (run_dir(args.work, args.scale) / "work" / "checkpoints").is_dir():
        ap.error(f"no learning-curve run at scale {args.scale:g} under {args.work}")
    torch.set_num_threads(1)
    done = json.loads(args.json.read_text())["variants"] if args.json.exists() else []
    for name in args.variants:
        if any(d["name"] == name and d["scale"] == args.scale and d["seed"] == args.seed for d in done):
            continue
        done.append(variant(args.work, args.scale, args.seed, name))
        print(f"{name}: validation {done[-1]['validation']}  test {done[-1]['test']}  (causal NRMSE %, "
              f"{' / '.join(AXES)})")
        write_json(args.json, {"metric": "causal NRMSE %, Fx / Fy / Fz", "variants": done})
    return 0


if __name__ == "__main__":
    sys.exit(main())
