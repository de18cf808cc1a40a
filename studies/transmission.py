"""Learned models against physics on a real EndoWrist cable transmission (MRD Lab bench of
O'Neill et al., RA-L 2018; ``../shared/data/mrdlab``, read by
:mod:`psmforce.identification.transmission.recording`).

    python studies/transmission.py --seeds 1 2 3 --jobs 2      # full run, resumable
    python studies/transmission.py --quick --models physics fcn --json OUT.json   # smoke run

Inputs (every learned model): motor current [A], motor angle [rad at the input spindle] and
velocity [rad/s], causal, at 100 Hz (the loader's default), each session homed once
(``home_session``). Outputs: jaw torque [Nm] and jaw angle [rad], both, standard-scaled with the
training statistics. Every estimate is causal (sample t reads inputs up to t; no post-filter).

Protocols:

* (a) ``Tool_4_Maryland_L_4``, held-out files: test = frequency index 2 or load index 5
  (14 files); validation (early stopping, ridge penalty) = load index 2 with frequency index != 2
  (4 files); train = the other 32.
* (b) the models of (a) on all 20 files of ``Tool_4_Maryland_L_2`` (another session).
* (c) ``Tool_5_Maryland_L_2`` (another instrument): test = all files but 01, 22, 43; "as is" =
  the models of (a); "calibrated" = each model adapted on 01, 22, 43 (3 x 20 s): networks
  finetuned (all weights, LR 1e-4, the same early stopping) on the first 80 % of each file, the
  last 20 % their validation; MultiRocket's ridge refitted towards its head; the physics model
  ``CableTransmission.fit(calib, initial=model)`` on the three whole files; the hybrid refits
  the physics, then finetunes its residual network.

Models: physics (``CableTransmission``, deterministic: one fit, no seeds), FCN, LSTM, the paper's
transformer, MultiRocket-Hydra, hybrid = physics + causal residual transformer
(:mod:`psmforce.experiments.transmission_networks`; design choices on (a)'s validation files:
:data:`DESIGN`), each learned model over ``--seeds``; training capped at 150 epochs, finetuning at
1,000. Extra row ``fcn+spindle``: the FCN with the input-spindle torque sensor as a 4th input (a
robot has none; left out of the verdicts). Metrics: RMSE of jaw torque [mNm] and jaw angle [deg],
NRMSE (% of the truth's range over the protocol's test files), pooled over the test files' samples,
on whole files and on their closing portions (``rec.closing``); mean +- std over seeds, std the
sample standard deviation (ddof 1; none for a single seed, 0 for the deterministic physics:
:func:`summarise`). The best model per protocol and metric wins over the runner-up only if
mean_a + std_a < mean_b - std_b (the spread rule,
:func:`psmforce.estimators.evaluation.tables.compare`), else they tie.

Resumable: each (model, seed) keeps its trained weights and its records under ``--work``, in a
folder named by the loader's hash (the hybrid's files also carry the physics code's hash); a
killed run started again with the same command continues, and a final run over everything
kept only scores and writes the table. ``--quick`` trains on 2 files for 2 epochs: a smoke run
whose figures compare nothing.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import pickle
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import kept_json, shown_path  # noqa: E402
from psmforce.estimators.evaluation.tables import compare, has_spread, mean_std  # noqa: E402
from psmforce.core.files import atomic_path, write_json_atomic, write_text_atomic
from psmforce.identification.transmission.model import CableTransmission
from psmforce.identification.transmission.recording import (
    home_session,
    read_transmission_file,
    read_transmission_session,
)

SESSIONS = {"a": "Tool_4_Maryland_L_4", "b": "Tool_4_Maryland_L_2", "c": "Tool_5_Maryland_L_2"}
CALIBRATION_FILES = ("01", "22", "43")
CALIBRATION_VAL_FRACTION = 0.2
PROTOCOLS = {
    "a_held_out_files": "Tool_4_Maryland_L_4, test = frequency 2 or load 5 (14 files)",
    "b_other_session": "models of (a) on Tool_4_Maryland_L_2 (20 files)",
    "c_other_tool_as_is": "models of (a) on Tool_5_Maryland_L_2 minus 01, 22, 43 (17 files)",
    "c_other_tool_calibrated": "the same 17 files after calibration on 01, 22, 43 (60 s)",
}
MODELS = ("physics", "fcn", "lstm", "transformer", "rocket", "hybrid", "fcn+spindle")
SPINDLE = "spindle_torque_nm"
"""``MODEL+spindle``: MODEL with the input-spindle torque sensor as a 4th input (a robot has no
such sensor: a reference row, left out of the best-model verdicts)."""
PUBLISHED = {"source": "O'Neill, Stephens, Kowalewski, RA-L 3(4):3027-3034, 2018",
             "model": "feed-forward network, 30 neurons, motor current + motor encoder",
             "split": "random sample split of Tool_4_Maryland_L_4 (test samples drawn at random "
                      "from the same recordings: neighbouring samples leak between train and "
                      "test), not comparable to held-out files",
             "jaw_torque_rmse_mNm": 4.42, "jaw_angle_rmse_deg": 0.37}
DESIGN = {
    "how": "seed 1, protocol (a): trained on its 32 train files, early-stopped on and scored on "
           "its 4 validation files; the lowest validation loss (scaled MSE, both targets) chosen; "
           "test files unused. Entries: [validation loss, torque RMSE mNm, angle RMSE deg]",
    "fcn": {"psmforce/estimators/networks/baselines.py FCN, 64 wide, batch 256 (only one tried)": [0.0505, 11.5, 0.99]},
    "lstm": {"hidden 64, 16 chunks a batch": [0.0854, 14.8, 1.78],
             "hidden 128, 16 chunks a batch": [0.0564, 11.7, 2.12],
             "hidden 128, 4 chunks a batch": [0.0584, 12.2, 1.52],
             "hidden 64, 4 chunks a batch (chosen)": [0.0263, 8.2, 1.08]},
    "transformer": {"note": "8,192 windows an epoch, batch 128",
                    "window 16": [0.0109, 5.20, 0.82], "window 32": [0.0070, 4.1, 0.70],
                    "window 64 (chosen)": [0.0060, 3.73, 0.78]},
    "rocket": {"window 32 (chosen)": [0.0157, 6.4, 0.56], "window 64": [0.0196, 7.1, 0.68]},
    "hybrid": {"note": "residual network on the motor signals and the physics' two outputs, "
                       "target = truth - physics unless noted; entries [torque RMSE mNm, angle "
                       "RMSE deg] on the validation files; chosen by torque / 5 mNm + angle / "
                       "0.5 deg (the widths' criterion in CableTransmission.fit)",
               "psmforce/estimators/networks/causal.py transformer, attention window 16": [6.90, 0.592],
               "psmforce/estimators/networks/causal.py transformer, attention window 32": [7.51, 0.614],
               "psmforce/estimators/networks/causal.py transformer, attention window 64": [9.21, 0.687],
               "LSTM, hidden 64": [6.71, 0.613],
               "FCN (one sample)": [6.13, 0.518],
               "FCN, torque without the physics base": [6.66, 0.539],
               "paper transformer, window 64, torque without the physics base": [5.02, 0.380],
               "paper transformer, window 64 (chosen)": [4.69, 0.409],
               "without the physics (psmforce/estimators/networks/causal.py, window 16), for reference": [8.33, 1.103]},
}
METRICS = ("torque_rmse_mNm", "angle_rmse_deg", "torque_nrmse_pct", "angle_nrmse_pct")


# ---------------------------------------------------------------- physics model
PHYSICS_SOURCE = "psmforce.identification.transmission.model.CableTransmission"


def loader_tag() -> str:
    """Identifies the data loader: a work folder per version, so no cache outlives a change."""
    path = ROOT / "psmforce" / "identification" / "transmission" / "recording.py"
    return hashlib.sha256(path.read_bytes()).hexdigest()[:12]


def physics_tag() -> str:
    """Identifies the physics code, so cached physics and hybrid results follow its changes."""
    path = ROOT / "psmforce" / "identification" / "transmission" / "model.py"
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


# ---------------------------------------------------------------- data and splits
def _stem(rec) -> str:
    return rec.name.rsplit("/", 1)[-1]


def splits(quick: bool) -> dict:
    """File stems per role: a_train, a_val, a_test, b_test, c_calib, c_test."""
    grid = [f"{x}{y}" for x in range(5) for y in range(10)]
    a_test = [s for s in grid if s[0] == "2" or s[1] == "5"]
    a_val = [s for s in grid if s[1] == "2" and s[0] != "2"]
    a_train = [s for s in grid if s not in a_test and s not in a_val]
    small = [f"{x}{y}" for x in range(5) for y in range(4)]
    c_test = [s for s in small if s not in CALIBRATION_FILES]
    if quick:
        return {"a_train": ["00", "11"], "a_val": ["12"], "a_test": ["25"], "b_test": ["13"],
                "c_calib": ["01"], "c_test": ["12"]}
    return {"a_train": a_train, "a_val": a_val, "a_test": a_test, "b_test": small,
            "c_calib": list(CALIBRATION_FILES), "c_test": c_test}


def load(data_dir: Path, quick: bool) -> dict:
    """{session letter: {stem: homed recording}}; ``quick`` reads only the files it uses (and
    the session's first file, which homing needs)."""
    for s in SESSIONS.values():
        if not (data_dir / s).is_dir():
            raise SystemExit(f"transmission benchmark: {data_dir / s} is missing; pass --data "
                             "with the folder holding the MRD Lab sessions (see its README.md)")
    if not quick:
        return {k: {_stem(r): r for r in home_session(read_transmission_session(data_dir / s))}
                for k, s in SESSIONS.items()}
    sp = splits(True)
    need = {"a": sp["a_train"] + sp["a_val"] + sp["a_test"], "b": sp["b_test"],
            "c": sp["c_calib"] + sp["c_test"]}
    out = {}
    for k, s in SESSIONS.items():
        names = sorted({"00", *need[k]})
        recs = home_session([read_transmission_file(data_dir / s / f"{n}.TXT") for n in names])
        out[k] = {_stem(r): r for r in recs}
    return out


def test_sets(data: dict, sp: dict) -> dict:
    return {"a_held_out_files": [data["a"][s] for s in sp["a_test"]],
            "b_other_session": [data["b"][s] for s in sp["b_test"]],
            "c_other_tool_as_is": [data["c"][s] for s in sp["c_test"]],
            "c_other_tool_calibrated": [data["c"][s] for s in sp["c_test"]]}


# ---------------------------------------------------------------- metrics
def metrics(recs: list, torque: list, angle: list) -> dict:
    """RMSE and NRMSE (% of the truth's range over all of ``recs``), whole files and closing."""
    t_true = np.concatenate([r.jaw_torque_nm for r in recs])
    a_true = np.concatenate([r.jaw_angle_rad for r in recs])
    closing = np.concatenate([r.closing for r in recs])
    t_err, a_err = np.concatenate(torque) - t_true, np.concatenate(angle) - a_true
    t_range, a_range = np.ptp(t_true), np.ptp(a_true)
    out = {}
    for part, m in (("whole", np.ones_like(closing)), ("closing", closing)):
        t, a = np.sqrt(np.mean(t_err[m] ** 2)), np.sqrt(np.mean(a_err[m] ** 2))
        out[part] = {"torque_rmse_mNm": 1e3 * t, "angle_rmse_deg": float(np.degrees(a)),
                     "torque_nrmse_pct": 100 * t / t_range, "angle_nrmse_pct": 100 * a / a_range,
                     "samples": int(m.sum())}
    return {p: {k: v if k == "samples" else float(v) for k, v in d.items()}
            for p, d in out.items()}


# ---------------------------------------------------------------- physics stage (main process)
def physics_stage(data: dict, sp: dict, work: Path) -> dict:
    """Fit the physics on (a)'s train files and refit it on (c)'s calibration files; keep both
    models' predictions of every file (the hybrid's inputs) in ``work/physics.pkl``."""
    path, tag = work / "physics.pkl", physics_tag()
    if path.exists():
        kept = pickle.loads(path.read_bytes())
        if kept["tag"] == tag and kept["splits"] == sp:
            return kept
    cls = CableTransmission
    t0 = time.perf_counter()
    trained = cls.fit([data["a"][s] for s in sp["a_train"]],
                      validation=[data["a"][s] for s in sp["a_val"]])
    fit_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    calibrated = cls.fit([data["c"][s] for s in sp["c_calib"]], initial=trained)
    cal_s = time.perf_counter() - t0

    def preds(model, recs):
        out = {}
        for r in recs:
            p = model.predict(r)
            out[r.name] = np.stack([np.asarray(p.jaw_torque_nm, float),
                                    np.asarray(p.jaw_angle_rad, float)], 1)
        return out

    everything = [r for k in data for r in data[k].values()]
    kept = {"tag": tag, "source": PHYSICS_SOURCE, "splits": sp,
            "trained": preds(trained, everything),
            "calibrated": preds(calibrated, list(data["c"].values())),
            "trained_params": trained.to_dict(), "calibrated_params": calibrated.to_dict(),
            "fit_seconds": round(fit_s, 1), "calibration_seconds": round(cal_s, 1)}
    work.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(pickle.dumps(kept))
    return kept


def physics_records(data: dict, sp: dict, phys: dict) -> list[dict]:
    out = []
    for protocol, recs in test_sets(data, sp).items():
        which = "calibrated" if protocol.endswith("calibrated") else "trained"
        p = [phys[which][r.name] for r in recs]
        out.append({"model": "physics", "seed": None, "protocol": protocol,
                    "metrics": metrics(recs, [q[:, 0] for q in p], [q[:, 1] for q in p]),
                    "fit": {"seconds": phys["fit_seconds"] if which == "trained"
                            else phys["calibration_seconds"], "deterministic": True}})
    return out


# ---------------------------------------------------------------- learned models (workers)
def run_learned(model: str, seed: int, data_dir: str, quick: bool, work: str) -> list[dict]:
    """Train ``model`` with ``seed`` on (a), score it on every protocol, calibrate it on (c);
    every stage is kept under ``work`` and reused."""
    import torch

    from psmforce.experiments import transmission_networks as tm
    torch.set_num_threads(1)
    work = Path(work)
    sp = splits(quick)
    data = load(Path(data_dir), quick)
    phys = pickle.loads((work / "physics.pkl").read_bytes()) if model.startswith("hybrid") \
        else None
    key = f"{model}_seed{seed}" + (f"_{phys['tag']}" if phys else "")
    base, inputs = model.split("+")[0], tm.INPUTS + ((SPINDLE,) if "+spindle" in model else ())
    records_dir, tests = work / "records", test_sets(data, sp)

    def physics_of(rec, which="trained"):
        return phys[which][rec.name] if phys else None

    def arrays(rec, which="trained"):
        x = np.stack([getattr(rec, k) for k in inputs], 1)
        y = np.stack([getattr(rec, k) for k in tm.TARGETS], 1)
        p = physics_of(rec, which)
        return (x, y) if p is None else (np.concatenate([x, p], 1), y - p)

    train_xy = [arrays(data["a"][s]) for s in sp["a_train"]]
    xs = tm.Scaler.fit([x for x, _ in train_xy])
    ys = tm.Scaler.fit([y for _, y in train_xy])

    def series(rec, which="trained", lo=0, hi=None, mask_from=None):
        x, y = arrays(rec, which)
        mask = None if mask_from is None else np.arange(len(x)) >= mask_from
        return tm.Series.of(xs(x)[lo:hi], ys(y)[lo:hi], None if mask is None else mask[lo:hi])

    epochs = 2 if quick else 150
    if base == "rocket":
        est = tm.RocketModel(seed, max_train_windows=300 if quick else 20_000)
        settings = est.settings
    else:
        torch.manual_seed(seed)
        net, settings = tm.build_network(base, len(inputs) + (2 if phys else 0))
        if quick:
            settings["windows_per_epoch"] = 512

    def predict(rec, which="trained"):
        x, _ = arrays(rec, which)
        s = est.predict_scaled(xs(x)) if base == "rocket" else tm.predict_scaled(net, settings,
                                                                                  xs(x))
        out = ys.invert(s)
        p = physics_of(rec, which)
        return out if p is None else out + p

    def score(protocol, which="trained"):
        recs = tests[protocol]
        p = [predict(r, which) for r in recs]
        return metrics(recs, [q[:, 0] for q in p], [q[:, 1] for q in p])

    ckpt = work / "models" / f"{key}.pt"
    if ckpt.exists():
        state = torch.load(ckpt, weights_only=False)
        (est.reg if base == "rocket" else net).load_state_dict(state["weights"])
        report = state["report"]
    else:
        train = [series(data["a"][s]) for s in sp["a_train"]]
        val = [series(data["a"][s]) for s in sp["a_val"]]
        if base == "rocket":
            report = est.fit(train, val)
        else:
            report = tm.train(net, settings, train, val, seed=seed, max_epochs=epochs,
                              time_limit_s=2400)
        ckpt.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(ckpt) as tmp:
            torch.save({"weights": (est.reg if base == "rocket" else net).state_dict(),
                        "report": report}, tmp)
    records = []
    for protocol in ("a_held_out_files", "b_other_session", "c_other_tool_as_is"):
        def record(protocol=protocol):
            return {"model": model, "seed": seed, "protocol": protocol,
                    "metrics": score(protocol), "fit": report}
        records.append(kept_json(records_dir / f"{key}_{protocol}.json", record))

    def calibrated():
        which = "calibrated"
        cal_train, cal_val = [], []
        for s in sp["c_calib"]:
            rec = data["c"][s]
            cut = round(len(rec) * (1 - CALIBRATION_VAL_FRACTION))
            cal_train.append(series(rec, which, 0, cut))
            cal_val.append(series(rec, which, mask_from=cut))
        if base == "rocket":
            cal = est.fit(cal_train, cal_val, refit=True)
        else:
            cal = tm.train(net, settings, cal_train, cal_val, seed=seed, lr=1e-4,
                           max_epochs=2 if quick else 1000, time_limit_s=900)
        return {"model": model, "seed": seed, "protocol": "c_other_tool_calibrated",
                "metrics": score("c_other_tool_calibrated", which), "fit": cal,
                "pretrained_fit": report}

    records.append(kept_json(records_dir / f"{key}_c_other_tool_calibrated.json", calibrated))
    return records


# ---------------------------------------------------------------- summary
def summarise(records: list[dict]) -> dict:
    """{protocol: {model: {part: {metric: {mean, std, n}}}}} over the records' seeds: std the
    sample standard deviation (ddof 1; None for one seed,
    :func:`psmforce.estimators.evaluation.tables.std_over_seeds`). A deterministic model's one
    record (seed None: the physics, one fit) has std 0: every seed would give the same."""
    out, seeded = {}, {}
    for r in records:
        for part, m in r["metrics"].items():
            for k in METRICS:
                out.setdefault(r["protocol"], {}).setdefault(r["model"], {}).setdefault(
                    part, {}).setdefault(k, []).append(m[k])
        seeded[r["protocol"], r["model"]] = r["seed"] is not None
    for protocol, models in out.items():
        for model, parts in models.items():
            for part in parts.values():
                for k, v in part.items():
                    part[k] = mean_std(v) if seeded[protocol, model] else {
                        "mean": float(np.mean(v)), "std": 0.0, "n": len(v)}
    return out


def verdicts(summary: dict) -> dict:
    """Per protocol, part and metric: the best model and whether it wins (spread rule)."""
    out = {}
    for protocol, models in summary.items():
        for part in ("whole", "closing"):
            for k in METRICS:
                ranked = sorted((m for m in models if "+spindle" not in m),
                                key=lambda m: models[m][part][k]["mean"])
                a = models[ranked[0]][part][k]
                entry = {"best": ranked[0], "mean": a["mean"], "std": a["std"]}
                if len(ranked) > 1:
                    b = models[ranked[1]][part][k]
                    entry |= {"runner_up": ranked[1], "runner_up_mean": b["mean"],
                              "runner_up_std": b["std"],
                              "verdict": "win" if compare(a, b) == -1 else "tie"}
                out.setdefault(protocol, {}).setdefault(part, {})[k] = entry
    return out


def table(summary: dict, verdict: dict, fits: dict) -> str:
    def cell(d):
        return f"{d['mean']:7.2f} +- " + (f"{d['std']:5.2f}" if has_spread(d) else "  n/a")
    lines = []
    for protocol, models in summary.items():
        lines += ["", f"{protocol}: {PROTOCOLS[protocol]}",
                  (f"{'model':<12} {'torque mNm':>16} {'angle deg':>16} {'torque %':>16} "
                   f"{'angle %':>16} | closing: {'torque mNm':>16} {'angle deg':>16}  "
                   "epochs / converged")]
        for m, d in models.items():
            w, c = d["whole"], d["closing"]
            lines.append(f"{m:<12} {cell(w['torque_rmse_mNm'])} {cell(w['angle_rmse_deg'])} "
                         f"{cell(w['torque_nrmse_pct'])} {cell(w['angle_nrmse_pct'])} |          "
                         f"{cell(c['torque_rmse_mNm'])} {cell(c['angle_rmse_deg'])}  "
                         f"{fits.get((protocol, m), '')}")
        for part in ("whole", "closing"):
            for k in ("torque_rmse_mNm", "angle_rmse_deg"):
                v = verdict[protocol][part][k]
                versus = f", {v['verdict']} over {v['runner_up']}" if "verdict" in v else ""
                lines.append(f"  {part:<7} {k:<16} best {v['best']}{versus}")
    lines += ["", (f"published (not comparable: {PUBLISHED['split']}): torque "
                   f"{PUBLISHED['jaw_torque_rmse_mNm']} mNm, angle "
                   f"{PUBLISHED['jaw_angle_rmse_deg']} deg")]
    return "\n".join(lines)


def fit_flags(records: list[dict]) -> dict:
    out = {}
    for r in records:
        if r["model"] == "physics":
            continue
        out.setdefault((r["protocol"], r["model"]), []).append(
            f"{r['fit']['epochs_run']}{'' if r['fit']['converged'] else '!'}")
    return {k: " ".join(v) for k, v in out.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "mrdlab")
    ap.add_argument("--json", type=Path, default=ROOT / "results/benchmarks/transmission.json")
    ap.add_argument("--work", type=Path, default=ROOT / "runs/transmission")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS))
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (1 thread each)")
    ap.add_argument("--quick", action="store_true", help="2 training files, 2 epochs: smoke run")
    args = ap.parse_args(argv)
    started = time.perf_counter()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import torch
    torch.set_num_threads(1)
    sp = splits(args.quick)
    data = load(args.data, args.quick)
    args.work = args.work / f"{'quick_' if args.quick else ''}loader_{loader_tag()}"
    args.work.mkdir(parents=True, exist_ok=True)
    phys = physics_stage(data, sp, args.work) if {"physics", "hybrid"} & set(args.models) else None
    records = physics_records(data, sp, phys) if "physics" in args.models else []
    cost = ("transformer", "rocket", "hybrid", "lstm")  # longest first, to balance the workers
    order = sorted((m for m in args.models if m != "physics"),
                   key=lambda m: cost.index(m) if m in cost else len(cost))
    tasks = [(m, s) for m in order for s in args.seeds]
    call = [(m, s, str(args.data), args.quick, str(args.work)) for m, s in tasks]
    if args.jobs > 1 and len(tasks) > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            for out in pool.map(run_learned, *zip(*call)):
                records += out
    else:
        for c in call:
            records += run_learned(*c)
    summary = summarise(records)
    verdict = verdicts(summary)
    text = table(summary, verdict, fit_flags(records))
    quick = " (QUICK smoke run: compares nothing)" if args.quick else ""
    header = (f"transmission benchmark{quick}"
              f"; physics: {PHYSICS_SOURCE}; seeds {args.seeds}; RMSE mean +- std over seeds "
              "(ddof 1); epochs per seed, ! = not converged")
    print(header + text)
    result = {
        "benchmark": "transmission", "quick": args.quick,
        "note": "smoke run, not converged, compares nothing" if args.quick else
                "held-out files; causal estimates, no post-filter",
        "data": shown_path(args.data), "rate_hz": 100.0,
        "sessions": SESSIONS, "splits": sp,
        "inputs": ["motor_current_a", "motor_angle_rad", "motor_velocity_rad_s"],
        "targets": ["jaw_torque_nm", "jaw_angle_rad"], "protocols": PROTOCOLS,
        "calibration": {"files": list(CALIBRATION_FILES), "seconds": 60,
                        "network_validation": "last 20 % of each calibration file"},
        "seeds": args.seeds, "published": PUBLISHED, "design": DESIGN,
        "work_tags": {"loader": loader_tag(), "physics": physics_tag()},
        "physics": None if phys is None else {
            "source": phys["source"], "deterministic": True,
            "trained": phys["trained_params"], "calibrated": phys["calibrated_params"],
            "fit_seconds": phys["fit_seconds"],
            "calibration_seconds": phys["calibration_seconds"]},
        "summary": summary, "verdicts": verdict, "records": records,
        "run": {"seconds": round(time.perf_counter() - started, 1),
                "fit_seconds_total": round(sum(
                    r["fit"].get("seconds", 0) for r in records
                    if r["protocol"] in ("a_held_out_files", "c_other_tool_calibrated")), 1),
                "command": " ".join(["python", "studies/transmission.py", *sys.argv[1:]])},
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.json, result)
    write_text_atomic(args.json.with_suffix(".txt"), header + text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
