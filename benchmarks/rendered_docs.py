"""Blocks of the docs and the README, and whole result pages, rendered from committed result
JSONs, so that no figure a reader sees there is typed by hand.

    python benchmarks/rendered_docs.py            # rewrite every block from its JSON
    python benchmarks/rendered_docs.py --check    # exit 1 if a page differs from its JSON

Each block sits between ``<!-- NAME: rendered by benchmarks/rendered_docs.py -->`` and
``<!-- end NAME -->`` (:data:`BLOCKS`: page, JSON or tuple of JSONs, render function; the
findings of ``docs/results.md`` are rendered by :mod:`benchmarks._results_page`); nothing
outside the markers is touched. :data:`WHOLE_PAGES` are rewritten whole.
``tests/test_rendered_docs.py`` holds every page equal to what its JSON renders.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import _results_page as results_page  # noqa: E402
from psm_model.files import write_text_atomic  # noqa: E402

TRANSMISSION = ROOT / "results" / "benchmarks" / "transmission.json"
PRIOR_RECOVERY = ROOT / "results" / "benchmarks" / "prior_recovery.json"
PRIOR_ABLATION = ROOT / "results" / "benchmarks" / "prior_ablation.json"
COMPARISON = ROOT / "results" / "ports" / "none" / "results.json"
PORTS = ROOT / "results" / "benchmarks" / "port_comparison.json"
ANOTHER_TOOL = ROOT / "results" / "benchmarks" / "another_tool.json"
PORT_DESIGN = ROOT / "results" / "benchmarks" / "hybrid_port_design.json"
LEARNING_CURVE = ROOT / "results" / "learning_curve" / "learning_curve.json"
PORT_DESIGN_NOTCH = ROOT / "results" / "benchmarks" / "hybrid_port_design_notch.json"
TRAINING = ROOT / "results" / "benchmarks" / "training.json"
TRAINING_CONVERGENCE = ROOT / "results" / "benchmarks" / "training_convergence.json"
TRAINING_OPTIONS = ROOT / "results" / "benchmarks" / "training_speed_options.json"
STREAMING = ROOT / "results" / "benchmarks" / "streaming.json"
LIVE = ROOT / "results" / "benchmarks" / "live.json"
RESULTS = ROOT / "docs" / "results.md"
IDENTIFICATION = ROOT / "docs" / "identification.md"
README = ROOT / "README.md"
MODEL_NAMES = {"physics": "physics alone (`CableTransmission`)", "fcn": "FCN",
               "lstm": "LSTM", "transformer": "paper transformer",
               "rocket": "MultiRocket-Hydra", "hybrid": "hybrid (physics + causal residual)",
               "fcn+spindle": "FCN + input-spindle torque sensor (reference: a robot has none)",
               "hybrid_no_physics": "the hybrid's network without the physics (ablation)"}
LEARNED_BASELINES = ("fcn", "lstm", "transformer", "rocket")


def _cell(d: dict, digits: int = 2) -> str:
    return f"{d['mean']:.{digits}f} ± {d['std']:.{digits}f}"


def transmission_tables(result: dict) -> str:
    """docs/identification.md section 4: per protocol, every model; the physics' parameters."""
    pub = result["published"]
    lines = ["",
             f"Command: `{result['run']['command']}` (resumable; each model and seed cached); "
             f"seeds {result['seeds']} for the learned models (the physics fit is "
             f"deterministic); {result['rate_hz']:g} Hz; causal estimates, no post-filter. "
             "RMSE mean ± std over seeds, pooled over the protocol's test files; *closing*: the "
             "samples where the motor drives the jaw against the load, as the 2018 paper scored.",
             ""]
    for protocol, models in result["summary"].items():
        lines += [f"**{protocol}**: {result['protocols'][protocol]}", "",
                  "| model | jaw torque, mNm | jaw angle, deg | torque, closing | angle, closing |"
                  " torque NRMSE % |",
                  "|---|---|---|---|---|---|"]
        ranked = sorted(models, key=lambda m: models[m]["whole"]["torque_rmse_mNm"]["mean"])
        for m in ranked:
            w, c = models[m]["whole"], models[m]["closing"]
            lines.append(f"| {MODEL_NAMES.get(m, m)} | {_cell(w['torque_rmse_mNm'])} | "
                         f"{_cell(w['angle_rmse_deg'])} | {_cell(c['torque_rmse_mNm'])} | "
                         f"{_cell(c['angle_rmse_deg'])} | {_cell(w['torque_nrmse_pct'], 1)} |")
        verdicts = []
        for part in ("whole", "closing"):
            for k, label in (("torque_rmse_mNm", "torque"), ("angle_rmse_deg", "angle")):
                v = result["verdicts"][protocol][part][k]
                verdicts.append(f"{label} ({part}): {MODEL_NAMES.get(v['best'], v['best'])}"
                                + (f", {'a win over' if v['verdict'] == 'win' else 'a tie with'} "
                                   f"{MODEL_NAMES.get(v['runner_up'])}" if "verdict" in v else ""))
        lines += ["", "Best by the spread rule: " + "; ".join(verdicts) + ".", ""]
    lines += [f"Published on this data ({pub['source']}; {pub['model']}): jaw torque "
              f"{pub['jaw_torque_rmse_mNm']} mNm, jaw angle {pub['jaw_angle_rmse_deg']} deg, on a "
              f"{pub['split']}.", ""]
    phys = result.get("physics")
    if phys:
        t = phys["trained"]
        ident = t["info"].get("identifiability", {})
        sd = ident.get("relative_sd", {})
        lines += ["The physics model fitted on protocol (a)'s training files (jaw-referred "
                  "torque parameters; relative standard deviation from the Fisher information; "
                  f"condition number {ident.get('fisher_condition_number', float('nan')):.3g}):",
                  "", "| parameter | value | unit | bounds | relative sd |",
                  "|---|---|---|---|---|"]
        for name, p in t["torque"].items():
            rel = "fixed" if name in t["fixed"] else (f"{sd[name]:.2g}" if name in sd else "")
            lines.append(f"| {name} | {p['value']:.4g} | {p['unit']} | "
                         f"[{p['lower']:g}, {p['upper']:g}] | {rel} |")
        for name, value in t["angle"].items():
            lines.append(f"| {name} (angle path) | {value:.4g} | | | exact least squares |")
        lines += ["", f"Widths chosen on validation: pre-sliding {t['presliding_rad']:g} rad, "
                  f"hold {t['hold_rad']:g} rad, backlash {t['backlash_rad']:g} rad."
                  + (f" Tied: {t['info']['tied']}." if t["info"].get("tied") else ""), ""]
    return "\n".join(lines)


def _ratio(models: dict, metric: str, a: str = "hybrid", b: str = "transformer") -> str:
    return f"{models[a]['whole'][metric]['mean'] / models[b]['whole'][metric]['mean']:.2f}"


def _verdict(models: dict, metric: str, a: str = "hybrid", b: str = "transformer") -> str:
    """The spread rule between ``a`` and ``b`` on whole files."""
    x, y = models[a]["whole"][metric], models[b]["whole"][metric]
    if x["mean"] + x["std"] < y["mean"] - y["std"]:
        return "a win by the spread rule"
    if y["mean"] + y["std"] < x["mean"] - x["std"]:
        return "a loss by the spread rule"
    return "a tie by the spread rule"


def transmission_summary(result: dict) -> str:
    """The README's paragraph: held-out files, what the physics gives, what the residual network
    adds, against the best learned baseline and the published figures."""
    held = result["summary"]["a_held_out_files"]

    def fig(model: str) -> str:
        w = held[model]["whole"]
        return (f"{w['torque_rmse_mNm']['mean']:.2f} mNm / {w['angle_rmse_deg']['mean']:.2f} deg")

    best = min((m for m in LEARNED_BASELINES if m in held),
               key=lambda m: held[m]["whole"]["torque_rmse_mNm"]["mean"])
    pub = result["published"]
    text = (f"On a real EndoWrist's cable transmission (jaw torque and angle from the motor's "
            f"current and encoder, files held out by frequency and load; docs/identification.md "
            f"section 4) the identified physics model alone gives {fig('physics')}, the paper's "
            f"transformer {fig('transformer')}, and the hybrid, the same transformer learning the "
            f"physics' residual, {fig('hybrid')}")
    if best != "transformer":
        text += f"; the best other learned baseline ({MODEL_NAMES[best]}) {fig(best)}"
    text += (f" (whole files, mean over seeds {result['seeds']}; published on this data, "
             f"{pub['jaw_torque_rmse_mNm']} mNm / {pub['jaw_angle_rmse_deg']} deg on a random "
             f"sample split). What the physics adds to the learning: the angle error "
             f"x{_ratio(held, 'angle_rmse_deg')} ({_verdict(held, 'angle_rmse_deg')}), the "
             f"torque error x{_ratio(held, 'torque_rmse_mNm')} "
             f"({_verdict(held, 'torque_rmse_mNm')}). Another session or instrument, as is "
             "and after 60 s of calibration: the tables there.")
    return "\n" + text + "\n"


def prior_recovery_table(result: dict) -> str:
    """docs/identification.md section 2.1: truth against the fit per seed ("loaded" variant)."""
    from psm_model.identification.prior_law import PARAMETERS
    unit = {p[0]: p[1] for p in PARAMETERS}
    runs = [r for r in result["runs"] if r["variant"] == "loaded"]
    first = runs[0]["parameters"]
    lines = ["", f"`python benchmarks/prior_recovery.py --scale {result['scale']:g} --seeds "
             + " ".join(str(r["seed"]) for r in runs) + "`; `*` = listed not identifiable, with "
             "the relative error where the truth is not zero:", "",
             "| parameter | unit | truth | " + " | ".join(f"seed {r['seed']}" for r in runs)
             + " | SE (seed " + str(runs[0]["seed"]) + ") |",
             "|---|---|---|" + "---|" * len(runs) + "---|"]
    for name, p0 in first.items():
        cells = []
        for r in runs:
            p = r["parameters"][name]
            mark = "" if p["status"] == "identifiable" else " *"
            rel = (f" ({100 * p['relative_error']:.1f} %)" if p["truth"] != 0
                   and p.get("relative_error") is not None else "")
            cells.append(f"{p['fitted']:.4g}{rel}{mark}")
        se = p0.get("standard_error")
        lines.append(f"| {name} | {unit.get(name, '')} | {p0['truth']:.4g} | " + " | ".join(cells)
                     + f" | {'' if se is None else f'{se:.2g}'} |")
    conds = " / ".join(f"{r['identifiability']['condition_number']:.3g}" for r in runs)
    lines += ["", f"Fisher condition number {conds}; {sum(len(r['failures']) for r in runs)} "
              "identifiable parameters off by more than 10 %.", ""]
    return "\n".join(lines)


PRIOR_VARIANTS = {"weighted": "prior weighted on validation, subtracted from the inputs",
                  "as_fitted": "prior as fitted (every weight 1), subtracted from the inputs",
                  "raw_and_prior": "prior weighted, beside the raw HEX10 among the inputs",
                  "no_prior": "no prior (`no_prior`)"}


def prior_ablation_tables(result: dict) -> str:
    """docs/results.md: the hybrid with and without its prior, per bench and axis."""
    seeds = " ".join(str(s) for s in result["seeds"])
    chosen = result["chosen_on_validation"]
    lines = ["", f"`python benchmarks/prior_ablation.py --json "
             f"results/benchmarks/prior_ablation.json` (scale {result['scale']:g}, bench seeds "
             f"{seeds}; crossing bench: cables at {result['crossing_rad']:g} rad; every run "
             f"{'stopped by its patience' if result['all_converged'] else 'NOT all converged'})."
             " NRMSE % on the test trials, mean ± std over seeds; causal = the raw per-sample "
             "estimate a haptic loop gets, paper = the paper's offline post-processing; the "
             "last columns are the validation trials, where the design is chosen.", ""]
    for bench, rows in result["summary"].items():
        lines += [f"**{bench} bench**", "",
                  "| hybrid | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz "
                  "| validation causal Fx / Fy / Fz |",
                  "|---|---|---|---|---|---|---|---|"]
        for variant in PRIOR_VARIANTS:
            if variant not in rows:
                continue
            r = rows[variant]
            cells = [_cell(r[m][a]) for m in ("causal", "paper") for a in ("Fx", "Fy", "Fz")]
            val = " / ".join(f"{r['validation_causal'][a]['mean']:.2f}" for a in ("Fx", "Fy", "Fz"))
            shipped = " (shipped)" if variant == result["shipped"] else ""
            lines.append(f"| {PRIOR_VARIANTS[variant]}{shipped} | " + " | ".join(cells)
                         + f" | {val} |")
        for variant, verdict in result["verdicts"].get(bench, {}).items():
            cells = [f"{verdict[m][a]['verdict']} ({verdict[m][a]['ratio']:.2f}x)"
                     for m in ("causal", "paper") for a in ("Fx", "Fy", "Fz")]
            lines.append(f"| {variant} against no prior, spread rule | " + " | ".join(cells)
                         + " | |")
        weights = [t["axis_weights"] for t in result["tasks"]
                   if t["bench"] == bench and t["variant"] == "weighted"]
        if weights:
            lines += ["", "Weights the validation trials gave the prior (fx fy fz tx ty tz; "
                      "one group per seed): " + "; ".join(
                          " ".join(f"{w:.2f}" for w in ws) for ws in weights) + "."]
        lines.append("")
    ratios = ", ".join(f"{v} {x:.3f}" for v, x in chosen["validation_ratio_to_no_prior"].items())
    lines += [f"Chosen on the validation trials (causal NRMSE relative to no prior, averaged "
              f"over axes and benches: {ratios}): **{chosen['variant']}**.", ""]
    return "\n".join(lines)


def prior_ablation_summary(result: dict) -> str:
    """README: what the physics prior adds to the hybrid, per axis, as the ablation measures it."""
    shipped = result["shipped"]
    parts = []
    for bench, variants in result["verdicts"].items():
        v = variants[shipped]["causal"]
        rows = result["summary"][bench]
        cells = ", ".join(
            f"{a} {rows[shipped]['causal'][a]['mean']:.2f} % against "
            f"{rows['no_prior']['causal'][a]['mean']:.2f} % ({v[a]['verdict']})"
            for a in ("Fx", "Fy", "Fz"))
        parts.append(f"on the {bench} bench {cells}")
    seeds = ", ".join(str(s) for s in result["seeds"])
    return ("\nWhat the physics prior adds to the hybrid on the simulated bench (simulator "
            f"{results_page.SIMULATOR_NOT_RECORDED['prior_ablation']}, scale "
            f"{result['scale']:g}, bench seeds {seeds}, every run trained to early "
            "stopping; causal NRMSE with the prior as shipped against the same network "
            "without it, verdicts by the spread rule; docs/results.md, \"The prior, axis by "
            "axis\"): " + "; ".join(parts) + ". The crossing bench adds an internal lateral "
            "force the prior does not model. Each component of the prior is weighed on "
            "validation trials (0: it explains nothing held out); "
            + _lateral_weights(result) + ". " + _validation_choice(result) + "\n")


def _validation_choice(result: dict) -> str:
    """Which variant the validation trials prefer, and by how much."""
    shipped = result["shipped"]
    chosen = result["chosen_on_validation"]
    ratios = chosen["validation_ratio_to_no_prior"]
    prior_ratios = [r for v, r in ratios.items() if v != "no_prior"]
    return (f"On the validation trials the variants with a prior score "
            f"{min(prior_ratios):.3f}-{max(prior_ratios):.3f}x the error without it (mean over "
            f"axes and benches); the lowest is {PRIOR_VARIANTS[chosen['variant']]}"
            + ("" if chosen["variant"] == shipped else
               f"; the shipped hybrid is {PRIOR_VARIANTS[shipped]}, "
               f"{ratios[shipped] / ratios[chosen['variant']] - 1:.1%} above it") + ".")


def _lateral_weights(result: dict) -> str:
    """How many of the weighted prior's fits kept its lateral force components."""
    weights = [t["axis_weights"][:2] for t in result["tasks"] if t["variant"] == "weighted"]
    kept = sum(w > 0 for pair in weights for w in pair)
    return (f"{kept} of its {2 * len(weights)} lateral force weights over "
            f"{len(weights)} fits are above zero")


def status_table(result: dict) -> str:
    """README: where the estimator stands, model against model on the causal metric, the bench
    and the protocol named."""
    causal, verdicts, call = result["automated"]["causal"], result["verdicts"]["causal"], \
        result["call"]
    versions = sorted(set(result["benches"].values()))
    seeds = ", ".join(str(s) for s in call["seeds"])
    lines = ["", f"On the simulated bench (simulator {', '.join(versions)}, its joint-effort "
             "channels calibrated against a real dVRK; the paper's automated protocol at "
             f"{call['scale']:g} of its data; bench seeds {seeds}; "
             + ("every model trained to early stopping" if result["all_converged"]
                else "NOT every model converged")
             + "). Causal NRMSE % of the force on the tool (HEX10 frame): the raw per-sample "
             "estimate a haptic loop gets, mean ± std over seeds, lower is better; **bold**: a "
             "win by the spread rule (mean + std below every other model's mean - std).", "",
             "| model | Fx | Fy | Fz |", "|---|---|---|---|"]
    for model, axes in causal.items():
        cells = []
        for axis in ("Fx", "Fy", "Fz"):
            cell = _cell(axes[axis]["nrmse_pct"])
            won = verdicts[axis]["win"] and verdicts[axis]["best"] == model
            cells.append(f"**{cell}**" if won else cell)
        lines.append(f"| {model} | " + " | ".join(cells) + " |")
    lines += ["", f"That is {100 * call['scale']:g} % of the data the paper trained on"
              + (", a small-data regime: whether the lead holds at the paper's amount of data "
                 "is measured by the learning curve below." if call["scale"] < 1 else "."), ""]
    return "\n".join(lines)


def ports_table(result: dict) -> str:
    """docs/results.md: every model without a port and through each port, causal NRMSE."""
    by_port = result["causal_nrmse_pct"]
    names = {"none": "no port", "cannula": "cannula", "abdominal-wall": "abdominal wall"}
    ports = [p for p in names if p in by_port]
    lines = ["", "Automated test set, causal NRMSE %, mean ± std over bench seeds "
             + " ".join(str(s) for s in result["call"]["seeds"])
             + f" (scale {result['call']['scale']:g}; "
             + ("every run converged" if all(result["all_converged"].values())
                else "NOT every run converged")
             + "); through a port, x: the ratio to the same model without one.", "",
             "| Model | " + " | ".join(f"{names[p]} Fx / Fy / Fz" for p in ports) + " |",
             "|---|" + "---|" * len(ports)]
    for model in by_port["none"]:
        cells = []
        for port in ports:
            axes = by_port[port][model]
            cell = " / ".join(_cell(axes[a]) for a in ("Fx", "Fy", "Fz"))
            if port != "none":
                cell += " (x" + " / x".join(f"{axes[a]['ratio_to_no_port']:.2f}"
                                             for a in ("Fx", "Fy", "Fz")) + ")"
            cells.append(cell)
        lines.append(f"| {model} | " + " | ".join(cells) + " |")
    lines.append("")
    for target, t in result["targets"].items():
        detail = ", ".join(f"{k} {v:.2f}" if isinstance(v, float) else
                           f"{k} " + " / ".join(f"{a} {x:.2f}" for a, x in v.items())
                           for k, v in t.items() if k != "met")
        lines.append(f"- Target \"{target}\": {'met' if t['met'] else '**not met**'} "
                     f"({detail}).")
    lines.append("")
    return "\n".join(lines)


AXIAL_CHANNELS = {
    "insertion_fz": "`insertion_fz` (insertion effort minus the identified stage model)",
    "insertion_fz, best fixed filter": "`insertion_fz`, best fixed filter",
    "comp_fz": "`comp_fz` (HEX10 axial minus the prior's internal force)",
    "complementary": "`insertion_fz` below a crossover + `comp_fz` above (best crossover)",
    "perfect stage model": "a perfect stage model: truth + the insertion effort's disturbance "
                           "only",
    "perfect stage model, best fixed filter": "a perfect stage model, best fixed filter"}


def axial_channels_table(result: dict) -> str:
    """docs/results.md: the axial channels without a network against the networks' Fz."""
    channels, models = result["axial_channels_fz_nrmse_pct"], result["causal_nrmse_pct"]
    ports = [p for p in ("none", "cannula", "abdominal-wall") if p in channels]
    names = {"none": "no port", "cannula": "cannula", "abdominal-wall": "abdominal wall"}
    lines = ["", "| axial channel (causal Fz NRMSE %) | " + " | ".join(names[p] for p in ports)
             + " |", "|---|" + "---|" * len(ports)]
    for key, label in AXIAL_CHANNELS.items():
        lines.append(f"| {label} | " + " | ".join(_cell(channels[p][key]) for p in ports) + " |")
    for model in ("Hybrid (ours)", "Transformer (paper)"):
        lines.append(f"| {model}, for comparison | "
                     + " | ".join(_cell(models[p][model]["Fz"]) for p in ports) + " |")
    lines.append("")
    return "\n".join(lines)


TOOL_ROWS = ("nominal as is", "nominal calibrated", "1x as is", "1x calibrated", "2x as is",
             "2x calibrated")


def another_tool_table(result: dict) -> str:
    """docs/results.md: every model on another tool, as is and calibrated."""
    lines = ["", "| model | tool | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy "
             "| paper Fz |", "|---|---|---|---|---|---|---|---|"]
    for model, rows in result["table"].items():
        for tool in (t for t in TOOL_ROWS if t in rows):
            cells = [f"{rows[tool][m][a][0]:.2f} ± {rows[tool][m][a][1]:.2f}"
                     for m in ("causal", "paper") for a in ("Fx", "Fy", "Fz")]
            lines.append(f"| {model} | {tool} | " + " | ".join(cells) + " |")
    lines += ["", "Every training and calibration "
              + ("stopped by its patience." if result["converged"] else "did NOT converge."), ""]
    return "\n".join(lines)


DESIGN_VARIANTS = {"default": "previous default", "+ insertion velocity": "+ insertion velocity",
                   "+ insertion velocity, position": "+ insertion velocity and position "
                                                     "(new default)",
                   "no base on z": "no `insertion_fz` base on z"}


def port_design_table(result: dict) -> str:
    """docs/results.md: the hybrid's input variants on the validation trials, per port."""
    ports = list(result["ports"])
    names = {"none": "no port", "cannula": "cannula", "abdominal-wall": "abdominal wall"}
    lines = ["", "| variant | " + " | ".join(f"{names[p]} Fx / Fy / Fz" for p in ports) + " |",
             "|---|" + "---|" * len(ports)]
    for key, label in DESIGN_VARIANTS.items():
        cells = [" / ".join(f"{x:.2f}" for x in result["ports"][p][key]["mean"]["causal"])
                 for p in ports]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    runs = [r for p in ports for v in result["ports"][p].values() for r in v["runs"]]
    lines += ["", f"{sum(r['converged'] for r in runs)} of the {len(runs)} runs stopped by "
              "their patience.", ""]
    return "\n".join(lines)


def current_bench_summary(result: dict) -> str:
    """README: the hybrid against the paper transformer on today's simulator at every finished
    scale of the learning curve, and what is not measured yet."""
    if not result["points"]:
        return "\nNo point of the learning curve has finished yet (`results/learning_curve/`).\n"
    pts = result["points"]
    versions = sorted({v for p in pts for v in p["simulator_versions"]})
    at_scale = "; ".join(
        f"at scale {p['scale']:g} ({p['training_minutes']:.0f} min of training data, "
        f"{len(p['seeds'])} seeds"
        + ("" if p["all_converged"] else ", NOT every run converged") + ") "
        + ", ".join(f"{a} {v['ratio']:.2f}x ({v['verdict']})"
                    for a, v in p["hybrid_vs_transformer"]["causal"].items())
        for p in pts)
    return (f"\nOn today's simulator ({', '.join(versions)}), the same protocol retrained as a "
            "learning curve (hybrid, paper transformer, FCN and MultiRocket-Hydra, every run "
            "to early stopping; `results/learning_curve/`), the hybrid's causal error against "
            f"the transformer's: {at_scale}. Scales not yet measured: "
            + (", ".join(f"{s:g}" for s in result["missing_scales"]) or "none")
            + (" (1 = the paper's amount of data: no claim is made for it yet)."
               if 1.0 in result["missing_scales"] else ".") + "\n")


BLOCKS = (
    (RESULTS, "results-status",
     (LEARNING_CURVE, PRIOR_ABLATION, PORTS, COMPARISON, PORT_DESIGN, ANOTHER_TOOL),
     results_page.status),
    (RESULTS, "learning-curve", LEARNING_CURVE, results_page.learning_curve),
    (RESULTS, "ports-findings", (PORTS, COMPARISON), results_page.ports_findings),
    (RESULTS, "port-design-findings", (PORT_DESIGN, PORT_DESIGN_NOTCH),
     results_page.port_design_findings),
    (RESULTS, "axial-findings", PORTS, results_page.axial_findings),
    (RESULTS, "another-tool-findings", ANOTHER_TOOL, results_page.another_tool_findings),
    (RESULTS, "training-speed", (TRAINING, TRAINING_CONVERGENCE, TRAINING_OPTIONS),
     results_page.training_speed),
    (RESULTS, "latency", (STREAMING, LIVE), results_page.latency),
    (README, "current-bench-summary", LEARNING_CURVE, current_bench_summary),
    (RESULTS, "port-design-table", PORT_DESIGN, port_design_table),
    (RESULTS, "another-tool-table", ANOTHER_TOOL, another_tool_table),
    (RESULTS, "axial-channels-table", PORTS, axial_channels_table),
    (RESULTS, "ports-table", PORTS, ports_table),
    (README, "status-table", COMPARISON, status_table),
    (IDENTIFICATION, "transmission-tables", TRANSMISSION, transmission_tables),
    (README, "transmission-summary", TRANSMISSION, transmission_summary),
    (IDENTIFICATION, "prior-recovery-table", PRIOR_RECOVERY, prior_recovery_table),
    (RESULTS, "prior-ablation-tables", PRIOR_ABLATION, prior_ablation_tables),
    (README, "prior-ablation-summary", PRIOR_ABLATION, prior_ablation_summary),
)


def _run_page(result: dict) -> str:
    from hybrid.tables import results_markdown
    return results_markdown(result)


def _learning_curve_page(result: dict) -> str:
    from benchmarks.learning_curve import table
    return table(result)


WHOLE_PAGES = tuple(
    [(ROOT / "results" / run / "results.md", ROOT / "results" / run / "results.json", _run_page)
     for run in ("ports/none", "ports/cannula", "ports/abdominal-wall",
                 "history/previous_hybrid")]
    + [(LEARNING_CURVE.parent / "README.md", LEARNING_CURVE, _learning_curve_page)])
"""Pages rendered whole from one JSON: each committed run's page, and the learning curve's
table (its figures are drawn by ``benchmarks/learning_curve.py --render-only``). Run D's page
is not here: its JSON predates today's format, and the page is the run's own output."""


def markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}: rendered by benchmarks/rendered_docs.py -->", f"<!-- end {name} -->"


def splice(doc: str, name: str, body: str) -> str:
    """``doc`` with block ``name``'s content replaced by ``body``."""
    begin, end = markers(name)
    if doc.count(begin) != 1 or doc.count(end) != 1:
        raise SystemExit(f"expected one '{begin}' and one '{end}' marker")
    head, rest = doc.split(begin)
    return head + begin + body + end + rest.split(end, 1)[1]


def pages(results: dict[Path, dict] | None = None) -> dict[Path, str]:
    """Each page with every block rendered from its JSON (``results`` overrides a JSON's
    content, for tests)."""
    out: dict[Path, str] = {}
    for doc, name, json_paths, render in BLOCKS:
        found = [(results or {}).get(p) or json.loads(p.read_text())
                 for p in block_jsons(json_paths)]
        out[doc] = splice(out.get(doc, doc.read_text()), name, render(*found))
    for doc, json_path, render in WHOLE_PAGES:
        out[doc] = render((results or {}).get(json_path) or json.loads(json_path.read_text()))
    return out


def block_jsons(json_paths: Path | tuple[Path, ...]) -> tuple[Path, ...]:
    """A block's JSONs: one path, or a tuple when it renders from several."""
    return json_paths if isinstance(json_paths, tuple) else (json_paths,)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare, write nothing")
    args = ap.parse_args(argv)
    rendered = pages()
    stale = [p for p, text in rendered.items() if text != p.read_text()]
    if args.check:
        for p in stale:
            print(f"{p.relative_to(ROOT)} differs from what its JSON renders: rerun "
                  "benchmarks/rendered_docs.py")
        return 1 if stale else 0
    for p in stale:
        write_text_atomic(p, rendered[p])
    return 0


if __name__ == "__main__":
    sys.exit(main())
