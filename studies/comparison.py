"""The published comparison (issue 45): every model trained to early stopping on the bench seeds
declared for it before any was run, paired by seed, with intervals.

For one simulator version and one scale (1.0 = the paper's amount of training data), one
``psmforce reproduce`` run of the automated protocol with the main models only (no ablations,
data efficiency or teleoperation) on :data:`psmforce.experiments.seeds.COMPARISON_SEEDS` of that
scale, never used while designing (refused otherwise). Per model, axis and metric (causal: the
raw per-sample estimate a haptic loop gets; paper: the paper's offline post-processing), the
NRMSE % over seeds as mean and sample standard deviation (ddof 1), and each of our models'
error over each other model's (:data:`SUBJECTS`), paired by seed: the geometric-mean ratio with a
95 % Student t interval on the per-seed log ratios (:mod:`psmforce.experiments.paired`). "ahead"
only when the interval lies below 1, "behind" only above it, else "tie". A model whose trainings
did not all stop early is shown and kept out of the verdicts.

    python studies/comparison.py --version 2.3 --scale 0.1 --json results/benchmarks/comparison.json

Each seed runs as its own ``reproduce`` call, and what each (seed, model) training scored is kept
as a record: a file under ``--work`` as it ends, and in the JSON, so a run on a machine without
``--work`` (a fresh checkout: ``runs/`` is not committed) trains only what the JSON lacks, and
the work of several sessions adds up (:mod:`studies.records`). Several calls may share
``--work`` to use several cores (``--threads 1`` each) with disjoint ``--seeds`` or
``--models``; a training killed midway resumes from its saved state. The point of a scale is
written once every declared seed has every model. The JSON keeps one point per (version,
scale); ``--render-only`` prints the table of the JSON.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from psmforce.experiments.seeds import COMPARISON_SEEDS, check_fresh  # noqa: E402
from psmforce.estimators.evaluation.tables import spread_text  # noqa: E402

MODELS = ("hybrid", "transformer", "fcn", "rocket", "lstm", "hybrid_transformer")
"""In the table's order; :data:`SUBJECTS` are paired with the others. ``hybrid_transformer``
(the hybrid's physics read by the paper's transformer) replaced the hybrid as shipped by the
rule of ``studies/hybrid_wide_confirm.py``, on seeds of its own, after this comparison's scale
0.1 point was first written. That point was built before each training was kept as a record;
it was rebuilt from records, the new model in it, once every model had been retrained there
(with records), and the new model is in every point written since."""
SUBJECTS = ("hybrid_transformer", "hybrid")
"""Our models, each paired with every other model: the one ``psmforce train`` ships first, then
the hybrid with its causal network (its pair with the shipped one is the shipped one's, not
repeated). A point written before the shipped model was in the comparison pairs the hybrid
only."""
AXES = ("Fx", "Fy", "Fz")
METRICS = ("causal", "paper")


def run_dir(work: Path, version: str, scale: float) -> Path:
    return work / version / f"scale_{scale:g}"


RECORD_KEYS = ("nrmse_pct", "causal_rmse_n_by_condition", "training", "bench", "device")
"""What one (seed, model) record holds: the test NRMSE % per metric and axis, the causal RMSE (N)
per test condition and axis, the training's stop, the bench's simulator version, the device.
Records written since they were traced also hold ``code`` (the package version and, run from a
git checkout, its commit) and ``machine`` (the processor and the instruction set torch ran on),
``reproduce``'s own, so a record that disagrees with a rerun can be traced to its code or its
machine; older records lack them and are read all the same."""


def records_from_results(results: dict) -> dict[int, dict[str, dict]]:
    """``{seed: {model: record}}`` from a ``reproduce`` result of one seed (its per-condition
    errors are means over the call's seeds, so only a one-seed call gives a seed's own)."""
    from psmforce.experiments.plan import plan
    seeds = results["call"]["seeds"]
    if len(seeds) != 1:
        raise ValueError(f"a record is one seed's: this result holds seeds {seeds}")
    seed = seeds[0]
    out: dict[int, dict[str, dict]] = {seed: {}}
    for m in results["call"]["models"]:
        label = plan(m).label
        t = results["training"][f"{m} full 1.0 seed {seed}"]
        out[seed][m] = {
            "nrmse_pct": {mt: results["automated_nrmse_pct_per_seed"][mt][label][0]
                          for mt in METRICS},
            "causal_rmse_n_by_condition": {
                c: {a: v["causal"][label][a]["rmse_n"]["mean"] for a in AXES}
                for c, v in results["automated_by_condition"].items()},
            "training": {k: t.get(k) for k in ("epochs_run", "stopped_by", "converged",
                                                "seconds")},
            "bench": results["benches"][f"automated seed {seed}"],
            "device": results["call"]["device"],
            "code": results.get("code"), "machine": results.get("machine")}
    return out


def point(records: dict[int, dict[str, dict]], version: str, scale: float) -> dict:
    """The comparison of one scale from its records (``{seed: {model: record}}``, every model
    on every seed): per model its per-seed NRMSE, mean and sd (ddof 1) per metric and axis,
    convergence and stops; each of :data:`SUBJECTS` over each other model, paired by seed, per
    metric and axis (``paired[subject][model]``, only between models that all converged); per
    test condition each model's causal RMSE (N), mean and sd (ddof 1) over seeds, to show where
    the errors come from."""
    from psmforce.experiments.paired import mean_sd, paired_record
    from psmforce.experiments.plan import plan
    seeds = sorted(records)
    present = [m for m in MODELS if all(m in records[s] for s in seeds)]
    models = {}
    for m in present:
        rows = [records[s][m] for s in seeds]
        per_seed = {mt: [r["nrmse_pct"][mt] for r in rows] for mt in METRICS}
        models[m] = {
            "label": plan(m).label, "per_seed": per_seed,
            "summary": {mt: {a: mean_sd([x[a] for x in per_seed[mt]]) for a in AXES}
                        for mt in METRICS},
            "converged": all(bool(r["training"]["converged"]) for r in rows),
            "stopped": [f"{r['training']['epochs_run']} epochs, {r['training']['stopped_by']}"
                        for r in rows],
            "training_seconds": [r["training"].get("seconds") for r in rows]}
    paired: dict[str, dict] = {}
    for subject in (s for s in SUBJECTS if s in models and models[s]["converged"]):
        ours = models[subject]["per_seed"]
        pairs = {m: {mt: paired_record(ours[mt], other["per_seed"][mt], AXES) for mt in METRICS}
                 for m, other in models.items()
                 if m != subject and m not in paired and other["converged"]}
        if pairs:
            paired[subject] = pairs
    conditions = sorted(records[seeds[0]][present[0]]["causal_rmse_n_by_condition"]) \
        if present else []
    by_condition = {c: {m: {a: mean_sd([records[s][m]["causal_rmse_n_by_condition"][c][a]
                                        for s in seeds]) for a in AXES} for m in models}
                    for c in conditions}
    return {"version": version, "scale": scale, "seeds": seeds, "by_condition": by_condition,
            "device": ", ".join(sorted({records[s][m]["device"] for s in seeds for m in models})),
            "simulator_versions": sorted({records[s][m]["bench"] for s in seeds
                                          for m in models}),
            "models": models, "paired": paired,
            "not_converged": [m for m, v in models.items() if not v["converged"]],
            "not_compared": [m for m in models if m not in paired
                             and not any(m in pairs for pairs in paired.values())],
            "interval": "95 % Student t on the log of the per-seed ratios (ddof 1), mapped back"}


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
                  "seeds (ddof 1); each of our models' error over each other model's, paired by "
                  f"seed, with the {p['interval']}.", ""]
        for mt in METRICS:
            lines += [f"| {mt} | " + " | ".join(AXES) + " | converged |",
                      "|---|" + "---|" * (len(AXES) + 1)]
            for m, v in p["models"].items():
                cells = [f"{v['summary'][mt][a]['mean']:.2f} ± {v['summary'][mt][a]['sd']:.2f}"
                         for a in AXES]
                lines.append(f"| {v['label']} | " + " | ".join(cells)
                             + f" | {'yes' if v['converged'] else 'NO'} |")
            for subject, pairs in p["paired"].items():
                for m, pr in pairs.items():
                    lines.append(f"| {subject} / {p['models'][m]['label']} | "
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
            lines += [f"Not compared (a training did not stop early, or none of ours): "
                      f"{', '.join(p['not_compared'])}.", ""]
    if len(lines) == 1:
        lines += ["No point yet.", ""]
    return "\n".join(lines + _in_progress(result))


def _in_progress(result: dict) -> list[str]:
    """One line per (version, scale) with records and no point yet: which models have a record
    on which declared seeds (and where a training did not stop early), which have none; nothing
    is compared there. A point whose records are not all there yet (a rerun) says what is
    trained of the rerun."""
    lines = []
    for version, by_scale in sorted(result.get("records", {}).items()):
        for scale, by_seed in sorted(by_scale.items(), key=lambda kv: float(kv[0])):
            declared = COMPARISON_SEEDS.get(float(scale), ())
            done = {m: sorted(int(s) for s in by_seed if m in by_seed[s] and int(s) in declared)
                    for m in MODELS}
            standing = result.get("points", {}).get(f"{version} scale {float(scale):g}")
            if standing is not None:
                if all(len(seeds) == len(declared) for seeds in done.values()):
                    continue
                lines += [f"Simulator {version}, scale {float(scale):g}: being retrained with "
                          "a record per training; its point above, from earlier trainings, "
                          "stands until every model has a record on every declared seed. "
                          f"Trained so far: {_trained(by_seed, done)}; no record on every "
                          "declared seed yet: " + ", ".join(
                              m for m, seeds in done.items() if len(seeds) < len(declared))
                          + "." + _against_point(standing, by_seed, done), ""]
                continue
            lines += [f"Simulator {version}, scale {float(scale):g}: in progress, no point yet "
                      f"(nothing compared). Trained so far: {_trained(by_seed, done)}; declared "
                      f"seeds "
                      f"{', '.join(map(str, declared))}; no record yet: "
                      f"{', '.join(m for m, seeds in done.items() if not seeds) or 'none'}."
                      + (_against_robot(by_seed, done) if float(scale) == 1.0 else ""), ""]
    return lines


def _against_point(standing: dict, by_seed: dict, done: dict[str, list[int]]) -> str:
    """How far a rerun's records lie from the standing point's per-seed NRMSE on the same
    seeds: per model, the largest relative difference over seeds, metrics and axes (0: the
    rerun reproduces the point)."""
    apart = {}
    for m, seeds in done.items():
        if m not in standing["models"]:
            continue
        per_seed = standing["models"][m]["per_seed"]
        gaps = [abs(by_seed[str(s)][m]["nrmse_pct"][mt][a] - per_seed[mt][k][a])
                / abs(per_seed[mt][k][a])
                for s in seeds if s in standing["seeds"]
                for k in [standing["seeds"].index(s)] for mt in per_seed for a in AXES]
        if gaps:
            apart[m] = max(gaps)
    if not apart:
        return ""
    return (" Against the standing point's per-seed NRMSE on the same seeds (largest relative "
            "difference over seeds, metrics and axes): " + ", ".join(
                f"{m} {'0' if gap == 0 else f'{gap:.1e}'}" for m, gap in apart.items()) + ".")


def _trained(by_seed: dict, done: dict[str, list[int]]) -> str:
    """Which models have a record on which seeds, and where a training did not stop early."""
    unconverged = {m: [s for s in seeds if not by_seed[str(s)][m]["training"]["converged"]]
                   for m, seeds in done.items()}
    return "; ".join(f"{m} on {', '.join(map(str, seeds))}" + (
        f" (NOT converged on {', '.join(map(str, unconverged[m]))})" if unconverged[m] else "")
        for m, seeds in done.items() if seeds) or "nothing"


def _against_robot(by_seed: dict, done: dict[str, list[int]]) -> str:
    """At the paper's amount of data: each model with a robot figure in the calibration's table
    (:data:`studies.bench_paper_calibration.PAPER`), its paper-metric NRMSE over the seeds it
    has so far against that figure, as the calibration's band reads it; a figure the paper does
    not publish says so."""
    from studies.bench_paper_calibration import BAND, PAPER, published
    parts = []
    for m, seeds in done.items():
        if not seeds or m not in PAPER:
            continue
        robot = PAPER[m]["nrmse_pct"]
        mean = {a: sum(by_seed[str(s)][m]["nrmse_pct"]["paper"][a] for s in seeds) / len(seeds)
                for a in AXES}
        ratio = {a: mean[a] / robot[a] for a in AXES}
        outside = [a for a in AXES if not BAND[0] <= ratio[a] <= BAND[1]]
        parts.append(f"{PAPER[m]['label']} " + " / ".join(f"{ratio[a]:.2f}x" for a in AXES)
                     + f" (seed{'s' if len(seeds) > 1 else ''} {', '.join(map(str, seeds))}"
                     + ("" if published(m) else "; against the issue's figure, which no "
                        "publication gives")
                     + (f"; {', '.join(outside)} outside the band" if outside else "; in band")
                     + ")")
    return (" On the paper's metric against the paper's robot (its Table III; mean over the "
            "seeds so far over the robot's figure, Fx / Fy / Fz; the calibration's band "
            f"[{BAND[0]:g}, {BAND[1]:g}]): " + "; ".join(parts) + ".") if parts else ""


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
    try:
        result = _read(args.json)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
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
    from psmforce.experiments.reproduce import reproduce
    from psmforce.sim.versions import version
    from studies.records import gather

    records_dir = args.work / args.version / "records"
    in_json = _in_json(args.version)
    try:
        for seed in seeds:
            done = gather(records_dir, "models", args.json, MODELS, RECORD_KEYS, in_json).get(
                (args.scale, seed), {})
            missing = tuple(m for m in args.models if m not in done)
            if missing:   # one seed per call: its per-condition errors are its own
                results = reproduce(run_dir(args.work, args.version, args.scale),
                                    scale=args.scale, seeds=(seed,), models=missing,
                                    ablations=False, efficiency=False, teleop=False,
                                    threads=args.threads, device=args.device,
                                    sim_version=version(args.version))
                for m, record in records_from_results(results)[seed].items():
                    write_json(records_dir / f"seed{seed}_scale{args.scale:g}" / "models"
                               / f"{m}.json", record)
            result = assemble(records_dir, args.json, args.version, _read(args.json))
            write_json(args.json, result)
    except ValueError as err:   # a record read back, or an output the guard refuses
        print(f"error: {err}", file=sys.stderr)
        return 2
    key = f"{args.version} scale {args.scale:g}"
    if key in result["points"] and sorted(result["points"][key]["seeds"]) == sorted(declared):
        print(table(result))
    else:
        print(f"part done (seeds {seeds}); the point is written once every declared seed has "
              f"every model")
    return 0


def _read(path: Path) -> dict:
    """The comparison's results at ``path`` (its other scales' points and every record are kept),
    read back as user input; none yet: an empty one."""
    if not path.exists():
        return {"points": {}}
    from studies.records import read_json
    try:
        result = read_json(path, "comparison")
    except ValueError as err:
        raise ValueError(f"{path}: not a comparison's results ({err}); move it aside to start "
                         f"a new one") from None
    if not isinstance(result, dict) or not isinstance(result.get("points"), dict):
        raise ValueError(f"{path}: not a comparison's results (no points); move it aside to "
                         f"start a new one")
    return result


def _in_json(version: str):
    """The records the comparison's JSON holds for simulator ``version``, as (scale, seed,
    model, record) (:func:`studies.records.gather`)."""
    def listed(result: dict):
        for scale, by_seed in result.get("records", {}).get(version, {}).items():
            for seed, models in by_seed.items():
                for m, record in models.items():
                    yield float(scale), int(seed), m, record
    return listed


def subject_keyed(paired: dict) -> dict:
    """A point's pairs as ``{subject: {model: pair}}``; a point written before the comparison
    had more than one of ours held the hybrid's pairs as ``{model: pair}``."""
    flat = paired and all(set(v) <= set(METRICS) for v in paired.values())
    return {"hybrid": paired} if flat else paired


def assemble(records_dir: Path, json_path: Path, version: str, result: dict) -> dict:
    """``result`` with simulator ``version``'s records (those under ``records_dir`` over those
    ``json_path`` holds) and a point for every scale whose declared seeds all have every model;
    a scale's point built before records were kept (no record of it here) stays as it is."""
    from studies.records import gather
    records = gather(records_dir, "models", json_path, MODELS, RECORD_KEYS, _in_json(version))
    by_scale: dict[float, dict[int, dict]] = {}
    for (scale, seed), models in sorted(records.items()):
        by_scale.setdefault(scale, {})[seed] = dict(sorted(models.items()))
    points = {k: {**p, "paired": subject_keyed(p["paired"])} for k, p in result["points"].items()}
    result = {**result, "points": points, "records": {
        **result.get("records", {}), version: {
            f"{scale:g}": {str(seed): models for seed, models in by_seed.items()}
            for scale, by_seed in by_scale.items()}}}
    for scale, by_seed in by_scale.items():
        declared = COMPARISON_SEEDS.get(scale, ())
        if declared and all(s in by_seed and all(m in by_seed[s] for m in MODELS)
                            for s in declared):
            key = f"{version} scale {scale:g}"
            result["points"][key] = point({s: by_seed[s] for s in declared}, version, scale)
            result["points"][key]["command"] = result["command"] = (
                f"python studies/comparison.py --version {version} --scale {scale:g} "
                f"--work {shown_path(records_dir.parent.parent)} --json {shown_path(json_path)}")
    return result

if __name__ == "__main__":
    sys.exit(main())
