"""The learning curve: each model's error against the amount of training data, up to the paper's.

Each point is one ``psmforce reproduce`` run of the automated protocol at a scale (1.0 = the paper's
amount of data) with the main models only (no ablations, data efficiency or teleoperation), every
model trained to early stopping over the bench seeds, cached per task and resumable inside a task
(:mod:`psmforce.estimators.training.resume`): rerunning the same command goes on where a killed run
stopped. A scale is a point of the curve once every model has finished there over at least two seeds
(:func:`complete`); until then the models finished so far are a partial point, shown in the table
and the figures.

    python studies/learning_curve.py --scales 0.05 0.1 --json
    results/learning_curve/learning_curve.json python studies/learning_curve.py --render-only --json
    results/learning_curve/learning_curve.json

Several calls may share one ``--work`` to use several cores (``--threads 1`` each): give them
disjoint ``--seeds`` or ``--models`` and a ``--json`` of their own under ``runs/``; once the parts
are done, the full call finds every task cached, writes the point, and ``--render-only`` renders
it. A call for some of the models over the seeds is a part of the point, and the JSON keeps it:
a later call for the other models on the same seeds, on another machine too, completes the point
(:func:`merge`) when its benches are the same files (their digests are in the point). A point
already in the JSON is kept when its run is not under ``--work`` (``runs/`` is not committed).

``--lanes N`` does that split itself: each seed's bench (simulation, prior, floor) first, one
process per seed, then every (seed, model) call, the costliest first, over ``N`` processes of
``--threads`` each, then the full call, which finds every task cached. On a machine with many
cores (``--threads 1``) or a GPU, one call finishes a scale:

    python studies/learning_curve.py --scales 1 --seeds 1 2 3 --lanes 9 --threads 1 --device cuda

``--device cuda`` trains a scale's run on a GPU. A run's networks train on one device (each task's
cache key holds it, so a CPU call does not reuse a GPU run's tasks); the closed-form
MultiRocket-Hydra fits on the CPU in either (:func:`psmforce.experiments.reproduce.task_device`).
``--finish-on cpu`` finishes a GPU run on the CPU, its tasks keyed as before, a training resuming
its saved state (:func:`psmforce.experiments.reproduce.reproduce`). The point records the device(s)
each model's networks trained on, per seed where a training moved, and the table shows them.

The JSON holds, per scale, the minutes of training recordings (the automated training split,
validation included, at the bench's rate), each model's causal and paper NRMSE per axis (mean,
std and number of seeds, as the run's ``results.json`` holds them: the sample std, ddof 1, since
issue 45, :func:`psmforce.estimators.evaluation.tables.spread`), whether every model converged,
and, per axis, the verdict of the hybrid
against the paper's transformer by the spread rule (a win needs mean + std below the other's
mean - std); and where each model stands: per axis, the first scale at which the transformer
matches the hybrid, and the minutes of data the transformer needs to reach the hybrid's error at
scale 0.1 (:func:`data_efficiency`). ``--render-only`` assembles the JSON, the table
(``README.md``), the three axes in one figure (``learning_curve.png``) and one figure per axis
(``<axis>.png``: error against minutes of data, log-log,
the spread as error bars) beside it from the finished runs under ``--work``, training nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from psmforce.estimators.evaluation.tables import (SPREAD, compare, has_spread,  # noqa: E402
                                                   spread_text)
from psmforce.core.files import folder_sha256, write_text_atomic  # noqa: E402

SCALES = (0.05, 0.1, 0.25, 0.5, 1.0)
MODELS = ("hybrid", "transformer", "fcn", "rocket")
AXES = ("Fx", "Fy", "Fz")
METRICS = ("causal", "paper")
HYBRID, TRANSFORMER = "Hybrid (ours)", "Transformer (paper)"
EFFICIENCY_SCALE = 0.1
"""The scale whose hybrid error the transformer's data needs are measured against (issue 28)."""
PAPER_SCALE = 1.0
"""The paper's amount of training data: the scale the curve's headline claim is made at."""


def run_dir(work: Path, scale: float) -> Path:
    return work / f"scale_{scale:g}"


def run_scale(work: Path, scale: float, seeds, models, threads: int, device: str = "cpu",
              finish_on: str | None = None) -> None:
    """Run (or resume) the reproduction at ``scale`` with its networks on ``device`` (a torch
    device; one per run, since a task's cache key holds it), or, with ``finish_on``, the
    trainings still to do on that device instead (:func:`psmforce.experiments.reproduce.reproduce`)."""
    from psmforce.experiments.reproduce import reproduce
    reproduce(run_dir(work, scale), scale=scale, seeds=seeds, device=device, threads=threads,
              finish_on=finish_on, models=models, ablations=False, efficiency=False,
              teleop=False)


TRAINING_COST = {"transformer": 3, "hybrid": 2, "fcn": 1, "rocket": 0}
"""Rank of each model's training time on the curve (costliest first in the lanes' queue)."""


def lane_jobs(seeds, models) -> list[tuple[int, str]]:
    """The (seed, model) calls of a scale in the order the lanes take them: the costliest model
    first, seeds interleaved, so the longest trainings start soonest."""
    unranked = max(TRAINING_COST.values()) + 1
    ranked = sorted(models, key=lambda m: -TRAINING_COST.get(m, unranked))
    return [(s, m) for m in ranked for s in seeds]


def run_lanes(work: Path, scale: float, seeds, models, lanes: int, threads: int,
              device: str, finish_on: str | None = None) -> None:
    """Run a scale in ``lanes`` processes of ``threads`` threads each, in the one resumable run
    folder: first each seed's bench (:func:`psmforce.experiments.reproduce.prepare_benches`, one
    process per seed, since two must not write one bench), then the (seed, model) calls of
    :func:`lane_jobs`. Each call's log is ``<work>/lanes/scale_<scale>/<name>.log``, beside the run
    folder, which holds one run and nothing else. Raises naming the logs of the calls that failed
    once the stage's others have finished (rerun the same command to resume)."""
    from psmforce.experiments.reproduce import prepare_benches
    logs = work / "lanes" / run_dir(work, scale).name
    logs.mkdir(parents=True, exist_ok=True)
    prepare_benches(run_dir(work, scale), scale, (), teleop=False)  # claim it before the lanes

    def call(job: tuple[int, str | None]) -> tuple[str, int, Path]:
        seed, model = job
        name = f"{model or 'bench'}_seed{seed}"
        what = ["--benches-only"] if model is None else ["--models", model]
        cmd = [sys.executable, str(Path(__file__).resolve()), "--scales", f"{scale:g}",
               "--seeds", str(seed), *what, "--threads", str(threads), "--device", device,
               *(["--finish-on", finish_on] if finish_on else []), "--work", str(work),
               "--json", str(logs / f"{name}.json")]
        with open(logs / f"{name}.log", "a") as f:
            rc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode
        return name, rc, logs / f"{name}.log"

    with ThreadPoolExecutor(max_workers=lanes) as pool:
        for stage in ([(s, None) for s in seeds], lane_jobs(seeds, models)):
            failed = [(name, log) for name, rc, log in pool.map(call, stage) if rc != 0]
            if failed:
                raise RuntimeError("lane calls failed (rerun the same command to resume): "
                                   + "; ".join(f"{name}, see {log}" for name, log in failed))


def _training_minutes(out: Path, seeds) -> float:
    """Minutes of recordings in the automated training split (validation included), mean over
    the seeds' benches."""
    minutes = []
    for seed in seeds:
        meta = json.loads((out / "work" / "data" / f"automated_seed{seed}" / "metadata.json")
                          .read_text())
        rows = sum(t["rows"] for t in meta["trials"] if t["split"] == "train")
        minutes.append(rows / meta["sample_rate_hz"] / 60.0)
    return sum(minutes) / len(minutes)


def bench_digests(out: Path, seeds) -> dict[str, str]:
    """Per seed, the SHA-256 of its automated bench's files (:func:`psmforce.core.files.folder_sha256`,
    as the run's simulate task records it): two parts of a point are one run's results only on
    identical files, and a bench simulated again from its seed on another machine (other
    library versions) need not be."""
    return {str(seed): folder_sha256(out / "work" / "data" / f"automated_seed{seed}")
            for seed in seeds}


def _sample_std(cell: dict) -> dict:
    """``{mean, std, n}`` with the population std (ddof 0) a run wrote as the sample std (ddof 1):
    exactly ``std * sqrt(n / (n - 1))``; none for one seed."""
    n, std = cell["n"], cell["std"]
    return {**cell, "std": None if n < 2 or std is None else std * math.sqrt(n / (n - 1))}


def sample_spread(p: dict) -> dict:
    """A point whose spreads are the sample std over seeds (:data:`SPREAD`): one assembled from
    runs that wrote the population std (no ``spread`` entry) converted exactly
    (:func:`_sample_std`), and its verdicts, which the spread rule draws from those stds, drawn
    again."""
    if p.get("spread") == SPREAD:
        return p
    models = {label: {m: {a: _sample_std(c) for a, c in axes.items()} for m, axes in by.items()}
              for label, by in p["models"].items()}
    return {**p, "models": models, "hybrid_vs_transformer": _verdicts(models), "spread": SPREAD}


def point(out: Path) -> dict:
    """One finished run's point of the curve (or its part, when the run holds some models of
    the curve only: ``model_names``)."""
    results = json.loads((out / "results.json").read_text())
    call = results["call"]
    seeds = call["seeds"]
    automated = results["automated"]
    models = {label: {m: {a: automated[m][label][a]["nrmse_pct"] for a in AXES}
                      for m in METRICS}
              for label in automated["causal"]}
    return {"scale": call["scale"], "seeds": seeds, "model_names": sorted(call["models"]),
            "devices": _trained_on(results),
            "training_minutes": _training_minutes(out, seeds),
            "bench_sha256": bench_digests(out, seeds),
            "simulator_versions": sorted(set(results["benches"].values())),
            "all_converged": results["all_converged"], "models": models,
            "stopped": _stopped(results.get("training", {})),
            "optimiser": _optimiser(out, results),
            "hybrid_vs_transformer": _verdicts(models), "run": shown_path(out),
            "spread": results.get("spread")}


def _trained_on(results: dict) -> dict:
    """{label: the device(s) its networks trained on}: the run's, or, where a seed's training
    moved (a run finished on another device, :func:`psmforce.experiments.reproduce.reproduce`), per
    seed the devices its epochs ran on in order. A training cached before trainings recorded their
    devices trained on the run's."""
    from psmforce.estimators.networks.recipes import recipe
    from psmforce.experiments.reproduce import task_device
    per_seed: dict[str, dict[str, list[str]]] = {}
    for key, t in sorted(results.get("training", {}).items(),
                         key=lambda kv: int(kv[0].rsplit(" ", 1)[1])):
        model, seed = key.split(" ", 1)[0], key.rsplit(" ", 1)[1]
        if not recipe(model).closed_form:
            ran = " then ".join(t.get("devices") or [task_device(model, results["call"]["device"])])
            per_seed.setdefault(_label(model), {}).setdefault(ran, []).append(seed)
    return {label: next(iter(by)) if len(by) == 1 else "; ".join(
                f"{ran} (seed{'s' if len(s) > 1 else ''} {', '.join(s)})" for ran, s in by.items())
            for label, by in per_seed.items()}


def _label(model: str) -> str:
    from psmforce.experiments.plan import plan
    return plan(model).label


def devices(p: dict) -> dict:
    """{label: the device its networks trained on} of a point's trained networks (a point
    assembled before points held them names one device for the run)."""
    if "devices" in p:
        return p["devices"]
    from psmforce.estimators.networks.recipes import recipe
    closed_form = {_label(m) for m in MODELS if recipe(m).closed_form}
    return {label: p.get("device", "not recorded") for label in p["models"]
            if label not in closed_form}


def merge(a: dict, b: dict) -> dict | None:
    """One point from two parts at one scale on the same benches (seeds, simulator version,
    amount of training recordings and, where both parts hold them, the digests of the bench
    files: :func:`bench_digests`), ``b``'s models replacing ``a``'s; None when the benches
    differ. The models of one bench seed train independently (each task's cache key holds all
    it depends on), so parts run apart, on other machines too, are one run's results."""
    def bench(p: dict) -> tuple:
        return p["scale"], p["seeds"], p["simulator_versions"], round(p["training_minutes"], 6)

    digests = a.get("bench_sha256"), b.get("bench_sha256")
    if bench(a) != bench(b) or (None not in digests and digests[0] != digests[1]):
        return None
    models = {**a["models"], **b["models"]}
    a_kept = set(a["models"]) - set(b["models"])
    return {**b, "bench_sha256": digests[1] or digests[0],
            "model_names": sorted(set(a.get("model_names", [])) | set(b["model_names"])),
            "devices": {**{k: v for k, v in devices(a).items() if k in a_kept}, **devices(b)},
            "all_converged": b["all_converged"] and (a["all_converged"] or not a_kept),
            "models": models, "stopped": {**a["stopped"], **b["stopped"]},
            "optimiser": {**a.get("optimiser", {}), **b.get("optimiser", {})},
            "hybrid_vs_transformer": _verdicts(models),
            "run": "; ".join(dict.fromkeys(a["run"].split("; ") + [b["run"]]))}


def _stopped(training: dict) -> dict:
    """{label: ["46 epochs", ...] or ["closed form", ...]} over the seeds, from the run's
    training records (keyed ``"<model> <variant> <fraction> seed <n>"``)."""
    from psmforce.experiments.plan import plan
    out: dict[str, list[str]] = {}
    for key, t in sorted(training.items(), key=lambda kv: int(kv[0].rsplit(" ", 1)[1])):
        how = ("closed form" if t["stopped_by"] == "closed form"
               else f"{t['epochs_run']} epochs" + ("" if t["converged"] else " (NOT converged)"))
        out.setdefault(plan(key.split(" ", 1)[0]).label, []).append(how)
    return out


def _optimiser(out: Path, results: dict) -> dict:
    """{label: the distinct recipe optimiser settings its seeds trained with}: from the run's
    training records, or, for a task cached before they held them, from its checkpoint's
    provenance (None where neither says). A change of a model's recipe retrains it, so scales
    run before and after the change differ here, and the table says so."""
    from psmforce.estimators.training.checkpoint import load_checkpoint
    from psmforce.experiments.plan import plan
    from psmforce.experiments.reproduce import _checkpoint, task_device
    out_settings: dict[str, list] = {}
    for key, t in results.get("training", {}).items():
        model, variant, fraction, _, seed = key.split(" ")
        settings = t.get("optimiser")
        if settings is None and "budget" in results["call"]:
            path = _checkpoint(str(out / "work"), {
                "model": model, "variant": variant, "fraction": float(fraction),
                "seed": int(seed), "budget": results["call"]["budget"],
                "device": task_device(model, results["call"]["device"])})
            if path.is_file():
                settings = load_checkpoint(path).provenance.get("reproduce", {}).get(
                    "recipe", {}).get("optimiser")
        seen = out_settings.setdefault(plan(model).label, [])
        if settings not in seen:
            seen.append(settings)
    return out_settings


def settings_lines(curve: dict) -> list[str]:
    """Markdown lines: per model whose recipe sets training settings at some point, the settings
    each scale was trained with ("not recorded" for a point assembled before points held them),
    so a curve across a recipe change says where it changed."""
    by_label: dict[str, dict[str, list[str]]] = {}
    for p in curve["points"]:
        for label in p["models"]:
            for settings in p.get("optimiser", {}).get(label, [None]):
                text = "not recorded" if settings is None else json.dumps(settings,
                                                                           sort_keys=True)
                by_label.setdefault(label, {}).setdefault(text, []).append(f"{p['scale']:g}")
    return [f"- {label}: " + "; ".join(f"`{text}` at scale {', '.join(scales)}"
                                       for text, scales in by_setting.items())
            for label, by_setting in sorted(by_label.items()) if set(by_setting) != {"{}"}]


def _verdicts(models: dict) -> dict:
    if HYBRID not in models or TRANSFORMER not in models:
        return {}
    out = {}
    for m in METRICS:
        out[m] = {}
        for a in AXES:
            h, t = models[HYBRID][m][a], models[TRANSFORMER][m][a]
            verdict = {-1: "hybrid ahead", 0: "tie", 1: "transformer ahead"}[compare(h, t)]
            out[m][a] = {"verdict": verdict, "ratio": h["mean"] / t["mean"]}
    return out


def crossovers(points: list[dict], metric: str = "causal") -> dict:
    """Per axis, the first measured scale at which the paper transformer matches the hybrid (the
    spread rule no longer says "hybrid ahead"), or None while the hybrid leads at every one."""
    out = {}
    for a in AXES:
        matched = [p for p in points if p["hybrid_vs_transformer"]
                   and p["hybrid_vs_transformer"][metric][a]["verdict"] != "hybrid ahead"]
        out[a] = ({"scale": matched[0]["scale"], "minutes": matched[0]["training_minutes"],
                   "verdict": matched[0]["hybrid_vs_transformer"][metric][a]["verdict"]}
                  if matched else None)
    return out


def data_efficiency(points: list[dict], at_scale: float = 0.1, metric: str = "causal") -> dict:
    """Per axis, the minutes of training data the paper transformer needs to reach the hybrid's
    mean error at ``at_scale``: interpolated log-log between the transformer's measured means
    where its curve crosses that error; otherwise a bound (``"more than"`` the largest measured
    amount, ``"at most"`` the smallest). ``ratio`` = those minutes / the hybrid's."""
    ref = [p for p in points if p["scale"] == at_scale and HYBRID in p["models"]]
    curve = [(p["training_minutes"], p["models"][TRANSFORMER][metric])
             for p in points if TRANSFORMER in p["models"]]
    if not ref or not curve:
        return {}
    hybrid_minutes = ref[0]["training_minutes"]
    out = {}
    for a in AXES:
        target = ref[0]["models"][HYBRID][metric][a]["mean"]
        errors = [(m, e[a]["mean"]) for m, e in curve]
        minutes, bound = None, "more than"
        if errors[0][1] <= target:
            minutes, bound = errors[0][0], "at most"
        for (m0, e0), (m1, e1) in zip(errors, errors[1:]):
            if minutes is None and e0 > target >= e1:
                t = math.log(e0 / target) / math.log(e0 / e1)
                minutes, bound = m0 * (m1 / m0) ** t, "interpolated"
        if minutes is None:
            minutes = errors[-1][0]
        out[a] = {"hybrid_nrmse_pct": target, "hybrid_minutes": hybrid_minutes,
                  "transformer_minutes": minutes, "bound": bound,
                  "ratio": minutes / hybrid_minutes}
    return out


def standing(curve: dict) -> list[str]:
    """Markdown lines: where the transformer first matches the hybrid, and the hybrid's data
    efficiency, from the curve's JSON."""
    lines = []
    measured = ", ".join(f"{p['scale']:g}" for p in curve["points"])
    for a, c in curve.get("crossover", {}).items():
        per_scale = ", ".join(f"{p['hybrid_vs_transformer']['causal'][a]['verdict']} at "
                              f"{p['scale']:g}" for p in curve["points"]
                              if p["hybrid_vs_transformer"])
        lines.append(f"- {a}: " + (
            f"the transformer matches the hybrid first at scale {c['scale']:g} "
            f"({c['minutes']:.1f} min of training data); per scale: {per_scale}" if c else
            f"the hybrid is ahead at every measured scale ({measured})") + ".")
    for a, e in curve.get("data_efficiency", {}).items():
        amount = {"interpolated": f"about {e['transformer_minutes']:.0f} min",
                  "more than": f"more than {e['transformer_minutes']:.0f} min (the largest "
                               "amount measured)",
                  "at most": f"at most {e['transformer_minutes']:.0f} min"}[e["bound"]]
        lines.append(f"- {a}: to reach the hybrid's error at scale {curve['efficiency_scale']:g} "
                     f"({e['hybrid_nrmse_pct']:.2f} %, {e['hybrid_minutes']:.1f} min of data) "
                     f"the transformer needs {amount}: "
                     + ("" if e["bound"] == "interpolated" else e["bound"] + " ")
                     + f"{e['ratio']:.1f}x the data.")
    return lines


def _against(h: dict, other: dict) -> str:
    """The hybrid's mean error over another model's, with the spread rule's verdict."""
    verdict = {-1: "hybrid ahead", 0: "tie", 1: "hybrid behind"}[compare(h, other)]
    return f"{h['mean'] / other['mean']:.2f}x ({verdict})"


def paper_budget(curve: dict) -> str:
    """One sentence: the hybrid against every other model at the paper's amount of data
    (:data:`PAPER_SCALE`), per axis, causal, and against the transformer on the paper's metric
    too; or that nothing is claimed there while the point is not whole."""
    at = [p for p in curve["points"] if p["scale"] == PAPER_SCALE]
    if not at:
        return (f"At the paper's own budget (scale {PAPER_SCALE:g}) the hybrid against the "
                "transformer is not measured yet: no claim is made for it.")
    p = at[0]
    hybrid = p["models"][HYBRID]

    def row(label: str, metric: str) -> str:
        return f"{label} " + ", ".join(
            f"{a} {_against(hybrid[metric][a], p['models'][label][metric][a])}" for a in AXES)

    others = [TRANSFORMER] + sorted(set(p["models"]) - {HYBRID, TRANSFORMER})
    return (f"At the paper's own budget (scale {PAPER_SCALE:g}, {p['training_minutes']:.0f} min "
            f"of training data, {len(p['seeds'])} seeds"
            + ("" if p["all_converged"] else ", NOT every run converged")
            + "), the hybrid's causal error over each model's: "
            + "; ".join(row(label, "causal") for label in others)
            + f". On the paper's offline metric: {row(TRANSFORMER, 'paper')}.")


def table(curve: dict) -> str:
    """The Markdown table of the curve (``README.md`` beside the JSON)."""
    lines = ["# The learning curve", "",
             f"Rendered by `python studies/learning_curve.py --render-only --json "
             f"{curve['json']}` from the JSON beside it; the runs' commands are there. The "
             "automated protocol of the simulated bench at each scale (1.0 = the paper's amount "
             "of data); NRMSE % on the test trials, mean ± std over bench seeds; causal = the "
             "raw per-sample estimate a haptic loop gets, paper = the paper's offline "
             "post-processing. Figures: one per axis, causal metric, beside this page.", ""]
    shown = _shown(curve)
    if not shown:
        return "\n".join(lines + ["No scale has finished yet.", ""])
    for m in METRICS:
        lines += [f"**{m}**", "", "| scale | minutes of training data | seeds | converged | model "
                  "| trained to its early stop, per seed | Fx | Fy | Fz |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for p in shown:
            for label, r in p["models"].items():
                cells = " | ".join(spread_text(r[m][a]) for a in AXES)
                stopped = ", ".join(p.get("stopped", {}).get(label, []))
                lines.append(f"| {p['scale']:g} | {p['training_minutes']:.1f} | "
                             f"{len(p['seeds'])} | {'yes' if p['all_converged'] else 'NO'} | "
                             f"{label} | {stopped} | {cells} |")
            if p["hybrid_vs_transformer"]:
                v = p["hybrid_vs_transformer"][m]
                lines.append(f"| {p['scale']:g} | | | | hybrid / transformer | | " + " | ".join(
                    f"{v[a]['ratio']:.2f}x ({v[a]['verdict']})" for a in AXES) + " |")
        lines.append("")
    lines += ["Networks trained on: " + "; ".join(
        f"scale {p['scale']:g} {_devices_text(p)}" for p in shown)
        + ". MultiRocket-Hydra fits in closed form on the CPU at every scale.", ""]
    settings = settings_lines(curve)
    if settings:
        lines += ["Training settings of the models' recipes beyond the defaults of "
                  "`psmforce.estimators.training.train.TrainConfig`, per scale:", ""] + settings + [""]
    lines += ["**Where each model stands** (causal metric; spread rule)", ""] + standing(curve)
    lines += ["", "Scales not yet measured: "
              + (", ".join(f"{s:g}" for s in curve["missing_scales"]) or "none") + "."
              + "".join(f" At scale {p['scale']:g} only {', '.join(p['models'])} so far: the "
                        "hybrid against the transformer is not measured there."
                        for p in curve.get("partial", [])), ""]
    return "\n".join(lines)


def _shown(curve: dict) -> list[dict]:
    """The points and the partial points, by scale: what the table and the figures show."""
    return sorted(curve["points"] + curve.get("partial", []), key=lambda p: p["scale"])


def _devices_text(p: dict) -> str:
    """"cuda", or per device the networks trained on it where a point's parts differ."""
    by_device: dict[str, list[str]] = {}
    for label, device in devices(p).items():
        by_device.setdefault(device, []).append(label)
    if len(by_device) == 1:
        return next(iter(by_device))
    return ", ".join(f"{d} ({', '.join(labels)})" for d, labels in by_device.items())


def figures(curve: dict, folder: Path) -> list[str]:
    """The curve as log-log figures of causal NRMSE against minutes of training data: all three
    axes side by side (``learning_curve.png``, the README's figure), then one per axis."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    shown = _shown(curve)
    labels = sorted({label for p in shown for label in p["models"]})
    fig, axes = plt.subplots(1, len(AXES), figsize=(13, 3.8), layout="constrained")
    for ax, a in zip(axes, AXES):
        _draw_axis(ax, a, shown, labels)
        ax.set_title(a)
    handles, names = axes[0].get_legend_handles_labels()
    fig.legend(handles, names, fontsize=8, loc="outside lower center", ncols=len(names))
    written = [_save(fig, folder / "learning_curve.png", plt)]
    for a in AXES:
        fig, ax = plt.subplots(figsize=(7.5, 4), layout="constrained")
        _draw_axis(ax, a, shown, labels)
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))  # clear of the data
        written.append(_save(fig, folder / f"{a}.png", plt))
    return written


def _draw_axis(ax, a: str, shown: list[dict], labels: list[str]) -> None:
    """Axis ``a``'s causal NRMSE of each model against minutes of data, log-log, on ``ax``."""
    from matplotlib.ticker import FuncFormatter
    for label in labels:
        pts = [p for p in shown if label in p["models"]]
        x = [p["training_minutes"] for p in pts]
        y = [p["models"][label]["causal"][a]["mean"] for p in pts]
        e = [c["std"] if has_spread(c) else math.nan  # one seed: no error bar
             for c in (p["models"][label]["causal"][a] for p in pts)]
        ax.errorbar(x, y, yerr=e, marker="o", capsize=3, label=label)
    # scale 1's own minutes once measured: trial lengths do not shrink exactly with scale
    full = next((p for p in shown if p["scale"] == 1.0), shown[0])
    ax.axvline(full["training_minutes"] / full["scale"], color="grey", linestyle="--",
               label="the paper's amount of data (scale 1)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain = FuncFormatter(lambda v, _: f"{v:g}")  # 20, not 2 x 10^1
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(plain)
        axis.set_minor_formatter(plain)
    ax.xaxis.set_minor_formatter(FuncFormatter(  # the minutes span decades: 2, 3, 5 only
        lambda v, _: f"{v:g}" if round(v / 10 ** math.floor(math.log10(v))) in (2, 3, 5)
        else ""))
    ax.grid(True, which="both", alpha=0.3)
    ax.set_xlabel("training data [minutes of recordings]")
    ax.set_ylabel(f"{a}, HEX10 frame: causal NRMSE [%]")


def _save(fig, path: Path, plt) -> str:
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path.name


MIN_SEEDS = 2
"""Bench seeds a point needs (issue 28: three, at least two at the largest scales)."""


def finished(out: Path) -> bool:
    """Whether the run in ``out`` holds a part of the curve's point: results over at least
    :data:`MIN_SEEDS` seeds (a call for one seed beside the main one writes a ``results.json``
    too, and is not a part)."""
    path = out / "results.json"
    return path.exists() and len(json.loads(path.read_text())["call"]["seeds"]) >= MIN_SEEDS


def complete(p: dict, models=MODELS) -> bool:
    """Whether a point covers every model of the curve (a point assembled before points named
    their models was complete)."""
    return set(models) <= set(p.get("model_names", models))


def _combined(kept: dict | None, here: dict | None, models) -> dict | None:
    """A scale's point from the JSON's (``kept``) and this machine's run (``here``): the run's
    when it is whole or nothing is kept, both merged when they are parts on the same benches;
    else the kept one if it is whole (a part never drops a point), else the run's."""
    if here is None or kept is None:
        return here or kept
    if complete(here, models):
        return here
    merged = merge(kept, here)
    if merged is not None:
        return merged
    return kept if complete(kept, models) else here


def assemble(work: Path, scales, json_path: Path, models=MODELS) -> dict:
    """The curve over every scale of :data:`SCALES` and ``scales``: a point from each finished
    run under ``work``, merged (:func:`merge`) with the part of that scale the JSON at
    ``json_path`` already holds, which is kept when its run is not under ``work`` (``runs/`` is
    not committed, and a new machine starts without it). A point covering every model of the
    curve is in ``points``; one that covers some (``partial``: trained so far) shows in the
    table and the figures, and its scale stays missing."""
    scales = sorted(set(SCALES) | set(scales))
    old = json.loads(json_path.read_text()) if json_path.exists() else {}
    kept = {p["scale"]: sample_spread(p) for p in old.get("points", []) + old.get("partial", [])}
    points, partial = [], []
    for s in scales:
        here = sample_spread(point(run_dir(work, s))) if finished(run_dir(work, s)) else None
        p = _combined(kept.get(s), here, models)
        if p is not None:
            (points if complete(p, models) else partial).append(p)
    done = {p["scale"] for p in points}
    curve = {"command": "python studies/learning_curve.py " + " ".join(sys.argv[1:]),
             "json": shown_path(json_path), "scales": scales,
             "missing_scales": [s for s in scales if s not in done],
             "points": points, "partial": partial, "crossover": crossovers(points),
             "efficiency_scale": EFFICIENCY_SCALE,
             "data_efficiency": data_efficiency(points, EFFICIENCY_SCALE)}
    json_path.parent.mkdir(parents=True, exist_ok=True)
    curve["figures"] = figures(curve, json_path.parent) if points or partial else []
    write_json(json_path, curve)
    write_text_atomic(json_path.parent / "README.md", table(curve))
    return curve


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scales", type=float, nargs="+", default=list(SCALES))
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--models", nargs="+", default=list(MODELS))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default="cpu",
                    help="torch device the networks train on (cpu, cuda); one per scale's run")
    ap.add_argument("--finish-on", default=None,
                    help="torch device the trainings still to do run on instead of --device "
                         "(a GPU run whose machine is gone finishes on the CPU, tasks keyed "
                         "as before)")
    ap.add_argument("--work", type=Path, default=Path("runs/learning_curve"))
    ap.add_argument("--json", type=Path, default=ROOT / "results" / "learning_curve"
                    / "learning_curve.json")
    ap.add_argument("--render-only", action="store_true",
                    help="assemble the finished scales, train nothing")
    ap.add_argument("--lanes", type=int, default=1,
                    help="parallel processes per scale, --threads each (1: this process only)")
    ap.add_argument("--benches-only", action="store_true",
                    help="simulate each seed's bench and fit its prior, train nothing")
    args = ap.parse_args(argv)
    if len(set(args.seeds)) != len(args.seeds):
        ap.error(f"--seeds: repeated seeds {args.seeds}")
    from psmforce.estimators.networks.recipes import RECIPES
    unknown = sorted(set(args.models) - set(RECIPES))
    if unknown:
        ap.error(f"--models: unknown {unknown}; known: {list(RECIPES)}")
    if args.lanes < 1 or args.threads < 1:
        ap.error(f"--lanes and --threads must be at least 1, got {args.lanes} and {args.threads}")
    if args.benches_only:
        from psmforce.experiments.reproduce import prepare_benches
        for scale in sorted(args.scales):
            prepare_benches(run_dir(args.work, scale), scale, args.seeds, teleop=False)
        return 0
    if not args.render_only:
        for scale in sorted(args.scales):
            if args.lanes > 1:
                try:
                    run_lanes(args.work, scale, args.seeds, args.models, args.lanes,
                              args.threads, args.device, args.finish_on)
                except RuntimeError as e:
                    print(f"learning_curve: {e}", file=sys.stderr)
                    return 1
            run_scale(args.work, scale, args.seeds, args.models, args.threads, args.device,
                      args.finish_on)
            assemble(args.work, args.scales, args.json)  # kept at once
    assemble(args.work, args.scales, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
