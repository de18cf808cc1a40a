"""The blocks of ``docs/ati_free.md``: the excitation and the known weights, rendered from
``results/benchmarks/excitation.json`` (``studies/excitation.py``); the re-mounting section
("3. Re-mounting") from ``results/benchmarks/remount.json`` (``studies/remount.py``) and
``results/benchmarks/hex10_compression.json`` (``studies/hex10_compression.py``). Each function
takes the parsed JSON and returns the block's markdown."""

from __future__ import annotations

from reports.cells import (as_held, miss_rule, relative_error, rescored_note, sag_sentence,
                           with_pins)

FORCE_AXES = ("fx", "fy", "fz")


def _f(v, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}g}"


def _ratios(d: dict, axes=FORCE_AXES) -> str:
    return " / ".join(f"{d[a]:.2f}" for a in axes)


MOMENT_AXES = ("tx", "ty", "tz")


MOTIONS = {"excitation": "the excitation", "random": "a random motion, same duration and limits",
           "paper_free": "the paper's free-space motion"}


def excitation_tables(result: dict) -> str:
    """The excitation against a random and the paper's free-space motion (condition number,
    log-det, what stays unidentifiable), then the known weights added greedily to the paper's
    motion."""
    lines = ["", f"{result['duration_s'] / 60:.1f} min, seed {result['seed']}; "
             + ", ".join(f"{v} {k}" for k, v in result["segment_counts"].items())
             + " segments. Criterion: " + result["criterion"] + ".", "",
             "| motion | condition number | log-det | not identifiable |", "|---|---|---|---|"]
    for key, label in MOTIONS.items():
        missing = result["not_identifiable"][key]
        lines.append(f"| {label} | {result['condition_number'][key]:,.0f} | "
                     f"{result['log_det'][key]:.1f} | "
                     + (", ".join(f"`{p}`" for p in missing) if missing else "none") + " |")
    weights = result.get("known_weights")
    if weights:
        lines += ["", f"Known weights ({', '.join(f'{m:g}' for m in weights['masses_kg'])} kg, "
                  f"held {weights['hold_s']:g} s each), added one at a time to the paper's "
                  "free-space motion, the most informative first:", "",
                  "| added | log-det gain | condition number | still not identifiable |",
                  "|---|---|---|---|"]
        for step in weights["paper_free"]["greedy"]:
            lines.append(f"| {step['added']} | {step['log_det_gain']:.2f} | "
                         f"{step['condition_number']:,.0f} | "
                         + (", ".join(f"`{p}`" for p in step["not_identifiable"]) or "none")
                         + " |")
        needed = weights["paper_free"]["needed"]
        lines += ["", "Weights that make the paper's motion identifiable: "
                  + ("none does" if needed is None else str(needed))
                  + "; added to the excitation: "
                  + (str(weights["excitation"].get("needed", 0)) if weights["excitation"].get(
                      "not_identifiable_without") else "none needed") + "."]
        if "load_path" in weights:
            lines += ["", load_path_sentence(weights)]
    return "\n".join(lines) + "\n"


def _names(names) -> str:
    return ", ".join(f"`{n}`" for n in names) if names else "none"


def load_path_sentence(weights: dict) -> str:
    """What the known weights of an excitation report (``known_weights``) give read through
    the load path, as ``calibrate --known-loads`` identifies the instrument: what the excitation
    alone leaves, and how many holds make every parameter identifiable or what stays out of
    reach with every hold given."""
    gains = weights["load_path"]["excitation"]
    needed = gains["needed"]
    left = gains["not_identifiable_with_all"]
    return ("Read through the load path (the tip force known: 0 N in free space, the weight "
            "on a hold), as `calibrate --known-loads` identifies the instrument, every "
            "parameter of the law free: the excitation alone leaves "
            f"{_names(gains['not_identifiable_without'])} unidentifiable; "
            + ("no hold is needed" if needed == 0 else
               f"the first {needed} holds of the greedy order make every parameter identifiable"
               if needed else
               f"with all {len(gains['greedy'])} holds given, still not identifiable: "
               f"{_names(left)}") + ".")


def excitation_paired_summary(result: dict) -> str:
    """The known weights of the lab's identification procedure (three masses in the sixteen
    paired orientations) on the excitation: read from the efforts and through the load path."""
    weights = result["known_weights"]
    needed = weights["excitation"]["needed"]
    return "\n".join([
        "", f"{result['duration_s'] / 60:.1f} min excitation, seed {result['seed']}; "
        f"{', '.join(f'{m:g}' for m in weights['masses_kg'])} kg in "
        f"{len(weights['orientations'])} orientations, held {weights['hold_s']:g} s each"
        + (f" (left out, past the HEX10's safety limit: {', '.join(weights['left_out_unsafe'])})"
           if weights["left_out_unsafe"] else "") + ".", "",
        "Read from the efforts (the prior `calibrate` refits for the estimator), on top of the "
        "excitation: " + ("no hold is needed" if needed == 0 else f"{needed} holds" if needed
                          else "the holds never make every parameter identifiable") + ".", "",
        load_path_sentence(weights), ""])


def remount_tables(result: dict) -> str:
    """The errors before and after a re-mount per prior and recalibration (ratios over the
    re-mounts), then each re-mount drawn and its ratios."""
    modes = list(result["summary"])
    variants = [k for k in result["summary"][modes[0]] if isinstance(result["summary"][modes[0]][k], dict)
                and "ratio_max" in result["summary"][modes[0]][k]]
    n = len(result["runs"])
    lines = ["", f"Simulator {result['simulator_version']}, {result['bench']}; scale "
             f"{result['scale']:g}, seed {result['seed']}; {n} re-mounts; test set "
             + ", ".join(f"{v} {k}" for k, v in result["test_trials"].items())
             + f" trials ({result['test_rows']} rows). Rule: {result['rule']}.", "",
             "| prior (fit-prior mode) | before: RMSE fx / fy / fz (N) | old prior: max ratio "
             "| old prior + 0.5 s tare: max ratio | recalibration | ratio median | ratio max "
             "| misses | moments: ratio max tx / ty / tz |",
             "|---|---|---|---|---|---|---|---|---|"]
    for mode in modes:
        s = result["summary"][mode]
        b = result["before"][mode]["all"]
        for k, v in enumerate(variants):
            row = s[v]
            misses = ", ".join(f"{m['axis']} {m['ratio']:.2f} (re-mount {m['remount_seed']})"
                               for m in row["misses"]) or "none"
            lines.append(
                (f"| {mode} | " + " / ".join(_f(b[a]["rmse"]) for a in FORCE_AXES)
                 + f" | {_ratios(s['old_ratio_max'])} | {_ratios(s['old_tared_ratio_max'])} |"
                 if k == 0 else "| | | | |")
                + f" {v} | {_ratios(row['ratio_median'])} | {_ratios(row['ratio_max'])} "
                  f"| {'**met**' if row['rule_met'] else 'missed: ' + misses} "
                  f"| {_ratios(row['ratio_max'], MOMENT_AXES)} |")
    lines += ["", "Ratios are fx / fy / fz (moments: tx / ty / tz, not under the rule), "
              "recalibrated (or old) RMSE over the RMSE before the re-mount, on the same test "
              "trials with the same noise streams.", "",
              "| re-mount | pretension change (N) | offset change fx, fy, fz (N) | tilt (mrad) "
              "| about the shaft (mrad) | "
              + " | ".join(f"{m}, {v}: ratio fx / fy / fz" for m in modes for v in variants[-1:])
              + " |",
              "|---|---|---|---|---|" + "---|" * len(modes)]
    for r in result["runs"]:
        rm = r["remount"]
        lines.append(
            f"| {r['remount_seed']} | {rm['pretension_change_n']:+.2f} | "
            + ", ".join(f"{x:+.3f}" for x in rm["hex10_offset_change_n"])
            + f" | {1e3 * rm['tilt_rad']:.2f} | {1e3 * rm['rotation_change_rad'][2]:+.1f} | "
            + " | ".join(_ratios(r["modes"][m]["recalibrations"][variants[-1]]["ratio"])
                         for m in modes) + " |")
    if all("truth" in r for r in result["runs"]):  # a study run before the truth was recorded
        lines += _remount_truth_table(result, modes)
    return "\n".join(lines) + "\n"


TRUTH_SHOWN = ("pretension_total", "bias_fx", "bias_fy", "bias_fz")
"""The per-mount values the truth table shows: those every recalibration re-estimates
(``prior_remount.FORCE_PER_MOUNT``); the JSON holds the moment offsets and the angles too."""


def _against(row: dict, key: str) -> str:
    """A per-mount value with its error against the truth: relative (signed, %) for the
    pretension, in N for the offsets (``compare_by``)."""
    value = row[key]
    err = row["error" if key == "recalibrated" else "error_before"]
    if row["compare_by"] == "error":
        return f"{value:+.3f} ({err:+.3f} N)"
    return f"{value:.2f} ({100 * err / row['truth']:+.1f} %)"


def _remount_truth_table(result: dict, modes: list[str]) -> list[str]:
    """Per re-mount, the per-mount values of each prior before its recalibration and after the
    recalibrations on the excitation, against the re-mounted bench's truth; then how many
    pretensions came back within the tolerance, and what the truth leaves out."""
    exc = [v for v, d in result["variants"].items() if d["motion"] == "excitation"]
    tol = result["recovery_tolerance"]
    lines = ["", "Per-mount values against the re-mounted bench's own (truth: "
             "`default_bench_truth` of the re-mounted `InstrumentParams`, the pretension "
             "`pretension_total_n`, the force offsets `hex10_residual_bias_n`; JSON `truth`, "
             "`truth_mapping`); before: the prior as first fitted, before the re-mount; after "
             "each recalibration on the excitation; values in N. In brackets the error against "
             "the truth: relative for the pretension, in N for the force offsets (their truth "
             "is near 0).", "",
             "| re-mount | parameter | truth | " + " | ".join(
                 f"{m}: before | " + " | ".join(f"{m}: {v}" for v in exc) for m in modes) + " |",
             "|---|---|---|" + "---|" * (len(modes) * (1 + len(exc)))]
    for r in result["runs"]:
        for name in TRUTH_SHOWN:
            first = r["modes"][modes[0]]["recalibrations"][exc[0]]["against_truth"][name]
            truth = (f"{first['truth']:.2f}" if first["compare_by"] != "error"
                     else f"{first['truth']:+.3f}")
            cells = []
            for m in modes:
                rows = [r["modes"][m]["recalibrations"][v]["against_truth"][name] for v in exc]
                cells += [_against(rows[0], "before")] + [_against(x, "recalibrated")
                                                          for x in rows]
            lines.append(f"| {r['remount_seed']} | `{name}` | {truth} | " + " | ".join(cells)
                         + " |")
    n = len(result["runs"])
    counts = []
    for m in modes:
        for v in result["variants"]:  # every recalibration, the paper's motion's too
            p = result["summary"][m][v]["pretension_against_truth"]
            counts.append(f"{m}, {v}: {len(p['within'])} of {n} (largest error "
                          f"{100 * p['relative_error_max']:.1f} %)")
    talk = {a: [r["crosstalk_of_rest_level"][f"bias_{a}"] for r in result["runs"]]
            for a in ("fx", "fy")}
    lines += ["", f"Pretension recalibrated within {100 * tol:g} % of the truth, every "
              "recalibration (the paper's motion's too): " + "; ".join(counts) + ".", "",
              "Not in the force offsets' truth: what the HEX10's cross-talk makes of the rest "
              "level, a constant the law can only carry in its offsets ("
              + ", ".join(f"{a} {min(x):+.3f} .. {max(x):+.3f} N" for a, x in talk.items())
              + " over these re-mounts; JSON `crosstalk_of_rest_level`)."]
    return lines


def hex10_compression_table(result: dict) -> str:
    """The simulated HEX10 pretension, compression, overload margin and tip forces under the
    paper's test loads, beside the paper's figures."""
    p, pre, paper = result["loaded"], result["pretension"], result["paper"]
    v = result["verdict"]
    tips = ", ".join(f"{a} {p['tip_force_min_n'][a]:.2f}..{p['tip_force_max_n'][a]:.2f}"
                     for a in "xyz")
    paper_tips = ", ".join(f"{a} {lo}..{hi}" for a, (lo, hi) in paper["tip_force_ranges_n"].items())
    lines = ["", f"Simulator {result['simulator_version']}, {result['bench']}; scale "
             f"{result['scale']:g}, seed {result['seed']}; test Traction and Palpation trials "
             f"({p['trials']} trials, {p['rows']} rows).", "",
             "| figure | simulated | paper |", "|---|---|---|",
             f"| pretension (parameter; section force at rest; reading at rest, first 0.5 s of "
             f"the Free test trials) | {pre['parameter_n']:g} N; {pre['section_at_rest_n']:.2f} N; "
             f"{pre['reading_at_rest_n']:.2f} N ({pre['reading_at_rest_range_n'][0]:.2f} .. "
             f"{pre['reading_at_rest_range_n'][1]:.2f}) | {paper['pretension_n']:g} N |",
             f"| peak compression, reading (section force before the sensor model) | "
             f"{p['reading_fz_min_n']:.1f} N ({p['section_fz_min_n']:.1f} N) | within "
             f"{paper['compression_margin_n']:g} N of the -{paper['overload_n']:g} N overload |",
             f"| margin to the -{paper['overload_n']:g} N overload | "
             f"{p['margin_to_overload_n']:.1f} N: "
             f"{'within' if v['compression_reaches_paper'] else 'not within'} "
             f"{paper['compression_margin_n']:g} N"
             + (f"; the section force passes the overload by {v['section_beyond_overload_n']:.1f} N"
                if v["overloaded"] else "") + f" | <= {paper['compression_margin_n']:g} N |",
             f"| reading percentiles 0.1 / 1 / 5 % | "
             + " / ".join(f"{p['reading_fz_percentiles_n'][k]:.1f}" for k in ("0.1", "1", "5"))
             + " N | |",
             f"| overloaded samples (of them with the wrist moving) | {p['overloaded_rows']} "
             f"({100 * p['overloaded_fraction']:.4f} %; {p['overloaded_rows_wrist_moving']}); "
             f"{p['rows_below_minus_85_n']} samples at or below -85 N | kept below the limit |",
             f"| tip force (ATI, HEX10 frame) per axis | {tips} N | {paper_tips} N |",
             f"| largest tip force norm | {p['tip_force_norm_max_n']:.2f} N | about "
             f"{paper['tip_force_max_n']:g} N (largest axis) |"]
    for c, s in result["conditions"].items():
        g = s["internal_compression_per_tip_newton_p50_p95"]
        lines.append(f"| {c}: peak reading; margin; largest tip force; internal compression per "
                     f"N of tip force (median, p95) | {s['reading_fz_min_n']:.1f} N; "
                     f"{s['margin_to_overload_n']:.1f} N; {s['tip_force_norm_max_n']:.2f} N; "
                     f"{_f(g[0])}, {_f(g[1])} N/N | |")
    return "\n".join(lines) + "\n"


ATI_FREE_ROWS = {
    "free": "(a) ATI-free: free space", "free+self": "(b) ATI-free: + self-loading",
    "free+self+weights": "(c) ATI-free: + known weights",
    "free+self+paired": "(c') ATI-free: + the identifying weights",
    "identified:free+self+paired": "(c'') as (c'), the identified instrument in the prior",
    "per_mount:free+self": "(b') as (b), the prior refitted per mount only",
    "network_alone:free": "network alone, (a)'s data", "network_alone:free+self": "network alone, (b)'s data",
    "network_alone:free+self+weights": "network alone, (c)'s data",
    "network_alone:free+self+paired": "network alone, (c')'s data",
    "physics_alone:free": "physics alone, (a)'s prior", "physics_alone:free+self": "physics alone, (b)'s prior",
    "physics_alone:free+self+weights": "physics alone, (c)'s prior",
    "physics_alone:free+self+paired": "physics alone, (c')'s prior",
    "physics_alone:identified:free+self+paired": "physics alone, (c'')'s prior",
    "network_off_carried:identified:free+self+paired": "(c'') with the network kept out of "
                                                       "the lateral axes the physics carries",
    "network_off:identified:free+self+paired": "(c'') as calibrate --network-off carried "
                                               "writes it",
    "no_finetune:identified:free+self+paired": "(c'')'s prior under the source network, not "
                                               "finetuned",
    "network_off_carried:no_finetune:identified:free+self+paired": "(c'')'s prior under the "
        "source network, not finetuned, the network off the carried axes",
    "prior_only:identified:free+self+paired": "(c'')'s prior under the source network, not "
                                              "finetuned, the prior alone on Fx and Fy",
    "network_prior:identified:free+self+paired": "the source hybrid as trained, (c'')'s prior "
                                                 "alone on Fx and Fy (--network-prior trained)",
    "network_prior:identified:free+self": "(b'') (b)'s recordings, the instrument identified "
                                          "with the clenches' lateral forces, its prior alone "
                                          "on Fx and Fy (--network-prior trained)",
    "free_offsets:network_prior:identified:free+self": "(b''') as (b''), the lateral "
                                                       "offsets never held "
                                                       "(--free-lateral-offsets)",
    "least_uncertain:free_offsets:network_prior:identified:free+self":
        "(b'''') as (b'''), the design value held only where better known "
        "(--hold-rule least-uncertain)",
    "ati_same_minutes": "(d) ATI: (c)'s minutes",
    "ati_same_minutes_self": "(d_b) ATI: (b)'s minutes",
    "ati_same_minutes_paired": "(d') ATI: (c')'s minutes", "ati_full": "(e) ATI: full data",
    "source": "source hybrid (other tool), as is"}
ERROR_AXES = ("Fx", "Fy", "Fz")
NO_FINETUNE_OFF = "network_off_carried:no_finetune:identified:free+self+paired"
"""The row :func:`network_off_table` composes: not finetuned, and the network kept off the
carried axes (:func:`studies.ati_free.network_off_carried`)."""


def _mean_sd(cell) -> str:
    mean, sd = cell
    return f"{mean:.2f}" + ("" if sd is None else f" ± {sd:.2f}")


def _paired(p: dict) -> str:
    if p["n"] < 2:
        return f"{p['mean_ratio']:.2f}x"
    return f"{p['mean_ratio']:.2f}x [{p['low']:.2f}, {p['high']:.2f}]"


def _fresh_seed_goals(result: dict, goals: dict | None = None,
                      axes: tuple[str, ...] = ERROR_AXES) -> list[str]:
    """The goals on the study's fresh seeds alone (``studies.ati_free.FRESH_SEEDS``, declared
    before any run on them): per goal arm and reference, each fresh seed's largest error ratio
    over both metrics and ``axes``, against the goal (``goals``: arm -> goal, default the
    study's ``GOALS``)."""
    from studies.ati_free import FRESH_SEEDS, GOALS, same_minutes
    declared = result.get("fresh_seeds", FRESH_SEEDS)  # a run written before the field: these
    fresh = [str(s) for s in declared if str(s) in result["records"]]
    if not fresh:
        return []
    lines = ["", f"On the fresh seeds alone ({', '.join(fresh)}, declared in the study before "
             "any run on them): each seed's largest error ratio over both metrics and "
             + ("the three axes" if axes == ERROR_AXES else "the axes " + ", ".join(axes))
             + ".", "", "| row | against | " + " | ".join(f"seed {s}" for s in fresh)
             + " | goal |", "|---|---|" + "---|" * len(fresh) + "---|"]
    for arm, goal in (GOALS if goals is None else goals).items():
        for ref in (same_minutes(arm), "ati_full"):
            name = ATI_FREE_ROWS[ref].split(" ", 1)[0]
            cells = []
            for seed in fresh:
                rows = result["records"][seed]
                if arm not in rows or ref not in rows:
                    cells = []
                    break
                worst = max((rows[arm]["nrmse_pct"][m][a] / rows[ref]["nrmse_pct"][m][a], m, a)
                            for m in ("causal", "paper") for a in axes)
                cells.append(f"{worst[0]:.2f}x ({worst[1]} {worst[2]})"
                             + ("" if worst[0] <= goal else " **miss**"))
            if cells:
                lines.append(f"| {ATI_FREE_ROWS[arm]} | {name} | " + " | ".join(cells)
                             + f" | <= {goal:g}x |")
    return lines


def ati_free_tables(result: dict) -> str:
    """The ATI-free calibrations, their ablations and the ATI references on the contact test
    trials (NRMSE per axis, both metrics), their paired ratios against the two ATI references
    with the goals' misses, the prior's parameters against the bench's, and every run's
    convergence."""
    s = result["settings"]
    seeds = list(result["records"])
    lines = ["", f"**{result['label']}.** Scale {s['scale']:g}, bench seeds "
             + ", ".join(seeds) + f"; start: {result['start']}; test: {result['test']}; "
             f"metrics: {result['metrics']}.", "",
             "| row | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
             "|---|---|---|---|---|---|---|"]
    for key, label in ATI_FREE_ROWS.items():
        row = result["summary"].get(key)
        if row:
            lines.append(f"| {label} | " + " | ".join(_mean_sd(row[m][a]) for m in ("causal", "paper")
                                                      for a in ERROR_AXES) + " |")
    for ref, name in (("ati_same_minutes", "(d), the ATI on (c)'s minutes"),
                      ("ati_same_minutes_paired", "(d'), the ATI on (c')'s minutes"),
                      ("ati_full", "(e), the ATI at full data")):
        paired = result["paired"].get(ref)
        if not paired:   # a study run before (d') existed
            continue
        lines += ["", f"Error ratio against {name}: geometric mean over seeds [95 % t "
                  "interval on log ratios].", "",
                  "| row | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
                  "|---|---|---|---|---|---|---|"]
        for key, label in ATI_FREE_ROWS.items():
            if key in paired:
                lines.append(f"| {label} | " + " | ".join(
                    _paired(paired[key][m][a]) for m in ("causal", "paper")
                    for a in ERROR_AXES) + " |")
        for arm, check in result["goal_check"][ref].items():
            misses = ", ".join(f"{x['metric']} {x['axis']} {x['ratio']:.2f}x"
                               for x in check["misses"])
            lines.append(f"\nGoal, {ATI_FREE_ROWS[arm]} <= {check['goal']:g}x every axis: "
                         + ("**met**" if check["met"] else f"**missed**: {misses}") + ".")
    lines += _fresh_seed_goals(result)
    lines += ["", "The prior's parameters against the bench's (the drawn tool; relative error "
              "per seed; held: kept at the source model's value, in (a)-(c) because the data "
              "could not pin it down, in (b') by design"
              + ("; load path: held at the instrument's identified value"
                 if any("identified:free+self+paired" in result["runs"][k] for k in seeds)
                 else "") + "):", "",
              "| arm | parameter | truth (seed " + seeds[0] + ") | status per seed "
              "| relative error per seed | within 10 % |", "|---|---|---|---|---|---|"]
    for arm in ("free", "free+self", "free+self+weights", "free+self+paired",
                "identified:free+self+paired", "per_mount:free+self"):
        if any(arm not in result["runs"][k] for k in seeds):  # a study run before the arm
            continue
        per_seed = [result["runs"][k][arm]["prior_against_truth"] for k in seeds]
        for name in per_seed[0]:
            cells = [p[name] for p in per_seed]
            within = [c["within"] for c in cells if c["within"] is not None]
            lines.append(
                f"| {ATI_FREE_ROWS[arm]} | `{name}` | {_f(cells[0]['truth'])} | "
                + ", ".join(c["status"] for c in cells) + " | "
                + ", ".join("n/a" if c["relative_error"] is None else f"{c['relative_error']:.2f}"
                            for c in cells) + " | "
                + (f"{sum(within)} of {len(within)}" if within else "n/a") + " |")
    late = [k for k, v in result["convergence"].items() if v is not True]
    lines += ["", "Convergence: " + ("every training and calibration stopped early."
                                     if not late else "not converged: " + ", ".join(late) + ".")]
    return "\n".join(lines) + "\n"


def _effect_rows(rows) -> tuple[list[str], dict[str, list[str]]]:
    """Table rows of paired ratios, one per ``(label, a, b)`` (``a``, ``b``: per seed, the
    row's ``{metric: {axis: NRMSE}}``), a over b per metric and axis, and the cells by verdict."""
    from psmforce.experiments.paired import paired_by_axis
    lines, verdicts = [], {}
    for label, a, b in rows:
        cells = []
        for m in ("causal", "paper"):
            ratios = paired_by_axis([x[m] for x in a], [x[m] for x in b], ERROR_AXES)
            cells += [_paired(r.to_dict()) for r in ratios.values()]
            for axis, r in ratios.items():
                verdicts.setdefault(r.verdict, []).append(f"{label}, {m} {axis}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines, verdicts


def identified_effect_table(result: dict) -> str:
    """What carrying the instrument's identification into the estimator's prior changes: (c'')
    over (c') on the same bench seeds, the calibrated hybrid and the physics alone, geometric
    mean ratio [95 % t interval on log ratios] per axis and metric, and the cells whose interval
    lies wholly below or above 1."""
    from studies.ati_free import IDENTIFIED_ARM, PAIRED_ARM
    seeds = [k for k, r in result["records"].items() if IDENTIFIED_ARM in r and PAIRED_ARM in r]
    unit = result.get("settings", {}).get("jackknife_unit", "orientation")
    how = "" if unit == "orientation" else (
        f" ((c'')'s identification with its jackknife over the weights' orientations by "
        f"{unit.replace('_', ' ')}; (c')'s by orientation)")
    lines = ["", f"(c'') over (c'), the same row on the same bench seeds ({', '.join(seeds)})"
             f"{how}: geometric mean [95 % t interval on log ratios]; below 1: carrying the "
             "identification helps.", "",
             "| row | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
             "|---|---|---|---|---|---|---|"]
    table, verdicts = _effect_rows(
        (label, [result["records"][k][prefix + IDENTIFIED_ARM]["nrmse_pct"] for k in seeds],
         [result["records"][k][prefix + PAIRED_ARM]["nrmse_pct"] for k in seeds])
        for prefix, label in (("", "the calibrated hybrid"), ("physics_alone:", "physics alone")))
    lines += table
    lines += ["", "Intervals wholly below 1 (carrying helps): "
              + ("; ".join(verdicts.get("ahead", [])) or "none") + ".", "",
              "Intervals wholly above 1 (carrying hurts): "
              + ("; ".join(verdicts.get("behind", [])) or "none") + "."]
    rows = (PAIRED_ARM, IDENTIFIED_ARM, "physics_alone:" + PAIRED_ARM,
            "physics_alone:" + IDENTIFIED_ARM, "ati_full")
    lines += ["", "Per seed, causal NRMSE % Fx / Fy, and what (c'') carried from the load path "
              "(its prior's `held_at_identified`, when the run recorded it):", "",
              "| seed | carried | " + " | ".join(ATI_FREE_ROWS[r] for r in rows) + " |",
              "|---|---|" + "---|" * len(rows)]
    for k in seeds:
        prior = result.get("runs", {}).get(k, {}).get(IDENTIFIED_ARM, {}).get("prior") or {}
        carried = ", ".join(f"`{n}`" for n in prior.get("held_at_identified", {})) or "nothing"
        cells = [" / ".join(f"{result['records'][k][r]['nrmse_pct']['causal'][a]:.2f}"
                            for a in ("Fx", "Fy")) for r in rows]
        lines.append(f"| {k} | {carried} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def crosstalk_effect_table(held: dict, fitted: dict) -> str:
    """Each row of the ATI-free study with the HEX10's cross-talk fitted in every hybrid's prior
    (``fitted``, ``--prior-crosstalk``) over the same row with it held (``held``), paired on
    the bench seeds both ran: geometric mean ratio [95 % t interval on log ratios] per axis and
    metric, then the cells whose interval lies wholly below or above 1. Refused for studies
    whose settings differ."""
    same = ("scale", "free_minutes", "excitation_minutes", "excitation_seed", "masses", "hold_s",
            "calibration_epochs", "quick")
    differ = [k for k in same if held["settings"].get(k) != fitted["settings"].get(k)]
    if differ or fitted["settings"].get("prior_crosstalk") is not True \
            or held["settings"].get("prior_crosstalk", False) is not False:
        raise ValueError(f"the two ATI-free studies do not pair: settings {differ} differ, or "
                         "the second does not fit the cross-talk where the first holds it")
    seeds = [k for k in fitted["records"] if k in held["records"]]
    lines = ["", f"Error with the cross-talk fitted over the error with it held, the same row "
             f"on the same bench seeds ({', '.join(seeds)}): geometric mean [95 % t interval on "
             "log ratios]; below 1: the term helps.", "",
             "| row | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
             "|---|---|---|---|---|---|---|"]
    table, verdicts = _effect_rows(
        (label, [fitted["records"][k][key]["nrmse_pct"] for k in seeds],
         [held["records"][k][key]["nrmse_pct"] for k in seeds])
        for key, label in ATI_FREE_ROWS.items()
        if all(key in held["records"][k] and key in fitted["records"][k] for k in seeds))
    lines += table
    lines += ["", "Intervals wholly below 1 (the term helps): "
              + ("; ".join(verdicts.get("ahead", [])) or "none") + ".", "",
              "Intervals wholly above 1 (the term hurts): "
              + ("; ".join(verdicts.get("behind", [])) or "none") + "."]
    return "\n".join(lines) + "\n"


_MARKS = {"fixed": "*fixed*", "identified": "identified", "free, not identified": "free, NOT id."}


def instrument_identification_tables(result: dict) -> str:
    """The instrument identified without an ATI through the load path
    (``studies/ati_free_identification.py``): per seed, each parameter's truth and, per case
    (weights and poses), the final value with its relative error and status; the all-free fit of
    the last case beside them; the verdicts, the capstan against its mean over the
    configurations."""
    from psmforce.identification.prior_law import PARAMETERS
    unit = {p[0]: p[1] for p in PARAMETERS}
    cases = list(result["cases"])
    last = cases[-1]
    lines = ["", f"`{result['command']}`{rescored_note(result)} (simulator "
             f"{result['simulator_version']}; scale "
             f"{result['settings']['scale']:g}; "
             + (f"seed {result['design_seed']} is the design seed, the others fresh"
                if result["design_seed"] in result["settings"]["seeds"] else
                "every seed fresh, declared before the run")
             + "). Per case, the final fit of `psmforce calibrate --free-space "
             "--known-loads`'s identification (`calibrate.identify_instrument`): its value, its "
             "error against the drawn tool's truth, and *fixed* (held at the design value: the "
             "report or the jackknife over trial groups lists it"
             + (", or the jackknife over the weights' orientations"
                if any(r.get("orientation_jackknife_groups") for r in result["runs"]) else "")
             + "), identified (free, not "
             f"listed), **MISS** (identified, "
             f"{miss_rule(result['runs'][0], result['runs'])}). The last "
             f"column is the all-free fit of \"{last}\" (its first round).", ""]
    by_seed: dict = {}
    for run in result["runs"]:
        by_seed.setdefault(run["seed"], {})[run["case"]] = run
    for seed, runs in by_seed.items():
        lines += [f"**seed {seed}**" + (" (design)" if seed == result["design_seed"] else "")
                  + ":", "", "| parameter | unit | truth | " + " | ".join(cases)
                  + f" | all-free, {last} |", "|---|---|---|" + "---|" * (len(cases) + 1)]
        for name in runs[cases[0]]["parameters"]:
            truth = runs[cases[0]]["parameters"][name]["truth"]
            cells = []
            for case in cases:
                r = runs[case]["parameters"][name]
                err = relative_error(r)
                rel = "" if err is None else f" ({100 * err:.0f} %)"
                mark = ("identified, **MISS**" if name in runs[case]["misses"]
                        else _MARKS.get(r["status"], r["status"]))
                cells.append(f"{r['fitted']:.4g}{rel}{as_held(r)} {mark}")
            first = runs[last]["parameters"][name]["all_free_fit"]
            rel = ("" if truth in (None, 0) or first is None
                   else f" ({100 * abs(first / truth - 1):.0f} %)")
            lines.append(f"| {name} | {unit[name]} | {'—' if truth is None else f'{truth:.4g}'} | "
                         + " | ".join(cells) + f" | {'—' if first is None else f'{first:.4g}'}"
                         f"{rel} |")
        lines.append("")
        for case in cases:
            run = runs[case]
            lines.append(f"- {case} ({', '.join(f'{k} {v:.2f} min' for k, v in run['minutes'].items())}"
                         f"; {run['n_samples']} samples, {run['fit_time_s']:.0f} s): "
                         f"{run['verdict']}. The bench's wrist friction (the idlers' capstan"
                         f"{with_pins(run)}) averaged over these recordings' configurations: "
                         f"{run['capstan_mu_over_training']:.3g}."
                         + ("" if "all_free_residual" not in run else
                            " The all-free fit's residual on its own recordings, RMS fz "
                            f"{run['all_free_residual']['fz']['rms']:.3g} N, tx "
                            f"{run['all_free_residual']['tx']['rms']:.3g} Nm.")
                         + sag_sentence(run) + _orientation_sentence(run))
        lines.append("")
    return "\n".join(lines)


def _orientation_sentence(run: dict) -> str:
    """What the jackknife over the weights' orientations held in one run (a run written before
    it existed says nothing)."""
    from psmforce.identification.prior_identifiability import JACKKNIFE_OVER
    groups = run.get("orientation_jackknife_groups")
    if groups is None:
        return ""
    unit = run.get("orientation_jackknife_unit") or "orientation"
    words = JACKKNIFE_OVER[unit][0]
    held = [n for n, r in run["parameters"].items()
            if r["status"] == "fixed" and words in (r.get("reason") or "")]
    return (f" The jackknife over the {groups} "
            f"{'orientations' if unit == 'orientation' else 'sign pairs of orientations'} held: "
            f"{', '.join(held) if held else 'nothing'}.")


def load_path_holds_table(result: dict) -> str:
    """The law at the bench's truth on the hung weights' holds, per reading of the load path
    (``studies/load_path_holds.py``): holds kept and the settled residual's RMS over them."""
    readings, runs = result["readings"], result["runs"]
    head = ("| seed | case | " + " | ".join(readings) + " |\n|---|---|"
            + "---|" * len(readings))
    lines = ["", f"`{result['command']}` (simulator {result['simulator_version']}; seed "
             f"{result['design_seed']} is the design seed). Per seed and case, for each reading: "
             "holds kept / holds, then the RMS over the kept holds of their settled residual "
             "(the HEX10's internal wrench minus the law at the bench's truth, mean over each "
             "hold's second half), fz in N and tx, ty in mNm.", "", head]
    for seed in dict.fromkeys(r["seed"] for r in runs):
        for case in result["cases"]:
            cells = []
            for reading in readings:
                r = next(x for x in runs if (x["seed"], x["case"], x["reading"])
                         == (seed, case, reading))
                cells.append(f"{r['holds_used']}/{r['holds']}: {r['rms']['fz']:.3f}; "
                             f"{1e3 * r['rms']['tx']:.2f}, {1e3 * r['rms']['ty']:.2f}")
            lines.append(f"| {seed} | {case} | " + " | ".join(cells) + " |")
    return "\n".join(lines + [""])



HELD_CHECK_WORDS = "rests on held design values"
"""The reason ``prior_identifiability.identifiability`` gives a parameter held by the check of
what the held design values move (``fit_identified(design_tolerance=...)``)."""


PAIRED_SETTINGS = ("scale", "free_minutes", "excitation_minutes", "excitation_seed", "hold_s",
                   "crosstalk")
"""The study's settings two runs share when their rows are the same recordings and fit."""


def held_values_check_table(checked: dict, *as_held_results: dict) -> str:
    """The identification with the check of what rests on held design values against the same
    seeds and cases without it (``studies/ati_free_identification.py --held-values checked``
    against the committed runs as held): per seed and case, the misses, the parameters
    identified within the needed precision of the truth, and what the check held."""
    return _variant_table(checked, as_held_results, names=("as held", "checked"),
                          against="as held", held_words=HELD_CHECK_WORDS, also_same=(),
                          when="the check was added after seeing seed 433's eight-pose misses",
                          held_column="held with the check's reason (in the round it listed "
                                      "them)")


def sign_pair_jackknife_table(pairs: dict, *orientation_results: dict) -> str:
    """The identification with the jackknife over the weights' orientations left out by sign
    pair (``studies/ati_free_identification.py --jackknife-unit sign_pair``) against the same
    seeds and cases with each orientation left out alone: per seed and case, the misses, the
    parameters identified within the needed precision of the truth, and what the pairs'
    jackknife held."""
    from psmforce.identification.prior_identifiability import JACKKNIFE_OVER
    return _variant_table(pairs, orientation_results, names=("orientations", "sign pairs"),
                          against="with each orientation left out alone",
                          held_words=JACKKNIFE_OVER["sign_pair"][0], also_same=("held_values",),
                          when="the pairs' unit was tried after the orientations' jackknife "
                               "had held the radii on some of these rows",
                          held_column="held by the sign pairs' jackknife")


def both_guards_table(both: dict, *pairs_results: dict) -> str:
    """The identification with both guards (``--jackknife-unit sign_pair --held-values
    checked``) against the same seeds and cases with the sign pairs' jackknife alone: per seed
    and case, the misses, the parameters identified within the needed precision of the truth,
    and what the check of the held values held on top of the pairs."""
    return _variant_table(both, pairs_results, names=("sign pairs", "sign pairs + checked"),
                          against="with the sign pairs' jackknife alone",
                          held_words=HELD_CHECK_WORDS, also_same=("jackknife_unit",),
                          when="both guards together were run after each had been seen alone "
                               "on these rows",
                          held_column="held with the check's reason (in the round it listed "
                                      "them)")


_SETTING_DEFAULTS = {"held_values": "as-held", "jackknife_unit": "orientation"}
"""A study setting a run written before it existed ran at."""


def _variant_table(variant: dict, baselines, *, names: tuple[str, str], against: str,
                   held_words: str, also_same: tuple[str, ...], when: str,
                   held_column: str) -> str:
    """One variant of the identification against the same seeds and cases of ``baselines``
    (refused unless they share the recordings and fit: :data:`PAIRED_SETTINGS` and
    ``also_same``): per row the misses and the parameters identified within the needed
    precision, ``names`` (baseline, variant), and what the variant held with a reason
    containing ``held_words``; rows only one side ran are left out."""
    def setting(result, key):
        return result["settings"].get(key, _SETTING_DEFAULTS.get(key))
    for res in baselines:
        differ = [k for k in (*PAIRED_SETTINGS, *also_same)
                  if setting(res, k) != setting(variant, k)]
        if differ or res["simulator_version"] != variant["simulator_version"]:
            raise ValueError(f"{res['settings']['json']}: not the same recordings and fit as "
                             f"the {names[1]} run ({differ or 'simulator version'} differ)")
    before_runs = {(r["seed"], r["case"]): r for res in baselines for r in res["runs"]}
    seeds = ((f"seed {variant['design_seed']} is the design seed")
             if variant["design_seed"] in variant["settings"].get("seeds", ()) else
             "no design seed among them")
    lines = ["", f"`{variant['command']}` (simulator {variant['simulator_version']}; {seeds}; "
             f"{when}) against the same seeds and "
             f"cases {against} (the tables above: "
             + ", ".join(f"`{res['settings']['json']}`" for res in baselines)
             + "). Identified: free and within the needed precision of the truth (a miss is "
             "free and not).", "",
             f"| seed | case | misses, {names[0]} → {names[1]} | identified, {names[0]} → "
             f"{names[1]} | {held_column} |",
             "|---|---|---|---|---|"]
    totals = {name: [0, 0] for name in names}

    def counts(r):
        good = [n for n, p in r["parameters"].items()
                if p["status"] == "identified" and n not in r["misses"]]
        return r["misses"], good
    for run in variant["runs"]:
        before = before_runs.get((run["seed"], run["case"]))
        if before is None:
            continue
        (miss0, good0), (miss1, good1) = counts(before), counts(run)
        for name, miss, good in ((names[0], miss0, good0), (names[1], miss1, good1)):
            totals[name][0] += len(miss)
            totals[name][1] += len(good)
        held = [n for n, p in run["parameters"].items()
                if p["status"] == "fixed" and held_words in (p.get("reason") or "")]
        lost = [n for n in good0 if n not in good1]
        gained = [n for n in good1 if n not in good0]
        lines.append(f"| {run['seed']} | {run['case']} | {', '.join(miss0) or 'none'} → "
                     f"{', '.join(miss1) or 'none'} | {len(good0)} → {len(good1)}"
                     + (f" (no longer: {', '.join(lost)})" if lost else "")
                     + (f" (now also: {', '.join(gained)})" if gained else "")
                     + f" | {', '.join(held) or 'nothing'} |")
    lines += ["", f"Over these rows: misses {totals[names[0]][0]} {names[0]}, "
              f"{totals[names[1]][0]} {names[1]}; parameters identified within the needed "
              f"precision {totals[names[0]][1]} {names[0]}, {totals[names[1]][1]} {names[1]}."]
    return "\n".join(lines + [""])


HOLD_RULE_SAME = ("scale", "free_minutes", "excitation_minutes", "excitation_seed",
                  "paired_masses", "hold_s", "calibration_epochs", "quick", "jackknife_unit",
                  "prior_crosstalk")
"""Settings an ATI-free study run with the hold rule ``"unresolved"`` shares with the runs it is
paired with (:func:`hold_rule_table`)."""


def hold_rule_table(unresolved: dict, *imprecise: dict) -> str:
    """(c'') with its identification's hold rule ``"unresolved"`` (``studies/ati_free.py
    --hold-rule unresolved``) against the same seeds with the 10 % rule (``"imprecise"``, the
    runs ``imprecise``; refused unless they share the recordings and the calibration): per seed,
    what each carried into the prior (estimated values marked), the causal lateral errors of
    the calibrated hybrid and its physics alone, and (e); each carried estimate against the
    bench's truth and its own uncertainty; the paired ratio unresolved / imprecise on the fresh
    seeds (:data:`studies.ati_free.HOLD_RULE_FRESH_SEEDS`) and on the design seeds."""
    from studies.ati_free import (GOALS, HOLD_RULE_FRESH_SEEDS, IDENTIFIED_ARM,
                                  network_off_carried)
    if unresolved["settings"].get("hold_rule") != "unresolved":
        raise ValueError("the first study must be run with --hold-rule unresolved")
    for res in imprecise:
        differ = [k for k in HOLD_RULE_SAME
                  if res["settings"].get(k) != unresolved["settings"].get(k)]
        if differ or res["settings"].get("hold_rule", "imprecise") != "imprecise":
            raise ValueError(f"an ATI-free study does not pair with the unresolved run: "
                             f"settings {differ or ['hold_rule']} differ")
    base = {k: (res["records"][k], res.get("runs", {}).get(k, {}))
            for res in imprecise for k in res["records"] if IDENTIFIED_ARM in res["records"][k]}
    switched = "network_off_carried:" + IDENTIFIED_ARM
    records = {k: {**r, switched: network_off_carried(
        r[IDENTIFIED_ARM], r["physics_alone:" + IDENTIFIED_ARM],
        (unresolved["runs"][k][IDENTIFIED_ARM]["prior"] or {}).get("held_at_identified", {}))}
        for k, r in unresolved["records"].items() if IDENTIFIED_ARM in r}
    seeds = [k for k, r in unresolved["records"].items() if IDENTIFIED_ARM in r and k in base]
    fresh = [k for k in seeds if int(k) in HOLD_RULE_FRESH_SEEDS]
    design = [k for k in seeds if k not in fresh]
    lines = ["", f"(c'') with the hold rule `unresolved` against (c'') with the 10 % rule "
             f"(`imprecise`) on bench seeds {', '.join(seeds)} (fresh, declared before any run "
             f"on them: {', '.join(fresh) or 'none'}; the others are design seeds for the "
             "rule). Carried: what (c'')'s prior holds at the load path's values, estimated ones "
             "(kept free by the rule) in italics. Causal NRMSE % Fx / Fy.", "",
             "| seed | carried, imprecise | carried, unresolved | (c'') imprecise | (c'') "
             "unresolved | physics alone, imprecise | physics alone, unresolved | (c'') "
             "unresolved, the network off the carried axes | (e) ATI full |",
             "|---|---|---|---|---|---|---|---|---|"]
    truth_rows = []
    for k in seeds:
        rows, runs = base[k]
        new_rows, new_run = records[k], unresolved["runs"][k][IDENTIFIED_ARM]
        estimated = (new_run.get("instrument") or {}).get("estimated", {})

        def carried(run, marked=()):
            held = ((run.get(IDENTIFIED_ARM) or {}).get("prior") or {}).get(
                "held_at_identified", {})
            return ", ".join(f"*{n}*" if n in marked else n for n in held) or "nothing"

        def lateral(r):
            return " / ".join(f"{r['nrmse_pct']['causal'][a]:.2f}" for a in ("Fx", "Fy"))
        lines.append(f"| {k}{' (fresh)' if k in fresh else ''} | {carried(runs)} | "
                     f"{carried(unresolved['runs'][k], estimated)} | "
                     f"{lateral(rows[IDENTIFIED_ARM])} | "
                     f"{lateral(new_rows[IDENTIFIED_ARM])} | "
                     f"{lateral(rows['physics_alone:' + IDENTIFIED_ARM])} | "
                     f"{lateral(new_rows['physics_alone:' + IDENTIFIED_ARM])} | "
                     f"{lateral(records[k][switched])} | {lateral(new_rows['ati_full'])} |")
        against = new_run.get("prior_against_truth", {})
        for name, e in sorted(estimated.items()):
            truth = (against.get(name) or {}).get("truth")
            if truth is None or name not in (new_run["prior"] or {}).get("held_at_identified",
                                                                           {}):
                continue
            off = abs(e["value"] - truth)
            truth_rows.append(f"| {k} | {name} | {e['value']:.4g} ± {e['uncertainty']:.2g} | "
                              f"{truth:.4g} | {off / abs(truth):.0%} | "
                              + ("yes" if off <= e["uncertainty"] else "**no**") + " |")
    lines += ["", "Each carried estimate against the bench's truth: value ± its uncertainty "
              "(3 of its largest standard errors plus the held values' shift), the truth, the "
              "relative error, and whether the truth lies within the uncertainty.", "",
              "| seed | parameter | estimated | truth | error | truth within |",
              "|---|---|---|---|---|---|", *(truth_rows or ["| none | | | | | |"])]
    for which, group in (("fresh", fresh), ("design", design)):
        if not group:
            continue
        lines += ["", f"Unresolved over imprecise on the {which} seeds ({', '.join(group)}): "
                  "geometric mean [95 % t interval on log ratios]; below 1: the rule helps (the "
                  "last row: keeping the network off the carried axes helps).", "",
                  "| row | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
                  "|---|---|---|---|---|---|---|"]
        table, verdicts = _effect_rows(
            (label, [unresolved["records"][k][prefix + IDENTIFIED_ARM]["nrmse_pct"]
                     for k in group],
             [base[k][0][prefix + IDENTIFIED_ARM]["nrmse_pct"] for k in group])
            for prefix, label in (("", "the calibrated hybrid"),
                                  ("physics_alone:", "physics alone")))
        switch, switch_verdicts = _effect_rows([(
            "the network off the carried axes, over the hybrid (both unresolved)",
            [records[k][switched]["nrmse_pct"] for k in group],
            [records[k][IDENTIFIED_ARM]["nrmse_pct"] for k in group])])
        table += switch
        for verdict, cells in switch_verdicts.items():
            verdicts.setdefault(verdict, []).extend(cells)
        lines += table + ["", "Intervals wholly below 1 (helps): "
                          + ("; ".join(verdicts.get("ahead", [])) or "none") + "; wholly "
                          "above 1 (hurts): "
                          + ("; ".join(verdicts.get("behind", [])) or "none") + "."]
    for axes in (("Fx", "Fy"), ("Fx", "Fy", "Fz")):
        lines += _fresh_seed_goals({**unresolved, "records": records,
                                    "fresh_seeds": [int(k) for k in fresh]},
                                   {IDENTIFIED_ARM: GOALS[IDENTIFIED_ARM],
                                    switched: GOALS[IDENTIFIED_ARM]}, axes)
    return "\n".join(lines) + "\n"


def network_off_table(result: dict) -> str:
    """(c'') as ``psmforce calibrate --network-off carried`` writes it (``studies/ati_free.py
    --hold-rule unresolved``'s :data:`studies.ati_free.NETWORK_OFF_ARM`) and, where the run has
    it, (c'')'s prior under the source network not finetuned
    (:data:`studies.ati_free.NO_FINETUNE_ARM`) alone and composed with the network kept off the
    carried axes: per seed, the axes the prior alone answers and each row's causal errors beside
    (c''), the physics alone, (d') and (e); whether the scored checkpoint equals the score
    composed from (c'') and its physics alone (:func:`studies.ati_free.network_off_carried`);
    paired ratios on the seeds declared for it (:data:`studies.ati_free.NETWORK_OFF_FRESH_SEEDS`)
    and on the others; the goals on those fresh seeds, laterally and on all three axes."""
    from studies.ati_free import (GOALS, IDENTIFIED_ARM, NETWORK_OFF_ARM,
                                  NETWORK_OFF_FRESH_SEEDS, NO_FINETUNE_ARM, network_off_carried)
    seeds, records, carried = _unresolved_rows(result, NETWORK_OFF_ARM)
    physics = "physics_alone:" + IDENTIFIED_ARM
    unfinetuned = all(NO_FINETUNE_ARM in r for r in records.values())
    for k, r in records.items():
        if unfinetuned:
            r[NO_FINETUNE_OFF] = network_off_carried(r[NO_FINETUNE_ARM], r[physics], carried[k])
    rows = ((NETWORK_OFF_ARM, "network off"),
            *(((NO_FINETUNE_ARM, "not finetuned"), (NO_FINETUNE_OFF, "not finetuned, network "
                                                                     "off")) if unfinetuned
              else ()),
            (IDENTIFIED_ARM, "(c'')"), (physics, "physics alone"),
            ("ati_same_minutes_paired", "(d')"), ("ati_full", "(e)"))
    pairs = [(NETWORK_OFF_ARM, ref) for ref in (IDENTIFIED_ARM, physics,
                                                "ati_same_minutes_paired", "ati_full")]
    goals = {IDENTIFIED_ARM: GOALS[IDENTIFIED_ARM], NETWORK_OFF_ARM: GOALS[NETWORK_OFF_ARM]}
    if unfinetuned:
        pairs += [(NO_FINETUNE_ARM, IDENTIFIED_ARM), (NO_FINETUNE_ARM, "ati_full"),
                  (NO_FINETUNE_OFF, NETWORK_OFF_ARM), (NO_FINETUNE_OFF, "ati_full")]
        goals |= {NO_FINETUNE_ARM: GOALS[NO_FINETUNE_ARM], NO_FINETUNE_OFF: GOALS[NO_FINETUNE_ARM]}

    def same(k: str) -> str:
        r = records[k]
        composed = network_off_carried(r[IDENTIFIED_ARM], r[physics], carried[k])
        return "yes" if all(
            abs(composed["nrmse_pct"][m][a] - r[NETWORK_OFF_ARM]["nrmse_pct"][m][a])
            <= 1e-6 * max(1.0, abs(composed["nrmse_pct"][m][a]))
            for m in ("causal", "paper") for a in ERROR_AXES) else "**no**"
    intro = ("(c'') with `--network-off carried`", "Network off: the lateral axes carried are "
             "answered by the prior alone"
             + ("; not finetuned: (c'')'s prior under the source network as trained" if
                unfinetuned else "") + ".")
    return _rows_against_references(result, records, carried, NETWORK_OFF_FRESH_SEEDS, rows,
                                    pairs, goals, intro, ("checkpoint = composed", same))


def prior_only_table(result: dict) -> str:
    """(c'')'s prior under the source network not finetuned, the prior alone on Fx and Fy
    (:data:`studies.ati_free.PRIOR_ONLY_ARM`: ``psmforce calibrate --prior-refit identified
    --no-finetune --network-off Fx Fy``): per seed its causal errors beside (c''), the network
    kept off the carried axes, the physics alone, (d') and (e); paired ratios on the seeds
    declared for it (:data:`studies.ati_free.PRIOR_ONLY_FRESH_SEEDS`) and on the others; the
    goals on those fresh seeds, on all three axes and laterally."""
    from studies.ati_free import (GOALS, IDENTIFIED_ARM, NETWORK_OFF_ARM, NO_FINETUNE_ARM,
                                  PRIOR_ONLY_ARM, PRIOR_ONLY_FRESH_SEEDS)
    seeds, records, carried = _unresolved_rows(result, PRIOR_ONLY_ARM)
    physics = "physics_alone:" + IDENTIFIED_ARM
    rows = ((PRIOR_ONLY_ARM, "prior only"), (NO_FINETUNE_ARM, "not finetuned"),
            (NETWORK_OFF_ARM, "network off"), (IDENTIFIED_ARM, "(c'')"),
            (physics, "physics alone"), ("ati_same_minutes_paired", "(d')"),
            ("ati_full", "(e)"))
    pairs = [(PRIOR_ONLY_ARM, ref) for ref in (IDENTIFIED_ARM, NETWORK_OFF_ARM,
                                               "ati_same_minutes_paired", "ati_full")]
    goals = {IDENTIFIED_ARM: GOALS[IDENTIFIED_ARM], NETWORK_OFF_ARM: GOALS[NETWORK_OFF_ARM],
             PRIOR_ONLY_ARM: GOALS[PRIOR_ONLY_ARM]}
    intro = ("Prior only: `--prior-refit identified --no-finetune --network-off Fx Fy`",
             "Not finetuned: (c'')'s prior under the source network as trained; network off: "
             "(c'') with `--network-off carried`.")
    return _rows_against_references(result, records, carried, PRIOR_ONLY_FRESH_SEEDS, rows,
                                    pairs, goals, intro)


def network_prior_table(result: dict) -> str:
    """The prior-only calibration with the network reading the prior it was trained with
    (:data:`studies.ati_free.NETWORK_PRIOR_ARM`: ``psmforce calibrate --prior-refit identified
    --no-finetune --network-off Fx Fy --network-prior trained``): per seed its causal errors
    beside the prior only, the source hybrid as it was, (c''), (d') and (e); paired ratios on
    the seeds declared for it (:data:`studies.ati_free.NETWORK_PRIOR_FRESH_SEEDS`) and on the
    others; the goals on those fresh seeds, on all three axes and laterally."""
    from studies.ati_free import (GOALS, IDENTIFIED_ARM, NETWORK_PRIOR_ARM,
                                  NETWORK_PRIOR_FRESH_SEEDS, PRIOR_ONLY_ARM)
    seeds, records, carried = _unresolved_rows(result, NETWORK_PRIOR_ARM)
    rows = ((NETWORK_PRIOR_ARM, "trained prior"), (PRIOR_ONLY_ARM, "prior only"),
            ("source", "source as is"), (IDENTIFIED_ARM, "(c'')"),
            ("ati_same_minutes_paired", "(d')"), ("ati_full", "(e)"))
    pairs = [(NETWORK_PRIOR_ARM, ref) for ref in (PRIOR_ONLY_ARM, "source",
                                                  "ati_same_minutes_paired", "ati_full")]
    goals = {PRIOR_ONLY_ARM: GOALS[PRIOR_ONLY_ARM], NETWORK_PRIOR_ARM: GOALS[NETWORK_PRIOR_ARM]}
    intro = ("Trained prior: `--prior-refit identified --no-finetune --network-off Fx Fy "
             "--network-prior trained`",
             "Prior only: the same without `--network-prior trained` (the network reads the "
             "refitted prior); source as is: the source hybrid uncalibrated.")
    return _rows_against_references(result, records, carried, NETWORK_PRIOR_FRESH_SEEDS, rows,
                                    pairs, goals, intro)


def self_loading_table(result: dict) -> str:
    """(b)'s recordings through the network-prior recipe, the instrument identified with the
    clenched samples' lateral forces counted (:data:`studies.ati_free.SELF_LOADING_ARM`:
    ``psmforce calibrate --free-space --prior-refit identified --hold-rule unresolved
    --clenched-lateral --no-finetune --network-off Fx Fy --network-prior trained``, no known
    loads): per seed its causal errors beside the source hybrid as it was, (d_b) and (e), with
    the lateral cross-talk it carried against the drawn tool's; paired ratios on the seeds
    declared for it (:data:`studies.ati_free.SELF_LOADING_FRESH_SEEDS`) and on the others; the
    goal on those fresh seeds, on all three axes and laterally."""
    from studies.ati_free import SELF_LOADING_ARM, SELF_LOADING_FRESH_SEEDS
    return _self_loading(result, SELF_LOADING_ARM, SELF_LOADING_FRESH_SEEDS, "(b'')", (),
                         "`--prior-refit identified --hold-rule unresolved --clenched-lateral "
                         "--no-finetune --network-off Fx Fy --network-prior trained`")


def self_offsets_table(result: dict) -> str:
    """:func:`self_loading_table` for :data:`studies.ati_free.SELF_OFFSETS_ARM` (the same with
    ``--free-lateral-offsets``), beside (b'') and paired with it too, judged on
    :data:`studies.ati_free.SELF_OFFSETS_FRESH_SEEDS`."""
    from studies.ati_free import SELF_LOADING_ARM, SELF_OFFSETS_ARM, SELF_OFFSETS_FRESH_SEEDS
    return _self_loading(result, SELF_OFFSETS_ARM, SELF_OFFSETS_FRESH_SEEDS, "(b''')",
                         ((SELF_LOADING_ARM, "(b'')"),),
                         "(b'') with `--free-lateral-offsets`")


def self_least_table(result: dict) -> str:
    """:func:`self_loading_table` for :data:`studies.ati_free.SELF_LEAST_ARM` (the offsets
    row with ``--hold-rule least-uncertain``), beside (b''') and (b''), paired with them too,
    judged on :data:`studies.ati_free.SELF_LEAST_FRESH_SEEDS`."""
    from studies.ati_free import (SELF_LEAST_ARM, SELF_LEAST_FRESH_SEEDS, SELF_LOADING_ARM,
                                  SELF_OFFSETS_ARM)
    return _self_loading(result, SELF_LEAST_ARM, SELF_LEAST_FRESH_SEEDS, "(b'''')",
                         ((SELF_OFFSETS_ARM, "(b''')"), (SELF_LOADING_ARM, "(b'')")),
                         "(b''') with `--hold-rule least-uncertain`")


def _self_loading(result: dict, arm: str, declared, name: str, beside, recipe: str) -> str:
    """The per-seed table, paired ratios and goal of one self-loading row ``arm`` (``name``;
    ``beside``: other rows shown and paired with it; ``recipe``: what it is)."""
    from psmforce.estimators.training.calibrate import CARRIED_AXES
    from studies.ati_free import GOALS
    seeds = [k for k, r in result["records"].items() if arm in r]
    if not seeds:
        raise ValueError(f"the study has no {arm} row")
    runs = {k: result["runs"][k][arm] for k in seeds}
    carried = {k: (runs[k]["prior"] or {}).get("held_at_identified", {}) for k in seeds}
    rows = ((arm, name), *beside, ("source", "source as is"),
            ("ati_same_minutes_self", "(d_b)"), ("ati_full", "(e)"))
    pairs = [(arm, ref) for ref, _ in rows[1:]]

    def recovered(k: str) -> str:
        truth = runs[k]["prior_against_truth"]
        cells = [f"{term} {truth[term]['fitted']:.4f} / {truth[term]['truth']:.4f}"
                 for term in CARRIED_AXES.values() if term in carried[k]]
        return "; ".join(cells) or "none carried"
    intro = (f"{name}: {recipe} on (b)'s recordings (free space and the excitation's clenches, "
             "no weight)",
             "Source as is: the source hybrid uncalibrated (the row's Fz by construction); "
             f"(d_b): the ATI calibration on as many minutes as {name} used.")
    return _rows_against_references(
        result, {k: dict(result["records"][k]) for k in seeds}, carried, declared, rows, pairs,
        {arm: GOALS[arm]}, intro, ("cross-talk carried: fitted / the drawn tool's", recovered))


def _unresolved_rows(result: dict, subject: str) -> tuple[list[str], dict, dict]:
    """(the seeds with the ``subject`` row, their records copied, what (c'')'s prior carried
    per seed) of a study run with ``--hold-rule unresolved``; anything else refused."""
    from studies.ati_free import IDENTIFIED_ARM
    if result["settings"].get("hold_rule") != "unresolved":
        raise ValueError("the study must be run with --hold-rule unresolved")
    seeds = [k for k, r in result["records"].items() if subject in r]
    if not seeds:
        raise ValueError(f"the study has no {subject} row")
    carried = {k: (result["runs"][k][IDENTIFIED_ARM]["prior"] or {}).get("held_at_identified",
                                                                          {}) for k in seeds}
    return seeds, {k: dict(result["records"][k]) for k in seeds}, carried


def _rows_against_references(result: dict, records: dict, carried: dict, declared, rows,
                             pairs, goals: dict, intro: tuple[str, str], check=None) -> str:
    """The per-seed table of ``rows`` (causal NRMSE per axis, the lateral axes the network is
    kept off by ``carried``, and ``check``'s column: (title, seed -> cell); ``intro``: the
    subject and what the other rows are), the paired ratios
    ``pairs`` on the ``declared`` fresh seeds and on the others, and ``goals`` on the fresh
    seeds, laterally and on all three axes."""
    from psmforce.estimators.training.calibrate import network_off_axes
    seeds = list(records)
    fresh = [k for k in seeds if int(k) in declared]
    label = dict(rows)
    lines = ["", f"{intro[0]} on bench seeds {', '.join(seeds)} (fresh, declared before any run "
             f"on them: {', '.join(fresh) or 'none'}). {intro[1]} Carried: the lateral axes "
             "whose cross-talk the identification carried into the prior. Causal NRMSE % "
             "Fx / Fy / Fz.", "",
             "| seed | carried | " + " | ".join(name for _, name in rows)
             + (f" | {check[0]} |" if check else " |"),
             "|---|---|" + "---|" * (len(rows) + bool(check))]
    for k in seeds:
        r = records[k]
        lines.append(f"| {k}{' (fresh)' if k in fresh else ''} | "
                     f"{', '.join(network_off_axes('carried', carried[k])) or 'none'} | "
                     + " | ".join(" / ".join(f"{r[row]['nrmse_pct']['causal'][a]:.2f}"
                                             for a in ERROR_AXES) for row, _ in rows)
                     + (f" | {check[1](k)} |" if check else " |"))
    for which, group in (("fresh", fresh), ("design", [k for k in seeds if k not in fresh])):
        if not group:
            continue
        lines += ["", f"Paired ratios on the {which} seeds ({', '.join(group)}): geometric "
                  "mean [95 % t interval on log ratios]; below 1: the first row ahead.", "",
                  "| ratio | causal Fx | causal Fy | causal Fz | paper Fx | paper Fy | paper Fz |",
                  "|---|---|---|---|---|---|---|"]
        table, verdicts = _effect_rows(
            (f"{label[a]} / {label[b]}", [records[k][a]["nrmse_pct"] for k in group],
             [records[k][b]["nrmse_pct"] for k in group]) for a, b in pairs)
        lines += table + ["", "Intervals wholly below 1 (ahead): "
                          + ("; ".join(verdicts.get("ahead", [])) or "none") + "; wholly "
                          "above 1 (behind): "
                          + ("; ".join(verdicts.get("behind", [])) or "none") + "."]
    for axes in (("Fx", "Fy"), ERROR_AXES):
        lines += _fresh_seed_goals({**result, "records": records,
                                    "fresh_seeds": [int(k) for k in fresh]}, goals, axes)
    return "\n".join(lines) + "\n"
