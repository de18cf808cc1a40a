"""Render the real-EndoWrist transmission tables of docs/identification.md from the committed
``results/benchmarks/transmission.json`` (written by ``benchmarks/transmission.py``).

    python benchmarks/transmission_report.py            # rewrite the block in the docs
    python benchmarks/transmission_report.py --check    # exit 1 if the docs differ from the JSON

The block sits between :data:`BEGIN` and :data:`END`; nothing outside it is touched, and no
figure inside it is typed by hand (``tests/test_transmission_report.py`` holds the two equal).
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
BEGIN = "<!-- transmission-tables: rendered by benchmarks/transmission_report.py -->"
END = "<!-- end transmission-tables -->"
MODEL_NAMES = {"physics": "physics alone (`CableTransmission`)", "fcn": "FCN",
               "lstm": "LSTM", "transformer": "paper transformer",
               "rocket": "MultiRocket-Hydra", "hybrid": "hybrid (physics + causal residual)",
               "fcn+spindle": "FCN + input-spindle torque sensor (reference: a robot has none)"}


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


def splice(doc: str, block: str) -> str:
    """``doc`` with its rendered block replaced by ``block``."""
    if doc.count(BEGIN) != 1 or doc.count(END) != 1:
        raise SystemExit(f"{DOC.name}: expected one '{BEGIN}' and one '{END}' marker")
    head, rest = doc.split(BEGIN)
    return head + block + rest.split(END, 1)[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare, write nothing")
    args = ap.parse_args(argv)
    rendered = splice(DOC.read_text(), render(json.loads(RESULT.read_text())))
    if args.check:
        same = rendered == DOC.read_text()
        print("docs match the JSON" if same else f"{DOC} differs from {RESULT}: rerun this script")
        return 0 if same else 1
    write_text_atomic(DOC, rendered)
    return 0


if __name__ == "__main__":
    sys.exit(main())
