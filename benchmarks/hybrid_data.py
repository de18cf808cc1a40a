"""Data-pipeline speed: load ~1 M recorded rows, build the windowed training set, gather batches.

    python benchmarks/hybrid_data.py [--rows 1000000] [--files 100] [--json OUT.json]

Writes synthetic recordings in the contract's layout (psmforce.io.recording, all columns random, 100
Hz) into a temporary folder, then times :func:`psmforce.estimators.data.dataset.load_dataset` (the
CSV parse and checks), scaler fitting, :class:`psmforce.estimators.data.dataset.WindowSet`
construction for the paper's transformer (L = 100, s = 5, zero-copy view) and the gathering of 100
batches of 256 windows. One thread for torch; the CSV reader uses two threads.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from psmforce.estimators.data.dataset import (WindowSet, fit_scalers, index_recordings,
                                              load_dataset, resolve_features)
from psmforce.io.recording import REQUIRED, TARGETS, write_recording
from psmforce.experiments.report import write_json


def main() -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--files", type=int, default=100)
    parser.add_argument("--json", default=None)
    args = parser.parse_args()
    torch.set_num_threads(1)
    rng = np.random.default_rng(0)
    per_file = args.rows // args.files
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for k in range(args.files):
            folder = root / "train" / ("Free", "Traction", "Palpation")[k % 3]
            folder.mkdir(parents=True, exist_ok=True)
            data = {"time": np.arange(per_file) / 100.0}
            data.update({c: rng.normal(size=per_file) for c in REQUIRED[1:] + TARGETS})
            write_recording(pd.DataFrame(data), folder / f"trial_{k:03d}.csv")
        index_recordings(root)
        t0 = time.perf_counter()
        dataset = load_dataset(root)
        t_load = time.perf_counter() - t0
    rows = sum(len(t) for t in dataset.trials)
    features = resolve_features("paper")
    t0 = time.perf_counter()
    x_scaler, y_scaler = fit_scalers(dataset.trials, features)
    t_scale = time.perf_counter() - t0
    t0 = time.perf_counter()
    windows = WindowSet(dataset.trials, features, x_scaler, y_scaler, 100, 5,
                        downsample_free=True)
    t_windows = time.perf_counter() - t0
    order = torch.randperm(len(windows), generator=torch.Generator().manual_seed(0))
    t0 = time.perf_counter()
    for b in range(100):
        windows.batch(order[b * 256:(b + 1) * 256])
    t_batches = time.perf_counter() - t0
    result = {"rows": rows, "files": args.files, "load_s": t_load, "fit_scalers_s": t_scale,
              "window_set_s": t_windows, "windows": len(windows),
              "batch_256_gather_ms": t_batches / 100 * 1e3,
              "rows_per_s_loading": rows / t_load}
    print(f"loaded {rows} rows from {args.files} CSV files in {t_load:.2f} s "
          f"({rows / t_load / 1e6:.2f} M rows/s); scalers {t_scale:.2f} s; "
          f"{len(windows)} windows (L=100, s=5, free x4 sparser) in {t_windows:.2f} s; "
          f"one batch of 256 windows gathered in {t_batches / 100 * 1e3:.2f} ms")
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
