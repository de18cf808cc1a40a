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
the static compliance, computed the same way on the real recordings and on the bench's cable law
replaying their grid (psmforce/experiments/cable_law_figures.py), with the ratio sim / real (rule:
every checked ratio within [0.67, 1.5] on Tool_4_Maryland_L_4; the other sessions are a spread),
also for the defaults before the calibration; skipped when the MRD Lab folder is absent.
``--cable-law`` runs only these rows (seconds). ``--json PATH`` writes everything. Usage::

    python studies/sim_calibration.py [--scale 1.0] [--seed 0] [--out DIR] [--json PATH]
                                         [--wpi ../shared/data/wpi_psm] [--derive]
                                         [--mrdlab ../shared/data/mrdlab] [--cable-law]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from psmforce.robot.conventions import JOINTS
from psmforce.sim import (Contact, Effects, InstrumentParams, motion, protocols, run_trajectory,
                          simulate)
from psmforce.experiments import bench_calibration as calibration
from psmforce.experiments import cable_law_figures as transmission_figures
from psmforce.experiments.report import shown_path, write_json

WPI_DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data" / "wpi_psm"
MRDLAB_DEFAULT = Path(__file__).resolve().parents[2] / "shared" / "data" / "mrdlab"
CABLE_LAW_SESSION = "Tool_4_Maryland_L_4"
"""The session the cable-law rule is checked on (the 2018 paper's; ten load levels)."""
PREVIOUS_CABLE_DEFAULTS = {"cable_stiffness_n_per_m": 6.0e5, "pitch_path_mismatch_m": 1.5e-6}
"""The ``InstrumentParams`` defaults before the calibration against the real EndoWrist (the
"sim before" column)."""
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


def cable_law(mrdlab_dir: Path) -> dict:
    """The cable law against the real EndoWrist: per MRD Lab session the real figures, the
    simulated ones with the current and with the previous defaults, their comparison, and the
    figures per load level; on :data:`CABLE_LAW_SESSION` the rule and a load-scale sensitivity."""
    start = time.perf_counter()
    before = dataclasses.replace(InstrumentParams(), **PREVIOUS_CABLE_DEFAULTS)
    out = {"mrdlab": shown_path(mrdlab_dir), "checked_session": CABLE_LAW_SESSION,
           "checked_figures": list(transmission_figures.CHECKED),
           "previous_defaults": PREVIOUS_CABLE_DEFAULTS,
           "current_defaults": {k: getattr(InstrumentParams(), k) for k in PREVIOUS_CABLE_DEFAULTS},
           "sessions": {}}
    for folder in transmission_figures.sessions(mrdlab_dir):
        now = transmission_figures.real_vs_sim(folder)
        old = transmission_figures.real_vs_sim(folder, before)
        rows = {k: {"real": v["real"], "sim_before": old["comparison"][k]["sim"],
                    "ratio_before": old["comparison"][k]["ratio"], "sim": v["sim"],
                    "ratio": v["ratio"], "ok": v["ok"]} for k, v in now["comparison"].items()}
        out["sessions"][folder.name] = {
            "load_scale_sim_per_real": now["load_scale_sim_per_real"], "table": rows,
            "real": _without_runs(now["real"]), "sim": _without_runs(now["sim"]),
            "sim_before": _without_runs(old["sim"]),
            "by_load_level": {"real": transmission_figures.by_load_level(now["real"]),
                              "sim": transmission_figures.by_load_level(now["sim"])}}
    if CABLE_LAW_SESSION not in out["sessions"]:
        raise FileNotFoundError(f"{mrdlab_dir}: no {CABLE_LAW_SESSION} session")
    checked = out["sessions"][CABLE_LAW_SESSION]["table"]
    out["rule"] = (f"every {', '.join(transmission_figures.CHECKED)} ratio sim/real within "
                   f"{list(transmission_figures.RATIO_RANGE)} on {CABLE_LAW_SESSION}")
    out["cable_law_ok"] = bool(all(r["ok"] for r in checked.values()))
    out["load_scale_sensitivity"] = {
        str(f): {k: v["ratio"] for k, v in transmission_figures.real_vs_sim(
            Path(mrdlab_dir) / CABLE_LAW_SESSION, load_scale_factor=f)["comparison"].items()}
        for f in LOAD_SCALE_SENSITIVITY}
    out["seconds"] = round(time.perf_counter() - start, 1)
    return out


def _print_cable_law(c: dict) -> None:
    print(f"\ncable law vs the real EndoWrist (MRD Lab; rule on {c['checked_session']})")
    print(f"{'session / figure':44s}{'real':>10s}{'sim before':>12s}{'ratio':>8s}{'sim':>10s}"
          f"{'ratio':>8s}")
    for name, sess in c["sessions"].items():
        print(f"{name} (sim load per real load {sess['load_scale_sim_per_real']:.3f})")
        for k, r in sess["table"].items():
            print(f"  {k:42s}{r['real']:10.4g}{r['sim_before']:12.4g}{r['ratio_before']:8.3f}"
                  f"{r['sim']:10.4g}{r['ratio']:8.3f}{'' if r['ok'] else '  outside'}")
        for k in ("zero_load_friction_fraction", "friction_fraction_at_full_load"):
            print(f"  {k + ' (not checked)':42s}{sess['real'][k]:10.4g}"
                  f"{sess['sim_before'][k]:12.4g}{'':8s}{sess['sim'][k]:10.4g}")
    print(f"load-scale sensitivity (ratios): {c['load_scale_sensitivity']}")
    print(f"{'rule':22s}{c['rule']}: {'ok' if c['cable_law_ok'] else 'NOT MET'}")


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
    args = ap.parse_args(argv)
    if args.cable_law:
        if not (args.mrdlab / CABLE_LAW_SESSION).is_dir():
            print(f"sim_calibration: error: no {CABLE_LAW_SESSION} in {args.mrdlab}",
                  file=sys.stderr)
            return 2
        c = cable_law(args.mrdlab)
        _print_cable_law(c)
        if args.json:
            write_json(args.json, {"cable_law": c})
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
        r["cable_law"] = cable_law(args.mrdlab)
        _print_cable_law(r["cable_law"])
    else:
        r["cable_law"] = f"skipped: no {CABLE_LAW_SESSION} in {args.mrdlab}"
        print(r["cable_law"])
    if args.json:
        write_json(args.json, r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
