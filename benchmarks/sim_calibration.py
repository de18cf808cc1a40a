"""Calibration of the simulated bench against the seed paper's observations.

Runs the automated protocol (``--scale``, default 1.0 = the paper's size), times it, reads the
written dataset back and prints each figure next to the paper's value and the acceptance rule of
issue 3; ``--json PATH`` writes them. Usage::

    python benchmarks/sim_calibration.py [--scale 1.0] [--seed 0] [--out DIR] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from psm_model.sim import Contact, Effects, InstrumentParams, protocols, run_trajectory, simulate
from _report import write_json

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
        q = protocols.piecewise(way, np.full(4, 1.5), np.full(4, 1.0))
        fz = run_trajectory(q, protocols.DT, Contact(), InstrumentParams(), Effects(),
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=None, help="dataset folder (default: a temporary one)")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp) / "sim"
        r = calibrate(args.scale, args.seed, out)
    for k, v in r.items():
        if k != "paper":
            print(f"{k:40s} {v}")
    print(f"{'paper':40s} {r['paper']}")
    if args.json:
        write_json(args.json, r)
    return 0


if __name__ == "__main__":
    sys.exit(main())
