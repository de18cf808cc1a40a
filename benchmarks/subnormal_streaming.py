"""What subnormal weights would cost the streaming step, and that flushing them at load removes it.

    python benchmarks/subnormal_streaming.py [--steps 3000] [--json OUT.json]

The hybrid's network (the recipe's default architecture, untrained, 21 features) gets the share
of subnormal weights that ``results/benchmarks/subnormal_weights.json`` measured on a GPU-trained
checkpoint (read from it, not typed here), each of either sign and below 1.2e-38 in magnitude.
Per backend (:func:`psmforce.estimators.runtime.steppers.make_backend`), one thread: the batch-1
step's median and p99 (ms) over ``--steps`` standard-normal inputs after 200 warm-up steps, on
the weights as saved (``flush=False``) and as every streaming path now runs them (flushed), their
ratio, and the largest difference between the two backends' outputs (float32 rounding).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import torch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.estimators.networks.recipes import build_model  # noqa: E402
from psmforce.estimators.runtime.steppers import (BACKENDS, make_backend,  # noqa: E402
                                                  subnormal_count)
from psmforce.experiments.report import write_json  # noqa: E402

SOURCE = ROOT / "results" / "benchmarks" / "subnormal_weights.json"
N_FEATURES = 21
WARMUP = 200


def make_subnormal(model: torch.nn.Module, share: float, seed: int = 0) -> torch.nn.Module:
    """``model`` (in place, returned) with ``share`` of its weights replaced by subnormal values
    of either sign, as a GPU training's weight decay leaves them."""
    gen = torch.Generator().manual_seed(seed)
    tiny = torch.finfo(torch.float32).tiny
    with torch.no_grad():
        for p in model.parameters():
            pick = torch.rand(p.shape, generator=gen) < share
            sign = torch.where(torch.rand(p.shape, generator=gen) < 0.5, -1.0, 1.0)
            p[pick] = (sign * tiny * torch.rand(p.shape, generator=gen) * 0.9)[pick]
    return model


def with_subnormals(share: float, seed: int = 0) -> torch.nn.Module:
    """The default hybrid network with ``share`` of its weights made subnormal."""
    torch.manual_seed(seed)
    return make_subnormal(build_model("hybrid", N_FEATURES).eval(), share, seed)


def time_steps(stepper, x: np.ndarray) -> tuple[dict, np.ndarray]:
    """Median / p99 ms of one step after the warm-up, and every output."""
    stepper.reset()
    times, out = [], []
    for row in x:
        t0 = time.perf_counter_ns()
        y = stepper.step(row)
        times.append(time.perf_counter_ns() - t0)
        out.append(y.copy())
    ms = np.array(times[WARMUP:]) * 1e-6
    return {"median_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99))}, \
        np.array(out)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    share = json.loads(SOURCE.read_text())["subnormal_share"]
    model = with_subnormals(share)
    x = np.random.default_rng(0).standard_normal((WARMUP + args.steps, N_FEATURES)
                                                 ).astype(np.float32)
    out = {"share_from": "results/benchmarks/subnormal_weights.json", "subnormal_share": share,
           "subnormal_weights": subnormal_count(model), "steps": args.steps,
           "threads": 1, "backends": {}}
    for backend in BACKENDS:
        saved, y_saved = time_steps(make_backend(model, backend, flush=False), x)
        flushed, y_flushed = time_steps(make_backend(model, backend), x)
        out["backends"][backend] = {
            "as_saved": saved, "flushed": flushed,
            "median_slowdown_as_saved": saved["median_ms"] / flushed["median_ms"],
            "max_abs_output_difference": float(np.abs(y_saved - y_flushed).max())}
    print(json.dumps(out, indent=1))
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    main()
