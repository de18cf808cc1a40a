"""The blocks of ``docs/simulator.md``, rendered from the cable-law comparison's JSON
(``results/benchmarks/sim_calibration_cable_law.json``, ``studies/sim_calibration.py
--cable-law``)."""

from __future__ import annotations

FIGURE_NAMES = {
    "kinematic_ratio": "kinematic ratio n",
    "loop_width_fraction": "loop width / output stroke",
    "friction_load_slope": "friction-load slope dF/dL",
    "friction_frequency_ratio": "friction, high / low frequency",
    "compliance_fraction": "compliance x full load / output stroke",
    "zero_load_friction_fraction": "zero-load friction / full load",
}


def _short(name: str) -> str:
    return name.replace("Tool_", "T").replace("_Maryland_L", "")


def _num(v, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}g}"


def _ratio(v) -> str:
    return "n/a" if v is None else f"{v:.2f}"


def cable_law_tables(result: dict) -> str:
    """Per folder the real figures, the ratios sim / real of the default and the calibrated
    simulator versions, the rule per figure, and the calibrated version's parameters."""
    c = result["cable_law"]
    default, calibrated = c["default_version"], c["calibrated_version"]
    figures, checked = c["figures"], c["checked_figures"]
    names = list(c["sessions"])
    lines = ["", "**Real figures per folder** (the real folders' own spread in the last row):", "",
             "| folder | roll, pitch (deg) | runs | Hz | " + " | ".join(FIGURE_NAMES[k] for k in figures)
             + " | zero-load friction (Nm at the jaw) |",
             "|---|---|---|---|" + "---|" * (len(figures) + 1)]
    for n in names:
        s = c["sessions"][n]
        pose = s["pose"]
        hz = s["real"]["frequencies_hz"]
        lines.append(f"| {_short(n)} | {pose['roll_rad'] * 57.29578:.0f}, "
                     f"{pose['pitch_rad'] * 57.29578:.0f} | {s['runs']} | "
                     + (f"{hz[0]:g}" if hz[0] == hz[1] else f"{hz[0]:g}-{hz[1]:g}") + " | "
                     + " | ".join(_num(s["table"][k]["real"]) for k in figures)
                     + f" | {s['real']['zero_load_friction_nm']:.3f} |")
    across = c["across_folders"][calibrated]
    spread = ["" if k not in across or across[k]["rule"] == "not measurable"
              else f"{across[k]['real_min']:.3g}..{across[k]['real_max']:.3g} "
                   f"(x{across[k]['real_spread']:.2f})" for k in figures]
    f0 = [c["sessions"][n]["real"]["zero_load_friction_nm"] for n in names]
    lines.append("| *spread (min..max)* | | | | " + " | ".join(spread)
                 + f" | {min(f0):.3f}..{max(f0):.3f} (x{max(f0) / min(f0):.2f}) |")

    lines += ["", f"**Ratios sim / real per folder**, simulator {default} (the default) → "
                  f"**{calibrated}** (the calibrated cable law); *miss* marks a {calibrated} ratio "
                  f"outside [{c['ratio_range'][0]}, {c['ratio_range'][1]}]:", "",
              "| folder | " + " | ".join(FIGURE_NAMES[k] for k in figures) + " |",
              "|---|" + "---|" * len(figures)]
    for n in names:
        t = c["sessions"][n]["table"]
        cells = []
        for k in figures:
            a, b = t[k][f"ratio_{default}"], t[k][f"ratio_{calibrated}"]
            if b is None:
                cells.append("n/a (one frequency)")
                continue
            miss = k in checked and not t[k][f"ok_{calibrated}"]
            cells.append(f"{_ratio(a)} → **{_ratio(b)}**" + (" *miss*" if miss else ""))
        lines.append(f"| {_short(n)} | " + " | ".join(cells) + " |")
    rule_cells = []
    for k in figures:
        if k not in checked:
            rule_cells.append("geometry: no rule")
            continue
        a, a0 = across[k], c["across_folders"][default][k]
        rule = ("band" if a["rule"] == "band" else
                "band, or sim within the real spread")
        rule_cells.append(f"{rule}: **{'met' if a['met'] else 'NOT met'}** "
                          f"({default}: {'met' if a0['met'] else 'not met'})")
    lines.append("| *rule* | " + " | ".join(rule_cells) + " |")

    misses = [f"{_short(n)} {FIGURE_NAMES[k]} ({c['sessions'][n]['table'][k][f'ratio_{calibrated}']:.3f}"
              + (", inside the real spread" if across[k]["folders"][n].get("sim_in_real_spread")
                 else ", outside the real spread") + ")"
              for k in checked for n in names
              if c["sessions"][n]["table"][k][f"ok_{calibrated}"] is False]
    lines += ["", f"Simulator {calibrated} meets the rule on every folder and checked figure: "
                  f"**{'yes' if c['cable_law_ok'] else 'no'}**; ratios outside the band: "
                  + ("; ".join(misses) if misses else "none") + ". Simulator "
                  f"{default}: {'met' if c['met'][default] else 'not met'}."]

    lines += ["", f"**Parameters** of the cable law, simulator {default} → {calibrated} "
                  "(`psmforce/sim/versions.py`; every other parameter is the same):", "",
              f"| parameter | {default} | {calibrated} |", "|---|---|---|"]
    changed = c["versions"][calibrated]
    base = c.get("default_values", {})
    for k, v in changed.items():
        lines.append(f"| `{k}` | {_num(base.get(k), 4)} | {_num(v, 4)} |")
    if "fit" in c:
        fit = c["fit"]
        lines += ["", f"Fit (`--fit`, from {fit['start_version']}, {fit['evaluations']} evaluations): "
                      f"objective {fit['objective']:.3f} (squared log ratios, plus "
                      f"{fit['band_penalty']:g}x their squared excess beyond the band), largest "
                      f"|log ratio| {fit['max_abs_log_ratio']:.3f}; fitted "
                      + ", ".join(f"`{k}` {v:.4g}" for k, v in fit["fitted"].items()) + "."]
    sens = c["load_scale_sensitivity"]
    lines += ["", f"Load-scale sensitivity ({c['load_scale_sensitivity_version']}, "
                  "Tool_4_Maryland_L_4, ratios): "
                  + "; ".join(f"factor {f}: " + ", ".join(
                      f"{FIGURE_NAMES[k]} {_num(v, 2)}" for k, v in r.items() if k in checked)
                      for f, r in sens.items()) + "."]
    return "\n".join(lines) + "\n"
