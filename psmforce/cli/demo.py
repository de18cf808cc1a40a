"""`psmforce demo`: the whole library on a small simulated bench in a few minutes on a CPU.

1. simulate the paper's automated protocol at ``scale`` (default 3 %: about 6 min of 100 Hz data);
2. fit the internal-force prior (CasADi) on its training trials, loaded ones included with the
   known ATI force subtracted: only loads excite the pulley radii that turn tip moments into
   shaft compression, which is most of what the HEX10 reads under load;
3. train the hybrid (prior + causal transformer) and the paper's FCN baseline with a small,
   fixed compute budget (the budget is printed and written: this is a smoke-scale run, not the
   paper's training; `psmforce reproduce` is the full comparison);
4. evaluate both on the test trials as in the paper (bias from the first 0.5 s, median filter
   k = 71, RMSE / NRMSE / R^2 per axis), print the table and the paths of the plots.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

DEMO_SCALE = 0.03
DEMO_BUDGET = {"max_epochs": 100}
"""Per model: at most 100 epochs over all training windows / chunks (early stopping as usual),
on top of the model's recipe settings (its batches and chunks, as ``psmforce train`` trains)."""


def run_demo(out: str | Path, *, seed: int = 0, scale: float = DEMO_SCALE,
             budget: dict | None = None) -> dict:
    """Run the demo into the new or empty folder ``out``; return the metrics table as a dict."""
    from psmforce.estimators.evaluation.evaluate import evaluate
    from psmforce.estimators.networks.recipes import recipe
    from psmforce.estimators.evaluation.tables import automated_table
    from psmforce.core.files import write_text_atomic
    from psmforce.estimators.training.train import TrainConfig, train
    from psmforce.identification import fit_prior_cli
    from psmforce.sim import simulate

    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise ValueError(f"{out} is not empty (refusing to mix runs); choose another --out")
    budget = {**DEMO_BUDGET, **(budget or {})}
    started = time.perf_counter()

    def step(text: str) -> None:
        print(f"[{time.perf_counter() - started:6.1f} s] {text}", flush=True)

    data = out / "data"
    step(f"simulating the automated bench protocol at scale {scale} -> {data}")
    sim = simulate("automated", scale=scale, seed=seed, out=data)
    step(f"{sim['trials']} trials, {sim['rows']} samples")

    prior_path = out / "prior.json"
    step("fitting the internal-force prior on training trials (CasADi / IPOPT)")
    prior_fit = fit_prior_cli(data, prior_path, use_loaded=True)

    metrics, checkpoints = {}, {}
    for model in ("hybrid", "fcn"):
        ckpt = out / f"{model}.pt"
        step(f"training {model} (budget {budget})")
        config = TrainConfig(**{**recipe(model).optimiser, **budget}, seed=seed)
        train(data, model, ckpt, epochs=budget["max_epochs"], seed=seed,
              prior=prior_path if recipe(model).uses_prior else None, train_config=config)
        step(f"evaluating {model} on the test trials")
        metrics[model] = evaluate(ckpt, data, out / f"eval_{model}")
        checkpoints[model] = str(ckpt)

    table = automated_table({m: r["overall"] for m, r in metrics.items()},
                            f"Demo: test trials of a {scale:g}-scale simulated bench")
    write_text_atomic(out / "table.md", table)
    plots = sorted(str(p) for p in out.glob("eval_*/*.png"))
    summary = {"scale": scale, "seed": seed, "budget": budget, "simulation": sim,
               "prior_fit": prior_fit, "checkpoints": checkpoints,
               "metrics": {m: r["overall"] for m, r in metrics.items()},
               "plots": plots, "seconds": round(time.perf_counter() - started, 1)}
    write_text_atomic(out / "demo.json", json.dumps(summary, indent=2, default=str) + "\n")
    print()
    print(table)
    print("plots:")
    for p in plots:
        print(f"  {p}")
    print(f"table: {out / 'table.md'}   summary: {out / 'demo.json'}")
    return summary
