"""The blocks of ``docs/identification.md``, rendered from the committed JSONs that measured them
(registered in :data:`reports.render.BLOCKS`): the real EndoWrist's transmission
benchmark and the prior's parameter recovery on the bench."""

from __future__ import annotations

from reports.cells import spread_cell

MODEL_NAMES = {"physics": "physics alone (`CableTransmission`)", "fcn": "FCN",
               "lstm": "LSTM", "transformer": "paper transformer",
               "rocket": "MultiRocket-Hydra", "hybrid": "hybrid (physics + causal residual)",
               "fcn+spindle": "FCN + input-spindle torque sensor (reference: a robot has none)",
               "hybrid_no_physics": "the hybrid's network without the physics (ablation)"}


LEARNED_BASELINES = ("fcn", "lstm", "transformer", "rocket")


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
