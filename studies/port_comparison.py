"""Issue 13's targets, read from ``psmforce reproduce`` runs without a port and through ports.

    python studies/port_comparison.py --runs none=DIR cannula=DIR abdominal-wall=DIR
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

``--channels``: also score, per port, the axial channels a model can build Fz from, without any
network (same benches, the run's own prior, causal metric, mean ± std over seeds). They bound
what an estimator built on one of them can reach:

* ``insertion_fz``: the insertion effort minus the identified stage model (the hybrid's z base);
* ``comp_fz``: the HEX10 axial force minus the prior's internal force;
* ``complementary``: ``insertion_fz`` below a crossover plus ``comp_fz`` above it (first-order
  pair), the crossover picked on the validation trials from :data:`CROSSOVERS_HZ`;
* ``perfect stage model``: the ATI truth plus the insertion effort's disturbance as the bench
  draws it (white + coloured, ``psmforce.sim.drive``; parameters from the run's metadata, a
  fresh draw seeded by the bench seed): what the insertion channel gives when everything else
  in it (stage dynamics, friction, a port) is modelled exactly;
* ``..., best fixed filter``: ``insertion_fz`` and the perfect stage model through the causal
  filter (:func:`_fixed_filters`: notches at the stage mode, low-passes) that scores best on the
  validation trials.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy import signal

from psmforce.estimators.data.dataset import load_dataset, split_validation
from psmforce.estimators.evaluation.evaluate import score
from psmforce.estimators.data.hybrid_inputs import add_prior_columns
from psmforce.estimators.evaluation.metrics import AXES
from psmforce.estimators.evaluation.tables import spread_text, std_over_seeds
from psmforce.experiments.plan import plan
from psmforce.identification import InternalForcePrior
from psmforce.io.recording import TARGETS
from psmforce.sim import drive
from psmforce.sim.params import InstrumentParams
from psmforce.experiments.report import write_json

HYBRID, TRANSFORMER, TORQUE_ONLY = (plan(m).label for m in ("hybrid", "transformer", "lstm"))


def _table(run: Path) -> dict[str, dict[str, tuple[float, float]]]:
    """{model label: {axis: (mean, std) causal NRMSE %}} of a reproduce run's automated set."""
    results = json.loads((run / "results.json").read_text())
    return {label: {a: (m[a]["nrmse_pct"]["mean"], m[a]["nrmse_pct"]["std"]) for a in AXES}
            for label, m in results["automated"]["causal"].items()} | {
        "_call": results["call"], "_converged": results["all_converged"]}


CROSSOVERS_HZ = (0.3, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0)
"""Candidate crossovers of the complementary channel (picked on validation)."""


def _filtered(x: np.ndarray, sos: np.ndarray) -> np.ndarray:
    """``x`` through ``sos``, causal, started at steady state on its first sample."""
    return signal.sosfilt(sos, x, zi=signal.sosfilt_zi(sos) * x[0])[0]


def _complementary(trial, crossover_hz: float, rate_hz: float) -> np.ndarray:
    """``insertion_fz`` low-passed plus ``comp_fz`` high-passed (first order), causal."""
    sos = signal.butter(1, crossover_hz, fs=rate_hz, output="sos")
    insertion, hex10 = (trial.frame[c].to_numpy() for c in ("insertion_fz", "comp_fz"))
    return _filtered(insertion, sos) + hex10 - _filtered(hex10, sos)


def _fixed_filters(params: InstrumentParams, rate_hz: float) -> dict[str, np.ndarray]:
    """Candidate causal filters (second-order sections) of an axial channel: notches at the
    insertion stage's mode (``insertion_resonance_hz``, 12 Hz from WPI) and low-passes."""
    f0 = params.insertion_resonance_hz
    out = {f"notch {f0:g} Hz, Q {q:g}": signal.tf2sos(*signal.iirnotch(f0, q, fs=rate_hz))
           for q in (0.7, 1.0, 2.0)}
    return out | {f"low-pass {fc:g} Hz": signal.butter(2, fc, fs=rate_hz, output="sos")
                  for fc in (2.0, 4.0, 6.0, 8.0, 12.0)}


def _best_filtered(val, test, fz, filters: dict) -> tuple[float, str]:
    """(test NRMSE, name) of ``fz`` through the filter that scores best on ``val``."""
    name = min(filters, key=lambda k: _fz_nrmse(val, lambda t: _filtered(fz(t), filters[k])))
    return _fz_nrmse(test, lambda t: _filtered(fz(t), filters[name])), name


def _fz_nrmse(trials, fz) -> float:
    """Causal Fz NRMSE % of the per-trial axial estimates ``fz(trial)``."""
    def with_fz(t):
        est = t.matrix(TARGETS, np.float64)
        est[:, 2] = fz(t)
        return est
    return score({t.path: with_fz(t) for t in trials}, trials, mode="causal")["Fz"]["nrmse_pct"]


def _channels_of_bench(data_dir: Path, prior_json: Path, seed: int) -> dict[str, float]:
    ds = load_dataset(data_dir)
    add_prior_columns(ds, InternalForcePrior.load(prior_json))
    _, val = split_validation(ds.select(split="train"), 0.1, seed)   # reproduce's split
    test = ds.select(split="test")
    rate_hz = ds.metadata["sample_rate_hz"]
    crossover = min(CROSSOVERS_HZ,
                    key=lambda f: _fz_nrmse(val, lambda t: _complementary(t, f, rate_hz)))
    out = {"insertion_fz": _fz_nrmse(test, lambda t: t.frame["insertion_fz"].to_numpy()),
           "comp_fz": _fz_nrmse(test, lambda t: t.frame["comp_fz"].to_numpy()),
           "complementary": _fz_nrmse(test, lambda t: _complementary(t, crossover, rate_hz)),
           "complementary_crossover_hz": crossover}
    params = InstrumentParams.from_dict(ds.metadata["instrument"])
    filters = _fixed_filters(params, rate_hz)
    out["insertion_fz, best fixed filter"], out["insertion_fz filter"] = _best_filtered(
        val, test, lambda t: t.frame["insertion_fz"].to_numpy(), filters)
    if ds.metadata["effects"].get("coloured_effort_noise"):
        rng = np.random.default_rng(seed)
        perfect = {t.path: t.matrix(TARGETS, np.float64)[:, 2]
                   + params.effort_noise[2] * rng.standard_normal(len(t))
                   + drive.coloured_disturbance(len(t), 1.0 / rate_hz, params, rng)[:, 2]
                   for t in val + test}
        out["perfect stage model"] = _fz_nrmse(test, lambda t: perfect[t.path])
        out["perfect stage model, best fixed filter"], out["perfect stage model filter"] = \
            _best_filtered(val, test, lambda t: perfect[t.path], filters)
    return out


def _channels(run: Path, seeds) -> dict[str, dict[str, float]]:
    """{channel: {mean, std}} over the run's bench seeds (module docstring, ``--channels``); std
    the sample standard deviation (ddof 1; None for one seed,
    :func:`psmforce.estimators.evaluation.tables.std_over_seeds`)."""
    per_seed = [_channels_of_bench(run / "work" / "data" / f"automated_seed{s}",
                                   run / "work" / "data" / f"prior_seed{s}.json", s) for s in seeds]
    return {k: [p[k] for p in per_seed] if isinstance(per_seed[0][k], str) else
            {"mean": float(np.mean([p[k] for p in per_seed])),
             "std": std_over_seeds([p[k] for p in per_seed])} for k in per_seed[0]}


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
    ap.add_argument("--channels", action="store_true",
                    help="also score the axial channels without a network (module docstring)")
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
                f"{a} {spread_text({'mean': axes[a][0], 'std': axes[a][1]})}"
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
    if args.channels:
        print("axial channels without a network, causal Fz NRMSE % (mean ± std over seeds)")
        result["axial_channels_fz_nrmse_pct"] = {}
        for port, d in runs.items():
            ch = _channels(Path(d), calls[port]["seeds"])
            result["axial_channels_fz_nrmse_pct"][port] = ch
            print(f"  port {port}")
            for k, v in ch.items():
                print(f"    {k:40s} " + (", ".join(v) if isinstance(v, list)
                                          else spread_text(v)))
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
