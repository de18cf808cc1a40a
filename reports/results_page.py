"""The tables and findings of ``docs/results.md``, rendered from the committed JSONs that measured
them.

Each function takes the JSON(s) named in :data:`reports.render.BLOCKS` and returns a Markdown block.
Every sentence with a figure in it is built here, so the page's prose between the blocks names none
(``tests/reports/test_rendered_docs.py`` holds it to that). Verdicts between two models use the
project's one spread rule (:func:`psmforce.estimators.evaluation.tables.compare`: a win needs mean +
std below the other's mean - std, std as its JSON holds it; a cell without a spread, one seed,
shows the mean alone and ties).
"""

from __future__ import annotations

import statistics

from reports.cells import spread_cell
from studies.learning_curve import (
    HYBRID,
    TRANSFORMER,
    paper_budget,
    settings_lines,
    standing,
)
from psmforce.estimators.evaluation.tables import compare, verdicts

AXES = ("Fx", "Fy", "Fz")
LATERAL = ("Fx", "Fy")
PORT_NAMES = {"none": "no port", "cannula": "cannula", "abdominal-wall": "abdominal wall"}
SIMULATOR_NOT_RECORDED = {"prior_ablation": "2.1", "hybrid_port_design": "2.0",
                          "another_tool": "2.0"}
"""The simulator version of runs whose JSON predates the version record, read from the commit
that wrote each JSON (the prior ablation after 2.1's cable law, the other two before it)."""


FZ_TARGET_RATIO = 0.6
"""Issue 13's target for the hybrid's error, as a fraction of the paper transformer's (the
``targets`` of port_comparison.json name it, not its value)."""


def _pair(pair) -> dict:
    """``[mean, std]`` (another_tool.json's layout) as ``{mean, std}``."""
    return {"mean": pair[0], "std": pair[1]}


def _standings(by_model: dict) -> str:
    """Per axis, who has the lowest mean and whether it wins by the spread rule
    (:func:`psmforce.estimators.evaluation.tables.verdicts`); ``by_model``: {model: {axis: {mean, std}}}."""
    v = verdicts({m: {a: {"nrmse_pct": s[a]} for a in AXES} for m, s in by_model.items()})
    return "; ".join(f"{a}: {v[a]['best']} " + (
        f"lowest, tied with {' and '.join(v[a]['tied_with'])}" if v[a]["tied_with"] else "wins")
        for a in AXES)


def _verdict(a: dict, b: dict) -> str:
    """``a`` against ``b`` by the spread rule, with the ratio of the means."""
    word = {-1: "ahead", 0: "tie", 1: "behind"}[compare(a, b)]
    return f"{a['mean'] / b['mean']:.2f}x, {word}"


def _yes(flag: bool) -> str:
    return "yes" if flag else "**no**"


def status(curve: dict, ablation: dict, ports: dict, comparison: dict, design: dict,
           tool: dict) -> str:
    """What each section of the page measured: bench, data, seeds, convergence, its JSON."""
    pts = curve["points"]
    design_runs = [r for p in design["ports"].values() for v in p.values() for r in v["runs"]]
    rows = [
        ("1. The learning curve",
         ", ".join(sorted({v for p in pts for v in p["simulator_versions"]})),
         "scales " + ", ".join(f"{p['scale']:g}" for p in pts) + "; not yet: "
         + (", ".join(f"{s:g}" for s in curve["missing_scales"]) or "none"),
         "; ".join(f"{len(p['seeds'])} at {p['scale']:g}" for p in pts),
         _yes(all(p["all_converged"] for p in pts)), "results/learning_curve/learning_curve.json"),
        ("2. The prior, axis by axis",
         SIMULATOR_NOT_RECORDED["prior_ablation"] + " (not in its JSON)",
         f"scale {ablation['scale']:g}", " ".join(str(s) for s in ablation["seeds"]),
         _yes(ablation["all_converged"]), "results/benchmarks/prior_ablation.json"),
        ("3. Ports; 5. the axial channels",
         ", ".join(sorted(set(comparison["benches"].values()))),
         f"scale {ports['call']['scale']:g}", " ".join(str(s) for s in ports["call"]["seeds"]),
         _yes(all(ports["all_converged"].values())), "results/benchmarks/port_comparison.json"),
        ("4. The hybrid's inputs",
         SIMULATOR_NOT_RECORDED["hybrid_port_design"] + " (not in its JSON)",
         f"scale {design['scale']:g}, validation trials",
         f"{design['seed']} (the design bench)",
         f"{sum(r['converged'] for r in design_runs)} of {len(design_runs)}",
         "results/benchmarks/hybrid_port_design.json"),
        ("6. Another tool", SIMULATOR_NOT_RECORDED["another_tool"] + " (not in its JSON)",
         f"trained at scale {tool['settings']['scale']:g}, scored at "
         f"{tool['settings']['test_scale']:g}",
         " ".join(str(s) for s in tool["settings"]["seeds"]), _yes(tool["converged"]),
         "results/benchmarks/another_tool.json"),
    ]
    lines = ["", "| section | simulator | data | bench seeds | every run converged | JSON |",
             "|---|---|---|---|---|---|"]
    lines += ["| " + " | ".join(r[:5]) + f" | `{r[5]}` |" for r in rows]
    return "\n".join(lines + [""])


def learning_curve(curve: dict) -> str:
    """Section 1: the hybrid against the paper transformer per scale, both metrics, and where
    each model stands."""
    lines = ["", "NRMSE % on the test trials, mean ± std over bench seeds (the sample std, ddof 1); causal = the raw "
             "per-sample estimate a haptic loop gets, paper = the paper's offline "
             "post-processing; every model in `results/learning_curve/README.md`.", "",
             "| scale | minutes of training data | seeds | converged | metric | Hybrid (ours) "
             "Fx / Fy / Fz | Transformer (paper) Fx / Fy / Fz | hybrid against transformer |",
             "|---|---|---|---|---|---|---|---|"]
    for p in curve["points"]:
        for m in ("causal", "paper"):
            h, t = p["models"][HYBRID][m], p["models"][TRANSFORMER][m]
            v = p["hybrid_vs_transformer"][m]
            lines.append(
                f"| {p['scale']:g} | {p['training_minutes']:.1f} | {len(p['seeds'])} | "
                f"{_yes(p['all_converged'])} | {m} | " + " / ".join(spread_cell(h[a]) for a in AXES)
                + " | " + " / ".join(spread_cell(t[a]) for a in AXES) + " | "
                + " / ".join(f"{v[a]['ratio']:.2f}x ({v[a]['verdict']})" for a in AXES) + " |")
    settings = settings_lines(curve)
    if settings:
        lines += ["", "Training settings of the recipes beyond `psmforce.estimators.training.train.TrainConfig`'s "
                  "defaults, per scale:", ""] + settings
    lines += ["", "Where each model stands (causal metric, spread rule):", ""] + standing(curve)
    for p in curve.get("partial", []):
        lines += ["", f"At scale {p['scale']:g} ({p['training_minutes']:.1f} min of training "
                  f"data, {len(p['seeds'])} seeds, "
                  + ("every run converged" if p["all_converged"] else "NOT every run converged")
                  + "), so far only: " + "; ".join(
                      f"{label} causal " + " / ".join(spread_cell(r["causal"][a]) for a in AXES)
                      for label, r in p["models"].items())
                  + ". The hybrid against the transformer is not measured there yet."]
    largest = max((p["scale"] for p in curve["points"]), default=None)
    lines += ["", f"Measured up to scale {largest:g} of the paper's data; not yet: "
              + (", ".join(f"{s:g}" for s in curve["missing_scales"]) or "none")
              + ". " + paper_budget(curve), ""]
    return "\n".join(lines)


BENCH_ROBOT_BAND = (0.67, 1.5)
"""Issue 45's band for a model's bench error over its published robot error."""


def bench_against_robot(curve: dict) -> str:
    """At the paper's amount of data (scale 1), on the paper's metric: each model's bench error
    against the paper's published robot error (Table III), their ratio and whether it lies in
    :data:`BENCH_ROBOT_BAND`, and the FCN over the transformer laterally on either."""
    from psmforce.experiments.plan import PLAN
    point = next((p for p in curve["points"] if p["scale"] == 1.0), None)
    if point is None:
        return "\nThe curve has no point at the paper's amount of data yet.\n"
    published = {PLAN[m].label: PLAN[m].published_nrmse_pct for m in PLAN
                 if PLAN[m].published_nrmse_pct}
    low, high = BENCH_ROBOT_BAND
    lines = ["", f"Paper metric, NRMSE %, scale 1 ({point['training_minutes']:.0f} min of "
             f"training data, {len(point['seeds'])} bench seeds, simulator "
             f"{', '.join(point['simulator_versions'])}), against the paper's Table III on the "
             f"real robot; a bench that imitates the robot puts every ratio in "
             f"[{low:g}, {high:g}].", "",
             "| model | bench Fx / Fy / Fz | robot Fx / Fy / Fz | bench over robot | in band |",
             "|---|---|---|---|---|"]
    for label, robot in published.items():
        if label not in point["models"]:
            lines.append(f"| {label} | not on the curve | "
                         + " / ".join(f"{robot[a]:.2f}" for a in AXES) + " | | |")
            continue
        bench = {a: point["models"][label]["paper"][a]["mean"] for a in AXES}
        ratio = {a: bench[a] / robot[a] for a in AXES}
        inside = [a for a in AXES if low <= ratio[a] <= high]
        lines.append(f"| {label} | " + " / ".join(f"{bench[a]:.2f}" for a in AXES) + " | "
                     + " / ".join(f"{robot[a]:.2f}" for a in AXES) + " | "
                     + " / ".join(f"{ratio[a]:.2f}x" for a in AXES) + " | "
                     + (", ".join(inside) if inside else "none") + " |")
    unpublished = [label for label in point["models"] if label not in published]
    fcn, tr = published.get("FCN"), published.get(TRANSFORMER)
    if fcn and tr and "FCN" in point["models"] and TRANSFORMER in point["models"]:
        bench = point["models"]
        lines += ["", "The FCN over the transformer laterally (Fx / Fy): on the robot "
                  + " / ".join(f"{fcn[a] / tr[a]:.2f}x" for a in LATERAL) + ", on the bench "
                  + " / ".join(f"{bench['FCN']['paper'][a]['mean'] / bench[TRANSFORMER]['paper'][a]['mean']:.2f}x"
                               for a in LATERAL) + "."]
    if unpublished:
        lines += ["", "No published robot figure for: " + ", ".join(unpublished)
                  + " (the paper's Table III has none)."]
    return "\n".join(lines) + "\n"


def recipe_swap_tables(result: dict) -> str:
    """The training regimes swapped between models (``studies/recipe_swap.py``): each cell's
    errors per seed-mean with the sample sd, then the paired ratios with their intervals."""
    cells = result["cells"]
    lines = [""]
    if cells:
        first = next(iter(cells.values()))
        lines += [f"Scale {first['scale']:g}, fresh bench seeds "
                  f"{', '.join(str(x) for x in first['seeds'])}, simulator "
                  f"{', '.join(first['simulator_versions'])}; NRMSE %, mean ± sd over seeds "
                  "(ddof 1).", "",
                  "| model | regime | converged | causal Fx / Fy / Fz | paper Fx / Fy / Fz |",
                  "|---|---|---|---|---|"]
        from psmforce.experiments.paired import mean_sd
        for c in cells.values():
            stats = {m: {a: mean_sd([s[a] for s in c["per_seed"][m]]) for a in AXES}
                     for m in ("causal", "paper")}
            lines.append(f"| {c['label']} | {c['regime']} | "
                         f"{sum(c['converged'])} of {len(c['converged'])} | "
                         + " | ".join(" / ".join(f"{stats[m][a]['mean']:.2f} ± "
                                                 f"{stats[m][a]['sd']:.2f}" for a in AXES)
                                      for m in ("causal", "paper")) + " |")
    if result["comparisons"]:
        lines += ["", f"Paired by seed, the first model's error over the second's, "
                  f"{result['interval']}; a verdict other than tie needs the interval to "
                  "exclude 1.", "", "| comparison | causal Fx / Fy / Fz | paper Fx / Fy / Fz |",
                  "|---|---|---|"]
        for name, row in result["comparisons"].items():
            lines.append(f"| {name} | " + " | ".join(
                " / ".join(row[m][a]["text"] for a in AXES) for m in ("causal", "paper"))
                + " |")
    if result["missing_cells"]:
        lines += ["", "Not run yet: " + ", ".join(result["missing_cells"]) + "."]
    if result["not_converged"]:
        lines += ["", "Not every training stopped early in: " + ", ".join(result["not_converged"])
                  + " (left out of the comparisons)."]
    if result["other_bench"]:
        lines += ["", "On another bench (scale, seeds or simulator) than the first row's, so not "
                  "paired with it: " + ", ".join(result["other_bench"]) + "."]
    return "\n".join(lines) + "\n"


def ports_findings(ports: dict, comparison: dict) -> str:
    """Section 3: who wins each axis without a port and through each one, and the paper metric."""
    lines = [""]
    for port, by_model in ports["causal_nrmse_pct"].items():
        lines.append(f"- {PORT_NAMES[port]} (causal): {_standings(by_model)}.")
    paper = {m: {a: s[a]["nrmse_pct"] for a in AXES}
             for m, s in comparison["automated"]["paper"].items()}
    lines.append(f"- no port, the paper's metric: {_standings(paper)}.")
    hyb = {p: ports["causal_nrmse_pct"][p][HYBRID] for p in ports["causal_nrmse_pct"]}
    lines.append("- The hybrid through a port against itself without one (causal): "
                 + "; ".join(f"{PORT_NAMES[p]} " + ", ".join(
                     f"{a} x{hyb[p][a]['ratio_to_no_port']:.2f}" for a in AXES)
                             for p in hyb if p != "none") + ".")
    return "\n".join(lines + [""])


def port_design_findings(design: dict, notch: dict) -> str:
    """Section 4: the initialisations' Fz ranges of the chosen inputs against the previous
    default, per port, and the notched base tried after."""
    new, old = "+ insertion velocity, position", "default"
    lines = [""]
    for port, variants in design["ports"].items():
        ranges = {k: [r["causal"][2] for r in variants[k]["runs"]] for k in (new, old)}
        apart = max(ranges[new]) < min(ranges[old])
        lines.append(f"- {PORT_NAMES[port]}: Fz over the initialisations "
                     f"{min(ranges[new]):.2f}-{max(ranges[new]):.2f} with the insertion state "
                     f"against {min(ranges[old]):.2f}-{max(ranges[old]):.2f} without it ("
                     + ("the ranges do not overlap" if apart else "the ranges overlap") + ").")
    means = notch["ports"]["none"]
    (base_name, base), (tried_name, tried) = list(means.items())
    lines.append(f"- The notched base ({tried_name}), no port, causal Fx / Fy / Fz: "
                 + " / ".join(f"{x:.2f}" for x in tried["mean"]["causal"]) + " against "
                 + " / ".join(f"{x:.2f}" for x in base["mean"]["causal"])
                 + f" for {base_name}: "
                 + ("worse on every axis" if all(t > b for t, b in zip(
                     tried["mean"]["causal"], base["mean"]["causal"])) else "not worse everywhere")
                 + " (`results/benchmarks/hybrid_port_design_notch.json`).")
    return "\n".join(lines + [""])


def axial_findings(ports: dict) -> str:
    """Section 5: the hybrid's Fz against the best a fixed filter makes of a perfect stage
    model, the issue's target, and what the HEX10's axial channel leaves."""
    ch, models = ports["axial_channels_fz_nrmse_pct"], ports["causal_nrmse_pct"]
    bound = ch["none"]["perfect stage model, best fixed filter"]
    hybrid = models["none"][HYBRID]["Fz"]
    target = FZ_TARGET_RATIO * models["none"][TRANSFORMER]["Fz"]["mean"]
    return "\n".join([
        "",
        f"- No port: the hybrid's Fz {spread_cell(hybrid)} against a perfect stage model through "
        "the "
        f"best fixed filter {spread_cell(bound)} ({_verdict(hybrid, bound)}).",
        f"- The target, {FZ_TARGET_RATIO:g}x the paper transformer's Fz without a port, is "
        f"{target:.2f} %: "
        f"{target / bound['mean']:.2f}x that bound.",
        f"- The HEX10's axial reading after the prior (`comp_fz`) misses by "
        f"{ch['none']['comp_fz']['mean']:.0f} % of the force's range; blended above the best "
        f"crossover it scores {spread_cell(ch['none']['complementary'])} against "
        f"{spread_cell(ch['none']['insertion_fz'])} for `insertion_fz` alone.", ""])


def another_tool_findings(tool: dict) -> str:
    """Section 6: the hybrid against the FCN and the paper transformer on a drawn tool, as is
    and calibrated; its Fz across tools."""
    table = tool["table"]
    lines = [""]
    for spread in ("1x", "2x"):
        for state in ("as is", "calibrated"):
            row = f"{spread} {state}"
            hyb = table["hybrid"][row]["causal"]
            parts = [f"{a} against {other} " + _verdict(_pair(hyb[a]),
                                                         _pair(table[other][row]["causal"][a]))
                     for other in ("fcn", "transformer") for a in LATERAL]
            lines.append(f"- Tool at {spread} the spread, {state} (causal, hybrid's ratio): "
                         + "; ".join(parts) + ".")
    nominal = {s: table["hybrid"][f"nominal {s}"]["causal"] for s in ("as is", "calibrated")}
    lines.append("- Calibrating the nominal tool, the hybrid's lateral error: "
                 + "; ".join(f"{a} {nominal['as is'][a][0]:.2f} -> "
                             f"{nominal['calibrated'][a][0]:.2f} %" for a in LATERAL) + ".")
    for model in ("hybrid", "fcn", "transformer"):
        fz = [table[model][f"{t} as is"]["causal"]["Fz"][0] for t in ("nominal", "1x", "2x")]
        lines.append(f"- {model} Fz as is, nominal -> 1x -> 2x: "
                     + " -> ".join(f"{x:.2f}" for x in fz) + " %.")
    return "\n".join(lines + [""])


def training_speed(training: dict, convergence: dict, options: dict) -> str:
    """Section 7: one training step per model, the paper transformer's converged run, and the
    speed options measured."""
    c = convergence["convergence"]
    lines = ["", f"Machine: {training['machine']['threads']} threads, torch "
             f"{training['machine']['torch']}.", "",
             "| model (training step) | batch x length | seconds per step | speed-up |",
             "|---|---|---|---|"]
    for name, t in training["throughput"].items():
        speedup = t.get("speedup_vs_before")
        lines.append(f"| {name} | {t['batch']} x {t['length']} | {t['seconds_per_step']:.3g} | "
                     + (f"{speedup:.2f}x the stock encoder" if speedup else "") + " |")
    lines += ["", f"The paper transformer at scale {c['scale']:g} ({c['train_windows']:,} training "
              f"windows per epoch, {convergence['machine']['threads']} threads): stopped by "
              f"{c['stopped_by']} after {c['epochs_run']} epochs in {c['seconds'] / 60:.1f} min "
              f"({c['seconds'] / c['epochs_run']:.0f} s per epoch, validation included; "
              + ("compiled" if c["compiled"] else "eager") + ").", "",
              f"Speed options ({options['machine']['threads']} thread, "
              "`benchmarks/training.py --speed-options`):", "",
              "| option | seconds per step | windows per s | speed-up |", "|---|---|---|---|"]
    speed = options["speed_options"]
    for name, o in speed.items():
        if "seconds_per_step" in o:
            lines.append(f"| {name} | {o['seconds_per_step']:.2f} | {o['windows_per_s']:.0f} | "
                         f"{o['speedup']:.2f}x |")
    if "data path" in speed:
        lines += ["", f"The data path: {speed['data path']['share_of_step']:.2%} of a step."]
    return "\n".join(lines + [""])


def training_gpu(training: dict) -> str:
    """Section 7, on a GPU: one training step per model, and what the CPU's chunked attention
    would cost there."""
    m, t = training["machine"], training["throughput"]
    chunked = t["transformer (chunked attention, the CPU's path)"]["seconds_per_step"]
    fused = t["transformer (after)"]["seconds_per_step"]
    lines = ["", f"Machine: {m['gpu']}, torch {m['torch']}.", "",
             "| model (training step) | batch x length | seconds per step |", "|---|---|---|"]
    lines += [f"| {name} | {r['batch']} x {r['length']} | {r['seconds_per_step']:.3g} |"
              for name, r in t.items()]
    lines += ["", f"On this GPU the CPU's chunked attention would make the paper transformer's "
              f"step {chunked / fused:.0f}x slower than torch's fused kernel, which "
              "`psmforce.estimators.networks.attention.attention` takes off the CPU."]
    return "\n".join(lines + [""])


def latency(streaming: dict, live: dict) -> str:
    """Section 8: the streaming step at batch 1, and the live node over DDS."""
    def row(name, t):
        return f"| {name} | {t['median_ms']:.3f} | {t['p99_ms']:.3f} | {t['max_ms']:.3f} |"

    machine = streaming["machine"]
    cpu = f" of {machine['cpu']}" if machine.get("cpu") else ""
    lines = ["", f"`results/benchmarks/streaming.json`: {streaming['estimator']}, "
             f"{machine['threads']} thread{cpu}, one recorded trial replayed sample by "
             f"sample (`{streaming.get('command', 'python benchmarks/streaming.py')}`). "
             "The figures are this machine's; the ratios between rows of one run carry over "
             "better than the times.", "",
             "| step | median ms | p99 ms | max ms |", "|---|---|---|---|",
             row("hybrid pipeline (HEX10 frame)", streaming["hybrid_pipeline"]),
             row("hybrid pipeline, base frame too", streaming["hybrid_pipeline_base_frame"]),
             row("paper transformer, full window", streaming["reference_paper_transformer"])]
    window_step = streaming.get("paper_transformer_pipeline")   # since window models stream
    if window_step:
        lines.append(row(f"paper transformer pipeline, its window as the state "
                         f"({window_step['backend']})", window_step))
    lines += [row(f"hybrid network step, {b}", t)
              for b, t in streaming["network_step_by_backend"].items()]
    if window_step:
        ratio = window_step["median_ms"] / streaming["hybrid_pipeline"]["median_ms"]
        lines += ["", f"A window model's step (the paper's transformer through the streaming "
                  f"pipeline, as `hybrid_transformer` runs: its network and window, on the paper's inputs) "
                  f"costs {ratio:.1f}x the hybrid's cached step at the median, in the same run."]
    d, node = live["dds"], live["node"]
    lines += ["", f"`results/benchmarks/live.json` (`python benchmarks/live.py`, "
              f"{live['machine']['cpus']} CPUs): the node's own time per HEX10 message at "
              f"{live['session']['rate_hz']:.0f} Hz, median {node['all']['median_ms']:.3f} ms, "
              f"p99 {node['all']['p99_ms']:.3f} ms, "
              f"{node['all']['over_budget_fraction']:.1%} over its {node['budget_ms']:g} ms "
              f"budget. Decoding one sample's three messages from their bytes: median "
              f"{1e3 * live['decode']['psmforce.live.cdr']['median_ms']:.0f} µs with "
              f"`psmforce.live.cdr` (what the node uses), "
              f"{1e3 * live['decode']['cyclonedds']['median_ms']:.0f} µs with `cyclonedds`' "
              f"classes. Over DDS, robot, node and subscriber in three processes for "
              f"{d['seconds']:.0f} s: {d['hex10_sent']:,} sent, {d['answers_received']:,} "
              f"answers received ({d['lost_fraction']:.1%} lost); end-to-end latency median "
              f"{d['latency']['median_ms']:.2f} ms, p99 {d['latency']['p99_ms']:.2f} ms, max "
              f"{d['latency']['max_ms']:.1f} ms (the robot's own messages to the subscriber, "
              f"no node, in the same run: median {d['transport_latency']['median_ms']:.2f} ms, "
              f"p99 {d['transport_latency']['p99_ms']:.2f} ms, "
              + ("within" if d["transport_latency"]["p99_ms"] <= node["budget_ms"]
                 else "already over")
              + f" the target without the node); the p99 target of {node['budget_ms']:g} ms is "
              + ("met" if d["within_target"] else "**not met**") + "."]
    if "burst" in live:  # the lab's conditions (issue 47)
        added, busy, b = d["node_added_latency"], live["dds_busy_core"], live["burst"]
        first = live["dds_rate_measured"]["first_answer_ms"]

        def three(t):
            return f"p50 {t['median_ms']:.2f} ms, p99 {t['p99_ms']:.2f} ms, max {t['max_ms']:.1f} ms"

        def burst(b):
            return (f"| burst of {b['samples']:,} samples at {b['rate_hz']:,.0f} Hz "
                    f"({b['times_the_stream_rate']:.1f}x the stream"
                    + (", one core busy" if b.get("busy_core") else "") + "): messages the "
                    f"node lost | {sum(b['node_lost'].values()):,} of {3 * b['samples']:,} "
                    f"({b['answers_published']:,} answered) |")
        lines += ["", "| the node under a lab's conditions | figure |", "|---|---|",
                  f"| transport alone (the robot's own messages, same run) | "
                  f"{three(d['transport_latency'])} |",
                  f"| transport through the node | {three(d['latency'])} |",
                  f"| node-added latency per message (answer minus the robot's own message: "
                  f"the node and one more hop) | {three(added)} |"]
        if d.get("node_residence"):
            own = d["node_residence"]
            goal = d.get("residence_goal_p99_ms")
            goal = "" if goal is None else f"; goal p99 <= {goal:g} ms"
            lines += [f"| the node's residence per answer (taken off the reader to last output "
                      f"written, its own clock{goal}) | {three(own)}: goal "
                      + ("met" if d["residence_goal_met"] else "**not met**") + " |"]
        if d.get("node_residence_writes"):  # what the DDS writes alone take of it
            lines += [f"| of which the four DDS writes per answer (the same answers) | "
                      f"{three(d['node_residence_writes'])} |"]
        lines += [f"| steady {live['session']['rate_hz']:.0f} Hz, {d['seconds']:.0f} s: "
                  f"messages the node lost | {d['node_lost']:,} of {d['hex10_sent']:,} |",
                  f"| one core busy, {busy['seconds']:.0f} s: messages the node lost; "
                  f"latency p99 | {busy['node_lost']:,} of {busy['hex10_sent']:,}; "
                  f"{busy['latency']['p99_ms']:.2f} ms |",
                  burst(b)]
        if "burst_busy_core" in live:
            lines += [burst(live["burst_busy_core"])]
        lines += [f"| first answer after the first HEX10 message, rate measured by the node "
                  f"(no `--input-rate`) | {first:.0f} ms |"]
    if "dds_network_after_answer" in live:  # issue 47 item 8: the network off the answer's path
        lines += network_order(live)
    if "dds_realtime" in live or "realtime_refused" in live:
        lines += scheduling(live)
    if "dds_floor" in live:
        lines += floor(live)
    return "\n".join(lines + [""])


def floor(live: dict) -> list[str]:
    """What the node's own work adds over a node without it: ``benchmarks/live_floor.py``'s
    echo node over the same transport, and the node's in-process time back to back and woken
    from sleep at every message, from the same run of ``benchmarks/live.py``."""
    def cell(t):
        return f"{t['median_ms']:.3f} / {t['p99_ms']:.3f} / {t['max_ms']:.2f}"

    rows = [("no estimator (the floor), normal", live["dds_floor"]),
            ("no estimator (the floor), " + live.get("dds_floor_realtime", {}).get(
                "scheduling", ""), live.get("dds_floor_realtime")),
            ("`serve`, network after the answer, normal", live.get("dds_network_after_answer")),
            ("`serve`, network after the answer, " + live.get(
                "dds_realtime_network_after_answer", {}).get("scheduling", ""),
             live.get("dds_realtime_network_after_answer")),
            ("`serve --busy-poll`, network after the answer, normal",
             live.get("dds_busy_poll_network_after_answer")),
            ("`serve --busy-poll`, network after the answer, normal, one core busy",
             live.get("dds_busy_core_busy_poll_network_after_answer"))]
    lines = ["", "The floor: the same node without its estimator (`benchmarks/live_floor.py`: "
             "every HEX10 message answered with four outputs encoded before), over the same "
             "transport in the same run; what the node's own work adds is the difference. "
             "Times p50 / p99 / max in ms.", "",
             "| node | residence over DDS | node-added latency | messages the node lost |",
             "|---|---|---|---|"]
    lines += [f"| {name} | {cell(t['node_residence'])} | {cell(t['node_added_latency'])} "
              f"| {t['node_lost']:,} of {t['hex10_sent']:,} |" for name, t in rows if t]
    paced = live.get("node_network_after_answer_paced")
    if paced and "node_network_after_answer" in live:
        hot = live["node_network_after_answer"]["all"]
        ratio = paced["all"]["median_ms"] / hot["median_ms"]
        lines += ["", f"The node's work in-process, every message, network after the answer: "
                  f"back to back {cell(hot)} ms; each message 1 ms after the one before, "
                  f"the process asleep in between as on the robot, {cell(paced['all'])} ms "
                  f"({ratio:.1f}x at the median"
                  + ("; woken from sleep, the same work runs slower on this host" if ratio > 1.2
                     else "") + ")."]
    return lines


def scheduling(live: dict) -> list[str]:
    """``serve --rt-priority``: the node's residence and added latency over DDS as a normal
    process and under SCHED_FIFO, both orders of ``--network``, quiet and with a core busy,
    from the same run of ``benchmarks/live.py``."""
    if "dds_realtime" not in live:
        return ["", f"`serve --rt-priority` was not measured: {live['realtime_refused']}"]

    def cell(t, goal=None):
        met = "" if goal is None else (" (goal met)" if t["p99_ms"] <= goal else "")
        return f"{t['median_ms']:.3f} / {t['p99_ms']:.3f} / {t['max_ms']:.2f}{met}"

    goal = live["dds"].get("residence_goal_p99_ms")
    rows = {}
    for tail, order in (("", "before-answer"), ("_network_after_answer", "after-answer")):
        if f"dds{tail}" not in live or f"dds_realtime{tail}" not in live:
            continue
        rows[f"normal, {order}"] = (live[f"dds{tail}"], live[f"dds_busy_core{tail}"])
        rows[f"{live['dds_realtime']['scheduling']}, {order}"] = (
            live[f"dds_realtime{tail}"], live[f"dds_busy_core_realtime{tail}"])
    lines = ["", "`serve --rt-priority`: the node as a normal process and under SCHED_FIFO (the "
             "robot, the subscriber and the busy process stay normal), the same run. Times p50 "
             "/ p99 / max in ms" + (f"; the residence's goal is p99 <= {goal:g} ms" if goal
                                    else "") + ".", "",
             "| scheduling, order | residence over DDS | node-added latency | residence, one "
             "core busy | node-added latency, one core busy | messages the node lost (steady; "
             "busy) |", "|---|---|---|---|---|---|"]
    for name, (quiet, busy) in rows.items():
        lines.append(f"| {name} | {cell(quiet['node_residence'], goal)} "
                     f"| {cell(quiet['node_added_latency'])} "
                     f"| {cell(busy['node_residence'], goal)} "
                     f"| {cell(busy['node_added_latency'])} "
                     f"| {quiet['node_lost']:,}; {busy['node_lost']:,} |")
    return lines


def network_order(live: dict) -> list[str]:
    """The two orders of ``serve --network``, from one run of ``benchmarks/live.py``: what the
    node's residence and added latency are with the network's step before or after the answer
    of the sample it is due on, and what answering first costs the estimate."""
    def p99s(t):
        return f"{t['median_ms']:.3f} / {t['p99_ms']:.3f} / {t['max_ms']:.2f}"

    orders = {"before-answer (default)": (live["node"], live["dds"], live["dds_busy_core"]),
              "after-answer": (live["node_network_after_answer"], live["dds_network_after_answer"],
                               live["dds_busy_core_network_after_answer"])}
    acc = live["network_after_answer_accuracy"]
    lines = ["", "`serve --network`: the same run with the network's step before the answer of "
             "the sample it is due on and after it (`after-answer` answers that sample with the "
             "step before's residual, one input period older). Times p50 / p99 / max in ms.", "",
             "| order | in-process, every message | in-process, messages the network is due on "
             "| residence over DDS | node-added latency | residence, one core busy "
             "| messages the node lost (steady; busy) |", "|---|---|---|---|---|---|---|"]
    for name, (node, dds, busy) in orders.items():
        lines.append(f"| {name} | {p99s(node['all'])} | {p99s(node['network_steps'])} "
                     f"| {p99s(dds['node_residence'])} | {p99s(dds['node_added_latency'])} "
                     f"| {p99s(busy['node_residence'])} | {dds['node_lost']:,}; "
                     f"{busy['node_lost']:,} |")
    after = live["node_network_after_answer"].get("after_the_answer")
    if after:
        lines += ["", f"The deferred step, run once the answer is written: {p99s(after)} ms."]
    nrmse = acc["nrmse_percent"]
    lines += ["", f"What it costs the estimate ({acc['checkpoint']}, the session above, NRMSE % "
              "of the ATI's range):", "",
              "| order | " + " | ".join(a.rsplit("_", 1)[-1].capitalize() for a in acc["axes"])
              + " |",
              "|---|" + "---|" * len(acc["axes"]),
              "| before-answer | " + " | ".join(f"{v:.2f}" for v in nrmse["before_answer"]) + " |",
              "| after-answer | " + " | ".join(f"{v:.2f}" for v in nrmse["after_answer"]) + " |",
              "| the two estimates apart, RMS N | "
              + " | ".join(f"{v:.3f}" for v in acc["difference_rms_N"]) + " |"]
    return lines


def node_ab(result: dict) -> str:
    """docs/results.md section 8: the node's time per HEX10 message against an earlier revision,
    as ratios measured in one run (``benchmarks/node_ab.py``)."""
    names = {"all": "all messages", "network_steps": "network steps (one message in ten)",
             "physics_and_filter_only": "physics and filter only"}
    lines = ["", f"The node's own time per HEX10 message, this code (`{result['this'][:10]}`) "
             f"against `{result['before'][:10]}` in one run ({result['pairs']} pairs of fresh "
             f"processes alternating, {result['measurements_per_process']} measurements each; "
             "ms, each side's median over its runs; the ratio is the median of the pairs' "
             "ratios, the figure that carries over to another machine):", "",
             "| messages | median: before -> this (ratio) | p99: before -> this (ratio) |",
             "|---|---|---|"]
    for split, stats in result["splits"].items():
        cells = [f"{stats[k]['before']:.3f} -> {stats[k]['this']:.3f} ({stats[k]['ratio']:.2f}x)"
                 for k in ("median_ms", "p99_ms")]
        lines.append(f"| {names.get(split, split)} | {cells[0]} | {cells[1]} |")
    busy = result.get("busy_core")
    if busy:
        lines += ["", f"Over DDS with one core busy ({busy['seconds']:g} s at 1 kHz, robot, node "
                  f"and subscriber in three processes beside the busy one, {busy['checkpoint']}"
                  "), the two revisions alternating; ms, median / p99:", "",
                  "| revision | end to end | the node's residence | transport alone (same run) "
                  "| messages the node lost |", "|---|---|---|---|---|"]
        for side in ("before", "this"):
            for r in busy[side]:
                cells = [" / ".join(f"{x:.3g}" if x < 1000 else f"{x:,.0f}"
                                    for x in (r[f]["median_ms"], r[f]["p99_ms"]))
                         for f in ("latency", "node_residence", "transport_latency")]
                lines.append(f"| {result[side][:10]} | " + " | ".join(cells)
                             + f" | {r['node_lost']} of {r['sent']:,} |")
    return "\n".join(lines + [""])


WAITING = {"sleeping": "asleep between messages, normal",
           "sleeping_realtime": "asleep between messages, SCHED_FIFO",
           "busy_poll": "`--busy-poll`, normal"}


def busy_poll_ab(result: dict) -> str:
    """docs/results.md section 8: ``serve --busy-poll`` against the sleeping node, alternating
    in one run (``benchmarks/busy_poll_ab.py``): each way's figures and the ratios per round."""
    def median(runs, figure, stat):
        return statistics.median(r[figure][stat] for r in runs)

    lines = ["", f"How the node waits, alternating in one run (`{result['command']}`: "
             f"{result['rounds']} rounds of {result['seconds']:g} s at 1 kHz per way, the order "
             f"rotated each round, the network after the answer, {result['checkpoint']}, "
             f"{result['machine']['cpus']} CPUs). ms, each way's median over its rounds:", "",
             "| the node | residence p50 / p99 | node-added latency p50 / p99 | transport "
             "alone p99 | messages the node lost | node CPU (cores) |", "|---|---|---|---|---|---|"]
    for way, runs in result["runs"].items():
        cells = [" / ".join(f"{median(runs, f, s):.3f}" for s in ("median_ms", "p99_ms"))
                 for f in ("node_residence", "node_added_latency")]
        lost = sum(r["node_lost"] for r in runs)
        sent = sum(r["hex10_sent"] for r in runs)
        cpu = statistics.median(r["node_cpu_fraction"] for r in runs)
        lines.append(f"| {WAITING.get(way, way)} | {cells[0]} | {cells[1]} | "
                     f"{median(runs, 'transport_latency', 'p99_ms'):.3f} | {lost:,} of "
                     f"{sent:,} | {cpu:.2f} |")
    if result.get("realtime_refused"):
        lines += ["", f"SCHED_FIFO was not measured: {result['realtime_refused']}"]
    lines += ["", "Ratios, the round's figure with `--busy-poll` over the other way's in the same "
              "round (below 1: shorter with polling); the median over the rounds, each round's "
              "in brackets:", "", "| ratio | residence p50 | residence p99 | node-added p50 | "
              "node-added p99 |", "|---|---|---|---|---|"]
    def ratio(x):   # a round whose other figure was 0 has none (busy_poll_ab.ratios)
        return "n/a" if x is None else f"{x:.2f}"

    for name, by in result["ratios"].items():
        other = WAITING.get(name.split(" / ")[1], name)
        cells = [f"{ratio(r['median'])} [" + ", ".join(map(ratio, r["per_round"])) + "]"
                 for r in (by[f"{f} {s}"] for f in ("node_residence", "node_added_latency")
                           for s in ("median_ms", "p99_ms"))]
        lines.append(f"| polling over {other} | " + " | ".join(cells) + " |")
    return "\n".join(lines + [""])


PRIOR_VARIANTS = {"weighted": "prior weighted on validation, subtracted from the inputs",
                  "as_fitted": "prior as fitted (every weight 1), subtracted from the inputs",
                  "raw_and_prior": "prior weighted, beside the raw HEX10 among the inputs",
                  "no_prior": "no prior (`no_prior`)"}


def stale_no_prior_arm(result: dict) -> str:
    """A warning where the ablation's ``no_prior`` arm dropped the insertion-effort base together
    with the prior (the runs before issue 43: their ``no_prior`` tasks have no ``insertion_fz``
    base), so that its "prior helps" ratios do not read as the prior's alone; "" otherwise."""
    arms = [t for t in result["tasks"] if t["variant"] == "no_prior"]
    if not arms or all("insertion_fz" in t["base_columns"] for t in arms):
        return ""
    return ("**Needs a rerun (issue 43): these figures are not the prior's alone.** Their "
            "`no_prior` arm dropped the insertion-effort base (`insertion_fz`) together with "
            "the prior (base " + " / ".join(f"`{c or 'none'}`" for c in arms[0]["base_columns"])
            + "), so each \"against no prior\" ratio, Fz above all, measures the insertion "
            "base as much as the prior. `studies/prior_ablation.py` now keeps the base in both "
            "arms; the full run (24 trainings) has not been repeated since.")


def _ablation_paired(tasks: list[dict], bench: str) -> list[str]:
    """Rows: each variant's test error over no prior's, paired by seed (95 % t interval on the
    log ratios, :func:`psmforce.experiments.paired.paired_ratio`); none where a seed lacks
    either arm."""
    from psmforce.experiments.paired import paired_by_axis
    by = {(t["variant"], t["seed"]): t["test"] for t in tasks if t["bench"] == bench}
    seeds = sorted({seed for _, seed in by})
    rows = []
    for variant in PRIOR_VARIANTS:
        if variant == "no_prior" or not all((v, s) in by for v in (variant, "no_prior")
                                            for s in seeds):
            continue
        cells = []
        for m in ("causal", "paper"):
            paired = paired_by_axis([by[variant, s][m] for s in seeds],
                                    [by["no_prior", s][m] for s in seeds], ("Fx", "Fy", "Fz"))
            cells += [paired[a].text() for a in ("Fx", "Fy", "Fz")]
        rows.append(f"| {variant} over no prior, paired by seed | " + " | ".join(cells) + " | |")
    return rows


def prior_ablation_tables(result: dict) -> str:
    """docs/results.md: the hybrid with and without its prior, per bench and axis."""
    seeds = " ".join(str(s) for s in result["seeds"])
    chosen = result["chosen_on_validation"]
    stale = stale_no_prior_arm(result)
    lines = [""] + ([stale, ""] if stale else []) + [f"`python studies/prior_ablation.py --json "
             f"results/benchmarks/prior_ablation.json` (scale {result['scale']:g}, bench seeds "
             f"{seeds}; crossing bench: cables at {result['crossing_rad']:g} rad; every run "
             f"{'stopped by its patience' if result['all_converged'] else 'NOT all converged'})."
             " NRMSE % on the test trials, mean ± std over seeds (the sample std, ddof 1); "
             "causal = the raw per-sample "
             "estimate a haptic loop gets, paper = the paper's offline post-processing; the "
             "last columns are the validation trials, where the design is chosen. "
             "\"Paired by seed\": the variant's error over no prior's on the same seeds, the "
             "geometric mean with a 95 % t interval on the log ratios; \"ahead\" only where the "
             "interval lies below 1.", ""]
    for bench, rows in result["summary"].items():
        lines += [f"**{bench} bench**", "",
                  "| hybrid | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz "
                  "| validation causal Fx / Fy / Fz |",
                  "|---|---|---|---|---|---|---|---|"]
        for variant in PRIOR_VARIANTS:
            if variant not in rows:
                continue
            r = rows[variant]
            cells = [spread_cell(r[m][a]) for m in ("causal", "paper") for a in ("Fx", "Fy", "Fz")]
            val = " / ".join(f"{r['validation_causal'][a]['mean']:.2f}" for a in ("Fx", "Fy", "Fz"))
            shipped = " (shipped)" if variant == result["shipped"] else ""
            lines.append(f"| {PRIOR_VARIANTS[variant]}{shipped} | " + " | ".join(cells)
                         + f" | {val} |")
        for variant, verdict in result["verdicts"].get(bench, {}).items():
            cells = [f"{verdict[m][a]['verdict']} ({verdict[m][a]['ratio']:.2f}x)"
                     for m in ("causal", "paper") for a in ("Fx", "Fy", "Fz")]
            lines.append(f"| {variant} against no prior, spread rule | " + " | ".join(cells)
                         + " | |")
        lines += _ablation_paired(result["tasks"], bench)
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
            cell = " / ".join(spread_cell(axes[a]) for a in ("Fx", "Fy", "Fz"))
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
        lines.append(f"| {label} | " + " | ".join(spread_cell(channels[p][key]) for p in ports)
                     + " |")
    for model in ("Hybrid (ours)", "Transformer (paper)"):
        lines.append(f"| {model}, for comparison | "
                     + " | ".join(spread_cell(models[p][model]["Fz"]) for p in ports) + " |")
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
            cells = [spread_cell(_pair(rows[tool][m][a]))
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


def prior_ablation_summary(result: dict) -> str:
    """Section 2's summary: what the physics prior adds to the hybrid, per axis, as the ablation
    measures it, in words (the tables below it hold every figure)."""
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
    stale = stale_no_prior_arm(result)
    return ("\n" + (stale + "\n\n" if stale else "")
            + "What the physics prior adds to the hybrid on the simulated bench (simulator "
            f"{SIMULATOR_NOT_RECORDED['prior_ablation']}, scale "
            f"{result['scale']:g}, bench seeds {seeds}, every run trained to early "
            "stopping; causal NRMSE with the prior as shipped against the same network "
            "without it, verdicts by the spread rule): " + "; ".join(parts)
            + ". The crossing bench adds an internal lateral force the prior does not model. "
            "Each component of the prior is weighed on validation trials (0: it explains "
            "nothing held out); "
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
