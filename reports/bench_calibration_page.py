"""The bench-paper calibration block of docs/simulator.md (issue 45), from
``results/benchmarks/bench_paper_calibration.json`` (written by
``studies/bench_paper_calibration.py``): per simulator version tried, each calibration model's
paper-metric NRMSE per axis on the bench against the paper's figure for its family, the ratio
and whether it lies in the band.

Block name: ``bench-paper-calibration``."""

from __future__ import annotations

AXES = ("Fx", "Fy", "Fz")
MODEL_ORDER = ("fcn", "lstm", "rocket", "transformer")


def _fmt(values: dict, pattern: str = "{:.2f}") -> str:
    return " / ".join(pattern.format(values[a]) for a in AXES)


SHOWN_CHANGES = ("roll_backlash_rad", "hex10_readout_lag_s", "hex10_thermal_drift_n",
                 "hex10_thermal_time_s", "cable_crossing_angle_rad")
"""The 2.3 parameters a version's heading lists (2.2's cable-law values are common to all)."""
REGISTERED = {"2.1": "the default version, no 2.3 effect, no 2.2 cable law",
              "2.2": "2.2's cable law alone"}


def _definition_line(name: str, definition: dict | None, note: str | None) -> str:
    if name in REGISTERED:
        return f"**{name}** ({REGISTERED[name]})"
    if not definition:
        return f"**{name}**"
    changes = ", ".join(f"`{k}` {definition['changes'][k]:g}" for k in SHOWN_CHANGES
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
    line = (f"The paper's transformer (held out, scale {check['scale']:g}{budget}, seeds "
            f"{', '.join(map(str, check['seeds']))}): {_fmt(check['ratio'], '{:.2f}x')}, "
            f"{state}. ")
    if isinstance(lateral, str):
        return line + f"The FCN worse than it laterally: {lateral}."
    ratio = lateral["fcn_over_transformer"]
    robot = {a: paper["fcn"]["nrmse_pct"][a] / paper["transformer"]["nrmse_pct"][a]
             for a in ("Fx", "Fy")}
    return line + (f"The FCN over the transformer, Fx / Fy: {ratio['Fx']:.2f}x / "
                   f"{ratio['Fy']:.2f}x (the robot's {robot['Fx']:.2f}x / {robot['Fy']:.2f}x): "
                   + ("worse laterally, as on the robot." if lateral["met"] else
                      "not worse on both lateral axes, unlike the robot."))


def lines(result: dict) -> list[str]:
    """The block's markdown lines: per version tried (in the order tried), a table model x
    scale: bench, paper, ratio, in band, RMSE and test range; its verdict; the 2.1 reference
    and the held-out check's status."""
    if not result.get("rows"):
        return ["", "No calibration run yet.", ""]
    low, high = result.get("band", (0.67, 1.5))
    paper = result["paper"]
    out = ["", f"Paper metric (bias over the first 0.5 s, centred median of 71 samples), NRMSE % "
           f"on the automated test set, against the paper's Table III figure of each model's "
           f"family; in band: bench / paper in [{low:g}, {high:g}]. Calibration models only "
           f"(FCN, LSTM, MultiRocket-Hydra), design seeds only; the paper's transformer is the "
           f"held-out check and the hybrid is not looked at. Versions in the order tried.", ""]
    names = list(dict.fromkeys(r["candidate"] for r in result["rows"]))
    names.sort(key=lambda n: (n not in REGISTERED, n == "2.3", n))
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
        mine.sort(key=lambda r: (MODEL_ORDER.index(r["model"]) if r["model"] in MODEL_ORDER
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


def bench_paper_calibration(result: dict) -> str:
    """The ``bench-paper-calibration`` block (render function for ``reports/render.py``)."""
    return "\n".join(lines(result))
