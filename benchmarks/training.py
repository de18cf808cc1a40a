"""Training throughput of every model, before and after the CPU work on the paper transformer,
and its wall-clock to convergence.

    python benchmarks/training.py [--steps 6] [--threads 2] [--converge-scale 0.1] [--json OUT]
    python benchmarks/training.py --profile [--json OUT]

Throughput: optimiser steps (forward, backward, Adam) on batches of the training loop's shape
(window models: 256 windows; chunk models: the batch and chunk of their recipe's training settings,
the LSTM's 16 of 1000 samples), timed after warm-up steps, best of ``--steps``. Printed and written
per model as windows/s (chunks/s for chunk models) and supervised samples/s (one per window; ``chunk
- window`` per chunk). The paper transformer is timed four ways, all the same function
(``tests/estimators/test_hybrid_pipeline.py`` checks the own forward against the stock encoder,
``tests/estimators/test_attention.py`` the chunked attention against plain autograd with the same
mask):

* ``before``: the stock ``nn.TransformerEncoder`` forward (the implementation this replaced);
* ``own forward, torch attention``:
  :class:`psmforce.estimators.networks.baselines.PaperTransformer`'s forward (last layer for the
  last sample only) with torch's attention kernel and its dropout;
* ``after``: the same with the attention and its dropout in cache-sized chunks
  (:mod:`psmforce.estimators.networks.attention`), the model as trained;
* ``after, compiled``: the same through ``torch.compile`` (``TrainConfig.compile``; the first
  two steps, which include compiling, are printed apart).

``--converge-scale S``: simulate an automated bench at scale ``S`` (seed 1), fit the prior, and
train the paper transformer with the published budget (early stopping, no caps) on it;
prints epochs, why it stopped and the wall-clock, and the test trials' prediction time in the
training process against a fresh one (a slowdown after training would show here; the one seen
in long runs came from numba's OpenMP pool, ``benchmarks/process_interference.py``). Target:
converged in under 30 minutes at S >= 0.1 on 2 cores.

``--profile`` (instead of the above): where the paper transformer's training step spends its
time, torch's profiler over two steps after warm-up, the operators with the largest share of
self CPU time. Shares, not seconds: they hold on a busy machine where timings do not.
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch
from torch.nn import functional as F

from psmforce.estimators.networks.attention import CHUNK_WINDOWS, _DroppedAttention
from psmforce.estimators.networks.baselines import PaperTransformer
from psmforce.estimators.networks.recipes import build_model, recipe
from psmforce.estimators.training.train import TrainConfig, chunk_length
from psmforce.experiments.report import write_json


class _TorchAttentionTransformer(PaperTransformer):
    """The model's own forward with torch's attention kernel, dropout included (torch's math
    path on a CPU): the implementation :mod:`psmforce.estimators.networks.attention` replaced."""

    attend = staticmethod(lambda q, k, v, dropout_p: F.scaled_dot_product_attention(
        q, k, v, dropout_p=dropout_p))


class _StockTransformer(PaperTransformer):
    """The paper transformer through the stock encoder: every layer over every position."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.decoder(self.encoder(self.positions(self.embed(x)))[:, -1])


class _ChunkedAttentionTransformer(PaperTransformer):
    """The model as a CPU trains it (:mod:`psmforce.estimators.networks.attention`'s chunk loop), on any device: off the
    CPU :func:`psmforce.estimators.networks.attention.attention` takes torch's kernel, and this times what it avoids."""

    attend = staticmethod(lambda q, k, v, dropout_p: _DroppedAttention.apply(
        q, k, v, dropout_p, CHUNK_WINDOWS))


def _step_seconds(model, x, steps: int, compile_model: bool = False,
                  bf16: bool = False) -> tuple[float, float]:
    """(best seconds per optimiser step, compile + warm-up seconds), on ``x``'s device. ``bf16``:
    the forward and the loss under CPU autocast to bfloat16 (weights and optimiser stay
    float32)."""
    torch.manual_seed(0)
    model.to(x.device).train()
    sync = torch.cuda.synchronize if x.device.type == "cuda" else (lambda: None)
    forward = torch.compile(model) if compile_model else model
    opt = torch.optim.Adam(model.parameters(), lr=1e-3, weight_decay=1e-4)

    def step():
        opt.zero_grad(set_to_none=True)
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
            out = forward(x)
            loss = out[:, model.window:].square().mean() if model.kind == "chunk" else \
                out.square().mean()
        loss.backward()
        opt.step()
        sync()  # a GPU runs the step asynchronously
    t0 = time.perf_counter()
    for _ in range(2):
        step()
    warm = time.perf_counter() - t0
    best = float("inf")
    for _ in range(steps):
        t0 = time.perf_counter()
        step()
        best = min(best, time.perf_counter() - t0)
    return best, warm


def _throughput(steps: int, device: str = "cpu") -> dict:
    """Every case on ``device``; off the CPU the compiled case is left out (its compile time
    dominates a short call) and the CPU's chunked attention is timed as a case of its own."""
    from psmforce.estimators.data.hybrid_inputs import hybrid_columns
    n_hybrid = len(hybrid_columns(True)[0])
    lstm_chunk = recipe("lstm").optimiser["chunk"]
    hybrid, hybrid_cfg = build_model("hybrid", n_hybrid), TrainConfig(**recipe("hybrid").optimiser)
    hybrid_chunk = chunk_length(hybrid, hybrid_cfg)
    cases = {  # name: (model, input columns, batch, samples per window or chunk, compiled)
        "transformer (before: stock encoder)": (_StockTransformer(21), 21, 256, 100, False),
        "transformer (own forward, torch attention)": (_TorchAttentionTransformer(21), 21, 256,
                                                       100, False),
        "transformer (after)": (PaperTransformer(21), 21, 256, 100, False),
        "transformer (after, compiled)": (PaperTransformer(21), 21, 256, 100, True),
        "fcn": (build_model("fcn", 21), 21, 256, 1, False),
        "lstm": (build_model("lstm", 36), 36, 16, lstm_chunk, False),
        "hybrid": (hybrid, n_hybrid, hybrid_cfg.chunk_batch_size, hybrid_chunk, False),
    }
    if device != "cpu":
        del cases["transformer (after, compiled)"]
        cases["transformer (chunked attention, the CPU's path)"] = (
            _ChunkedAttentionTransformer(21), 21, 256, 100, False)
    out = {}
    for name, (model, n_inputs, batch, length, compiled) in cases.items():
        sec, warm = _step_seconds(model, torch.randn(batch, length, n_inputs, device=device),
                                  steps, compiled)
        unit = "windows" if model.kind == "window" else "chunks"
        supervised = batch if model.kind == "window" else batch * (length - model.window)
        out[name] = {"seconds_per_step": sec, "first_two_steps_s": warm, "batch": batch,
                     "length": length, f"{unit}_per_s": batch / sec,
                     "supervised_samples_per_s": supervised / sec}
        print(f"  {name:38s} {batch / sec:9.1f} {unit}/s {supervised / sec:10.0f} supervised "
              f"samples/s ({sec:.3f} s/step; first two steps {warm:.1f} s)", flush=True)
    before = out["transformer (before: stock encoder)"]["seconds_per_step"]
    for k in [k for k in out if k.startswith("transformer (") and "before" not in k]:
        out[k]["speedup_vs_before"] = before / out[k]["seconds_per_step"]
    return out


SPEED_OPTIONS = {"float32, batch 256 (as trained)": (256, False),
                 "bf16 autocast, batch 256": (256, True),
                 "float32, batch 1024": (1024, False),
                 "bf16 autocast, batch 1024": (1024, True)}
"""Issue 28's training-speed options for the paper transformer: (batch, bf16 autocast)."""


def _speed_options(steps: int) -> dict:
    """Windows per second of the paper transformer's training step under each of
    :data:`SPEED_OPTIONS`, and the data path's share: the seconds
    :class:`psmforce.estimators.data.dataset.WindowSet` takes to gather a batch, against the
    step."""
    import numpy as np
    import pandas as pd
    from psmforce.estimators.data.dataset import Scaler, Trial, WindowSet
    out = {}
    for name, (batch, bf16) in SPEED_OPTIONS.items():
        torch.manual_seed(0)
        sec, _ = _step_seconds(PaperTransformer(21), torch.randn(batch, 100, 21), steps,
                               bf16=bf16)
        out[name] = {"batch": batch, "bf16": bf16, "seconds_per_step": sec,
                     "windows_per_s": batch / sec}
    base = out["float32, batch 256 (as trained)"]["windows_per_s"]
    for name, r in out.items():
        r["speedup"] = r["windows_per_s"] / base
        print(f"  {name:34s} {r['windows_per_s']:8.0f} windows/s  x{r['speedup']:.2f}", flush=True)
    cols = [f"c{k}" for k in range(21)]
    rng = np.random.default_rng(0)
    frame = pd.DataFrame(rng.normal(size=(20000, 24)), columns=cols + ["ati_fx", "ati_fy", "ati_fz"])
    scaler = Scaler(np.zeros(21, np.float32), np.ones(21, np.float32))
    target = Scaler(np.zeros(3, np.float32), np.ones(3, np.float32))
    data = WindowSet([Trial("t", "Traction", "train", frame)], cols, scaler, target, 100, 5,
                     targets="last")
    order = torch.randperm(len(data))
    best = float("inf")
    for b in range(max(steps, 3)):
        t0 = time.perf_counter()
        data.batch(order[b * 256:(b + 1) * 256])
        best = min(best, time.perf_counter() - t0)
    step = out["float32, batch 256 (as trained)"]["seconds_per_step"]
    out["data path"] = {"seconds_per_batch_256": best, "share_of_step": best / step}
    print(f"  data path: {best * 1e3:.2f} ms to gather 256 windows, {100 * best / step:.1f} % of "
          f"a float32 step", flush=True)
    return out


def _profile(top: int = 10) -> dict:
    from torch.profiler import ProfilerActivity, profile
    model, x = PaperTransformer(21), torch.randn(256, 100, 21)
    _step_seconds(model, x, 1)  # warm-up
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        _step_seconds(model, x, 0)  # its two untimed steps
    ops = prof.key_averages()
    total = sum(e.self_cpu_time_total for e in ops)
    shares = sorted(((e.key, e.self_cpu_time_total / total, e.count) for e in ops),
                    key=lambda t: -t[1])[:top]
    for name, share, count in shares:
        print(f"  {name:45s} {100 * share:5.1f} % of self CPU time ({count} calls)")
    return {"model": "transformer (after)", "batch": 256, "length": 100,
            "top_ops": [{"op": n, "self_cpu_share": sh, "calls": c} for n, sh, c in shares]}


_FRESH_PREDICT = """
import sys, time
import torch
from psmforce.estimators.training.checkpoint import load_checkpoint
from psmforce.estimators.data.dataset import load_dataset
from psmforce.estimators.evaluation.evaluate import predict_trial
torch.set_num_threads(int(sys.argv[3]))
setup = load_checkpoint(sys.argv[1])
ds = load_dataset(sys.argv[2])
setup.derive(ds)
t0 = time.perf_counter()
for t in ds.select(split="test"):
    predict_trial(setup, t)
print(time.perf_counter() - t0)
"""


def _predict_seconds(setup, trials) -> float:
    from psmforce.estimators.evaluation.evaluate import predict_trial
    t0 = time.perf_counter()
    for t in trials:
        predict_trial(setup, t)
    return time.perf_counter() - t0


def _converge(scale: float) -> dict:
    """Train to convergence, then time the test trials' prediction twice: in the process that
    trained (what ``reproduce`` and ``another_tool`` do) and in a fresh one from the checkpoint."""
    from psmforce.estimators.data.dataset import load_dataset, split_validation
    from psmforce.experiments.reproduce import _config
    from psmforce.estimators.training.train import make_setup, train_model
    from psmforce.sim import simulate
    with tempfile.TemporaryDirectory() as tmp:
        simulate("automated", scale=scale, seed=1, out=Path(tmp) / "bench")
        ds = load_dataset(Path(tmp) / "bench")
        train, val = split_validation(ds.select(split="train"), 0.1, 1)
        setup = make_setup("transformer", train)
        cfg = _config("full", "pretrain", 1, "cpu", "transformer", recipe("transformer").optimiser)
        cfg.progress = True   # a run of tens of minutes: show its epochs
        rep = train_model(setup, train, val, cfg)
        test = ds.select(split="test")
        setup.derive(ds)
        in_process = _predict_seconds(setup, test)
        setup.save(Path(tmp) / "transformer.pt")
        fresh = float(subprocess.run(
            [sys.executable, "-c", _FRESH_PREDICT, str(Path(tmp) / "transformer.pt"),
             str(Path(tmp) / "bench"), str(torch.get_num_threads())],
            check=True, capture_output=True, text=True).stdout.split()[-1])
    result = {"scale": scale, "epochs_run": rep["epochs_run"], "stopped_by": rep["stopped_by"],
              "converged": rep["converged"], "seconds": rep["seconds"],
              "train_windows": rep["train_windows"], "best_val_loss": rep["best_val_loss"],
              "compiled": cfg.compile, "test_predict_s_in_training_process": in_process,
              "test_predict_s_fresh_process": fresh}
    print(f"  paper transformer at scale {scale}: {rep['epochs_run']} epochs, stopped by "
          f"{rep['stopped_by']}, converged {rep['converged']}, {rep['seconds'] / 60:.1f} min, "
          f"{rep['train_windows']} training windows per epoch; test prediction {in_process:.1f} s "
          f"in the training process, {fresh:.1f} s in a fresh one", flush=True)
    return result


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=6, help="timed steps per model (best taken)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--converge-scale", type=float,
                    help="also train the paper transformer to convergence at this scale")
    ap.add_argument("--profile", action="store_true",
                    help="only profile the paper transformer's training step")
    ap.add_argument("--speed-options", action="store_true",
                    help="only time the paper transformer under SPEED_OPTIONS and the data path")
    ap.add_argument("--device", default="cpu", help="torch device of the throughput timings")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    if args.device != "cpu" and (args.speed_options or args.profile or args.converge_scale):
        ap.error("--device applies to the throughput timings only; --speed-options, --profile "
                 "and --converge-scale time the CPU")
    torch.set_num_threads(args.threads)
    result = {"machine": {"platform": platform.platform(), "threads": args.threads,
                          "torch": torch.__version__, "device": args.device}
              | ({"gpu": torch.cuda.get_device_name()} if args.device.startswith("cuda")
                 else {})}
    if args.speed_options:
        print(f"paper transformer training speed options, {args.threads} threads")
        result["speed_options"] = _speed_options(args.steps)
    elif args.profile:
        print(f"paper transformer training step, {args.threads} threads")
        result["profile"] = _profile()
    else:
        print(f"training throughput on {args.device}, {args.threads} threads, "
              f"torch {torch.__version__}")
        result["throughput"] = _throughput(args.steps, args.device)
    if args.converge_scale and not (args.profile or args.speed_options):
        result["convergence"] = _converge(args.converge_scale)
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
