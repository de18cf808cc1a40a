"""Calibration of the simulated bench against the seed paper's observations and a real dVRK.

Runs the automated protocol (``--scale``, default 1.0 = the paper's size), times it, reads the
written dataset back and prints each figure next to the paper's value and the acceptance rule of
issue 3. Then the joint-effort channels against the real WPI arm (issue 13): per joint, the
residual our arm identification leaves (fitted on one trajectory, scored on another) on the real
recordings and on the simulator replaying the same trajectories, its std raw / after the causal
5 Hz low-pass / after the paper's centred median, its spectrum and autocorrelation, and the
ratio sim / real (rule: every std ratio within [0.67, 1.5]); skipped when the WPI folder is
absent. ``--derive`` also prints the coloured disturbance derived from the WPI residual (the
numbers written into psmforce/sim/params.py). Then the cable law against a real EndoWrist
(the MRD Lab bench): hysteresis loop width, friction against load and against frequency and
the static compliance, the friction at zero load, computed the same way on the real recordings of
every MRD Lab folder and on the bench's cable law replaying each folder's protocol
(psmforce/experiments/cable_law_figures.py), with the ratio sim / real for the default simulator
version and for 2.2, whose cable law is calibrated on every folder (rule per figure: every
folder's ratio within [0.67, 1.5], or the sim value within the real folders' spread where that is
wider; docs/simulator.md section 12b); skipped when the MRD Lab folder is absent.
``--cable-law`` runs only these rows (about a minute); ``--fit`` also reruns 2.2's cable-law
calibration (minutes). ``--json PATH`` writes everything.

Size: the study of one bench against the paper, the real arm and the real EndoWrist: three
comparisons that share the bench and one command line. Usage::

    python studies/sim_calibration.py [--scale 1.0] [--seed 0] [--out DIR] [--json PATH]
                                         [--wpi ../shared/data/wpi_psm] [--derive]
                                         [--mrdlab ../shared/data/mrdlab] [--cable-law] [--fit]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from psmforce.robot.conventions import JOINTS
from psmforce.sim import (Contact, Effects, InstrumentParams, motion, protocols, run_trajectory,
                          simulate, versions)
from psmforce.experiments import bench_calibration as calibration
from psmforce.experiments import cable_law_figures as transmission_figures
from psmforce.experiments.report import shown_path, write_json

WPI_DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data" / "wpi_psm"
MRDLAB_DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data" / "mrdlab"
CABLE_LAW_SESSION = "Tool_4_Maryland_L_4"
"""The session the load-scale sensitivity is run on (the 2018 paper's; ten load levels); the
rule applies to every folder."""
CABLE_LAW_VERSIONS = (versions.DEFAULT_VERSION, "2.2")
"""The simulator versions compared: the default one (every committed result's) and the one
whose cable law is calibrated on every folder (:mod:`psmforce.sim.versions`)."""
CABLE_LAW_FIT = {
    "cable_coulomb_n": (2.0, 0.0, 60.0),
    "cable_coulomb_stretch_share": (0.05, 0.0, 1.0),
    "cable_stiffness_n_per_m": (2.0e4, 5.0e4, 1.0e6),
    "capstan_mu_wrap_distal": (0.02, 0.0, 1.0),
    "capstan_mu_wrap_proximal": (0.02, 0.0, 1.0),
    "twist_friction_gain_per_rad": (0.05, 0.0, 1.0),
    "capstan_wrap_pitch_gain": (0.1, 0.0, 2.0),
}
"""The fields :func:`fit_cable_law` calibrates: (initial step, lower bound, upper bound)."""
BAND_PENALTY = 100.0
"""Weight of a log ratio's squared distance outside the band in :func:`fit_cable_law`."""
LOAD_SCALE_SENSITIVITY = (0.8, 1.25)
"""Factors on the sim / real load scale (the equal-input-drum assumption): the sensitivity rows."""
EFFORT_RATIO_RANGE = (0.67, 1.5)
EFFORT_CHECKED = ("std_raw", "std_lowpass5", "std_median71")
DERIVE_SEEDS = (0, 1, 2)
"""Noise realisations the disturbance is derived on; the check runs on others (CHECK_SEEDS)."""
CHECK_SEEDS = (10, 11, 12)

PAPER = {"train_min": 131.1, "val_min": 14.6, "test_min": 54.5,
         "ati_range_x": (-2.9, 2.9), "ati_range_y": (-4.1, 3.2), "ati_range_z": (-4.1, 4.6)}
FREE_DOWNSAMPLE = 0.25   # the loader keeps 25 % of free-space training data (paper)
VALIDATION_SHARE = 0.10  # the loader splits ~10 % of training trials off for validation
COLS = ["fz", "ati_fx", "ati_fy", "ati_fz", "hex10_overload", "wrist_pitch_position", "wrist_yaw_position",
        "sim_wrist_pitch_true", "sim_wrist_yaw_true"]


def _read(out: Path, meta: dict) -> dict[str, list[pd.DataFrame]]:
    groups: dict[str, list[pd.DataFrame]] = {}
    for trial in meta["trials"]:
        frame = pd.read_csv(out / trial["path"], usecols=COLS, engine="c")
        groups.setdefault(f"{trial['split']}/{trial['condition']}", []).append(frame)
    return groups


def _hysteresis_probe(seed: int) -> dict[str, float]:
    """Free space, nominal tool, all effects: sweep one wrist joint 0 -> +a -> 0 -> -a -> 0 with
    1 s holds; HEX10 fz at the same pose (0) reached from the + side minus from the - side."""
    q0 = np.zeros(7)
    q0[:3] = protocols._traction_arm(0.0, 0.0, 1)
    q0[6] = 0.3
    out = {}
    for name, joint, amp in (("wrist_pitch", 4, 0.5), ("wrist_yaw", 5, 0.5), ("roll", 3, 1.5)):
        way = np.tile(q0, (5, 1))
        way[1, joint], way[3, joint] = amp, -amp
        q = motion.piecewise(way, np.full(4, 1.5), np.full(4, 1.0))
        fz = run_trajectory(q, motion.DT, Contact(), InstrumentParams(), Effects(),
                            np.random.default_rng(seed)).fz.to_numpy()
        n = len(q) // 4
        out[name] = float(fz[2 * n - 60:2 * n - 10].mean() - fz[4 * n - 60:4 * n - 10].mean())
    return out


def calibrate(scale: float, seed: int, out: Path) -> dict:
    start = time.perf_counter()
    summary = simulate("automated", scale=scale, seed=seed, out=out)
    gen_s = time.perf_counter() - start
    meta = json.loads((out / "metadata.json").read_text())
    groups = _read(out, meta)
    cat = {k: pd.concat(v, ignore_index=True) for k, v in groups.items()}
    r = {"scale": scale, "seed": seed, "rows": summary["rows"], "trials": summary["trials"],
         "generation_s": round(gen_s, 2), "generation_rows_per_s": round(summary["rows"] / gen_s)}

    free_first = np.array([f.fz.to_numpy()[:50].mean() for k in groups if k.endswith("/Free") for f in groups[k]])
    r["rest_fz_mean_N"] = float(free_first.mean())
    r["rest_fz_min_N"], r["rest_fz_max_N"] = float(free_first.min()), float(free_first.max())
    r["rest_ok"] = bool(abs(r["rest_fz_mean_N"] + 6.0) <= 2.0)

    test = pd.concat([cat[k] for k in cat if k.startswith("test/")], ignore_index=True)
    for axis in "xyz":
        v = test[f"ati_f{axis}"].to_numpy()
        r[f"test_ati_f{axis}_range_N"] = [round(float(v.min()), 3), round(float(v.max()), 3)]
    lat = max(abs(v) for a in "xy" for v in r[f"test_ati_f{a}_range_N"])
    zr = r["test_ati_fz_range_N"]
    r["ati_ranges_ok"] = bool(2.0 <= lat <= 6.0 and -6.0 <= zr[0] <= -2.0 and 2.0 <= zr[1] <= 7.0)

    loaded = pd.concat([cat[k] for k in cat if not k.endswith("/Free")], ignore_index=True)
    ati_mag = np.sqrt(loaded.ati_fx ** 2 + loaded.ati_fy ** 2 + loaded.ati_fz ** 2).to_numpy()
    fz = loaded.fz.to_numpy()
    small = ati_mag < 6.0
    r["loaded_min_fz_with_ati_below_6N"] = float(fz[small].min())
    r["loaded_share_fz_below_-60N"] = round(float((fz < -60.0).mean()), 4)
    r["loaded_share_overload"] = round(float(loaded.hex10_overload.mean()), 5)
    r["loaded_max_ati_magnitude_N"] = float(ati_mag.max())
    test_loaded = pd.concat([cat[k] for k in cat if k.startswith("test/") and not k.endswith("/Free")])
    r["test_loaded_min_fz_N"] = float(test_loaded.fz.min())
    r["compression_ok"] = bool(r["loaded_min_fz_with_ati_below_6N"] < -60.0)
    deflection = np.abs(np.concatenate([(loaded.sim_wrist_pitch_true - loaded.wrist_pitch_position).to_numpy(),
                                        (loaded.sim_wrist_yaw_true - loaded.wrist_yaw_position).to_numpy()]))
    r["loaded_wrist_deflection_p99_max_rad"] = [round(float(np.percentile(deflection, 99)), 4),
                                                round(float(deflection.max()), 4)]

    hyst = _hysteresis_probe(seed)
    r["hysteresis_fz_N"] = {k: round(v, 3) for k, v in hyst.items()}
    r["hysteresis_ok"] = bool(min(abs(hyst["wrist_pitch"]), abs(hyst["wrist_yaw"])) >= 0.5)

    free = [f.fz.rolling(50, center=True, min_periods=1).mean().to_numpy()
            for k in groups if k.endswith("/Free") for f in groups[k]]
    free_all = np.concatenate(free)
    r["free_fz_p1_p99_N"] = [round(float(np.percentile(free_all, 1)), 3), round(float(np.percentile(free_all, 99)), 3)]
    r["free_fz_variation_N"] = round(r["free_fz_p1_p99_N"][1] - r["free_fz_p1_p99_N"][0], 3)
    r["free_variation_ok"] = bool(r["free_fz_variation_N"] >= 2.0)

    minutes = summary["minutes"]
    pool = sum(v * (FREE_DOWNSAMPLE if k.endswith("/Free") else 1.0) for k, v in minutes.items() if k.startswith("train/"))
    split = {"train_min": pool * (1 - VALIDATION_SHARE), "val_min": pool * VALIDATION_SHARE,
             "test_min": sum(v for k, v in minutes.items() if k.startswith("test/"))}
    r["minutes_by_condition"] = minutes
    for k, v in split.items():  # compared with the paper's minutes times the scale
        r[k] = round(v, 2)
        r[k + "_ratio_to_paper"] = round(v / (PAPER[k] * scale), 3)
    r["durations_ok"] = bool(all(abs(v / (PAPER[k] * scale) - 1.0) <= 0.2 for k, v in split.items()))
    r["paper"] = PAPER
    return r


def effort_channels(wpi_dir: Path, derive: bool) -> dict:
    """Per-joint residual statistics, real vs simulated (mean over CHECK_SEEDS), their ratios and
    the check; with ``derive`` the disturbance parameters derived on DERIVE_SEEDS."""
    start = time.perf_counter()
    real_res = calibration.real_residual(wpi_dir)
    real = calibration.residual_statistics(real_res)
    sim = calibration.mean_statistics([calibration.simulated_residual(wpi_dir, s) for s in CHECK_SEEDS])
    table = {}
    for j, joint in enumerate(JOINTS):
        table[joint] = {stat: {"real": float(real[stat][j]), "sim": float(sim[stat][j]),
                               "ratio": float(sim[stat][j] / real[stat][j])}
                        for stat in calibration.STATISTICS}
    ratios = [table[j][s]["ratio"] for j in table for s in EFFORT_CHECKED]
    out = {"wpi": shown_path(wpi_dir), "rate_hz": calibration.RATE_HZ, "check_seeds": list(CHECK_SEEDS),
           "units": "Nm (insertion: N)", "table": table,
           "rule": f"every {', '.join(EFFORT_CHECKED)} ratio sim/real within {list(EFFORT_RATIO_RANGE)}",
           "effort_ok": bool(all(EFFORT_RATIO_RANGE[0] <= r <= EFFORT_RATIO_RANGE[1] for r in ratios))}
    if derive:
        quiet = dataclasses.replace(Effects(), coloured_effort_noise=False)
        det = [calibration.simulated_residual(wpi_dir, s, effects=quiet) for s in DERIVE_SEEDS]
        out["derived_disturbance"] = calibration.derive_disturbance(real_res, det)
        out["derived_on_seeds"] = list(DERIVE_SEEDS)
    out["seconds"] = round(time.perf_counter() - start, 1)
    return out


def _print_effort(e: dict) -> None:
    names = JOINTS
    print(f"\neffort channels vs the real WPI arm ({e['units']}; sim = mean over seeds {e['check_seeds']})")
    print(f"{'statistic':22s}" + "".join(f"{n:>12s}" for n in names))
    for stat in calibration.STATISTICS:
        for who in ("real", "sim", "ratio"):
            label = stat if who == "real" else f"  {who}"
            print(f"{label:22s}" + "".join(f"{e['table'][n][stat][who]:12.4g}" for n in names))
    print(f"{'rule':22s}{e['rule']}: {'ok' if e['effort_ok'] else 'NOT MET'}")
    if "derived_disturbance" in e:
        print(f"derived disturbance (seeds {e['derived_on_seeds']}):")
        for k, v in e["derived_disturbance"].items():
            print(f"  {k:28s} {np.round(v, 5).tolist()}")


def _without_runs(figures: dict) -> dict:
    return {k: v for k, v in figures.items() if k != "runs"}


def _real_sessions(mrdlab_dir: Path) -> dict[str, tuple[Path, dict]]:
    """Every MRD Lab session folder and its real figures (read once: the slow part)."""
    return {folder.name: (folder, transmission_figures.session_figures(
        transmission_figures.real_session(folder)))
        for folder in transmission_figures.sessions(mrdlab_dir)}


def _against(reals: dict[str, tuple[Path, dict]], params: InstrumentParams) -> dict[str, dict]:
    return {name: transmission_figures.real_vs_sim(folder, params, real=real)
            for name, (folder, real) in reals.items()}


def _log_ratios(results: dict[str, dict]) -> np.ndarray:
    return np.array([np.log(max(r["comparison"][k]["ratio"], 1e-3))
                     for r in results.values() for k in transmission_figures.CHECKED
                     if r["comparison"][k]["measurable"]])


def fit_cable_law(reals: dict[str, tuple[Path, dict]], version: str = versions.DEFAULT_VERSION,
                  sweeps: int = 12) -> dict:
    """The calibration of simulator 2.2's cable law: start from ``version``'s instrument with the
    load-independent friction off, then coordinate descent on the sum over folders and
    checked figures of the squared log ratio sim / real plus :data:`BAND_PENALTY` times the
    squared distance of each log ratio outside the band (least squares held to the rule's
    band), each field of :data:`CABLE_LAW_FIT`
    stepped by its step while that lowers the sum, the steps halved when no field does
    (``sweeps`` rounds). Returns the fitted fields, the sum and the largest |log ratio|."""
    names = list(CABLE_LAW_FIT)
    base = versions.instrument(version)
    x = np.array([getattr(base, n) for n in names], dtype=float)
    steps = np.array([CABLE_LAW_FIT[n][0] for n in names])
    lo = np.array([CABLE_LAW_FIT[n][1] for n in names])
    hi = np.array([CABLE_LAW_FIT[n][2] for n in names])

    band = np.log(transmission_figures.RATIO_RANGE)

    def cost(values):
        params = dataclasses.replace(base, **{n: float(v) for n, v in zip(names, values)})
        r = _log_ratios(_against(reals, params))
        outside = np.maximum(0.0, np.maximum(band[0] - r, r - band[1]))
        return (float(np.sum(r ** 2) + BAND_PENALTY * np.sum(outside ** 2)),
                float(np.abs(r).max()))

    best, worst = cost(x)
    evaluations = 1
    for _ in range(sweeps):
        improved = False
        for i in range(len(x)):
            for direction in (1.0, -1.0):
                while True:
                    y = x.copy()
                    y[i] = np.clip(y[i] + direction * steps[i], lo[i], hi[i])
                    if y[i] == x[i]:
                        break
                    c, m = cost(y)
                    evaluations += 1
                    if c >= best - 1e-4:
                        break
                    x, best, worst, improved = y, c, m, True
        if not improved:
            steps = steps / 2
    return {"start_version": version, "fitted": {n: float(v) for n, v in zip(names, x)},
            "objective": best, "max_abs_log_ratio": worst, "band_penalty": BAND_PENALTY,
            "evaluations": evaluations, "final_steps": dict(zip(names, steps.tolist()))}


def cable_law(mrdlab_dir: Path, fit: bool = False) -> dict:
    """The cable law against the real EndoWrist, on every MRD Lab folder: per folder the real
    figures, the simulated ones of the default version and of the calibrated one
    (:data:`CABLE_LAW_VERSIONS`), their comparison and the figures per load level; per figure
    the real folders' spread and the rule (:func:`cable_law_figures.across_folders`) for each
    version; on :data:`CABLE_LAW_SESSION` a load-scale sensitivity of the calibrated version.
    ``fit``: also rerun the calibration (:func:`fit_cable_law`; minutes)."""
    start = time.perf_counter()
    reals = _real_sessions(mrdlab_dir)
    if CABLE_LAW_SESSION not in reals:
        raise FileNotFoundError(f"{mrdlab_dir}: no {CABLE_LAW_SESSION} session")
    default, calibrated = CABLE_LAW_VERSIONS
    results = {v: _against(reals, versions.instrument(v)) for v in CABLE_LAW_VERSIONS}
    out = {"mrdlab": shown_path(mrdlab_dir),
           "command": "python studies/sim_calibration.py --cable-law " + ("--fit " if fit else "")
                      + "--json results/benchmarks/sim_calibration_cable_law.json",
           "versions": {v: versions.CHANGES[v] for v in CABLE_LAW_VERSIONS},
           "default_values": {k: getattr(versions.instrument(default), k)
                              for k in versions.CHANGES[calibrated]},
           "default_version": default, "calibrated_version": calibrated,
           "figures": list(transmission_figures.FIGURES),
           "checked_figures": list(transmission_figures.CHECKED),
           "ratio_range": list(transmission_figures.RATIO_RANGE), "sessions": {}}
    for name, (folder, real) in reals.items():
        first = results[default][name]
        table = {}
        for k in transmission_figures.FIGURES:
            row = {"real": first["comparison"][k]["real"]}
            for v in CABLE_LAW_VERSIONS:
                c = results[v][name]["comparison"][k]
                row.update({f"sim_{v}": c["sim"], f"ratio_{v}": c["ratio"], f"ok_{v}": c["ok"]})
            table[k] = row
        out["sessions"][name] = {
            "pose": first["pose"], "load_scale_sim_per_real": first["load_scale_sim_per_real"],
            "runs": len(real["runs"]), "table": table, "real": real,
            "sim": {v: _without_runs(results[v][name]["sim"]) for v in CABLE_LAW_VERSIONS},
            "by_load_level": {"real": transmission_figures.by_load_level(real),
                              **{f"sim_{v}": transmission_figures.by_load_level(
                                  results[v][name]["sim"]) for v in CABLE_LAW_VERSIONS}}}
    out["across_folders"] = {v: transmission_figures.across_folders(results[v])
                             for v in CABLE_LAW_VERSIONS}
    out["met"] = {v: all(a["met"] is not False for a in out["across_folders"][v].values())
                  for v in CABLE_LAW_VERSIONS}
    out["rule"] = (f"per checked figure, every folder's ratio sim/real within "
                   f"{list(transmission_figures.RATIO_RANGE)}, or, where the real folders "
                   f"spread wider than max/min = {transmission_figures.RATIO_RANGE[1] / transmission_figures.RATIO_RANGE[0]:.3f}, "
                   "the sim value within the real min..max")
    out["cable_law_ok"] = out["met"][calibrated]
    out["load_scale_sensitivity"] = {
        str(f): {k: v["ratio"] for k, v in transmission_figures.real_vs_sim(
            reals[CABLE_LAW_SESSION][0], versions.instrument(calibrated), load_scale_factor=f,
            real=reals[CABLE_LAW_SESSION][1])["comparison"].items()}
        for f in LOAD_SCALE_SENSITIVITY}
    out["load_scale_sensitivity_version"] = calibrated
    if fit:
        out["fit"] = fit_cable_law(reals)
    out["seconds"] = round(time.perf_counter() - start, 1)
    return out


def json_ready(c: dict) -> dict:
    """The cable-law result as standard JSON: a folder driven at one frequency (the roll folders)
    has no high / low friction ratio (:func:`cable_law_figures.session_figures` gives NaN), so
    its ``friction_frequency_ratio`` is written null with the reason in
    ``friction_frequency_ratio_note`` beside it, in the real figures and in every simulated
    version's; any other non-finite number is refused (ValueError), never written as ``NaN``."""
    def clean(obj, where):
        if isinstance(obj, dict):
            return {k: clean(v, f"{where}.{k}") for k, v in obj.items()}
        if isinstance(obj, (list, tuple)):
            return [clean(v, f"{where}[{i}]") for i, v in enumerate(obj)]
        if isinstance(obj, float) and not math.isfinite(obj):
            raise ValueError(f"cable law: {where} is {obj}, not a number JSON can hold")
        return obj

    out = {**c, "sessions": {}}
    for name, s in c["sessions"].items():
        s = dict(s)
        for key in ("real", "sim"):
            figs = {key: s[key]} if key == "real" else dict(s[key])
            for v, f in figs.items():
                r = f.get("friction_frequency_ratio")
                if isinstance(r, float) and math.isnan(r):
                    hz = f.get("frequencies_hz", [])
                    figs[v] = {**f, "friction_frequency_ratio": None,
                               "friction_frequency_ratio_note":
                                   "n/a: one drive frequency in this folder "
                                   f"({', '.join(f'{h:g}' for h in sorted(set(hz)))} Hz), "
                                   "no high / low ratio"}
            s[key] = figs["real"] if key == "real" else figs
        out["sessions"][name] = s
    return clean(out, "cable_law")


def _ratio_cell(r) -> str:
    return "   n/a" if r is None else f"{r:6.2f}"


def _print_cable_law(c: dict) -> None:
    default, calibrated = c["default_version"], c["calibrated_version"]
    print(f"\ncable law vs the real EndoWrist (MRD Lab), ratios sim/real: simulator {default} "
          f"(default) -> {calibrated} (calibrated)")
    names = list(c["sessions"])
    print(f"{'figure':30s}" + "".join(f"{n.replace('Tool_', '').replace('_Maryland_L', ''):>14s}"
                                      for n in names))
    for k in c["figures"]:
        cells = [f"{_ratio_cell(c['sessions'][n]['table'][k][f'ratio_{default}'])}->"
                 f"{_ratio_cell(c['sessions'][n]['table'][k][f'ratio_{calibrated}']).strip():6s}"
                 for n in names]
        print(f"{k:30s}" + "".join(f"{x:>14s}" for x in cells))
    for k, a in c["across_folders"][calibrated].items():
        if a["rule"] == "not measurable":
            continue
        print(f"  {k:28s} real {a['real_min']:.4g}..{a['real_max']:.4g} (x{a['real_spread']:.2f}),"
              f" rule {a['rule']}: {'met' if a['met'] else 'NOT MET'} "
              f"(default {default}: {'met' if c['across_folders'][default][k]['met'] else 'not met'})")
    print(f"load-scale sensitivity ({c['load_scale_sensitivity_version']}, ratios on "
          f"{CABLE_LAW_SESSION}): {c['load_scale_sensitivity']}")
    if "fit" in c:
        print(f"fit: {c['fit']}")
    print(f"{'rule':22s}{c['rule']}: {calibrated} {'met' if c['cable_law_ok'] else 'NOT MET'}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None, help="dataset folder (default: a temporary one)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--wpi", type=Path, default=WPI_DEFAULT, help="folder of the WPI recordings")
    ap.add_argument("--derive", action="store_true",
                    help="also derive the coloured effort disturbance from the WPI residual")
    ap.add_argument("--mrdlab", type=Path, default=MRDLAB_DEFAULT,
                    help="folder of the MRD Lab EndoWrist transmission sessions")
    ap.add_argument("--cable-law", action="store_true",
                    help="only the cable law against the real EndoWrist (no protocol, no WPI)")
    ap.add_argument("--fit", action="store_true",
                    help="with the cable law, rerun simulator 2.2's cable-law calibration "
                         "(minutes) and record it under cable_law.fit")
    args = ap.parse_args(argv)
    if args.cable_law:
        if not (args.mrdlab / CABLE_LAW_SESSION).is_dir():
            print(f"sim_calibration: error: no {CABLE_LAW_SESSION} in {args.mrdlab}",
                  file=sys.stderr)
            return 2
        c = cable_law(args.mrdlab, fit=args.fit)
        _print_cable_law(c)
        if args.json:
            write_json(args.json, {"cable_law": json_ready(c)})
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "sim"
        r = calibrate(args.scale, args.seed, out)
    for k, v in r.items():
        if k != "paper":
            print(f"{k:40s} {v}")
    print(f"{'paper':40s} {r['paper']}")
    if (args.wpi / "one_results.csv").is_file():
        r["effort_channels"] = effort_channels(args.wpi, args.derive)
        _print_effort(r["effort_channels"])
    else:
        r["effort_channels"] = f"skipped: no WPI recordings in {args.wpi}"
        print(r["effort_channels"])
    if (args.mrdlab / CABLE_LAW_SESSION).is_dir():
        r["cable_law"] = cable_law(args.mrdlab, fit=args.fit)
        _print_cable_law(r["cable_law"])
        r["cable_law"] = json_ready(r["cable_law"])
    else:
        r["cable_law"] = f"skipped: no {CABLE_LAW_SESSION} in {args.mrdlab}"
        print(r["cable_law"])
    if args.json:
        write_json(args.json, r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
