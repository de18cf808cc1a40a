"""The published comparison (issue 45): every model trained to early stopping on the bench seeds
declared for it before any was run, paired by seed, with intervals.

For one simulator version and one scale (1.0 = the paper's amount of training data), one
``psmforce reproduce`` run of the automated protocol with the main models only (no ablations,
data efficiency or teleoperation) on :data:`psmforce.experiments.seeds.COMPARISON_SEEDS` of that
scale, never used while designing (refused otherwise). Per model, axis and metric (causal: the
raw per-sample estimate a haptic loop gets; paper: the paper's offline post-processing), the
NRMSE % over seeds as mean and sample standard deviation (ddof 1), and the hybrid's error over
each other model's, paired by seed: the geometric-mean ratio with a 95 % Student t interval on
the per-seed log ratios (:mod:`psmforce.experiments.paired`). "ahead" only when the interval
lies below 1, "behind" only above it, else "tie". A model whose trainings did not all stop early
is shown and kept out of the verdicts.

    python studies/comparison.py --version 2.3 --scale 0.1 --json results/benchmarks/comparison.json

Resumable (each task cached, a training resuming its saved state). Several calls may share
``--work`` to use several cores (``--threads 1`` each) with disjoint ``--seeds`` (a part: it
trains and writes no point); the call with every declared seed then finds each task cached and
writes the point. The JSON keeps one point per (version, scale); ``--render-only`` prints the
table of the JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.core.files import MAX_JSON_BYTES, read_input_text  # noqa: E402
from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from psmforce.experiments.seeds import COMPARISON_SEEDS, check_fresh  # noqa: E402
from psmforce.estimators.evaluation.tables import spread_text  # noqa: E402

MODELS = ("hybrid", "transformer", "fcn", "rocket", "lstm")
"""In the table's order; the hybrid is compared with each of the others."""
AXES = ("Fx", "Fy", "Fz")
METRICS = ("causal", "paper")


def run_dir(work: Path, version: str, scale: float) -> Path:
    return work / version / f"scale_{scale:g}"


def point(results: dict, version: str, scale: float, seconds: float) -> dict:
    """The comparison of one ``reproduce`` result: per model its per-seed NRMSE, mean and sd
    (ddof 1) per metric and axis, convergence and stops; the hybrid over each other model,
    paired by seed, per metric and axis (only between models that all converged); per test
    condition each model's causal RMSE (N), mean and sd over seeds, to show where the errors
    come from (no pairing: ``reproduce`` keeps per-seed errors overall only)."""
    from psmforce.experiments.paired import mean_sd, paired_record
    from psmforce.experiments.plan import plan
    per_seed = results["automated_nrmse_pct_per_seed"]
    models = {}
    for m in results["call"]["models"]:
        label = plan(m).label
        training = [t for k, t in results["training"].items() if k.startswith(f"{m} full 1.0 ")]
        models[m] = {
            "label": label,
            "per_seed": {mt: per_seed[mt][label] for mt in METRICS},
            "summary": {mt: {a: mean_sd([s[a] for s in per_seed[mt][label]]) for a in AXES}
                        for mt in METRICS},
            "converged": all(bool(t["converged"]) for t in training),
            "stopped": [f"{t['epochs_run']} epochs, {t['stopped_by']}" for t in training],
            "training_seconds": [t.get("seconds") for t in training]}
    paired = {}
    hybrid = models.get("hybrid")
    for m, other in models.items():
        if m == "hybrid" or hybrid is None or not (hybrid["converged"] and other["converged"]):
            continue
        paired[m] = {mt: paired_record(hybrid["per_seed"][mt], other["per_seed"][mt], AXES)
                     for mt in METRICS}
    by_condition = {
        cond: {m: {a: {"mean": v["causal"][models[m]["label"]][a]["rmse_n"]["mean"],
                       "sd": v["causal"][models[m]["label"]][a]["rmse_n"]["std"]}
                   for a in AXES} for m in models}
        for cond, v in results.get("automated_by_condition", {}).items()}
    return {"version": version, "scale": scale, "seeds": results["call"]["seeds"],
            "by_condition": by_condition, "spread": results.get("spread"),
            "device": results["call"]["device"],
            "simulator_versions": sorted(set(results["benches"].values())),
            "models": models, "paired": paired,
            "not_converged": [m for m, v in models.items() if not v["converged"]],
            "not_compared": [m for m in models if m != "hybrid" and m not in paired],
            "interval": "95 % Student t on the log of the per-seed ratios (ddof 1), mapped back",
            "call_seconds": round(seconds, 1)}


def _mean_sd_text(d: dict) -> str:
    """A point's ``{mean, sd}`` (the key its JSON uses) in the tables' ``mean ± sd`` form."""
    return spread_text({"mean": d["mean"], "std": d.get("sd")}, digits=3)


def table(result: dict) -> str:
    """The markdown of every point in ``result`` (the ``comparison-fresh-seeds`` block)."""
    lines = [""]
    for key, p in sorted(result.get("points", {}).items(),
                         key=lambda kv: (kv[1]["version"], kv[1]["scale"])):
        lines += [f"**Simulator {p['version']}, scale {p['scale']:g}**, fresh seeds "
                  f"{', '.join(map(str, p['seeds']))} ({p['device']}); NRMSE %, mean ± sd over "
                  "seeds (ddof 1); the hybrid's error over each model's, paired by seed, with the "
                  f"{p['interval']}.", ""]
        for mt in METRICS:
            lines += [f"| {mt} | " + " | ".join(AXES) + " | converged |",
                      "|---|" + "---|" * (len(AXES) + 1)]
            for m, v in p["models"].items():
                cells = [f"{v['summary'][mt][a]['mean']:.2f} ± {v['summary'][mt][a]['sd']:.2f}"
                         for a in AXES]
                lines.append(f"| {v['label']} | " + " | ".join(cells)
                             + f" | {'yes' if v['converged'] else 'NO'} |")
            for m, pr in p["paired"].items():
                lines.append(f"| hybrid / {p['models'][m]['label']} | "
                             + " | ".join(pr[mt][a]["text"] for a in AXES) + " | |")
            lines.append("")
        if p.get("by_condition"):
            lines += ["Where the errors come from: causal RMSE in N per test condition, mean ± sd "
                      "over seeds (Free: no contact, the true force is zero).", "",
                      "| model | " + " | ".join(f"{c} {a}" for c in p["by_condition"]
                                              for a in AXES) + " |",
                      "|---|" + "---|" * (len(AXES) * len(p["by_condition"]))]
            for m, v in p["models"].items():
                lines.append(f"| {v['label']} | " + " | ".join(
                    _mean_sd_text(p["by_condition"][c][m][a]) for c in p["by_condition"]
                    for a in AXES) + " |")
            lines.append("")
        if p["not_compared"]:
            lines += [f"Not compared (a training did not stop early, or no hybrid): "
                      f"{', '.join(p['not_compared'])}.", ""]
    if len(lines) == 1:
        lines += ["No point yet.", ""]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--version", default="2.3", help="the simulator version of the benches")
    ap.add_argument("--scale", type=float, default=0.1, choices=sorted(COMPARISON_SEEDS))
    ap.add_argument("--seeds", type=int, nargs="+", default=None,
                    help="a part: some of the scale's declared seeds (default: all of them)")
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--work", type=Path, default=Path("runs/comparison"))
    ap.add_argument("--json", type=Path, default=ROOT / "results" / "benchmarks"
                    / "comparison.json")
    ap.add_argument("--render-only", action="store_true")
    args = ap.parse_args(argv)
    result = {"points": {}}
    if args.json.exists():   # its other scales' points are kept: read back as user input
        try:
            result = json.loads(read_input_text(args.json, MAX_JSON_BYTES, "comparison"))
            if not isinstance(result.get("points"), dict):
                raise ValueError("no points")
        except (ValueError, AttributeError) as err:   # JSONDecodeError is a ValueError
            print(f"error: {args.json}: not a comparison's results ({err}); move it aside to "
                  f"start a new one", file=sys.stderr)
            return 2
    if args.render_only:
        print(table(result))
        return 0
    declared = list(COMPARISON_SEEDS[args.scale])
    seeds = declared if args.seeds is None or set(args.seeds) == set(declared) else args.seeds
    try:
        check_fresh(seeds, "the published comparison")
    except ValueError as e:
        ap.error(str(e))
    if set(seeds) - set(declared):
        ap.error(f"--seeds {sorted(set(seeds) - set(declared))}: not declared for scale "
                 f"{args.scale:g} (psmforce/experiments/seeds.py COMPARISON_SEEDS: {declared})")
    if "hybrid" not in args.models and seeds == declared:
        ap.error("--models: the comparison is the hybrid against the others; include hybrid")
    from psmforce.experiments.reproduce import reproduce
    from psmforce.sim.versions import version
    started = time.perf_counter()
    results = reproduce(run_dir(args.work, args.version, args.scale), scale=args.scale,
                        seeds=tuple(seeds), models=tuple(args.models), ablations=False,
                        efficiency=False, teleop=False, threads=args.threads, device=args.device,
                        sim_version=version(args.version))
    if seeds != declared:
        print(f"part done (seeds {seeds}); the call with every declared seed writes the point")
        return 0
    key = f"{args.version} scale {args.scale:g}"
    result["points"][key] = point(results, args.version, args.scale,
                                  time.perf_counter() - started)
    result["points"][key]["command"] = result["command"] = (
        f"python studies/comparison.py --version {args.version} --scale {args.scale:g} "
        f"--models {' '.join(args.models)} --work {shown_path(args.work)} "
        f"--json {shown_path(args.json)}")
    write_json(args.json, result)
    print(table(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
