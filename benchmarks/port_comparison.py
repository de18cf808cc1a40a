"""Issue 13's targets, read from ``psmforce reproduce`` runs without a port and through ports.

    python benchmarks/port_comparison.py --runs none=DIR cannula=DIR abdominal-wall=DIR
        [--json OUT.json]

Each ``DIR`` is the ``--out`` of ``psmforce reproduce --port NAME`` at the same scale and seeds
(``none``: the calibrated bench without a port; the run's ``results.json`` is read, nothing is
retrained). Prints, per port and model, the automated test set's causal NRMSE % (mean ± std over
seeds) and its ratio to the same model's no-port value, then checks the targets:

* on the calibrated bench without a port, the hybrid's causal NRMSE <= 0.6x the converged paper
  transformer's on every axis;
* through the cannula, the hybrid's Fz NRMSE within 1.5x of its no-port value, while every
  torque-only estimator (the LSTM) degrades by more.

A target whose models are missing from a run is reported as not measured, never as met.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from hybrid.metrics import AXES
from hybrid.recipes import recipe
from _report import write_json

HYBRID, TRANSFORMER, TORQUE_ONLY = (recipe(m).label for m in ("hybrid", "transformer", "lstm"))


def _table(run: Path) -> dict[str, dict[str, tuple[float, float]]]:
    """{model label: {axis: (mean, std) causal NRMSE %}} of a reproduce run's automated set."""
    results = json.loads((run / "results.json").read_text())
    return {label: {a: (m[a]["nrmse_pct"]["mean"], m[a]["nrmse_pct"]["std"]) for a in AXES}
            for label, m in results["automated"]["causal"].items()} | {
        "_call": results["call"], "_converged": results["all_converged"]}


def _targets(tables: dict) -> dict:
    none, cannula = tables.get("none", {}), tables.get("cannula", {})
    out = {}
    if HYBRID in none and TRANSFORMER in none:
        ratios = {a: none[HYBRID][a][0] / none[TRANSFORMER][a][0] for a in AXES}
        out["hybrid <= 0.6x transformer, no port"] = {
            "ratio": ratios, "met": all(r <= 0.6 for r in ratios.values())}
    else:
        out["hybrid <= 0.6x transformer, no port"] = {"met": None, "why": "models missing"}
    if all(m in run for run in (none, cannula) for m in (HYBRID, TORQUE_ONLY)):
        hyb = cannula[HYBRID]["Fz"][0] / none[HYBRID]["Fz"][0]
        lstm = cannula[TORQUE_ONLY]["Fz"][0] / none[TORQUE_ONLY]["Fz"][0]
        out["cannula: hybrid Fz within 1.5x, LSTM degrades more"] = {
            "hybrid_ratio": hyb, "lstm_ratio": lstm, "met": hyb <= 1.5 and lstm > hyb}
    else:
        out["cannula: hybrid Fz within 1.5x, LSTM degrades more"] = {"met": None,
                                                                       "why": "models missing"}
    return out


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", nargs="+", required=True, metavar="PORT=DIR")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    runs = dict(item.split("=", 1) for item in args.runs)
    if "none" not in runs:
        raise SystemExit("--runs needs none=DIR: every ratio is to the no-port run")
    tables = {port: _table(Path(d)) for port, d in runs.items()}
    calls = {port: {k: t["_call"][k] for k in ("scale", "seeds", "budget")}
             for port, t in tables.items()}
    if len({json.dumps(c, sort_keys=True) for c in calls.values()}) != 1:
        raise SystemExit(f"the runs differ in scale, seeds or budget: {calls}")
    rows = {}
    print("automated test set, causal NRMSE % (mean ± std over seeds; x = ratio to no port)")
    for port, table in tables.items():
        print(f"  port {port}{'' if table['_converged'] else '  (NOT all converged)'}")
        for label, axes in table.items():
            if label.startswith("_"):
                continue
            base = tables["none"].get(label)
            rows.setdefault(port, {})[label] = {
                a: {"mean": axes[a][0], "std": axes[a][1],
                    "ratio_to_no_port": axes[a][0] / base[a][0] if base else None} for a in AXES}
            print(f"    {label:22s} " + "  ".join(
                f"{a} {axes[a][0]:6.2f} ± {axes[a][1]:4.2f}"
                + (f" (x{axes[a][0] / base[a][0]:.2f})" if base and port != "none" else "")
                for a in AXES))
    targets = _targets(tables)
    for name, t in targets.items():
        verdict = {True: "MET", False: "NOT MET", None: "NOT MEASURED"}[t["met"]]
        print(f"  target {name}: {verdict}  "
              + json.dumps({k: v for k, v in t.items() if k != "met"}, default=float))
    result = {"runs": runs, "call": calls["none"],
              "all_converged": {p: t["_converged"] for p, t in tables.items()},
              "causal_nrmse_pct": rows, "targets": targets}
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
