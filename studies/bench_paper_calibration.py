"""The bench calibrated to the paper's table (issue 45): simulator candidates against Table III.

For each candidate simulator version (:data:`CANDIDATES`: every setting tried, in the order
tried, kept as the calibration log; the one retained is ``psmforce.sim.versions`` "2.3"), the
automated bench is simulated and the calibration models are trained to early stopping with
``psmforce.experiments.reproduce.reproduce`` (``sim_version=``; main models only, no ablations,
data efficiency or teleoperation, one torch thread), cached per task and resumable: rerunning
the same command goes on where it stopped. Scored on the paper's metric (bias over the first
0.5 s, centred median of 71 samples, NRMSE % over the test set's range) per model and axis,
against the paper's figure for its family (:data:`PAPER`), their ratio and whether it lies in
:data:`BAND`.

Rules (the issue's): calibrate on the FCN, the LSTM and MultiRocket-Hydra only, on design
seeds only (:data:`psmforce.experiments.seeds.DESIGN_SEEDS`); the paper's transformer is the
held-out check (trained only on the version chosen, so that it cannot steer the choice);
the hybrid is never looked at. The FCN must end worse than the transformer laterally, as on the
robot (:func:`held_out_check`; "not checked" until the transformer has run on the version).
Train the transformer only on the version chosen (``--models transformer``); its rows are
marked ``held_out`` and never enter the band rule. Without such a row, the check reads the
published comparison's records of the version at the paper's budget (``--comparison``:
``studies/comparison.py``'s JSON), the transformer and the FCN on the fresh seeds both have:
bench seeds declared after the version was chosen, so held out from its choice as well.
``--verdicts-only`` draws the verdicts again from the rows and those records.

    python studies/bench_paper_calibration.py --version 2.3 --seeds 1 --models fcn rocket \\
        --json results/benchmarks/bench_paper_calibration.json
    python studies/bench_paper_calibration.py --candidates 2.3a 2.3b --scale 0.25 --models fcn \\
        --json runs/bench_paper_calibration/part.json
    python studies/bench_paper_calibration.py --merge runs/bench_paper_calibration/part.json \\
        --json results/benchmarks/bench_paper_calibration.json
    python studies/bench_paper_calibration.py --render-only --json ...

``--lstm-scale``: the LSTM's epochs are long on one CPU thread (about 80 s at scale 1), so it may
be trained on a smaller bench; its rows then say the scale, and that it is not the paper's
budget (:data:`SUBSTITUTES`: a model scored on another candidate's bench, and why). Each
(candidate, scale) is one ``reproduce`` run under ``--work``; the JSON keeps every row ever
written (a later call adds or replaces rows of the same candidate, model and scale), and
``--merge`` folds the rows of partial JSONs (calls run side by side) into it.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.plan import PLAN  # noqa: E402
from psmforce.experiments.report import write_json  # noqa: E402
from studies.records import read_json  # noqa: E402

AXES = ("Fx", "Fy", "Fz")
BAND = (0.67, 1.5)
"""A bench figure imitates the robot's when bench / paper lies in this band."""

_TABLE_III = "paper, Table III (automated test set)"
PAPER = {
    "fcn": {"label": PLAN["fcn"].label, "nrmse_pct": PLAN["fcn"].published_nrmse_pct,
            "source": _TABLE_III},
    "lstm": {"label": PLAN["lstm"].label, "nrmse_pct": PLAN["lstm"].published_nrmse_pct,
             "source": _TABLE_III},
    "rocket": {"label": PLAN["rocket"].label, "nrmse_pct": {"Fx": 2.25, "Fy": 2.46, "Fz": 2.71},
               "source": "given by the issue; no published source found (the paper's Table III "
                         "has no ROCKET column, nor does its supplement)"},
    "transformer": {"label": PLAN["transformer"].label,
                    "nrmse_pct": PLAN["transformer"].published_nrmse_pct,
                    "source": _TABLE_III + "; held out"},
}
"""The robot figures per model family (paper metric, NRMSE %): the paper's, as
:data:`psmforce.experiments.plan.PLAN` holds them, and MultiRocket-Hydra's as issue 45 gave it,
its provenance stated (:func:`published`)."""


def published(model: str) -> bool:
    """Whether the robot figure of ``model`` is the paper's own (Table III)."""
    return PAPER[model]["source"].startswith(_TABLE_III)


CALIBRATION_MODELS = ("fcn", "rocket", "lstm")
HELD_OUT_MODELS = ("transformer",)
"""Trained only on a version already chosen, to check it; never part of the band rule."""

REFERENCE_21 = {
    "source": "results/learning_curve/learning_curve.json, scale 1, seeds 1 and 2 (simulator "
              "2.1, the default)",
    "nrmse_pct": {"fcn": {"Fx": 0.93, "Fy": 1.02, "Fz": 1.88},
                  "rocket": {"Fx": 1.70, "Fy": 1.90, "Fz": 3.97},
                  "transformer": {"Fx": 0.92, "Fy": 1.02, "Fz": 1.38}},
}
"""Simulator 2.1 at the paper's budget, as the learning curve measured it (not rerun here)."""

CANDIDATES: dict[str, dict] = {
    "2.3a": {"changes": {"roll_backlash_rad": 0.046}, "remount_spread": 1.0,
             "note": "2.2's cable law + roll backlash at the jaw's lost motion + the "
                     "re-mount before every trial at the ranges of psmforce.sim.mounting"},
    "2.3a-backlash": {"changes": {"roll_backlash_rad": 0.046}, "remount_spread": 0.0,
                      "note": "2.3a's roll backlash alone (what it adds)"},
    "2.3a-remount": {"changes": {}, "remount_spread": 1.0,
                     "note": "2.3a's re-mount alone (what it adds)"},
    "2.3b": {"changes": {"roll_backlash_rad": 0.09}, "remount_spread": 2.0,
             "note": "2.3a with twice the roll backlash and twice the re-mount ranges"},
    "2.3c": {"changes": {"roll_backlash_rad": 0.046, "cable_crossing_angle_rad": 0.01},
             "remount_spread": 1.0,
             "note": "2.3a + the cables crossing the HEX10 section 0.01 rad off the shaft axis "
                     "(their pair differentials, friction memory included, push laterally)"},
    "2.3d": {"changes": {"roll_backlash_rad": 0.046, "hex10_readout_lag_s": 0.03},
             "remount_spread": 1.0,
             "note": "2.3a + a 30 ms first-order lag of the HEX10 readout"},
    "2.3e": {"changes": {"roll_backlash_rad": 0.09, "hex10_readout_lag_s": 0.05,
                         "hex10_thermal_drift_n": 0.05, "hex10_thermal_time_s": 60.0},
             "remount_spread": 2.0,
             "note": "2.3b + a 50 ms HEX10 readout lag + a thermal settling of 0.05 N (std) "
                     "over 60 s after each zeroing"},
    "2.3f": {"changes": {"roll_backlash_rad": 0.09, "hex10_readout_lag_s": 0.08,
                         "hex10_thermal_drift_n": 0.05, "hex10_thermal_time_s": 60.0},
             "remount_spread": 2.0,
             "note": "2.3e with an 80 ms HEX10 readout lag"},
    "2.3g": {"changes": {"roll_backlash_rad": 0.09, "hex10_readout_lag_s": 0.1,
                         "hex10_thermal_drift_n": 0.1, "hex10_thermal_time_s": 60.0},
             "remount_spread": 2.0,
             "note": "2.3f with a 100 ms readout lag and a 0.1 N thermal settling, to move "
                     "the FCN's Fx and Fz off the band's lower edge; registered as simulator "
                     "2.3 and scored under that name (rows '2.3')"},
}
"""Every candidate tried, in order: changes on top of simulator 2.2 (``InstrumentParams``
fields) and the re-mount spread. The version kept is registered as "2.3" in
``psmforce.sim.versions``; its row here is the candidate it was taken from."""


NOTES = {"2.3": "the version kept, registered in psmforce.sim.versions: candidate 2.3g's "
                "setting, scored under its own name"}
"""Headings of registered versions in the rendered block."""

SUBSTITUTES = {"2.3": {"lstm": {
    "from": "2.3b",
    "why": "the LSTM's epochs take about a minute each on one shared CPU thread, so it was "
           "trained once, on candidate 2.3b's bench at scale 0.25, while the HEX10 effects were "
           "being sized; 2.3 differs from 2.3b only in the HEX10's readout (its lag and thermal "
           "settling), which the LSTM does not read (it reads the joint states alone), so its "
           "inputs and targets on 2.3 are drawn from the same law (not the same numbers: the "
           "thermal draw shifts the noise streams)"}}}
"""Per version, a calibration model scored on another candidate's bench, and why that stands
for it; the verdict counts such a row and says so, unless the version's own row is at least as
large a bench (2.3's LSTM: trained on 2.3 at the paper's budget since)."""


def candidate_version(name: str):
    """The ``psmforce.sim.versions.Version`` of candidate ``name`` (or of a registered
    version: "2.1", "2.2", "2.3")."""
    from psmforce.sim import versions
    if name in versions.VERSIONS:
        return versions.version(name)
    c = CANDIDATES[name]
    return versions.Version(name, {**versions.CHANGES["2.2"], **c["changes"]},
                            c.get("remount_spread", 0.0))


def run_dir(work: Path, name: str, scale: float) -> Path:
    return work / name / f"scale_{scale:g}"


def train(name: str, scale: float, seeds, models, work: Path, threads: int,
          device: str = "cpu") -> dict:
    """One ``reproduce`` run of candidate ``name`` at ``scale`` on ``device`` (cached,
    resumable); its ``results.json``."""
    from psmforce.experiments.reproduce import reproduce
    return reproduce(run_dir(work, name, scale), scale=scale, seeds=tuple(seeds),
                     models=tuple(models), ablations=False, efficiency=False, teleop=False,
                     threads=threads, device=device, sim_version=candidate_version(name))


def rows(name: str, scale: float, results: dict) -> list[dict]:
    """Per model of a ``reproduce`` result: the paper metric per axis (mean over seeds, std,
    RMSE, range), the robot's figure, the ratio and whether it lies in :data:`BAND`."""
    out = []
    paper = results["automated"]["paper"]
    labels = {PAPER[m]["label"]: m for m in PAPER}
    for label, axes in paper.items():
        model = labels.get(label)
        if model is None or model not in CALIBRATION_MODELS + HELD_OUT_MODELS:
            continue   # never the hybrid
        robot = PAPER[model]["nrmse_pct"]
        bench = {a: axes[a]["nrmse_pct"]["mean"] for a in AXES}
        ratio = {a: bench[a] / robot[a] for a in AXES}
        out.append({
            "candidate": name, "model": model, "label": label, "scale": scale,
            "role": "held_out" if model in HELD_OUT_MODELS else "calibration",
            "paper_budget": scale == 1.0,
            "seeds": results["call"]["seeds"],
            "bench_nrmse_pct": bench,
            "bench_nrmse_std": {a: axes[a]["nrmse_pct"]["std"] for a in AXES},
            "bench_rmse_n": {a: axes[a]["rmse_n"]["mean"] for a in AXES},
            "test_range_n": {a: axes[a]["range_n"]["mean"] for a in AXES},
            "paper_nrmse_pct": robot,
            "ratio": ratio,
            "in_band": {a: BAND[0] <= ratio[a] <= BAND[1] for a in AXES},
            "training": _compact({k: v for k, v in results["training"].items()
                                  if k.startswith(model + " ")}),
        })
    return out


TRAINING_KEYS = ("epochs_run", "stopped_by", "converged", "seconds", "train_windows")


def _compact(training: dict) -> dict:
    """Per training task, the few figures the log keeps (no learning curve)."""
    return {k: {f: v.get(f) for f in TRAINING_KEYS} for k, v in training.items()}


def floor_rows(name: str, scale: float, results: dict) -> dict:
    floor = results["floor"]["automated"]["paper"]
    return {"candidate": name, "scale": scale,
            "nrmse_pct": {a: floor[a]["nrmse_pct"]["mean"] for a in AXES},
            "range_n": {a: floor[a]["range_n"]["mean"] for a in AXES}}


def verdict(data: dict, name: str, comparison: dict | None = None) -> dict:
    """Whether candidate ``name`` meets the issue's rule on the rows written for it: every
    calibration model in the band on every axis at the paper's budget (a model trained on a
    smaller bench is reported but does not count as met), and the held-out transformer's checks
    (:func:`held_out_check`, with the published comparison's records ``comparison``)."""
    by_model = {}
    for r in data["rows"]:
        if r["model"] not in CALIBRATION_MODELS:
            continue
        sub = SUBSTITUTES.get(name, {}).get(r["model"])
        if r["candidate"] != name and not (sub and r["candidate"] == sub["from"]):
            continue
        best = by_model.get(r["model"])
        # the version's own row wins at an equal scale; a larger scale wins over either
        if (best is None or r["scale"] > best["scale"]
                or (r["scale"] == best["scale"] and r["candidate"] == name)):
            by_model[r["model"]] = r
    substituted = {m: SUBSTITUTES[name][m] for m, r in by_model.items()
                   if r["candidate"] != name}
    misses = [f"{m} {a} ({r['ratio'][a]:.2f}x)" for m, r in sorted(by_model.items())
              for a in AXES if not r["in_band"][a]]
    not_at_budget = sorted(m for m, r in by_model.items() if not r["paper_budget"])
    missing = sorted(set(CALIBRATION_MODELS) - set(by_model))
    return {"models_in_band": not misses and not missing,
            "misses": misses, "not_at_paper_budget": not_at_budget, "missing": missing,
            "substituted": substituted,
            "met_at_paper_budget": not misses and not missing and not not_at_budget,
            **held_out_check(data, name, by_model.get("fcn"), comparison)}


COMPARISON_SOURCE = "the published comparison's records (fresh seeds)"


def comparison_rows(comparison: dict | None, name: str) -> dict:
    """The transformer's and the FCN's rows (the keys :func:`held_out_check` reads) from the
    published comparison's records of version ``name`` at the paper's budget, on the seeds
    both have (mean paper-metric NRMSE over those seeds); empty when there is none. A JSON
    read back that is not shaped as the comparison's is a ValueError naming what is wrong."""
    by_seed = comparison or {}
    for key in ("records", name, "1"):
        by_seed = by_seed.get(key, {}) if isinstance(by_seed, dict) else None
    if not isinstance(by_seed, dict) or not all(
            isinstance(m, dict) and s.isdigit() for s, m in by_seed.items()):
        raise ValueError(f"the published comparison: records of {name} at scale 1 are not "
                         f"seed -> model -> record")
    seeds = sorted(int(s) for s, models in by_seed.items()
                   if "transformer" in models and "fcn" in models)
    out = {}
    for model in ("transformer", "fcn"):
        if not seeds:
            break
        try:
            paper = [by_seed[str(s)][model]["nrmse_pct"]["paper"] for s in seeds]
            bench = {a: sum(float(p[a]) for p in paper) / len(seeds) for a in AXES}
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"the published comparison: a record of {model} at scale 1 "
                             f"lacks its paper-metric NRMSE per axis") from None
        ratio = {a: bench[a] / PAPER[model]["nrmse_pct"][a] for a in AXES}
        out[model] = {"scale": 1.0, "paper_budget": True, "seeds": seeds,
                      "bench_nrmse_pct": bench, "ratio": ratio,
                      "in_band": {a: BAND[0] <= ratio[a] <= BAND[1] for a in AXES},
                      "source": COMPARISON_SOURCE}
    return out


def held_out_check(data: dict, name: str, fcn: dict | None,
                   comparison: dict | None = None) -> dict:
    """The paper's transformer on version ``name``'s own bench (its largest scale): its ratios and
    whether each lies in :data:`BAND`, and whether the FCN (``fcn``, the verdict's row) is worse
    than it on Fx and Fy at the same scale, as on the robot. Without a row of it here, both from
    the published comparison's records (``comparison``, :func:`comparison_rows`). Strings saying
    why, when the transformer or a matching FCN row is missing."""
    mine = [r for r in data["rows"] if r["candidate"] == name and r["model"] in HELD_OUT_MODELS]
    published = {} if mine else comparison_rows(comparison, name)
    if published:
        mine, fcn = [published["transformer"]], published["fcn"]
    if not mine:
        return {"transformer_held_out": "not checked: the paper's transformer has not been "
                                        "trained on this version (it is trained only once a "
                                        "version is chosen, never while calibrating), nor has "
                                        "the published comparison a record of it at the "
                                        "paper's budget yet",
                "fcn_worse_than_transformer_laterally": "not checked (needs the transformer)"}
    t = max(mine, key=lambda r: r["scale"])
    check = {"scale": t["scale"], "paper_budget": t["paper_budget"], "seeds": t["seeds"],
             "ratio": t["ratio"], "in_band": t["in_band"],
             "misses": [f"{a} ({t['ratio'][a]:.2f}x)" for a in AXES if not t["in_band"][a]],
             "met": all(t["in_band"].values()) and t["paper_budget"],
             "source": t.get("source", "this calibration's own training")}
    if fcn is None or fcn["scale"] != t["scale"] or fcn["seeds"] != t["seeds"]:
        lateral = "not checked (no FCN row on the transformer's scale and seeds)"
    else:
        fcn_over = {a: fcn["bench_nrmse_pct"][a] / t["bench_nrmse_pct"][a] for a in ("Fx", "Fy")}
        lateral = {"fcn_over_transformer": fcn_over,
                   "met": all(v > 1.0 for v in fcn_over.values())}
    return {"transformer_held_out": check, "fcn_worse_than_transformer_laterally": lateral}


def merge(data: dict, new_rows: list[dict], floor: dict) -> dict:
    for r in new_rows:
        r["training"] = _compact(r.get("training", {}))
    keep = [r for r in data.get("rows", []) if not any(
        r["candidate"] == n["candidate"] and r["model"] == n["model"] and r["scale"] == n["scale"]
        for n in new_rows)]
    floors = [f for f in data.get("floors", [])
              if not (f["candidate"] == floor["candidate"] and f["scale"] == floor["scale"])]
    data["rows"] = keep + new_rows
    data["floors"] = floors + [floor]
    return data


def stamped(data: dict, argv=None, comparison: dict | None = None) -> dict:
    """``data`` with what every write of the JSON records beside its rows: the command (``argv``,
    else the process's), the settings this script holds (band, paper figures, the 2.1
    reference, substitutes, notes, candidates, re-mount ranges, the registered versions) and
    each candidate's :func:`verdict`."""
    from psmforce.sim import versions
    from psmforce.sim.mounting import RANGES
    data["command"] = "python studies/bench_paper_calibration.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    data.update({"band": list(BAND), "paper": PAPER, "reference_2.1": REFERENCE_21,
                 "substitutes": SUBSTITUTES, "notes": NOTES, "candidates": CANDIDATES,
                 "remount_ranges": RANGES,
                 "registered": {v: versions.version(v).to_dict() for v in versions.VERSIONS}})
    data["verdicts"] = {n: verdict(data, n, comparison) for n in
                        dict.fromkeys(r["candidate"] for r in data["rows"])}
    return data


# The block docs/simulator.md shows (``bench-paper-calibration``, rendered by python -m reports)

_MODEL_ORDER = ("fcn", "lstm", "rocket", "transformer")


def _fmt(values: dict, pattern: str = "{:.2f}") -> str:
    return " / ".join(pattern.format(values[a]) for a in AXES)


_SHOWN_CHANGES = ("roll_backlash_rad", "hex10_readout_lag_s", "hex10_thermal_drift_n",
                  "hex10_thermal_time_s", "cable_crossing_angle_rad")
"""The 2.3 parameters a version's heading lists (2.2's cable-law values are common to all)."""
_REGISTERED = {"2.1": "the default version, no 2.3 effect, no 2.2 cable law",
               "2.2": "2.2's cable law alone"}


def _definition_line(name: str, definition: dict | None, note: str | None) -> str:
    if name in _REGISTERED:
        return f"**{name}** ({_REGISTERED[name]})"
    if not definition:
        return f"**{name}**"
    changes = ", ".join(f"`{k}` {definition['changes'][k]:g}" for k in _SHOWN_CHANGES
                        if definition["changes"].get(k))
    parts = [f"**{name}**"]
    if note:
        parts.append(f"({note})")
    parts.append(f"— on 2.2's cable law: {changes or 'no 2.3 parameter'}; re-mount before each "
                 f"trial at spread {definition.get('remount_spread', 0.0):g}")
    return " ".join(parts)


def _verdict_line(v: dict) -> str:
    if v["models_in_band"]:
        state = "every calibration model in band on every axis"
    else:
        state = ("outside the band: " + ", ".join(v["misses"]) if v["misses"]
                 else "no miss among the models run")
        if v["missing"]:
            state += f"; not run: {', '.join(v['missing'])}"
    if v["not_at_paper_budget"]:
        state += (f"; trained below the paper's budget, so the rule is not met at it: "
                  f"{', '.join(v['not_at_paper_budget'])}")
    return f"Verdict: {state}."


def _held_out_line(v: dict, paper: dict) -> str:
    check, lateral = v["transformer_held_out"], v["fcn_worse_than_transformer_laterally"]
    if isinstance(check, str):
        return f"The paper's transformer (held out): {check}."
    budget = "" if check["paper_budget"] else " (below the paper's budget: not met at it)"
    state = ("in band on every axis" if not check["misses"]
             else "outside the band: " + ", ".join(check["misses"]))
    source = f"; {check['source']}" if check.get("source") == COMPARISON_SOURCE else ""
    line = (f"The paper's transformer (held out, scale {check['scale']:g}{budget}, seeds "
            f"{', '.join(map(str, check['seeds']))}{source}): "
            f"{_fmt(check['ratio'], '{:.2f}x')}, {state}. ")
    if isinstance(lateral, str):
        return line + f"The FCN worse than it laterally: {lateral}."
    ratio = lateral["fcn_over_transformer"]
    robot = {a: paper["fcn"]["nrmse_pct"][a] / paper["transformer"]["nrmse_pct"][a]
             for a in ("Fx", "Fy")}
    return line + (f"The FCN over the transformer, Fx / Fy: {ratio['Fx']:.2f}x / "
                   f"{ratio['Fy']:.2f}x (the robot's {robot['Fx']:.2f}x / {robot['Fy']:.2f}x): "
                   + ("worse laterally, as on the robot." if lateral["met"] else
                      "not worse on both lateral axes, unlike the robot."))


def _lines(result: dict) -> list[str]:
    """The block's markdown lines: per version tried (in the order tried), a table model x
    scale: bench, paper, ratio, in band, RMSE and test range; its verdict; the 2.1 reference
    and the held-out check's status."""
    if not result.get("rows"):
        return ["", "No calibration run yet.", ""]
    low, high = result.get("band", BAND)
    paper = result["paper"]
    out = ["", f"Paper metric (bias over the first 0.5 s, centred median of 71 samples), NRMSE % "
           f"on the automated test set, against the paper's Table III figure of each model's "
           f"family; in band: bench / paper in [{low:g}, {high:g}]. Calibration models only "
           f"(FCN, LSTM, MultiRocket-Hydra), design seeds only; the paper's transformer is the "
           f"held-out check and the hybrid is not looked at. Versions in the order tried.", ""]
    names = list(dict.fromkeys(r["candidate"] for r in result["rows"]))
    names.sort(key=lambda n: (n not in _REGISTERED, n == "2.3", n))
    notes = {k: v.get("note") for k, v in result.get("candidates", {}).items()}
    notes.update(result.get("notes", {}))
    for name in names:
        out += ["", _definition_line(name, result.get("definitions", {}).get(name),
                                     notes.get(name)), "",
                "| model | scale | seeds | bench Fx / Fy / Fz | paper Fx / Fy / Fz | "
                "bench / paper | in band | RMSE (N) | test range (N) |",
                "|---|---|---|---|---|---|---|---|---|"]
        v = result.get("verdicts", {}).get(name)
        subs = (v or {}).get("substituted", result.get("substitutes", {}).get(name, {}))
        mine = [r for r in result["rows"] if r["candidate"] == name
                or (r["model"] in subs and r["candidate"] == subs[r["model"]]["from"])]
        mine.sort(key=lambda r: (_MODEL_ORDER.index(r["model"]) if r["model"] in _MODEL_ORDER
                                 else 9, r["scale"]))
        for r in mine:
            inside = [a for a in AXES if r["in_band"][a]]
            budget = "" if r["paper_budget"] else " (below the paper's budget)"
            shown = "all" if len(inside) == len(AXES) else (", ".join(inside) or "none")
            where = "" if r["candidate"] == name else f", on {r['candidate']}'s bench"
            held = " (held out)" if r.get("role") == "held_out" else ""
            out.append(f"| {r['label']}{held}{where} | {r['scale']:g}{budget} | "
                       f"{', '.join(map(str, r['seeds']))} | {_fmt(r['bench_nrmse_pct'])} | "
                       f"{_fmt(r['paper_nrmse_pct'])} | {_fmt(r['ratio'], '{:.2f}x')} | "
                       f"{shown} | {_fmt(r['bench_rmse_n'], '{:.3f}')} | "
                       f"{_fmt(r['test_range_n'])} |")
        if v:
            out += ["", _verdict_line(v)]
            if isinstance(v.get("transformer_held_out"), dict):
                out += ["", _held_out_line(v, paper)]
        for model, sub in subs.items():
            label = result["paper"][model]["label"]
            out += ["", f"{label} on {sub['from']}'s bench: {sub['why']}."]
    checked = [v for v in result.get("verdicts", {}).values()
               if isinstance(v.get("transformer_held_out"), dict)]
    if not checked and result.get("verdicts"):
        out += ["", _held_out_line(next(iter(result["verdicts"].values())), paper)]
    ref = result.get("reference_2.1")
    if ref:
        out += ["", f"Reference, simulator 2.1 ({ref['source']}): "
                + "; ".join(f"{paper[m]['label']} {_fmt(v)}"
                            for m, v in ref["nrmse_pct"].items()) + "."]
    rocket = paper.get("rocket")
    if rocket:
        out += ["", f"MultiRocket-Hydra's robot figures ({_fmt(rocket['nrmse_pct'])}): "
                f"{rocket['source']}."]
    return out + [""]


def table(result: dict) -> str:
    """The ``bench-paper-calibration`` block of docs/simulator.md (``python -m reports``): per
    version tried, each calibration model's paper-metric NRMSE per axis on the bench against the
    paper's figure for its family, the ratio and whether it lies in :data:`BAND`."""
    return "\n".join(_lines(result))


def main(argv=None) -> None:
    from psmforce.experiments.seeds import DESIGN_SEEDS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--version", default=None,
                    help="a registered simulator version to score (e.g. 2.3)")
    ap.add_argument("--candidates", nargs="*", default=[], choices=list(CANDIDATES),
                    help="candidates of the calibration log to score")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--lstm-scale", type=float, default=None,
                    help="train the LSTM on a bench of this scale (default: --scale)")
    ap.add_argument("--models", nargs="+", default=list(CALIBRATION_MODELS),
                    choices=list(CALIBRATION_MODELS + HELD_OUT_MODELS),
                    help="the calibration models (default), or the held-out transformer once "
                         "a version is chosen")
    ap.add_argument("--work", default=str(ROOT / "runs" / "bench_paper_calibration"))
    ap.add_argument("--json", default=str(ROOT / "results" / "benchmarks" /
                                          "bench_paper_calibration.json"))
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--device", default="cpu",
                    help="where the networks train (cuda on a lent GPU: the held-out "
                         "transformer at the paper's budget needs one)")
    ap.add_argument("--comparison", default=str(ROOT / "results" / "benchmarks" /
                                                "comparison.json"),
                    help="the published comparison's JSON, whose records at the paper's budget "
                         "give the held-out check where this study has no transformer row")
    ap.add_argument("--verdicts-only", action="store_true",
                    help="draw the verdicts again (rows and the comparison's records), write")
    ap.add_argument("--render-only", action="store_true")
    ap.add_argument("--merge", nargs="*", default=[],
                    help="fold the rows of these JSONs (partial runs of this script, e.g. "
                         "candidates screened in parallel) into --json, then render")
    args = ap.parse_args(argv)
    path = Path(args.json)
    try:
        data = read_json(path, "calibration results") if path.exists() else {}
        comparison = (read_json(Path(args.comparison), "the published comparison")
                      if Path(args.comparison).exists() else None)
        for name in {r["candidate"] for r in data.get("rows", [])} | {args.version} - {None}:
            comparison_rows(comparison, name)   # refused now, not after a training
    except ValueError as err:
        raise SystemExit(f"error: {err}") from None
    if args.verdicts_only:
        if data.get("command") not in data.setdefault("commands", []):
            data["commands"].append(data.get("command"))   # what wrote the rows
        write_json(path, stamped(data, argv, comparison))
        print(table(data))
        return
    if args.merge:
        for other in args.merge:
            part = read_json(Path(other), "partial calibration results")
            for floor in part.get("floors", []):
                data = merge(data, [r for r in part["rows"] if r["candidate"] == floor["candidate"]
                                    and r["scale"] == floor["scale"]], floor)
            for key in ("definitions", "benches", "seconds"):
                data.setdefault(key, {}).update(part.get(key, {}))
            if part.get("command") not in data.setdefault("commands", []):
                data["commands"].append(part.get("command"))
        write_json(path, stamped(data, argv, comparison))
    if args.render_only or args.merge:
        print(table(data))
        return
    fresh = sorted(set(args.seeds) - DESIGN_SEEDS)
    if fresh:
        raise SystemExit(f"--seeds {fresh}: calibration runs on design seeds only "
                         f"(psmforce/experiments/seeds.py DESIGN_SEEDS), never on the seeds "
                         f"kept for published comparisons")
    names = list(args.candidates) + ([args.version] if args.version else [])
    if not names:
        raise SystemExit("nothing to score: give --version or --candidates")
    if set(args.models) & set(HELD_OUT_MODELS) and args.candidates:
        raise SystemExit("--models transformer: the held-out check runs on the version chosen "
                         "(--version), never on candidates still being calibrated")
    work = Path(args.work)
    started = time.time()
    for name in names:
        plan = {}
        for m in args.models:
            s = args.lstm_scale if (m == "lstm" and args.lstm_scale) else args.scale
            plan.setdefault(s, []).append(m)
        for scale, models in sorted(plan.items()):
            print(f"== {name} scale {scale:g}: {', '.join(models)}", flush=True)
            results = train(name, scale, args.seeds, models, work, args.threads, args.device)
            data = merge(data, rows(name, scale, results), floor_rows(name, scale, results))
            data.setdefault("definitions", {})[name] = candidate_version(name).to_dict()
            data.setdefault("benches", {})[f"{name} scale {scale:g}"] = results["benches"]
            stamped(data, argv, comparison)
            data.setdefault("seconds", {})[f"{name} scale {scale:g} {'+'.join(models)}"] = round(
                time.time() - started, 1)
            write_json(path, data)
    print(table(data))


if __name__ == "__main__":
    main()
