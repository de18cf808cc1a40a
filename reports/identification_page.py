"""The blocks of ``docs/identification.md``, rendered from the committed JSONs that measured them
(registered in :data:`reports.render.BLOCKS`): the real EndoWrist's transmission
benchmark and the prior's parameter recovery on the bench."""

from __future__ import annotations

import math

from reports.cells import (as_held, miss_rule, relative_error, rescored_note, sag_sentence,
                           spread_cell, with_pins)

MODEL_NAMES = {"physics": "physics alone (`CableTransmission`)", "fcn": "FCN",
               "lstm": "LSTM", "transformer": "paper transformer",
               "rocket": "MultiRocket-Hydra", "hybrid": "hybrid (physics + causal residual)",
               "fcn+spindle": "FCN + input-spindle torque sensor (reference: a robot has none)",
               "hybrid_no_physics": "the hybrid's network without the physics (ablation)"}


LEARNED_BASELINES = ("fcn", "lstm", "transformer", "rocket")
_CAPSTAN_GROWTH = ("capstan_pitch_gain", "capstan_roll_gain")
"""The law's capstan terms that follow the wrist's configuration (absent from runs before them)."""


def _capstan_sentence(run: dict, rows: dict) -> str:
    """What the law's capstan stands for on a recovery run: one constant for the bench's average
    over the training configurations (a law without growth terms, or with them at 0), or a
    capstan that grows as the bench's does; nothing where the run has no capstan."""
    if "capstan_mu_over_training" not in run or rows["capstan_mu"]["status"] == "fixed":
        return ""
    bench = (f" The bench's wrist friction (the idlers' capstan{with_pins(run)}) is "
             f"{_num(rows['capstan_mu']['truth'])} at the straight wrist and grows with |wrist "
             "pitch| and |roll|; averaged over the training samples' configurations it is "
             f"{run['capstan_mu_over_training']:.3g}")
    growth = {n: rows[n] for n in _CAPSTAN_GROWTH if n in rows}
    if not any(r["fitted"] for r in growth.values()):
        return f"{bench}, the law's one constant {_num(rows['capstan_mu']['fitted'])}."
    return (f"{bench}. The law's grows too: " + ", ".join(
        f"{n} {_num(r['fitted'])} ({r['status']})" for n, r in growth.items())
        + f", from {_num(rows['capstan_mu']['fitted'])} at the straight wrist.")


def transmission_tables(result: dict) -> str:
    """docs/identification.md section 4: per protocol, every model; the physics' parameters."""
    pub = result["published"]
    lines = ["",
             f"Command: `{result['run']['command']}` (resumable; each model and seed cached); "
             f"seeds {result['seeds']} for the learned models (the physics fit is "
             f"deterministic); {result['rate_hz']:g} Hz; causal estimates, no post-filter. "
             "RMSE mean ± std over seeds (the sample std, ddof 1; the physics' is 0), pooled "
             "over the protocol's test files; *closing*: the "
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
            cells = [spread_cell(w["torque_rmse_mNm"]), spread_cell(w["angle_rmse_deg"]),
                     spread_cell(c["torque_rmse_mNm"]), spread_cell(c["angle_rmse_deg"]),
                     spread_cell(w["torque_nrmse_pct"], 1)]
            lines.append(f"| {MODEL_NAMES.get(m, m)} | " + " | ".join(cells) + " |")
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


def prior_recovery_table(result: dict) -> str:
    """docs/identification.md section 2.1: truth against the fit per seed ("loaded" variant)."""
    from psmforce.identification.prior_law import PARAMETERS
    unit = {p[0]: p[1] for p in PARAMETERS}
    runs = [r for r in result["runs"] if r["variant"] == "loaded"]
    first = runs[0]["parameters"]
    lines = ["", f"`python studies/prior_recovery.py --scale {result['scale']:g} --seeds "
             + " ".join(str(r["seed"]) for r in runs) + "`; `*` = listed not identifiable, with "
             "the relative error where the truth is not zero; *held*: held by the efforts "
             "reading, not fitted:", "",
             "| parameter | unit | truth | " + " | ".join(f"seed {r['seed']}" for r in runs)
             + " | SE (seed " + str(runs[0]["seed"]) + ") |",
             "|---|---|---|" + "---|" * len(runs) + "---|"]
    for name, p0 in first.items():
        cells = []
        for r in runs:
            p = r["parameters"][name]
            mark = {"identifiable": "", "fixed": " *held*"}.get(p["status"], " *")
            rel = (f" ({100 * p['relative_error']:.1f} %)" if p["truth"] != 0
                   and p.get("relative_error") is not None else "")
            cells.append(f"{p['fitted']:.4g}{rel}{mark}")
        se = p0.get("standard_error")
        lines.append(f"| {name} | {unit.get(name, '')} | {p0['truth']:.4g} | " + " | ".join(cells)
                     + f" | {'' if se is None else f'{se:.2g}'} |")
    conds = " / ".join(f"{r['identifiability']['condition_number']:.3g}" for r in runs)
    lines += ["", f"Fisher condition number {conds}; {sum(len(r['failures']) for r in runs)} "
              "identifiable parameters off by more than 10 % (an offset: by more than its "
              "resolution).", ""]
    return "\n".join(lines)


def prior_drawn_trace_table(result: dict) -> str:
    """docs/identification.md section 2.3: the drawn tool's load-path fit redone with one of the
    tool's departures from the law removed at a time (``studies/prior_recovery_trace.py``)."""
    from psmforce.identification.prior_identifiability import recovered
    run = result["run"]
    lines = ["", f"The {run['case']}'s load-path run (seed {run['seed']}, scale "
             f"{run['scale']:g}; misses there: {', '.join(run['misses']) or 'none'}), its last "
             "round refitted on the bench with one departure removed; each judged against the "
             "bench's law projected onto the law as the run held it, on the variant's own "
             "trials (a variant that frees terms the run did not have, as the law's lateral "
             "cross-talk, projects with them free and judges them too):", "",
             "| bench | capstan_pitch_gain: fit / projection | capstan_mu: fit / projection "
             "| identified (or freed) terms off their projection (10 %; an offset: its "
             "resolution) |",
             "|---|---|---|---|"]
    for v in result["variants"]:
        fit, proj = v["fitted"], v["projected_truth"]
        off = [n for n in [*v["identified"], *v.get("freed", [])]
               if not recovered(n, fit[n], proj[n])]
        cells = [f"{fit[n]:.4g} / {proj[n]:.4g} ({100 * abs(fit[n] / proj[n] - 1):.1f} %)"
                 for n in ("capstan_pitch_gain", "capstan_mu")]
        lines.append(f"| {v['variant']} | {cells[0]} | {cells[1]} | {', '.join(off) or 'none'} |")
    return "\n".join(lines + [""])


def _rest_level_leak(run: dict) -> str:
    """The sentence on the HEX10's cross-talk of the pretension's axial force: into the channels
    whose law has no cross-talk term (a load-path law fits fx's and fy's, since prior format 5
    the moments' too), a constant only the biases carry; nothing where there is none."""
    if "crosstalk_of_rest_level" not in run:
        return ""
    fitted = [c for c in ("fx", "fy", "tx", "ty", "tz") if f"crosstalk_{c}" in run["parameters"]
              and run.get("inputs") == "load_path"]
    leaks = {n: x for n, x in run["crosstalk_of_rest_level"].items()
             if n.removeprefix("bias_") not in fitted}
    if not leaks:  # the law has a cross-talk term for every channel
        return ""
    return (" The sensor's cross-talk of the pretension's axial force, a constant only the biases "
            "can carry" + (f" where the law has no cross-talk term (it has one for "
                           f"{' and '.join(fitted)})" if fitted else "")
            + " (bench parameters): " + ", ".join(f"{n} {x:+.3g}" for n, x in leaks.items())
            + ".")


def _num(x) -> str:
    return "—" if x is None else f"{x:.4g}"


def prior_default_recovery_table(result: dict) -> str:
    """docs/identification.md section 2.1: on the default bench (and its variants), per
    parameter: truth, the all-free fit, the final fit (unidentifiable parameters held at design
    values), relative error, free / fixed, at a bound; the verdict and held-out fz per run."""
    from psmforce.identification.prior_law import PARAMETERS
    unit = {p[0]: p[1] for p in PARAMETERS}
    option = f" --crosstalk {result['crosstalk']}" if result.get("crosstalk") else ""
    fit = (f"`psmforce fit-prior --identify --use-loaded --load-path{option}` (Free, Traction "
           "and Palpation training trials; the cables read from the known tip force)"
           if result.get("load_path") else
           f"`psmforce fit-prior --identify{option}` (Free training trials)")
    lines = ["", f"`{result['command']}`{rescored_note(result)}: `psmforce simulate --seed S "
             f"--scale {result['scale']:g}` then {fit}. "
             "*fixed*: held at its design value (the value shown) because the report lists it "
             "on the fit before; *identified*: free and not listed on the final fit; "
             f"**MISS**: identified but {miss_rule(result['runs'][0], result['runs'])}; "
             "*B*: at a bound (the one rule of `bounds_hit` and the report).", ""]
    for run in result["runs"]:
        rows = run["parameters"]
        lines += [f"**{run['case']}, seed {run['seed']}** (pair law {run['pair_law']}; "
                  f"{run['n_samples']} samples, {run['fit_time_s']:.0f} s):", "",
                  "| parameter | unit | truth | all-free fit | final fit | rel. error | status |",
                  "|---|---|---|---|---|---|---|"]
        for name, r in rows.items():
            err = relative_error(r)
            rel = "" if err is None else f"{100 * err:.1f} %"
            status = r["status"]
            if status == "fixed" and rel:
                rel += " (design vs truth)"
            if status == "identified" and name in run["misses"]:
                status = "identified, **MISS**"
            elif status == "identified" and name in run["uncompared"]:
                status = "identified (no truth to compare)"
            bound_first = name in run["rounds"][0]["bounds_hit"]
            lines.append(f"| {name} | {unit[name]} | {_num(r['truth'])}{as_held(r)} | "
                         f"{_num(r['all_free_fit'])}{' *B*' if bound_first else ''} | "
                         f"{_num(r['fitted'])}{' *B*' if r['at_bound'] else ''} | {rel} | "
                         f"{status} |")
        fz, fz0 = ((m or {}).get("fz", {}) for m in (run["test_free_metrics"],
                                                     run["all_free_test_free_metrics"]))
        lines += ["", f"Verdict: {run['verdict']}.", "",
                  f"Identified {len([r for r in rows.values() if r['status'] == 'identified'])}"
                  f", fixed {len([r for r in rows.values() if r['status'] == 'fixed'])}; misses: "
                  f"{', '.join(run['misses']) or 'none'}. Test Free fz RMS: final fit "
                  f"{fz.get('rms', float('nan')):.3g} N, all-free fit "
                  f"{fz0.get('rms', float('nan')):.3g} N (R^2 {fz.get('r2', float('nan')):.3g} / "
                  f"{fz0.get('r2', float('nan')):.3g}); fit-prior rounds: {len(run['rounds'])}."
                  + _rest_level_leak(run)
                  + _capstan_sentence(run, rows) + sag_sentence(run), ""]
        loaded = run.get("test_loaded_internal_metrics")
        if loaded:
            first = run["all_free_test_loaded_internal_metrics"]
            lines[-1:-1] = [
                "", "Held-out loaded trials (Traction, Palpation), the internal wrench with the known "
                "force subtracted, RMS final fit / all-free fit: " + ", ".join(
                    f"{c} {loaded[c]['rms']:.3g} / {first[c]['rms']:.3g} "
                    f"{'N' if c.startswith('f') else 'Nm'}" for c in ("fx", "fy", "fz", "tz")
                    if c in loaded) + "."]
            if run.get("truth_law_test_loaded_internal_metrics"):
                lines[-1:-1] = ["", _truth_law_sentence(run)]
    return "\n".join(lines)


def _truth_law_sentence(run: dict) -> str:
    """What the law at the bench's own parameters leaves on a run's held-out loaded trials, read
    from the motor efforts and from the load path; not shown for a run that scored it with the
    blade cables' path tension in both forms (no ``truth_law`` record)."""
    truth = run["truth_law_test_loaded_internal_metrics"]
    if not run.get("truth_law"):
        return ("The law at the bench's own parameters: not shown, because this run scored it "
                "with the blade cables' path tension in both of its forms (written before "
                "`prior_recovery.truth_law`).")
    return ("The law at the bench's own parameters on the same trials, read from the motor "
            "efforts / from the load path: " + ", ".join(
                f"{c} {truth['efforts'][c]['rms']:.3g} / {truth['load_path'][c]['rms']:.3g}"
                f" {'N' if c.startswith('f') else 'Nm'}" for c in ("fx", "fy", "fz", "tz")
                if c in truth["efforts"]) + ".")


def transmission_transfer_tables(result: dict) -> str:
    """docs/identification.md section 4.1: the data checks on every folder, the parameters'
    roles, and the transfer of the physics to every other folder."""
    lines = ["", "**Data checks** (every file of every folder, before any fit; "
             "`psmforce/identification/transmission/checks.py`):", "",
             "| folder | files | left out | findings |", "|---|---|---|---|"]
    for folder, rep in result["data_checks"].items():
        found = "; ".join(f"{name}: " + ", ".join(f"{f['check']} ({f['detail']})" for f in fs)
                          for name, fs in rep["flagged"].items()) or "none"
        lines.append(f"| {folder} | {rep['files']} | {len(rep['flagged'])} | {found} |")
    boot = result["bootstrap"]
    lines += ["", f"**Roles** (fitted on {result['source_folder']}'s training files, the law "
              f"reading the drive's {result['current_source']} current; relative sd: bootstrap "
              f"over whole files, {boot['resamples']} resamples; a shared parameter above "
              f"{result['relative_sd_limit']:g} is fixed at its "
              "design value and named; *at bound*: within 0.1 % of its range from an end, the "
              "one rule for parameters and the widths' grid):", "",
              "| parameter | role | value | unit | relative sd | at bound |",
              "|---|---|---|---|---|---|"]
    for row in result["roles"]:
        value = row["value"]
        if isinstance(value, dict):
            value = ", ".join(f"{s} {v:.4g}" for s, v in value.items())
        elif isinstance(value, float):
            value = f"{value:.4g}"
        sd = row.get("relative_sd")
        if isinstance(sd, dict):
            sd = ", ".join(f"{v:.2g}" for v in sd.values() if v is not None)
        elif isinstance(sd, float):
            sd = f"{sd:.2g}"
        bound = row.get("at_bound")
        bound = ", ".join(bound) if isinstance(bound, list) else ("yes" if bound else "")
        lines.append(f"| {row['name']} | {row['role']} | {value} | {row.get('unit', '')} | "
                     f"{sd or ''} | {bound} |")
    lines += ["", "**Transfer** (jaw torque RMSE, mNm, whole files / closing portions; angle "
              "in degrees; each folder scored on its files outside its 60 s calibration):", "",
              "| folder | constant (calibration mean) | as is | recalibrated | in session | "
              "leave-one-configuration-out | recalibrated / in session | angle, recalibrated |",
              "|---|---|---|---|---|---|---|---|"]

    def pair(d):
        return f"{d['whole']['torque_rmse_mNm']:.1f} / {d['closing']['torque_rmse_mNm']:.1f}"

    misses = []
    for folder, f in result["folders"].items():
        if "recalibrated" not in f:
            lines.append(f"| {folder} (fitted here) | | | | {pair(f['in_session'])} | | | "
                         f"{f['in_session']['whole']['angle_rmse_deg']:.2f} |")
            continue
        v = result["verdicts"][folder]
        ratio = " / ".join(f"{v[p]['ratio']:.2f}x" for p in ("whole", "closing"))
        lines.append(f"| {folder} | {pair(f['constant_calibration_mean'])} | {pair(f['as_is'])} "
                     f"| {pair(f['recalibrated'])} | {pair(f['in_session'])} | "
                     f"{pair(f['loco']) if 'loco' in f else ''} | {ratio} | "
                     f"{f['recalibrated']['whole']['angle_rmse_deg']:.2f} |")
        for part in ("whole", "closing"):
            if not v[part]["within_goal"]:
                misses.append(f"{folder} ({part}: {v[part]['ratio']:.2f}x)")
            if not v[part]["beats_constant"]:
                misses.append(f"{folder} ({part}: not better than the constant)")
    goal = result["goals"]
    l2 = result["folders"].get("Tool_4_Maryland_L_2", {}).get("recalibrated")
    lines += ["", f"Goal: recalibrated within {goal['recalibrated_over_in_session']:g}x of in "
              "session and better than the constant on every folder: "
              + (f"missed on {', '.join(misses)}." if misses else "met on every folder.")]
    if l2:
        w = l2["whole"]["torque_rmse_mNm"]
        lines.append(f"Session transfer L_4 to L_2 on whole files: {w:.1f} mNm against the goal "
                     f"of {goal['l2_whole_mNm']:g} ({'met' if w < goal['l2_whole_mNm'] else 'missed'}).")
    lines += ["", "With the measured current in place of the command (same roles, refitted):", "",
              "| folder | as is | recalibrated |", "|---|---|---|"]
    for folder, f in result["folders"].items():
        m = f["measured_current"]
        if "recalibrated" in m:
            lines.append(f"| {folder} | {pair(m['as_is'])} | {pair(m['recalibrated'])} |")
        else:
            lines.append(f"| {folder} (in session) | {pair(m['in_session'])} | |")
    return "\n".join(lines) + "\n"


def transmission_per_session_table(result: dict) -> str:
    """docs/identification.md section 4.1: the per-session sets tried side by side (recalibrated
    / in session on every folder, and the lab's leave-one-calibration-file-out error), then the
    kept set's values per folder with those at a bound named."""
    cands = result.get("per_session_candidates")
    if not cands:
        raise ValueError("transmission_transfer.json has no per_session_candidates: rerun "
                         "`python studies/transmission_transfer.py --json "
                         "results/benchmarks/transmission_transfer.json`")
    folders = [f for f in result["folders"] if "recalibrated" in result["folders"][f]]
    lines = ["", "Jaw torque RMSE, mNm, whole files / closing portions. *recalibrated / in "
             "session*: on the folder's scored files, each set re-estimated on its 60 s; "
             "*calibration, leave one file out*: what a lab can compute without those files, "
             "each of the three calibration files scored after the other two recalibrate.", "",
             "| per-session set | " + " | ".join(folders) + " | worst ratio |",
             "|---|" + "---|" * (len(folders) + 1)]
    for label, c in cands.items():
        ratios, cells, lofo = [], [], []
        for f in folders:
            row, ins = c["folders"][f], result["folders"][f]["in_session"]
            r = [row["recalibrated"][p]["torque_rmse_mNm"] / ins[p]["torque_rmse_mNm"]
                 for p in ("whole", "closing")]
            ratios += r
            cells.append(f"{r[0]:.2f}x / {r[1]:.2f}x")
            left_out = row["calibration_leave_one_file_out"]
            lofo.append(" / ".join(f"{left_out[p]['torque_rmse_mNm']:.1f}"
                                   for p in ("whole", "closing")))
        extra = [n for n in c["per_session"]
                 if n not in ("pretension_torque", "torque_bias", "angle_offset")]
        what = "+ " + ", ".join(extra) if extra else "pretension and the two zeros"
        lines.append(f"| {label}: {what} (recalibrated / in session) | "
                     + " | ".join(cells) + f" | {max(ratios):.2f}x |")
        lines.append(f"| {label}: calibration, leave one file out | " + " | ".join(lofo) + " | |")
    kept = result["model"]["per_session"]
    lines += ["", f"Per-session values of the kept set ({', '.join(kept)}), re-estimated on "
              "each folder's 60 s; *at a bound*: the one rule of the roles table:", "",
              "| folder | " + " | ".join(kept) + " | at a bound |",
              "|---|" + "---|" * (len(kept) + 1)]
    for f in folders:
        entry = result["folders"][f]
        vals = entry["per_session"]
        lines.append(f"| {f} | " + " | ".join(f"{vals[n]:.4g}" for n in kept)
                     + f" | {', '.join(entry.get('per_session_at_bound', [])) or 'none'} |")
    return "\n".join(lines) + "\n"


def transmission_pitch_wrap_table(base: dict, *wraps: dict) -> str:
    """docs/identification.md section 4.1: the wrist pitch's capstan wrap terms
    (``--pitch-wrap antagonistic`` / ``symmetric``) against the default (both declared 0), per
    folder and protocol (jaw torque RMSE, whole / closing), the recalibrated / in-session
    ratios, and the fitted coefficients (in session: one per fold; then the LOCO fit's)."""
    def pair(d):
        return f"{d['whole']['torque_rmse_mNm']:.1f} / {d['closing']['torque_rmse_mNm']:.1f}"

    def coef(d):
        return "" if not d else f"{d['value']:+.3f} ({d['role']})"

    models = [("default", base)] + [(f"{w['pitch_wrap']} wrap", w) for w in wraps]
    lines = ["", "Jaw torque RMSE, mNm, whole files / closing portions; *default*: both terms "
             "declared 0; *antagonistic wrap*: `capstan_mu_pitch` free; *symmetric wrap*: "
             "`capstan_mu_abs_pitch` free. The freed coefficient (1/rad) is given per in-session "
             "fold, then for the leave-one-configuration-out (LOCO) fit.", "",
             "| folder | pitch (deg) | model | as is | recalibrated | in session | LOCO | "
             "recalibrated / in session | coefficient: in session; LOCO |",
             "|---|---|---|---|---|---|---|---|---|"]
    for folder, f0 in base["folders"].items():
        if "recalibrated" not in f0:
            continue
        pitch = next((w["folders"][folder].get("pitch_rad") for w in wraps), 0.0) or 0.0
        for label, res in models:
            f, v = res["folders"][folder], res["verdicts"][folder]
            ratio = " / ".join(f"{v[p]['ratio']:.2f}x" for p in ("whole", "closing"))
            coefs = ""
            if res is not base:
                coefs = ", ".join(coef(d) for d in f.get("in_session_pitch_wrap", []))
                if f.get("loco_pitch_wrap"):
                    coefs += "; " + coef(f["loco_pitch_wrap"])
            lines.append(f"| {folder} | {math.degrees(pitch):.0f} | {label} | "
                         f"{pair(f['as_is'])} | {pair(f['recalibrated'])} | "
                         f"{pair(f['in_session'])} | {pair(f['loco']) if 'loco' in f else ''} | "
                         f"{ratio} | {coefs} |")
    lines.append("")
    for label, res in models:
        misses = [f"{folder} ({p}: {v[p]['ratio']:.2f}x)"
                  for folder, v in res["verdicts"].items() for p in ("whole", "closing")
                  if not v[p]["within_goal"]]
        lines.append(f"- {label}: recalibrated within "
                     f"{res['goals']['recalibrated_over_in_session']:g}x of in session "
                     + (f"missed on {', '.join(misses)}." if misses else "on every folder."))
    return "\n".join(lines) + "\n"


_FINETUNE_VALIDATION = {
    "tail": "the last 20 % of each calibration file",
    "file": "the middle load's calibration file held out whole (a finetune that never improves "
            "on it keeps the weights it started from)",
}


def transmission_transfer_learned_tables(result: dict) -> str:
    """docs/identification.md section 4.1: every model on every folder, as is and recalibrated
    (jaw torque RMSE, whole / closing), and whether the hybrid is ahead of every learned
    model."""
    names = {"physics": "physics", "fcn": "FCN", "lstm": "LSTM", "transformer": "paper transformer",
             "rocket": "MultiRocket-Hydra", "hybrid": "hybrid",
             "hybrid_physics_recalibrated_only": "hybrid, physics recalibrated only",
             "hybrid_selected": "hybrid, residual kept where it helps"}
    seeds = result["seeds"]
    lines = ["", f"Seeds {seeds} (one seed: differences, not wins by the spread rule); inputs "
             f"{', '.join(result['inputs'])}; finetuning at most {result['finetune']['epochs']} "
             f"epochs or {result['finetune']['time_limit_s']:g} s, early-stopped on "
             + _FINETUNE_VALIDATION[result["finetune"].get("validation", "tail")]
             + ". Jaw torque RMSE, mNm, whole files / closing portions.", ""]
    summary = result["summary"]
    learned = [m for m in ("fcn", "lstm", "transformer", "rocket") if m in result["models"]]
    ahead_misses = {"hybrid": [], "hybrid_selected": []}
    for protocol, title in (("in_session", "in session (L_4's held-out files)"),
                            ("as_is", "as is"), ("recalibrated", "recalibrated on 60 s")):
        models = [m for m in names if any(m in summary[f].get(protocol, {}) for f in summary)]
        lines += [f"**{title}**", "", "| folder | " + " | ".join(names[m] for m in models) + " |",
                  "|---|" + "---|" * len(models)]
        for folder in summary:
            row = summary[folder].get(protocol)
            if not row:
                continue
            cells = []
            for m in models:
                if m not in row:
                    cells.append("")
                    continue
                w, c = row[m]["whole"]["torque_rmse_mNm"], row[m]["closing"]["torque_rmse_mNm"]
                cells.append(f"{w['mean']:.1f} / {c['mean']:.1f}")
            lines.append(f"| {folder} | " + " | ".join(cells) + " |")
            for hybrid, misses in ahead_misses.items():
                # as is there is nothing to select on: the selected hybrid is the hybrid
                shown = hybrid if protocol == "recalibrated" else "hybrid"
                if shown not in row or protocol == "in_session":
                    continue
                for part in ("whole", "closing"):
                    h = row[shown][part]["torque_rmse_mNm"]["mean"]
                    best = min(((row[m][part]["torque_rmse_mNm"]["mean"], m) for m in learned
                                if m in row), default=None)
                    if best and h >= best[0]:
                        misses.append(f"{folder} {protocol} {part} ({names[best[1]]} "
                                      f"{best[0]:.1f} against {h:.1f})")
        lines.append("")
    cut = {}
    for r in result["records"]:
        if r["protocol"] == "recalibrated" and r.get("fit", {}).get("stopped_by") == "time_limit":
            cut[r["model"]] = cut.get(r["model"], 0) + 1
    if cut:
        lines.append("Finetunes stopped by the time limit before early stopping (not converged): "
                     + ", ".join(f"{names[m]} {n} of {len(summary) - 1}"
                                 for m, n in sorted(cut.items())) + ".")
    kept = [(r["folder"], r["selection"]["kept"]) for r in result["records"]
            if r["model"] == "hybrid_selected"]
    for hybrid, title in (("hybrid", "The hybrid"),
                          ("hybrid_selected", "The hybrid with its residual kept where it "
                                              "helps (as is, the hybrid)")):
        if hybrid == "hybrid_selected" and not kept:
            continue
        misses = ahead_misses[hybrid]
        lines.append(f"{title} below every learned model on every transfer protocol: "
                     + (f"missed on {'; '.join(misses)}." if misses else "met.") + "")
    if kept:
        lines += ["", "Kept by the recalibration (" + result["selection"] + "): "
                  + "; ".join(f"{folder} {what}" for folder, what in kept) + "."]
    return "\n".join(lines) + "\n"


def lateral_crosstalk_table(*results: dict) -> str:
    """The identification with the sensor's lateral cross-talk in the law (the last of
    ``results``, a study JSON run with ``--crosstalk full``) beside the same runs with the
    axial column only (the others: the committed JSONs of the same study, matched by seed and
    case; a run they lack is marked so): per run, the misses of each; each parameter either one
    misses, fitted with the axial column / with every column, against the bench's value and,
    where the run judged it so, the truth as the law held it (the projection); and what became
    of the lateral terms (identified, or held at the design's 0 as not identifiable)."""
    from psmforce.identification.prior_law import CROSSTALK_LATERAL
    *axial_results, full = results
    axial = {(r["seed"], r["case"]): r for res in axial_results for r in res["runs"]}
    lines = ["", f"`{full['command']}`{rescored_note(full)} beside the same seeds and cases "
             "with the axial column only (" + ", ".join(f"`{r['command']}`"
                                                        for r in axial_results)
             + f"). A MISS is a parameter identified but {miss_rule(full['runs'][0])}. Missed "
             "parameters: the fit with the axial column / with every column, then the bench's "
             "value, and in brackets the truth as each run's held law carries it where the run "
             "judged it so.", "",
             "| seed | case | misses, axial column | misses, every force column | "
             "missed parameters | lateral terms identified | "
             "lateral terms held (not identifiable) |", "|---|---|---|---|---|---|---|"]

    def value(run, name):
        r = (run or {}).get("parameters", {}).get(name)
        return None if r is None else (r["fitted"], r.get("effective_truth"))

    for run in full["runs"]:
        before = axial.get((run["seed"], run["case"]))
        missed = list(dict.fromkeys([*(before or {}).get("misses", []), *run["misses"]]))
        cells = []
        for name in missed:
            (a, a_held), (f, f_held) = (value(before, name) or (None, None)), value(run, name)
            truth = run["parameters"][name]["truth"]
            held = ", ".join(f"{x:.4g}" if x is not None else "—" for x in (a_held, f_held))
            cells.append(f"{name} {'—' if a is None else f'{a:.4g}'} / {f:.4g}, bench "
                         f"{'—' if truth is None else f'{truth:.4g}'}"
                         + ("" if a_held is None and f_held is None else f" (as held {held})"))
        rows = run["parameters"]
        kept = [n for n in CROSSTALK_LATERAL if rows[n]["status"] == "identified"]
        held = [n for n in CROSSTALK_LATERAL if rows[n]["status"] != "identified"]
        lines.append(f"| {run['seed']} | {run['case']} | "
                     + ("not run" if before is None else ", ".join(before["misses"]) or "none")
                     + f" | {', '.join(run['misses']) or 'none'} | {'; '.join(cells) or '—'}"
                     f" | {', '.join(n.removeprefix('crosstalk_') for n in kept) or 'none'}"
                     f" | {', '.join(n.removeprefix('crosstalk_') for n in held) or 'none'} |")
    return "\n".join(lines + [""])
