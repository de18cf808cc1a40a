"""Markdown tables of a comparison, and the rule that calls a difference a win.

Every figure a table shows comes from the results dictionaries of
:mod:`psmforce.estimators.evaluation.evaluate` and :mod:`psmforce.experiments.reproduce`; nothing
here computes a metric, but the spread beside a mean over seeds is formed here, once
(:func:`std_over_seeds`): the sample standard deviation (ddof 1), none for a single seed. A model
wins an axis only when its mean plus its std stays below every other model's mean minus that one's
std (:func:`verdicts`); otherwise the table says tie, and a mean without a spread always ties.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from psmforce.estimators.evaluation.metrics import AXES, POSTPROCESSING, lowpass_lag_samples


def automated_table(results: Mapping[str, Mapping[str, Mapping[str, float]]],
                    title: str = "Automated test set") -> str:
    """The paper's Table (automated test set): one row per axis, range, then RMSE / NRMSE / R^2
    per model; the best NRMSE per axis in bold. ``results``: {model label: axis_metrics}."""
    labels = list(results)
    head = ("| Axis | Range (N) | " + " | ".join(f"{m} RMSE (N) | {m} NRMSE (%) | {m} R² (%)"
                                                for m in labels) + " |")
    sep = "|" + "---|" * (2 + 3 * len(labels))
    rows = [f"**{title}**", "", head, sep]
    first = results[labels[0]]
    for axis in AXES:
        best = min(results[m][axis]["nrmse_pct"] for m in labels)
        cells = []
        for m in labels:
            r = results[m][axis]
            n = f"{r['nrmse_pct']:.2f}"
            cells += [f"{r['rmse_n']:.3f}", f"**{n}**" if r["nrmse_pct"] == best else n,
                      f"{r['r2_pct']:.2f}"]
        rows.append(f"| {axis} | {first[axis]['range_n']:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"


def modes_table(results: Mapping[str, Mapping[str, Mapping]], floor: Mapping[str, Mapping]) -> str:
    """NRMSE (%) per axis of each model under each post-processing, with the floor (the truth
    through the same post-processing) as the first row. ``results``: {label: {mode: metrics}}."""
    head = "| Model | " + " | ".join(f"{m} {a}" for m in POSTPROCESSING for a in AXES) + " |"
    rows = [f"NRMSE %; causal = raw per-sample estimate (no look-ahead); causal_lowpass = causal "
            f"5 Hz Butterworth, lag {lowpass_lag_samples() * 10:.0f} ms; paper = centred median "
            f"k = 71 (looks 0.35 s ahead).", "", head, "|" + "---|" * (1 + 3 * len(POSTPROCESSING))]
    for label, by_mode in {"floor (truth post-processed)": floor, **results}.items():
        rows.append(f"| {label} | " + " | ".join(f"{by_mode[m][a]['nrmse_pct']:.2f}"
                                               for m in POSTPROCESSING for a in AXES) + " |")
    return "\n".join(rows) + "\n"


def uncertainty_table(block: Mapping[str, Mapping]) -> str:
    """The predicted uncertainty against the errors, per axis, overall then per condition:
    mean predicted std and RMSE (N), the fraction of samples within 1 and 2 std (0.683 / 0.954
    when calibrated), the Gaussian NLL (nats). ``block``: evaluate's ``uncertainty`` entry."""
    rows = ["**Predicted uncertainty** (raw per-sample estimate from the evaluation start; a "
            "calibrated Gaussian has 0.683 within 1 std, 0.954 within 2)", "",
            "| Trials | Axis | mean std (N) | RMSE (N) | within 1 std | within 2 std | NLL |",
            "|---|---|---|---|---|---|---|"]
    for label, by_axis in {"all": block["overall"], **block["by_condition"]}.items():
        for axis in AXES:
            r = by_axis[axis]
            rows.append(f"| {label} | {axis} | {r['mean_std_n']:.3f} | {r['rmse_n']:.3f} | "
                        f"{r['within_1std']:.3f} | {r['within_2std']:.3f} | {r['nll']:.3f} |")
    return "\n".join(rows) + "\n"


def teleop_table(results: Mapping[str, Mapping[str, Sequence[Mapping]]]) -> str:
    """The paper's finetuning table: rows (condition, seen/unseen, axis), mean ± std over the
    cross-validation folds (:func:`mean_std`: the sample std, none for one fold). ``results``:
    {model label: {"Rigid/Seen": [axis_metrics per fold]}}."""
    labels = list(results)
    groups = list(results[labels[0]])
    head = ("| Condition | Config | Axis | Range (N) | " + " | ".join(
        f"{m} RMSE (N) | {m} NRMSE (%) | {m} R² (%)" for m in labels) + " |")
    rows = [head, "|" + "---|" * (4 + 3 * len(labels))]

    def ms(values):
        return spread_text(mean_std(values))
    for g in groups:
        cond, seen = g.split("/")
        for axis in AXES:
            folds0 = results[labels[0]][g]
            cells = [ms([f[axis]["range_n"] for f in folds0])]
            for m in labels:
                folds = results[m][g]
                cells += [ms([f[axis][k] for f in folds])
                          for k in ("rmse_n", "nrmse_pct", "r2_pct")]
            rows.append(f"| {cond} | {seen} | {axis} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"


SPREAD = "sample std over seeds (ddof 1)"
"""How :func:`std_over_seeds` forms a spread, as results files record it (``spread``), so that a
reader tells it from the population std (ddof 0) that files without the entry hold."""


def std_over_seeds(values: Sequence[float]) -> float | None:
    """The spread shown beside a mean over seeds (or folds): the sample standard deviation of
    ``values`` (ddof 1, numpy's ``std(ddof=1)``), or None for a single value, from which no
    spread can be formed. A mean without a spread is shown without ± (:func:`spread_text`) and the
    spread rule calls it a tie with anything (:func:`compare`, :func:`verdicts`). None rather than
    NaN so that the JSONs holding it stay standard JSON (``null``)."""
    x = np.asarray(values, dtype=float)
    return float(x.std(ddof=1)) if x.size > 1 else None


def mean_std(values: Sequence[float]) -> dict:
    """``{mean, std, n}`` of ``values`` over seeds, ``std`` by :func:`std_over_seeds`."""
    return {"mean": float(np.mean(values)), "std": std_over_seeds(values), "n": len(values)}


def has_spread(d: Mapping) -> bool:
    """Whether ``d`` (a ``{mean, std}``) holds a spread: a finite ``std``, not None (one seed)
    nor NaN."""
    sd = d.get("std")
    return sd is not None and math.isfinite(sd)


def spread_text(d: Mapping, digits: int = 2) -> str:
    """``{mean, std}`` as ``mean ± std``, or the mean alone where it has no spread
    (:func:`has_spread`)."""
    text = f"{d['mean']:.{digits}f}"
    return f"{text} ± {d['std']:.{digits}f}" if has_spread(d) else text


def spread(values: Sequence[dict]) -> dict:
    """{axis: {key: {mean, std, n}}} over a list of axis_metrics dicts (:func:`mean_std`: the
    sample std over them, ddof 1; None for a single one)."""
    return {a: {k: mean_std([v[a][k] for v in values])
                for k in ("rmse_n", "nrmse_pct", "r2_pct", "range_n")} for a in AXES}


def compare(a: Mapping, b: Mapping) -> int:
    """The spread rule between two ``{mean, std}``, std the sample standard deviation over seeds
    (ddof 1, :func:`std_over_seeds`): -1 when ``a``'s mean + std lies below ``b``'s mean - std
    (``a`` wins), 1 when the reverse holds, 0 for a tie. Where either has no spread (one seed:
    std None or NaN) nothing can be called, and the rule says tie."""
    if not (has_spread(a) and has_spread(b)):
        return 0
    if a["mean"] + a["std"] < b["mean"] - b["std"]:
        return -1
    return 1 if b["mean"] + b["std"] < a["mean"] - a["std"] else 0


def verdicts(by_model: dict, key: str = "nrmse_pct") -> dict:
    """{axis: {"best": label, "win": bool, "tied_with": [labels]}} from {label: spread(...)}:
    the lowest mean wins the axis only when its mean + std lies below every other model's
    mean - std, std the sample standard deviation over seeds (ddof 1); otherwise it ties with
    those whose interval overlaps. A model without a spread (one seed, :func:`has_spread`) ties
    with the best, and the best without one ties with every other model."""
    out = {}
    for a in AXES:
        cells = {m: s[a][key] for m, s in by_model.items()}
        best = min(cells, key=lambda m: cells[m]["mean"])
        top = cells[best]["mean"] + cells[best]["std"] if has_spread(cells[best]) else None
        tied = [m for m, c in cells.items() if m != best
                and (top is None or not has_spread(c) or c["mean"] - c["std"] <= top)]
        out[a] = {"best": best, "win": not tied, "tied_with": tied}
    return out


def spread_table(by_model: dict, floor: dict | None, title: str, key: str = "nrmse_pct") -> str:
    """Markdown: one row per model, mean ± std per axis (:func:`spread_text`), the winner in
    bold, ties marked."""
    v = verdicts(by_model, key)
    unit = {"nrmse_pct": "NRMSE %", "rmse_n": "RMSE N", "r2_pct": "R² %"}[key]
    rows = [f"**{title}** ({unit}, mean ± std over {next(iter(by_model.values()))['Fx'][key]['n']}"
            f" runs)", "", "| Model | Fx | Fy | Fz |", "|---|---|---|---|"]
    if floor:
        rows.append("| *floor (truth post-processed)* | " + " | ".join(
            spread_text(floor[a][key]) for a in AXES) + " |")
    for m, s in by_model.items():
        cells = []
        for a in AXES:
            c = spread_text(s[a][key])
            if v[a]["best"] == m:
                c = f"**{c}**" if v[a]["win"] else f"{c} (tie)"
            elif m in v[a]["tied_with"]:
                c += " (tie)"
            cells.append(c)
        rows.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(rows) + "\n"


def results_markdown(r: dict) -> str:
    c = r["call"]
    conv = "every model converged (early stopping fired, no cap)" if r["all_converged"] else \
        "**not converged**: at least one model hit a cap or its epoch limit (see Training)"
    lines = ["# Reproduction of the seed paper on the simulated bench", "",
             f"- command: `{r['command']}`", f"- call: `{c}`",
             f"- code rendering these tables: {r['code']} (each cached task keeps what the "
             f"code that ran it computed); simulator versions of the benches: "
             f"{sorted(set(r['benches'].values()))}",
             f"- machine: {r['machine']['platform']}, {r['machine']['cpu_count']} CPU cores, "
             f"torch {r['machine']['torch']}; executor {r['executor']}",
             f"- started {r['started_utc']}, this invocation {r['duration_s']:.0f} s "
             f"(cached tasks not rerun)",
             f"- budget `{c['budget']}`: {r['budget']}", f"- convergence: {conv}", "",
             "Metrics. **causal** = the raw per-sample estimate a haptic loop gets (free-space "
             "tare at start-up, no filter, no look-ahead); **causal_lowpass** = the same through "
             f"a causal 5 Hz Butterworth ({r['causal_lowpass_lag_ms']:.0f} ms lag); **paper** = "
             "bias + centred median k = 71 (looks 0.35 s ahead). The causal metric leads: its "
             "floor is zero, so it separates models the paper metric's floor hides. A model wins "
             "an axis (bold) only when mean + std < every other model's mean - std; otherwise "
             "the cell says tie.", ""]
    floor = r["floor"]["automated"]
    for mode in ("causal", "causal_lowpass", "paper"):
        lines += [spread_table(r["automated"][mode], floor.get(mode),
                         f"Automated test set, {mode}"), ""]
    lines += ["## Per condition (causal and paper)", ""]
    for cond, by_mode in r["automated_by_condition"].items():
        for mode in ("causal", "paper"):
            lines += [spread_table(by_mode[mode], None, f"{cond} test trials, {mode}"), ""]
    if r["teleop"]:
        lines += ["## Teleoperation after finetuning (leave one configuration out; "
                  "mean ± std over seeds x 3 folds)", ""]
        for group, by_mode in r["teleop"].items():
            tf = r["floor"]["teleop"][group.split("/")[0]]
            for mode in ("causal", "paper"):
                lines += [spread_table(by_mode[mode], tf.get(mode), f"{group}, {mode}"), ""]
    if r["ablation"]:
        lines += ["## Ablations (automated test set)", ""]
        lines += [spread_table({k: v["causal"] for k, v in r["ablation"].items()}, None,
                         "Ablations, causal"), ""]
    if r["data_efficiency"]:
        lines += ["## Data efficiency (automated test set, causal)", ""]
        for lab, by_frac in r["data_efficiency"].items():
            lines += [spread_table({f"{lab} {f}": v["causal"] for f, v in by_frac.items()}, None,
                             f"{lab} by training fraction"), ""]
    for label, published in r["published_nrmse_pct"].items():
        ours = r["automated"]["paper"][label]
        lines += [f"## {label} vs the paper's figures (NRMSE %, paper metric)", "",
                  "| | Fx | Fy | Fz |", "|---|---|---|---|",
                  "| paper (real bench) | " + " | ".join(f"{published[a]:.2f}" for a in AXES)
                  + " |",
                  "| ours (simulated bench) | " + " | ".join(
                      spread_text(ours[a]["nrmse_pct"]) for a in AXES) + " |"]
    lines += ["", "## Training (every pretraining and finetuning)", "",
              "| Run | epochs | stopped by | converged | best val loss | seconds |",
              "|---|---|---|---|---|---|"]
    for k, t in {**r["training"], **r["finetune_training"]}.items():
        lines.append(f"| {k} | {t['epochs_run']} | {t['stopped_by']} | "
                     f"{'yes' if t['converged'] else '**no**'} | {t['best_val_loss']:.4f} | "
                     f"{t['seconds']:.0f} |")
    lines += ["", "## Inference timing (batch 1, one CPU thread)", "",
              "| Model | Mode | ms (mean ± std) | p99 ms | parameters |", "|---|---|---|---|---|"]
    for k, v in r["timing"].items():
        lines.append(f"| {k} | {v['mode']} | {v['ms_mean']:.3f} ± {v['ms_std']:.3f} | "
                     f"{v['ms_p99']:.3f} | {v['parameters']} |")
    lines += ["", "## Figures", ""] + [f"![{Path(f).stem}]({f})" for f in r["figures"]]
    return "\n".join(lines) + "\n"
