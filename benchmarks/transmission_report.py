"""Render the real-EndoWrist transmission tables of docs/identification.md from the committed
``results/benchmarks/transmission.json`` (written by ``benchmarks/transmission.py``).

    python benchmarks/transmission_report.py            # rewrite the blocks in the docs
    python benchmarks/transmission_report.py --check    # exit 1 if a page differs from the JSON

Two blocks, each between its markers: the tables in docs/identification.md section 4
(:func:`render`) and the summary in the README (:func:`render_summary`). Nothing outside them is
touched, and no figure inside them is typed by hand (``tests/test_transmission_report.py``
holds each page equal to what the committed JSON renders).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psm_model.files import write_text_atomic  # noqa: E402

RESULT = ROOT / "results" / "benchmarks" / "transmission.json"
DOC = ROOT / "docs" / "identification.md"
README = ROOT / "README.md"
BEGIN = "<!-- transmission-tables: rendered by benchmarks/transmission_report.py -->"
END = "<!-- end transmission-tables -->"
SUMMARY_BEGIN = "<!-- transmission-summary: rendered by benchmarks/transmission_report.py -->"
SUMMARY_END = "<!-- end transmission-summary -->"
MODEL_NAMES = {"physics": "physics alone (`CableTransmission`)", "fcn": "FCN",
               "lstm": "LSTM", "transformer": "paper transformer",
               "rocket": "MultiRocket-Hydra", "hybrid": "hybrid (physics + causal residual)",
               "fcn+spindle": "FCN + input-spindle torque sensor (reference: a robot has none)",
               "hybrid_no_physics": "the hybrid's network without the physics (ablation)"}
LEARNED_BASELINES = ("fcn", "lstm", "transformer", "rocket")


def _cell(d: dict, digits: int = 2) -> str:
    return f"{d['mean']:.{digits}f} ± {d['std']:.{digits}f}"


def render(result: dict) -> str:
    """The Markdown block for ``result`` (a transmission.json)."""
    pub = result["published"]
    lines = [BEGIN, "",
             f"Command: `{result['run']['command']}` ({result['run']['seconds'] / 60:.0f} min); "
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
                                + (f", a {v['verdict']} with {MODEL_NAMES.get(v['runner_up'])}"
                                   if "verdict" in v else ""))
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
                  "", "| parameter | value | unit | bounds | relative sd |", "|---|---|---|---|---|"]
        for name, p in t["torque"].items():
            rel = "fixed" if name in t["fixed"] else (f"{sd[name]:.2g}" if name in sd else "")
            lines.append(f"| {name} | {p['value']:.4g} | {p['unit']} | "
                         f"[{p['lower']:g}, {p['upper']:g}] | {rel} |")
        for name, value in t["angle"].items():
            lines.append(f"| {name} (angle path) | {value:.4g} | | | exact least squares |")
        lines += ["", f"Widths chosen on validation: pre-sliding {t['presliding_rad']:g} rad, "
                  f"hold {t['hold_rad']:g} rad, backlash {t['backlash_rad']:g} rad."
                  + (f" Tied: {t['info']['tied']}." if t["info"].get("tied") else ""), ""]
    lines.append(END)
    return "\n".join(lines)


def render_summary(result: dict) -> str:
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
            f"section 4) the identified physics model alone gives {fig('physics')}, the best "
            f"learned baseline ({MODEL_NAMES[best]}) {fig(best)}, and the hybrid, a causal "
            f"residual network on the physics, {fig('hybrid')}")
    if "hybrid_no_physics" in held:
        text += (f"; the same network without the physics gives {fig('hybrid_no_physics')}, "
                 "which is what the physics adds to the learning")
    text += (f" (mean over seeds {result['seeds']}; published on this data, "
             f"{pub['jaw_torque_rmse_mNm']} mNm / {pub['jaw_angle_rmse_deg']} deg on a random "
             "sample split). Other sessions and instruments, as is and calibrated: the tables "
             "there.")
    return "\n".join([SUMMARY_BEGIN, text, SUMMARY_END])


def splice(doc: str, block: str, begin: str = BEGIN, end: str = END) -> str:
    """``doc`` with its block between ``begin`` and ``end`` replaced by ``block`` (which carries
    the markers)."""
    if doc.count(begin) != 1 or doc.count(end) != 1:
        raise SystemExit(f"expected one '{begin}' and one '{end}' marker")
    head, rest = doc.split(begin)
    return head + block + rest.split(end, 1)[1]


def pages(result: dict) -> dict[Path, str]:
    """Each page as the JSON renders it."""
    return {DOC: splice(DOC.read_text(), render(result)),
            README: splice(README.read_text(), render_summary(result), SUMMARY_BEGIN,
                           SUMMARY_END)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare, write nothing")
    args = ap.parse_args(argv)
    rendered = pages(json.loads(RESULT.read_text()))
    stale = [p for p, text in rendered.items() if text != p.read_text()]
    if args.check:
        for p in stale:
            print(f"{p.relative_to(ROOT)} differs from {RESULT.relative_to(ROOT)}: rerun "
                  "benchmarks/transmission_report.py")
        return 1 if stale else 0
    for p in stale:
        write_text_atomic(p, rendered[p])
    return 0


if __name__ == "__main__":
    sys.exit(main())
