"""Changes to the hybrid carried from the design seeds, against every model on seeds of their own:
does what the design seeds suggested hold where nothing was chosen (issue 45)?

This study trains, on each seed of :data:`psmforce.experiments.seeds.WIDE_HYBRID_SEEDS` (declared
before any run on them; any other seed is refused), every model of the comparison and each
candidate, as the comparison trains them (the ``full`` budget of ``psmforce reproduce``, early
stopping, one thread, simulator 2.3), and scores them on the seed's test trials: NRMSE per axis
under the causal and the paper's post-processing, and causal RMSE per test condition. Each
candidate's error over each other model's is paired by seed, with the 95 % Student t interval
of the log ratios (:mod:`psmforce.experiments.paired`), only over seeds where both trainings
stopped early. The candidates (:data:`CANDIDATES`), each with its rule fixed before its first
training on these seeds:

- ``hybrid_wide`` (stop 63): the paper's transformer's width (d_model 64, 8 heads, 3 layers,
  d_ff 256), carried by ``studies/hybrid_calibrated_design.py``'s rule on design seeds 1 and 2.
- ``hybrid_transformer`` (stop 65): the hybrid's physics (its prior-compensated inputs, the
  insertion state and its base) read by the paper's transformer, its network and its own
  recipe, in place of the hybrid's causal network (``transformer_hybrid_inputs`` of the design
  study). On design seed 2's test trials it was lower than both the hybrid and the paper's
  transformer on every axis, where the 8 validation trials had said otherwise; design seed 1
  decides whether it runs here at all (below).

**The rule, for each candidate**: it replaces the hybrid as shipped only if, over all declared
seeds, it is ahead of it (the interval of the causal ratio wholly below 1) on at least one
lateral axis and behind it (interval wholly above 1) on no axis of either metric. Its standing
against the other models is reported either way. ``hybrid_transformer`` runs here only if, on
design seed 1's test trials too, it is below the hybrid as compared on Fx and Fy and not above
it on Fz by more than the smaller of those two lowerings (the design study's rule, on the test
trials: the validation trials at scale 0.1 are too few to choose on); :func:`design_gate` reads
it from the design study's committed JSON, and ``main`` skips the candidate while it is not open.

    python studies/hybrid_wide_confirm.py --seed 111 --scale 0.1 \\
        --work runs/hybrid_wide_confirm \\
        --json results/benchmarks/hybrid_wide_confirm.json        # resumable, one seed each

Every training finished is kept under ``--work`` as a record (one file per seed and model, so
processes on different seeds never write the same file) and the JSON is assembled from them; a
killed training resumes from its saved epoch. ``--again MODEL ...`` writes those models'
records anew: a finished training resumes from its kept state to its best weights (no epoch
runs) and is scored again, for a record written by older code.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from psmforce.experiments.seeds import WIDE_HYBRID_SEEDS  # noqa: E402
from studies.hybrid_calibrated_design import (PAPER_WIDTH, VERSION, Variant,  # noqa: E402
                                              lowers, train)

MODELS = {
    "hybrid_wide": Variant(config=PAPER_WIDTH),
    "hybrid_transformer": Variant(model="transformer", inputs_of="hybrid"),
    "hybrid": Variant(),
    "transformer": Variant(model="transformer"),
    "fcn": Variant(model="fcn"),
    "rocket": Variant(model="rocket"),
    "lstm": Variant(model="lstm"),
}
"""The trainings of one seed, in the table's order: the candidates first, then the comparison's
models (:data:`studies.comparison.MODELS`)."""
CANDIDATES = ("hybrid_wide", "hybrid_transformer")
"""The changes to the hybrid under confirmation (module docstring), each judged by the rule."""
LABELS = {"hybrid_wide": "hybrid, the paper transformer's width",
          "hybrid_transformer": "hybrid's physics, the paper transformer's network",
          "hybrid": "hybrid (as shipped)",
          "transformer": "paper transformer", "fcn": "FCN", "rocket": "MultiRocket-Hydra",
          "lstm": "LSTM"}
AXES = ("Fx", "Fy", "Fz")
METRICS = ("causal", "paper")
RECORD_KEYS = ("parameters", "epochs", "stopped_by", "converged", "test_nrmse_pct",
               "test_causal_rmse_n_by_condition")


def _train_model(name: str, work: Path, seed: int, threads: int) -> dict:
    from psmforce.experiments.reproduce import _scores

    v = MODELS[name]
    t0 = time.time()
    setup, rep, ds, _ = train(v, name, work, seed, threads)
    # a resumed training's earlier processes count: the trainer's clock runs across resumes
    earlier_s = max(0.0, rep.get("seconds", 0.0) - (time.time() - t0))
    scores = _scores(setup, ds.select(split="test"), "cpu")
    return {"model": v.model, "config": v.config,
            "test_nrmse_pct": {mt: {a: scores["overall"][mt][a]["nrmse_pct"] for a in AXES}
                               for mt in METRICS},
            "test_causal_rmse_n_by_condition": {
                c: {a: s["causal"][a]["rmse_n"] for a in AXES}
                for c, s in scores["by_condition"].items()},
            "epochs": rep.get("epochs_run"), "stopped_by": rep.get("stopped_by"),
            "converged": bool(rep.get("converged")), "parameters": rep.get("parameters"),
            "seconds": round(time.time() - t0 + earlier_s, 1)}


def _in_json(result: dict):
    """The records a JSON of this study holds, as (scale, seed, name, record); a point written
    before the JSON kept them holds none."""
    for point in result["points"].values():
        for seed, models in point.get("records", {}).items():
            for name, record in models.items():
                yield point["scale"], int(seed), name, record


def summarise(records: dict[int, dict[str, dict]], scale: float) -> dict:
    """One scale's point from ``{seed: {model: record}}``: per model its per-seed NRMSE and mean ±
    sd per metric and axis; each candidate over each other model, paired over the seeds where
    both trained and stopped early (``paired[candidate][model]``); the rule's verdict per
    candidate once every declared seed is in."""
    from psmforce.experiments.paired import mean_sd, paired_record

    seeds = sorted(records)
    models = {}
    for m in MODELS:
        done = [s for s in seeds if m in records[s]]
        if not done:
            continue
        per_seed = {mt: [records[s][m]["test_nrmse_pct"][mt] for s in done] for mt in METRICS}
        models[m] = {"label": LABELS[m], "seeds": done, "per_seed": per_seed,
                     "summary": {mt: {a: mean_sd([x[a] for x in per_seed[mt]]) for a in AXES}
                                 for mt in METRICS},
                     "not_converged": [s for s in done if not records[s][m]["converged"]],
                     "by_condition": {
                         c: {a: mean_sd([records[s][m]["test_causal_rmse_n_by_condition"][c][a]
                                         for s in done]) for a in AXES}
                         for c in records[done[0]][m]["test_causal_rmse_n_by_condition"]}}
    paired: dict[str, dict] = {}
    for c in CANDIDATES:
        for m in models:
            if c not in models or m in CANDIDATES:
                continue
            both = [s for s in seeds if all(k in records[s] and records[s][k]["converged"]
                                            for k in (c, m))]
            if both:
                paired.setdefault(c, {})[m] = {"seeds": both, **{mt: paired_record(
                    [records[s][c]["test_nrmse_pct"][mt] for s in both],
                    [records[s][m]["test_nrmse_pct"][mt] for s in both], AXES)
                    for mt in METRICS}}
    declared = WIDE_HYBRID_SEEDS[scale]
    return {"version": VERSION, "scale": scale, "declared_seeds": list(declared),
            "models": models, "paired": paired,
            "rule": {c: rule(paired.get(c, {}), declared) for c in CANDIDATES if c in models},
            "interval": "95 % Student t on the log of the per-seed ratios (ddof 1), mapped back",
            "records": {str(s): dict(sorted(records[s].items())) for s in seeds}}


GATED = {"hybrid_transformer": ("transformer_hybrid_inputs", (1, 2))}
"""Candidates that run here only past their design gate: (the design study's variant, the
design seeds whose test trials must all agree)."""
DESIGN_JSON = ROOT / "results" / "benchmarks" / "hybrid_calibrated_design.json"


def design_gate(candidate: str, design: dict) -> str:
    """The module docstring's gate of ``candidate`` from the design study's JSON ``design``:
    ``"open"`` (not gated, or below the hybrid as compared on Fx and Fy of every gate seed's
    test trials, Fz not raised by more than the smaller lowering), ``"pending"`` (a gate seed
    lacks either training) or ``"closed"``."""
    if candidate not in GATED:
        return "open"
    variant, gate_seeds = GATED[candidate]
    rows = {p["seed"]: p["variants"] for p in design.get("points", {}).values()
            if p.get("version") == VERSION and p.get("scale") == 0.1}
    for seed in gate_seeds:
        if variant not in rows.get(seed, {}) or "default" not in rows.get(seed, {}):
            return "pending"
    for seed in gate_seeds:
        try:
            new, old = ({a: float(rows[seed][v]["test_causal_nrmse_pct"][a]) for a in AXES}
                        for v in (variant, "default"))
            passed = lowers(new, old)
        except (KeyError, TypeError, ValueError, ZeroDivisionError):
            raise ValueError(f"the design study's JSON: seed {seed}'s test errors of {variant} "
                             "or default are missing or not numbers") from None
        if not passed:
            return "closed"
    return "open"


def rule(paired: dict, declared) -> str:
    """The module docstring's rule on one candidate over the hybrid as shipped (``paired``: that
    candidate's pairs): ``"pending"`` until both have stopped early on every declared seed, then
    ``"replaces"`` or ``"kept"``."""
    shipped = paired.get("hybrid")
    if shipped is None or sorted(shipped["seeds"]) != sorted(declared):
        return "pending"
    ahead = any(shipped["causal"][a]["verdict"] == "ahead" for a in ("Fx", "Fy"))
    behind = any(shipped[mt][a]["verdict"] == "behind" for mt in METRICS for a in AXES)
    return "replaces" if ahead and not behind else "kept"


RULE_WORDS = {"pending": "not yet judged (every declared seed is needed)",
              "replaces": "it replaces the hybrid as shipped",
              "kept": "the hybrid as shipped is kept"}


def _mean_sd(d: dict, digits: int = 2) -> str:
    """``mean ± sd``; the mean alone while one seed gives no sd."""
    sd = d.get("sd")
    return f"{d['mean']:.{digits}f}" if sd is None or sd != sd \
        else f"{d['mean']:.{digits}f} ± {sd:.{digits}f}"


SHORT = {"hybrid_wide": "wide hybrid", "hybrid_transformer": "hybrid's physics + transformer"}


def _cost_rows(p: dict) -> list[str]:
    """What each model costs to train, from the point's records: its parameters, its epochs and
    the wall-clock minutes from the start of its training to its test scores, the processes of
    a stopped and resumed training together (one CPU thread; at times beside another training
    on the same two cores), mean ± sd over its seeds."""
    from psmforce.experiments.paired import mean_sd

    lines = ["| training cost | seeds | parameters | epochs | minutes, one thread |",
             "|---|---|---|---|---|"]
    for m, v in p["models"].items():
        rows = [p["records"][str(s)][m] for s in v["seeds"]]
        if not all(isinstance(r.get("seconds"), (int, float)) for r in rows):
            continue
        minutes = mean_sd([r["seconds"] / 60.0 for r in rows])
        epochs = mean_sd([float(r["epochs"]) for r in rows])
        lines.append(f"| {v['label']} | {len(rows)} | {rows[0]['parameters']:,} | "
                     f"{epochs['mean']:.0f} | {_mean_sd(minutes, 1)} |")
    return lines + [""] if len(lines) > 2 else []


def table(result: dict) -> str:
    """The markdown of every point in ``result`` (the ``hybrid-wide-confirm`` block)."""
    lines = [""]
    for key, p in sorted(result.get("points", {}).items()):
        lines += [f"**Simulator {p['version']}, scale {p['scale']:g}**, declared seeds "
                  f"{', '.join(map(str, p['declared_seeds']))}; test trials, NRMSE %, mean ± sd "
                  "over the seeds each model has finished (ddof 1); each candidate's error over "
                  f"each model's, paired by seed, with the {p['interval']}.", ""]
        for mt in METRICS:
            lines += [f"| {mt} | seeds | " + " | ".join(AXES) + " |",
                      "|---|---|" + "---|" * len(AXES)]
            for m, v in p["models"].items():
                flag = f" (not converged on {v['not_converged']})" if v["not_converged"] else ""
                lines.append(f"| {v['label']}{flag} | {len(v['seeds'])} | " + " | ".join(
                    _mean_sd(v['summary'][mt][a]) for a in AXES) + " |")
            for c, pairs in p["paired"].items():
                for m, pr in pairs.items():
                    lines.append(f"| {SHORT[c]} / {p['models'][m]['label']} | "
                                 f"{len(pr['seeds'])} | "
                                 + " | ".join(pr[mt][a]["text"] for a in AXES) + " |")
            lines.append("")
        lines += _cost_rows(p)
        lines += ["By the rule (module docstring of `studies/hybrid_wide_confirm.py`): " + "; ".join(
            f"{LABELS[c]}: {RULE_WORDS[v]}" for c, v in p["rule"].items()) + ".", ""]
    if len(lines) == 1:
        lines += ["No training yet.", ""]
    return "\n".join(lines)


def assemble(work: Path, json_path: Path) -> dict:
    """Every finished training as the study's JSON, one point per scale: the records under
    ``work`` (one folder per seed and scale, one record per model) over those ``json_path``
    already holds (:func:`studies.records.gather`)."""
    from studies.records import gather

    by_scale: dict[float, dict[int, dict]] = {}
    for (scale, seed), models in sorted(
            gather(work, "models", json_path, MODELS, RECORD_KEYS, _in_json).items()):
        by_scale.setdefault(scale, {})[seed] = models
    return {"points": {f"{VERSION} scale {scale:g}": summarise(records, scale)
                       for scale, records in sorted(by_scale.items())},
            "command": ("python studies/hybrid_wide_confirm.py --seed S --scale X "
                        f"--work {shown_path(work)} --json {shown_path(json_path)}")}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--scale", type=float, default=0.1)
    ap.add_argument("--models", nargs="+", choices=list(MODELS), default=list(MODELS))
    ap.add_argument("--again", nargs="+", choices=list(MODELS), default=[],
                    help="write these models' records again although they exist (a finished "
                         "training resumes from its kept state to its best weights and is "
                         "scored again; nothing trains where the state is kept)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "hybrid_wide_confirm")
    ap.add_argument("--json", type=Path,
                    default=ROOT / "results" / "benchmarks" / "hybrid_wide_confirm.json")
    args = ap.parse_args(argv)
    declared = WIDE_HYBRID_SEEDS.get(args.scale, ())
    if args.seed not in declared:
        print(f"error: --seed {args.seed} at scale {args.scale:g} is not declared for this "
              f"study (psmforce/experiments/seeds.py, WIDE_HYBRID_SEEDS: "
              f"{WIDE_HYBRID_SEEDS}); it confirms, so it runs only where nothing was chosen",
              file=sys.stderr)
        return 2
    from psmforce.experiments.reproduce import prepare_benches
    from psmforce.sim.versions import version

    work = args.work / f"seed{args.seed}_scale{args.scale:g}"
    try:
        prepare_benches(work, args.scale, (args.seed,), teleop=False,
                        sim_version=version(VERSION))
        from studies.records import gather
        done = gather(args.work, "models", args.json, MODELS, RECORD_KEYS, _in_json).get(
            (args.scale, args.seed), {})
        for name in args.models:
            if name in GATED and name not in done:
                from studies.records import read_json
                gate = design_gate(name, read_json(DESIGN_JSON, "the design study's JSON"))
                if gate != "open":
                    print(f"skipped {name}: its design gate is {gate} "
                          f"({shown_path(DESIGN_JSON)}, module docstring)", file=sys.stderr)
                    continue
            if name not in done or name in args.again:
                write_json(work / "models" / f"{name}.json",
                           _train_model(name, work, args.seed, args.threads))
            write_json(args.json, assemble(args.work, args.json))
    except ValueError as err:   # a record read back, a folder holding another run, a refused output
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
