"""The README's rendered blocks (registered in :data:`reports.render.BLOCKS`): where the
estimator stands at the paper's amount of data (its first screen), and one paragraph each for the
transmission and the prior, each a summary of a table on another page, from the same JSON; and
the first comparison's table, now on the results page."""

from __future__ import annotations

from reports.identification_page import LEARNED_BASELINES, MODEL_NAMES
from reports.cells import spread_cell
from psmforce.experiments.plan import PLAN
from studies.bench_paper_calibration import published
from studies.learning_curve import AXES, HYBRID, PAPER_SCALE, TRANSFORMER
from psmforce.estimators.evaluation.tables import compare


def _ratio(models: dict, metric: str, a: str = "hybrid", b: str = "transformer") -> str:
    return f"{models[a]['whole'][metric]['mean'] / models[b]['whole'][metric]['mean']:.2f}"


def _verdict(models: dict, metric: str, a: str = "hybrid", b: str = "transformer") -> str:
    """The spread rule (:func:`psmforce.estimators.evaluation.tables.compare`) between ``a`` and ``b`` on whole files."""
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


FIGURE = "../results/learning_curve/learning_curve.png"
"""The learning curve's three-axis figure (drawn by ``studies/learning_curve.py``), as
``docs/results.md`` links it."""


def _by_verdict(ratios: dict) -> str:
    """``{axis: {ratio, verdict}}`` as words: the axes grouped by verdict, each with its ratio."""
    words = {"hybrid ahead": "ahead", "tie": "tied", "hybrid behind": "behind"}
    groups: dict[str, list[str]] = {}
    for a in AXES:
        groups.setdefault(words[ratios[a]["verdict"]], []).append(
            f"{a} ({ratios[a]['ratio']:.2f}x)")

    def listed(items: list[str]) -> str:
        return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]

    return ", ".join(f"{w} on {listed(axes)}" for w, axes in groups.items())


def _published() -> dict[str, dict]:
    """The seed paper's published NRMSE on its robot, by model label (Table III)."""
    return {plan.label: plan.published_nrmse_pct for plan in PLAN.values()
            if plan.published_nrmse_pct}


def _against_robot(point: dict) -> str:
    """How the bench's errors (paper metric) compare with those the paper published on its
    robot, for the models it published."""
    ratios = {label: [point["models"][label]["paper"][a]["mean"] / pub[a] for a in AXES]
              for label, pub in _published().items() if label in point["models"]}
    if not ratios:
        return ""
    every = [r for rs in ratios.values() for r in rs]
    words = ("easier than" if max(every) < 1 else "harder than" if min(every) > 1
             else "neither uniformly easier nor harder than")
    return (f"On the paper's metric the bench's {' and '.join(ratios)} score "
            f"{min(every):.2f}-{max(every):.2f}x the errors the paper published on its robot "
            f"(last column): the bench is {words} the robot.")


def headline(curve: dict) -> str:
    """``docs/results.md`` section 1's opening (the README's first screen until the comparison on
    fresh seeds replaced it): the hybrid against every model at the paper's amount of data on
    the learning curve's simulator, one sentence and one table, both metrics (ties stated as
    ties, the seed paper's published robot figures beside), and the learning curve's figure."""
    at = [p for p in curve["points"] if p["scale"] == PAPER_SCALE]
    if not at:
        return ("\nAt the paper's amount of training data nothing is measured yet, so nothing is "
                "claimed there (`results/learning_curve/`).\n")
    p = at[0]
    vs = p["hybrid_vs_transformer"]
    seeds = " and ".join(str(s) for s in p["seeds"])
    sentence = (
        f"At the paper's amount of training data ({p['training_minutes']:.0f} min of "
        f"recordings on the simulated bench, simulator {', '.join(p['simulator_versions'])}, "
        f"bench seeds {seeds}, "
        + ("every model trained to early stopping" if p["all_converged"]
           else "NOT every model converged")
        + "), the hybrid against the paper's transformer, on the causal error a haptic loop "
        f"gets, is {_by_verdict(vs['causal'])}; on the paper's offline metric it is "
        f"{_by_verdict(vs['paper'])} (the hybrid's error over the transformer's, verdicts by "
        f"the spread rule over {len(p['seeds'])} seeds). " + _against_robot(p))
    published = _published()
    head = ("| model | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz | "
            "published on the robot (paper metric) |")
    lines = ["", sentence, "", head, "|---|---|---|---|---|---|---|---|"]
    order = [HYBRID, TRANSFORMER] + sorted(set(p["models"]) - {HYBRID, TRANSFORMER})
    for label in order:
        r = p["models"][label]
        cells = [spread_cell(r[m][a]) for m in ("causal", "paper") for a in AXES]
        pub = published.get(label)
        lines.append(f"| {label} | " + " | ".join(cells) + " | "
                     + (" / ".join(f"{pub[a]:.2f}" for a in AXES) if pub else "not published")
                     + " |")
    lines.append("| hybrid / transformer | " + " | ".join(
        f"{vs[m][a]['ratio']:.2f}x ({vs[m][a]['verdict']})" for m in ("causal", "paper")
        for a in AXES) + " | |")
    lines += ["", "NRMSE % of the force on the tool (HEX10 frame), mean ± std over bench seeds (the sample std, ddof 1), "
              "lower is better; causal: the raw per-sample estimate, paper: the paper's offline "
              "post-processing (bias removed, centred median). Every scale: the tables below.", "",
              f"![The learning curve: causal NRMSE against minutes of training data, per axis]"
              f"({FIGURE})", ""]
    return "\n".join(lines)


def _bench_over_robot(calibration: dict, version: str) -> str:
    """What the bench calibration (``studies/bench_paper_calibration.py``) measured of
    ``version`` against the paper's robot: each calibration model's ratios and the held-out
    transformer's status."""
    rows = [r for r in calibration.get("rows", []) if r["candidate"] == version
            and r["paper_budget"]]
    if not rows:
        return ""
    text = "; ".join(f"{r['label']} " + " / ".join(f"{r['ratio'][a]:.2f}x" for a in AXES)
                     + ("" if published(r["model"]) else
                        " (against the issue's figure, which no publication gives)")
                     for r in rows)
    held = calibration["verdicts"][version]["transformer_held_out"]
    if isinstance(held, dict):
        ratios = " / ".join(f"{held['ratio'][a]:.2f}x" for a in AXES)
        held = f"the held-out paper transformer {ratios}"
    else:
        held = "the paper's transformer, its held-out check, not run yet"
    seeds = sorted({s for r in rows for s in r["seeds"]})
    return (f" On simulator {version} at the paper's amount of data (design seed"
            f"{'s' if len(seeds) > 1 else ''} {', '.join(map(str, seeds))}), the paper's models "
            f"score against the robot's errors in its Table III (Fx / Fy / Fz): {text}; {held}.")


_SUBJECT_NAMES = {"hybrid_transformer": "The model `psmforce train` ships, `hybrid_transformer`,",
                  "hybrid": "The hybrid with its causal network (`hybrid`)"}


def _paired_words(point: dict) -> str:
    """The paired verdicts of one comparison point in words, one sentence per model of ours,
    model by model ("ahead on Fz, tied on Fy, behind on Fx"), both metrics at once where they
    agree."""
    labels = {m: v["label"] for m, v in point["models"].items()}
    return " ".join(f"{_SUBJECT_NAMES.get(subject, f'`{subject}`')} is "
                    + "; ".join(_pairs_in_words(pairs, labels)) + "."
                    for subject, pairs in point["paired"].items() if pairs)


def _pairs_in_words(pairs: dict, labels: dict, seeds_of=None) -> list[str]:
    """One phrase per paired model (``pairs``: model -> {"causal"|"paper": {axis: {"verdict"}}}):
    "against the <label> ahead on every axis on both metrics"; ``seeds_of``: model -> a note on
    the seeds the pair rests on, appended in brackets."""
    word = {"ahead": "ahead", "tie": "tied", "behind": "behind"}

    def phrase(cells: dict) -> str:
        groups: dict[str, list[str]] = {}
        for a in AXES:
            groups.setdefault(cells[a]["verdict"], []).append(a)
        return ", ".join(f"{word.get(v, v)} on "
                         + ("every axis" if len(axes) == len(AXES) else " and ".join(axes))
                         for v, axes in groups.items())
    out = []
    for m, pr in pairs.items():
        causal, paper = phrase(pr["causal"]), phrase(pr["paper"])
        said = (f"{causal} on both metrics" if causal == paper
                else f"causal {causal}; paper metric {paper}")
        note = seeds_of(m) if seeds_of else ""
        out.append(f"against the {labels[m]} {said}" + (f" ({note})" if note else ""))
    return out


def shipped_model(result: dict) -> str:
    """README's first screen: the model ``psmforce train`` ships (``hybrid_transformer``, the
    hybrid's physics read by the paper's transformer) against every model trained on the seeds
    declared for its check (``studies/hybrid_wide_confirm.py``), paired by seed, in words, per
    point; a pair resting on fewer than the declared seeds says how many it has."""
    lines = [""]
    for p in sorted(result.get("points", {}).values(), key=lambda p: (p["version"], p["scale"])):
        pairs = p.get("paired", {}).get("hybrid_transformer")
        if not pairs:
            continue
        declared = p["declared_seeds"]
        # the study's "as shipped" is the hybrid it was checked against, no longer the default
        labels = {m: v["label"] for m, v in p["models"].items()} | {
            "hybrid": "hybrid with its causal network (`hybrid`)"}
        words = _pairs_in_words(pairs, labels, lambda m: (
            "" if sorted(pairs[m]["seeds"]) == sorted(declared) else
            f"on {len(pairs[m]['seeds'])} of the {len(declared)} declared seeds so far"))
        lines += ["The model `psmforce train` ships, `hybrid_transformer`, on the seeds declared "
                  f"for its check ({', '.join(map(str, declared))}; simulator {p['version']}, scale "
                  f"{p['scale']:g}; test trials; paired by seed, {p['interval']}; \"ahead\" "
                  "only when the interval lies below 1) is " + "; ".join(words) + ".", ""]
    if len(lines) == 1:
        lines += ["The shipped model has no paired check yet (`studies/hybrid_wide_confirm.py`).",
                  ""]
    return "\n".join(lines)


def fresh_comparison(result: dict, calibration: dict | None = None) -> str:
    """README's first screen: the published comparison on fresh seeds
    (``studies/comparison.py``), per point one sentence and one table: each model's NRMSE (mean
    ± sd over seeds, ddof 1) and the hybrid's error over each model's, paired by seed, with its
    interval and verdict, causal and paper metric; then the bench against the robot
    (``calibration``: the bench calibration's JSON)."""
    points = sorted(result.get("points", {}).values(), key=lambda p: (p["version"], p["scale"]))
    if not points:
        return "\nNo comparison on fresh seeds yet (`studies/comparison.py`).\n"
    lines = [""]
    last_of = {p["version"]: p for p in points}   # the bench against the robot, said once
    for p in points:
        trained = ("every model trained to early stopping" if not p["not_converged"] else
                   f"NOT converged: {', '.join(p['not_converged'])}")
        lines += [f"On fresh bench seeds ({', '.join(map(str, p['seeds']))}, declared before "
                  f"they were run; simulator {p['version']}, scale {p['scale']:g} of the paper's "
                  f"training data; {trained}, on {p['device']}): each model's error, and each "
                  "of our models' "
                  "error over each other model's, paired by seed (geometric mean "
                  f"[{p['interval']}]; \"ahead\" only when the interval lies below 1, "
                  "\"behind\" above 1, a tie otherwise). "
                  + _paired_words(p), "",
                  "| model | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
                  "|---|---|---|---|---|---|---|"]
        for v in p["models"].values():
            lines.append(f"| {v['label']}{'' if v['converged'] else ' (NOT converged)'} | "
                         + " | ".join(spread_cell({"mean": v["summary"][mt][a]["mean"],
                                                  "std": v["summary"][mt][a]["sd"]})
                                      for mt in ("causal", "paper") for a in AXES) + " |")
        for subject, pairs in p["paired"].items():
            for m, pr in pairs.items():
                lines.append(f"| {subject} / {p['models'][m]['label']} | "
                             + " | ".join(pr[mt][a]["text"] for mt in ("causal", "paper")
                                          for a in AXES) + " |")
        left = ([f"Not compared (a training did not stop early): "
                 f"{', '.join(p['not_compared'])}."] if p["not_compared"] else [])
        lines += ["", "NRMSE % of the force on the tool (HEX10 frame), mean ± sd over seeds "
                  "(ddof 1), lower is better; causal: the raw per-sample estimate a haptic loop "
                  "gets, paper: the paper's offline post-processing (bias removed, centred "
                  "median)." + (f" {' '.join(left)}" if left else "")
                  + (_bench_over_robot(calibration, p["version"])
                     if calibration and p is last_of[p["version"]] else ""), ""]
    from psmforce.experiments.seeds import COMPARISON_SEEDS
    for v in sorted({p["version"] for p in points}):
        missing = sorted(set(COMPARISON_SEEDS) - {p["scale"] for p in points
                                                   if p["version"] == v})
        started = [x for x in missing if result.get("records", {}).get(v, {}).get(f"{x:g}")]
        if started:
            lines += [f"In progress for simulator {v}, nothing compared there yet: scale "
                      f"{', '.join(f'{x:g}' for x in started)} (what is trained so far, and "
                      "against the robot, is listed under the comparison in `docs/results.md`).",
                      ""]
        missing = [x for x in missing if x not in started]
        if missing:
            lines += [f"Declared for simulator {v} and not measured yet, so nothing is claimed "
                      f"there: scale {', '.join(f'{x:g}' for x in missing)} (their seeds are "
                      f"declared in `psmforce/experiments/seeds.py`; `studies/comparison.py "
                      f"--scale S` runs them).", ""]
    return "\n".join(lines)
