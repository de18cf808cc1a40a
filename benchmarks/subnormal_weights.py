"""What subnormal weights cost a network on this CPU: a checkpoint as saved against the same
weights with subnormal floats flushed to zero.

    python benchmarks/subnormal_weights.py CHECKPOINT [--steps 3] [--threads 2] [--json OUT]

A float32 below 1.2e-38 in magnitude (other than 0) is subnormal; x86 CPUs compute with them in
microcode, slower than with normal floats, unless the process flushes them to zero
(``torch.set_flush_denormal``). Weight decay drives unused weights towards zero, and GPU
trainings of the paper transformer came back with a share of them subnormal. Printed and
written: the subnormal share of the parameters, then, with flushing off and on (the same
weights; flushing rounds only those values to zero), best of ``--steps`` seconds (of 50 times as
many for the milliseconds of a batch-1 forward pass, the streaming path), a forward pass over
256 windows (offline prediction) and a training step (forward, backward, Adam) on 256 windows.
Inputs are standard normal, the scaled space the networks see.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402

BATCH = 256


def subnormal_share(model: torch.nn.Module) -> float:
    """Fraction of the model's parameters that are subnormal float32 values."""
    tiny = torch.finfo(torch.float32).tiny
    params = [p.detach() for p in model.parameters()]
    return sum(int(((p != 0) & (p.abs() < tiny)).sum()) for p in params) / sum(
        p.numel() for p in params)


def _best_s(fn, steps: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(steps):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def time_model(model: torch.nn.Module, n_features: int, steps: int) -> dict:
    """Best-of-``steps`` seconds of the three workloads (module docstring)."""
    window = model.window
    gen = torch.Generator().manual_seed(0)
    one = torch.randn(1, window, n_features, generator=gen)
    many = torch.randn(BATCH, window, n_features, generator=gen)
    target = torch.randn(BATCH, 3, generator=gen)
    state = {k: v.clone() for k, v in model.state_dict().items()}

    def infer(x):
        model.eval()
        with torch.no_grad():
            model(x)

    def train_step():
        model.train()
        opt.zero_grad(set_to_none=True)
        torch.nn.functional.mse_loss(model(many), target).backward()
        opt.step()

    # a batch-1 pass takes milliseconds: many more repeats for a stable best
    out = {"batch_1_forward_s": _best_s(lambda: infer(one), 50 * steps),
           f"batch_{BATCH}_forward_s": _best_s(lambda: infer(many), steps)}
    opt = torch.optim.Adam(model.parameters(), lr=1e-5)
    out[f"batch_{BATCH}_training_step_s"] = _best_s(train_step, steps)
    model.load_state_dict(state)  # the steps moved the weights; the next run starts the same
    return out


def _shown(checkpoint: Path) -> dict:
    """The checkpoint as the JSON names it: inside a reproduce run (``RUN/work/checkpoints``),
    the run folder and the file name, as the learning curve names its runs; else its path."""
    path = checkpoint.resolve()
    if path.parent.name == "checkpoints" and path.parent.parent.name == "work":
        return {"run": shown_path(path.parents[2]), "checkpoint": path.name}
    return {"checkpoint": shown_path(path)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("checkpoint", type=Path, help="a window network's checkpoint (.pt)")
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    from psmforce.estimators.training.checkpoint import load_checkpoint
    from psmforce.estimators.training.train import is_chunk
    torch.set_num_threads(args.threads)
    setup = load_checkpoint(args.checkpoint)
    if is_chunk(setup.model) or not isinstance(setup.model, torch.nn.Module):
        ap.error(f"{args.checkpoint}: not a window network ({setup.model_name})")
    figures = {**_shown(args.checkpoint), "model": setup.model_name,
               "threads": args.threads, "subnormal_share": subnormal_share(setup.model)}
    for flush in (False, True):
        torch.set_flush_denormal(flush)
        figures["flushed" if flush else "as_saved"] = time_model(
            setup.model, len(setup.features), args.steps)
    torch.set_flush_denormal(False)
    for k in figures["as_saved"]:
        figures[f"{k.removesuffix('_s')}_slowdown"] = figures["as_saved"][k] / figures["flushed"][k]
    print({k: v for k, v in figures.items()})
    if args.json:
        write_json(args.json, figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
