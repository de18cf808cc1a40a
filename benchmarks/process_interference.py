"""Does one model's run slow the next one in the same process? The paper transformer's prediction
before and after MultiRocket-Hydra's, per numba threading layer.

    python benchmarks/process_interference.py [--scale 0.02] [--trials 3] [--threads 2] [--json OUT]

``psmforce reproduce`` and ``studies/another_tool.py`` train and score several models in one
process. MultiRocket-Hydra's kernels run on numba's parallel threads; with numba's OpenMP layer (its
default where TBB is absent) a second libgomp pool lives beside torch's, and torch's attention
afterwards ran about 85x slower (one test trial: 1.07 s -> 90.5 s).
:mod:`psmforce.estimators.networks.rocket` therefore picks numba's ``workqueue`` layer unless the
user set ``NUMBA_THREADING_LAYER``.

This simulates a small automated bench, trains a paper transformer (1 epoch: only its inference
time matters here) and a MultiRocket-Hydra (2,000 training windows), then, for each layer
(the library's choice, and ``omp``), in a fresh process: times the transformer's prediction of the
first ``--trials`` test trials (best of two), predicts them with MultiRocket-Hydra, and times the
transformer again.
Prints and writes (JSON) the seconds and the slowdown ``after / before``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

from psmforce.experiments.report import write_json

LAYERS = {"library (workqueue)": None, "omp (numba's default here)": "omp"}

_ONE_PROCESS = """
import json, sys, time
import torch
from psmforce.estimators.training.checkpoint import load_checkpoint
from psmforce.estimators.data.dataset import load_dataset
from psmforce.estimators.evaluation.evaluate import predict_trial
data, transformer, rocket, threads, n_trials = sys.argv[1:6]
torch.set_num_threads(int(threads))
ds = load_dataset(data)
test = ds.select(split="test")[:int(n_trials)]
models = {"transformer": load_checkpoint(transformer)}
models["transformer"].derive(ds)

def seconds(name):
    t0 = time.perf_counter()
    for t in test:
        predict_trial(models[name], t)
    return time.perf_counter() - t0

before = min(seconds("transformer") for _ in range(2))
models["rocket"] = load_checkpoint(rocket)   # loading rebuilds aeon's transforms: numba starts
models["rocket"].derive(ds)
rocket_s = seconds("rocket")
after = seconds("transformer")
import numba
print(json.dumps({"transformer_before_s": before, "rocket_s": rocket_s,
                  "transformer_after_s": after, "slowdown": after / before,
                  "numba_layer": numba.threading_layer()}))
"""


def _models(tmp: Path, scale: float) -> tuple[Path, Path, Path]:
    from psmforce.estimators.training.train import train
    from psmforce.sim import simulate
    data = tmp / "bench"
    simulate("automated", scale=scale, seed=1, out=data)
    transformer, rocket = tmp / "transformer.pt", tmp / "rocket.pt"
    train(data, "transformer", transformer, epochs=1)
    train(data, "rocket", rocket, config={"max_train_windows": 2000})
    return data, transformer, rocket


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=0.02)
    ap.add_argument("--trials", type=int, default=3, help="test trials predicted (the slow case "
                    "takes minutes per trial)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    result = {"machine": {"platform": platform.platform(), "threads": args.threads},
              "scale": args.scale, "test_trials": args.trials, "layers": {}}
    with tempfile.TemporaryDirectory() as tmp:
        paths = [str(p) for p in _models(Path(tmp), args.scale)]
        for name, layer in LAYERS.items():
            env = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
            if layer:
                env["NUMBA_THREADING_LAYER"] = layer
            out = subprocess.run([sys.executable, "-c", _ONE_PROCESS, *paths, str(args.threads),
                                  str(args.trials)],
                                 env=env, check=True, capture_output=True, text=True).stdout
            r = result["layers"][name] = json.loads(out.strip().splitlines()[-1])
            print(f"  numba layer {name:28s} transformer {r['transformer_before_s']:6.2f} s "
                  f"before MultiRocket-Hydra, {r['transformer_after_s']:7.2f} s after "
                  f"(x{r['slowdown']:.1f}; numba ran on {r['numba_layer']})", flush=True)
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
