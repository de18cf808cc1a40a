"""Real-time figures of the streaming hybrid estimator against the paper's transformer.

    python benchmarks/streaming.py [--checkpoint HYBRID.pt] [--data DIR] [--prior PRIOR.json]
                                   [--steps 5000] [--json OUT.json]

One core (torch, BLAS and OpenMP set to one thread before they load). ``--data``: a simulated
dataset folder (default: a small one simulated into a temporary folder, seed 0);
``--checkpoint``: a trained hybrid (default: an untrained hybrid of the default size, with the
scalers fitted on the data's train split and ``--prior`` if given; latency does not depend on
the weights). Prints and writes (JSON):

* per-step latency (median / p99 / max, ms; wall clock, and the thread's CPU time, which leaves out
  waits while other processes hold the core) over ``--steps`` steps after 500 warm-up steps of the
  full hybrid pipeline fed recorded samples as dicts: input checks, prior, compensated inputs,
  scaling, network step (backend ``auto``), un-scaling, causal low-pass; and of the same with
  base-frame output (PSM rotation per sample);
* the same for the paper's transformer (psmforce/estimators/networks/baselines.py, 155,715
  parameters) recomputing its 100-sample window each step in eager PyTorch (scaling included): the
  reference;
* the paper's transformer through the library's streaming pipeline (its last 100 inputs as the
  state, :mod:`psmforce.estimators.runtime.window_stream`; backend ``auto``, the same post-filter):
  what ``psmforce serve`` pays for a window model;
* network-step latency per backend (numpy, onnx, torch), the basis of ``backend="auto"``;
* offline batch throughput (windows = estimates per second) on the test recordings;
* max |streaming - offline| (N) on a recorded test trial;
* each causal post-filter's lag and, with a trained checkpoint, its accuracy (RMSE / NRMSE per
  axis on the test split, from sample 99, no bias step) next to the raw estimate and the paper's
  bidirectional median (k = 71).

Targets (wall clock): hybrid p99 < 1.0 ms; hybrid median >= 5x faster than the reference median in
the same run; offline >= 20,000 windows/s; streaming == offline within 1e-4 N.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import torch  # noqa: E402

from psmforce.estimators.networks.causal import CausalTransformer  # noqa: E402
from psmforce.estimators.data.dataset import fit_scalers, load_dataset  # noqa: E402
from psmforce.estimators.evaluation.evaluate import EVAL_START  # noqa: E402
from psmforce.estimators.data.hybrid_inputs import (add_prior_columns, hybrid_columns, select_base)  # noqa: E402
from psmforce.estimators.evaluation.metrics import axis_metrics, postprocess  # noqa: E402
from psmforce.estimators.networks.baselines import PaperTransformer, count_parameters  # noqa: E402
from psmforce.estimators.runtime.postfilter import CausalFilter  # noqa: E402
from psmforce.estimators.runtime.steppers import make_backend  # noqa: E402
from psmforce.estimators.runtime.streaming import Flags, StreamingEstimator  # noqa: E402
from psmforce.io.recording import PAPER_FEATURES, TARGETS  # noqa: E402
from psmforce.experiments.report import cpu_model, shown_path, write_json  # noqa: E402

TARGET_P99_MS = 1.0
TARGET_SPEEDUP = 5.0
TARGET_WINDOWS_PER_S = 20_000
TARGET_STREAM_DIFF_N = 1e-4
WARMUP = 500
POST_FILTER = {"post_filter": "lowpass", "lowpass_hz": 5.0, "lowpass_order": 2}
FILTERS = {"none": {"post_filter": "none"},
           "lowpass_5hz": POST_FILTER,
           "lowpass_2hz": {"post_filter": "lowpass", "lowpass_hz": 2.0, "lowpass_order": 2},
           "median_11": {"post_filter": "median", "median_kernel": 11},
           "median_71_trailing": {"post_filter": "median", "median_kernel": 71}}


def _stats(times: tuple[list[int], list[int]]) -> dict:
    """Wall-clock figures, and the same of the thread's CPU time (which leaves out the time the
    process waited while other processes had the core: the shared machine's noise)."""
    wall, cpu = (np.asarray(t) * 1e-6 for t in times)
    out = {"median_ms": float(np.median(wall)), "p99_ms": float(np.percentile(wall, 99)),
           "max_ms": float(wall.max()), "steps": len(wall)}
    out.update(cpu_median_ms=float(np.median(cpu)), cpu_p99_ms=float(np.percentile(cpu, 99)),
               cpu_max_ms=float(cpu.max()))
    return out


def _time_steps(step, n: int) -> tuple[list[int], list[int]]:
    wall, cpu = [], []
    wall_clock, cpu_clock = time.perf_counter_ns, time.thread_time_ns
    for i in range(WARMUP + n):
        w0, c0 = wall_clock(), cpu_clock()
        step(i)
        w1, c1 = wall_clock(), cpu_clock()
        if i >= WARMUP:
            wall.append(w1 - w0)
            cpu.append(c1 - c0)
    return wall, cpu


def _load(args, tmp: Path):
    data = Path(args.data) if args.data else None
    if data is None:
        from psmforce.sim.dataset import simulate
        data = tmp / "sim"
        simulate("automated", scale=0.03, seed=0, out=data)
    dataset = load_dataset(data)
    prior = None
    if args.checkpoint:
        est = StreamingEstimator.from_checkpoint(args.checkpoint)
        prior = est.inputs.prior
        label = f"checkpoint {args.checkpoint}"
        trained = True
        model_config = {"window": est.window, "parameters": count_parameters(est.model)}
        make = lambda **o: StreamingEstimator.from_checkpoint(args.checkpoint, **o)  # noqa: E731
    else:
        if args.prior:
            from psmforce.identification.prior import InternalForcePrior
            prior = InternalForcePrior.load(args.prior)
        features, base = hybrid_columns(use_prior=prior is not None)
        if prior is not None:
            add_prior_columns(dataset, prior)
        torch.manual_seed(0)
        model = CausalTransformer(len(features)).eval()
        base = select_base(dataset.select(split="train"), base)
        xs, ys = fit_scalers(dataset.select(split="train"), features, base_columns=base)
        make = lambda **o: StreamingEstimator(model, features, xs, ys, base, prior, **o)  # noqa
        label = "untrained default hybrid" + (" with prior" if prior is not None else
                                              " WITHOUT prior (no --prior given)")
        trained = False
        model_config = {"window": model.window, "parameters": count_parameters(model)}
    return dataset, make, label, trained, model_config, prior is not None, data


def main() -> tuple[dict, str | None]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoint")
    parser.add_argument("--data")
    parser.add_argument("--prior")
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--json")
    args = parser.parse_args()
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        dataset, make, label, trained, model_config, with_prior, data = _load(args, Path(tmp))
    test = dataset.select(split="test") or dataset.trials
    trial = max(test, key=len)
    rows = trial.frame.to_dict("records")
    period = 1.0 / 100.0
    command = " ".join(["python benchmarks/streaming.py"]
                       + [f"--{k} {shown_path(v)}" for k, v in (("checkpoint", args.checkpoint),
                                                                 ("data", args.data),
                                                                 ("prior", args.prior)) if v]
                       + [f"--steps {args.steps}"] * (args.steps != 5000)
                       + [f"--json {shown_path(args.json)}"] * bool(args.json))
    result = {"command": command,
              "machine": {"platform": platform.platform(), "processor": platform.processor(),
                          "cpu": cpu_model(),
                          "python": platform.python_version(), "torch": torch.__version__,
                          "threads": torch.get_num_threads()},
              "estimator": label, "with_prior": with_prior, "model": model_config,
              "data": (shown_path(data) if args.data
                       else "a scale-0.03 automated bench simulated into a temporary folder, seed 0"),
              "trial": trial.path, "trial_samples": len(trial)}

    # -- full hybrid pipeline, one sample at a time
    est = make(**POST_FILTER)
    result["backend_auto"] = est.backend_name
    n_rows = len(rows)
    result["hybrid_pipeline"] = _stats(_time_steps(
        lambda i: est.step(rows[i % n_rows], time=i * period), args.steps))
    try:
        from psmforce.robot import PSM
        est_base = make(psm=PSM(), **POST_FILTER)
        result["hybrid_pipeline_base_frame"] = _stats(_time_steps(
            lambda i: est_base.step(rows[i % n_rows], time=i * period, base_frame=True),
            min(args.steps, 2000)))
    except ImportError as err:
        result["hybrid_pipeline_base_frame"] = f"skipped: {err}"

    # -- the paper's transformer recomputing its whole 100-sample window (eager PyTorch)
    ref = PaperTransformer(len(PAPER_FEATURES)).eval()
    xs_ref, ys_ref = fit_scalers(dataset.select(split="train") or dataset.trials, PAPER_FEATURES)
    raw_ref = trial.frame[list(PAPER_FEATURES)].to_numpy(np.float32)
    ring = np.zeros((2 * ref.window, len(PAPER_FEATURES)), np.float32)

    def ref_step(i):
        pos = i % ref.window
        ring[pos] = (raw_ref[i % n_rows] - xs_ref.mean) / xs_ref.std
        ring[pos + ref.window] = ring[pos]
        with torch.inference_mode():
            return ref(torch.from_numpy(ring[pos + 1:pos + 1 + ref.window])[None])

    result["reference_paper_transformer"] = _stats(_time_steps(ref_step, args.steps))
    result["reference_paper_transformer"]["parameters"] = count_parameters(ref)
    est_ref = StreamingEstimator(ref, PAPER_FEATURES, xs_ref, ys_ref, **POST_FILTER)
    result["paper_transformer_pipeline"] = {
        **_stats(_time_steps(lambda i: est_ref.step(rows[i % n_rows], time=i * period),
                             args.steps)), "backend": est_ref.backend_name}

    # -- network step per backend
    x = est.inputs.x.copy()
    result["network_step_by_backend"] = {}
    for name in ("numpy", "onnx", "torch"):
        runner = make_backend(est.model, name)
        result["network_step_by_backend"][name] = _stats(_time_steps(lambda i: runner.step(x),
                                                                     2000))

    # -- offline batch throughput over the whole test split
    est_off = make(**POST_FILTER)
    total, best = sum(len(t) for t in test), np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for t in test:
            est_off.predict_recording(t.frame)
        best = min(best, time.perf_counter() - t0)
    result["offline_batch"] = {"windows": total, "seconds": best,
                               "windows_per_s": total / best}

    # -- streaming == offline on the recorded trial
    est_cmp = make(**POST_FILTER)
    estimates = [est_cmp.step(r) for r in rows]
    online = np.stack([e.force_hex10 for e in estimates])
    result["stream_vs_offline_max_abs_n"] = float(np.abs(online - est_off.predict_recording(
        trial.frame)).max())
    flags = np.array([e.flags for e in estimates])
    result["flagged_fraction_on_trial"] = {f.name: float(np.mean(flags & f > 0)) for f in Flags
                                           if f.name and f != Flags.NONE}

    # -- post-filters: lag, and accuracy with a trained model
    filters = {}
    for name, options in FILTERS.items():
        f = CausalFilter(options["post_filter"], rate_hz=100.0,
                         **{k: v for k, v in options.items() if k != "post_filter"})
        filters[name] = {"causal": True, "lag_ms": f.lag_samples() * 10.0}
    filters["paper_bidirectional_median_71"] = {"causal": False, "lag_ms": 0.0}
    if trained:
        raw = {t.path: make(post_filter="none").predict_recording(t.frame) for t in test}
        truth = np.concatenate([t.matrix(TARGETS, np.float64)[EVAL_START:] for t in test])
        for name, options in FILTERS.items():
            f = CausalFilter(options["post_filter"], rate_hz=100.0,
                             **{k: v for k, v in options.items() if k != "post_filter"})
            pred = np.concatenate([f.offline(raw[t.path])[EVAL_START:] for t in test])
            filters[name]["metrics"] = axis_metrics(pred, truth)
        pred = np.concatenate([postprocess(raw[t.path][EVAL_START:], bias=False) for t in test])
        filters["paper_bidirectional_median_71"]["metrics"] = axis_metrics(pred, truth)
    result["post_filters"] = filters

    hp, rp = result["hybrid_pipeline"], result["reference_paper_transformer"]
    result["speedup_median"] = rp["median_ms"] / hp["median_ms"]
    result["targets"] = {
        "hybrid_p99_below_1ms": hp["p99_ms"] < TARGET_P99_MS,
        "median_speedup_at_least_5x": result["speedup_median"] >= TARGET_SPEEDUP,
        "offline_at_least_20k_windows_per_s":
            result["offline_batch"]["windows_per_s"] >= TARGET_WINDOWS_PER_S,
        "stream_equals_offline_1e-4": result["stream_vs_offline_max_abs_n"] < TARGET_STREAM_DIFF_N}
    return result, args.json


def _print(result: dict) -> None:
    def line(name, s):
        print(f"{name:<40} median {s['median_ms']:.3f} p99 {s['p99_ms']:.3f} max "
              f"{s['max_ms']:.3f} ms | cpu time median {s['cpu_median_ms']:.3f} p99 "
              f"{s['cpu_p99_ms']:.3f} max {s['cpu_max_ms']:.3f} ms ({s['steps']} steps)")
    print(f"estimator: {result['estimator']}; trial {result['trial']} "
          f"({result['trial_samples']} samples); backend auto = {result['backend_auto']}")
    line("hybrid pipeline (hex10 frame, low-pass)", result["hybrid_pipeline"])
    if isinstance(result["hybrid_pipeline_base_frame"], dict):
        line("hybrid pipeline + base frame", result["hybrid_pipeline_base_frame"])
    line("paper transformer, full window, eager", result["reference_paper_transformer"])
    line(f"paper transformer pipeline ({result['paper_transformer_pipeline']['backend']})",
         result["paper_transformer_pipeline"])
    for name, s in result["network_step_by_backend"].items():
        line(f"network step only, backend {name}", s)
    print(f"median speed-up vs reference: {result['speedup_median']:.1f}x")
    ob = result["offline_batch"]
    print(f"offline batch: {ob['windows_per_s']:.0f} windows/s ({ob['windows']} windows)")
    print(f"streaming vs offline max |diff|: {result['stream_vs_offline_max_abs_n']:.2e} N")
    print("fraction of the trial's samples flagged:", json.dumps(
        {k: round(v, 4) for k, v in result["flagged_fraction_on_trial"].items()}))
    for name, f in result["post_filters"].items():
        text = f"post-filter {name:<32} lag {f['lag_ms']:6.1f} ms"
        if "metrics" in f:
            text += "  NRMSE % " + " / ".join(f"{f['metrics'][a]['nrmse_pct']:.2f}"
                                             for a in ("Fx", "Fy", "Fz"))
            text += "  RMSE N " + " / ".join(f"{f['metrics'][a]['rmse_n']:.3f}"
                                            for a in ("Fx", "Fy", "Fz"))
        print(text)
    print("targets:", json.dumps(result["targets"]))


if __name__ == "__main__":
    figures, json_path = main()
    _print(figures)
    if json_path:
        write_json(json_path, figures)
