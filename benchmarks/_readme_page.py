"""The README's rendered blocks (registered in :data:`benchmarks.rendered_docs.BLOCKS`): where the
estimator stands, and one paragraph each for the transmission, the prior and today's simulator,
each a summary of a table on another page, from the same JSON."""

from __future__ import annotations

from benchmarks._identification_page import LEARNED_BASELINES, MODEL_NAMES
from benchmarks._report import spread_cell
from benchmarks._results_page import PRIOR_VARIANTS, SIMULATOR_NOT_RECORDED
from benchmarks.learning_curve import paper_budget
from hybrid.tables import compare


def _ratio(models: dict, metric: str, a: str = "hybrid", b: str = "transformer") -> str:
    return f"{models[a]['whole'][metric]['mean'] / models[b]['whole'][metric]['mean']:.2f}"


def _verdict(models: dict, metric: str, a: str = "hybrid", b: str = "transformer") -> str:
    """The spread rule (:func:`hybrid.tables.compare`) between ``a`` and ``b`` on whole files."""
    word = {-1: "win", 0: "tie", 1: "loss"}[compare(models[a]["whole"][metric],
                                                    models[b]["whole"][metric])]
    return f"a {word} by the spread rule"


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
            f"{SIMULATOR_NOT_RECORDED['prior_ablation']}, scale "
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
            cell = spread_cell(axes[axis]["nrmse_pct"])
            won = verdicts[axis]["win"] and verdicts[axis]["best"] == model
            cells.append(f"**{cell}**" if won else cell)
        lines.append(f"| {model} | " + " | ".join(cells) + " |")
    lines += ["", f"That is {100 * call['scale']:g} % of the data the paper trained on"
              + (", a small-data regime: whether the lead holds at the paper's amount of data "
                 "is measured by the learning curve below." if call["scale"] < 1 else "."), ""]
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
            + ". " + paper_budget(result) + "\n")
