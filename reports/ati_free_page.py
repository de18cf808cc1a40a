"""The blocks of ``docs/ati_free.md``: the excitation and the known weights, rendered from
``results/benchmarks/excitation.json`` (``studies/excitation.py``); the re-mounting section
("3. Re-mounting") from ``results/benchmarks/remount.json`` (``studies/remount.py``) and
``results/benchmarks/hex10_compression.json`` (``studies/hex10_compression.py``). Each function
takes the parsed JSON and returns the block's markdown."""

from __future__ import annotations

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
    return "\n".join(lines) + "\n"


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
    return "\n".join(lines) + "\n"


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
    "per_mount:free+self": "(b') as (b), the prior refitted per mount only",
    "network_alone:free": "network alone, (a)'s data", "network_alone:free+self": "network alone, (b)'s data",
    "network_alone:free+self+weights": "network alone, (c)'s data",
    "physics_alone:free": "physics alone, (a)'s prior", "physics_alone:free+self": "physics alone, (b)'s prior",
    "physics_alone:free+self+weights": "physics alone, (c)'s prior",
    "ati_same_minutes": "(d) ATI: same minutes", "ati_full": "(e) ATI: full data",
    "source": "source hybrid (other tool), as is"}
ERROR_AXES = ("Fx", "Fy", "Fz")


def _mean_sd(cell) -> str:
    mean, sd = cell
    return f"{mean:.2f}" + ("" if sd is None else f" ± {sd:.2f}")


def _paired(p: dict) -> str:
    if p["n"] < 2:
        return f"{p['mean_ratio']:.2f}x"
    return f"{p['mean_ratio']:.2f}x [{p['low']:.2f}, {p['high']:.2f}]"


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
    for ref, name in (("ati_same_minutes", "(d), the ATI with the same minutes"),
                      ("ati_full", "(e), the ATI at full data")):
        paired = result["paired"][ref]
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
    lines += ["", "The prior's parameters against the bench's (the drawn tool; relative error "
              "per seed; held: kept at the source model's value, in (a)-(c) because the data "
              "could not pin it down, in (b') by design):", "",
              "| arm | parameter | truth (seed " + seeds[0] + ") | status per seed "
              "| relative error per seed | within 10 % |", "|---|---|---|---|---|---|"]
    for arm in ("free", "free+self", "free+self+weights", "per_mount:free+self"):
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
