"""The streaming estimator under 10^6 adversarial samples: nothing poisons it.

    python -m tests.robustness.adversarial_stream [--samples 1000000] [--checkpoint HYBRID.pt]
                                                  [--seed 0] [--json
                                                  results/benchmarks/streaming_fuzz.json]

Runs :func:`psmforce.experiments.stream_fuzzer.fuzz_stream` (the property, its corruption kinds and
its threshold are stated there) on the longest test recording of a small simulated bench (scale
0.03, seed 0), tiled to ``--samples`` samples with time gaps, 10 % of them corrupted, through the
README's configuration (causal 5 Hz low-pass, backend ``auto``). ``--checkpoint``: a trained hybrid;
default an untrained hybrid of the default size with the scalers fitted on the bench's training
split and the prior at its nominal parameters (robustness does not depend on the weights). One core.
Prints the counts and writes them (JSON).

Pass: 0 exceptions, 0 non-finite estimates, 0 malformed samples accepted, 0 unflagged estimates
farther than ``far_n`` from the clean stream's.
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import torch  # noqa: E402

from psmforce.experiments.report import write_json  # noqa: E402
from psmforce.estimators.networks.causal import CausalTransformer  # noqa: E402
from psmforce.estimators.data.dataset import fit_scalers, load_dataset  # noqa: E402
from psmforce.estimators.data.hybrid_inputs import (add_prior_columns, hybrid_columns, select_base)  # noqa: E402
from psmforce.estimators.runtime.streaming import StreamingEstimator  # noqa: E402
from psmforce.experiments.stream_fuzzer import fuzz_stream  # noqa: E402

NOMINAL_INSERTION = (0.3, -0.2, 8.8, 0.35, 2.0, 0.05)
"""Insertion effort model at physical values (gravity N x3, Coulomb N, viscous N s/m, offset N),
as in tests/estimators/test_streaming.py: no fit needed for a robustness run."""
CONFIG = {"post_filter": "lowpass", "lowpass_hz": 5.0, "lowpass_order": 2}


def _estimator(checkpoint: str | None, tmp: Path):
    from psmforce.sim.dataset import simulate
    data = tmp / "sim"
    simulate("automated", scale=0.03, seed=0, out=data)
    dataset = load_dataset(data)
    frame = max(dataset.select(split="test"), key=len).frame
    if checkpoint:
        return (lambda: StreamingEstimator.from_checkpoint(checkpoint, **CONFIG)), frame, checkpoint
    from psmforce.identification.insertion import InsertionEffortModel
    from psmforce.identification.prior import InternalForcePrior
    prior = InternalForcePrior(insertion=InsertionEffortModel(NOMINAL_INSERTION, 0.005, {}))
    add_prior_columns(dataset, prior)
    features, base = hybrid_columns(use_prior=True)
    train = dataset.select(split="train")
    base = select_base(train, base)
    xs, ys = fit_scalers(train, features, base_columns=base)
    torch.manual_seed(0)
    model = CausalTransformer(len(features)).eval()
    return ((lambda: StreamingEstimator(model, features, xs, ys, base, prior, **CONFIG)), frame,
            "untrained default hybrid, nominal prior")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--checkpoint")
    parser.add_argument("--json")
    args = parser.parse_args()
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        make, frame, label = _estimator(args.checkpoint, Path(tmp))
    start = time.perf_counter()
    report = fuzz_stream(make, frame, args.samples, seed=args.seed)
    seconds = time.perf_counter() - start
    failures = {k: report[k] for k in ("exceptions", "non_finite", "not_refused",
                                        "unflagged_far") if report[k]}
    print(f"{label}: {args.samples} samples ({report['kinds'].get('clean', 0)} clean) in "
          f"{seconds:.0f} s; kinds {report['kinds']}")
    print(f"flags {report['flags']}; largest unflagged deviation from the clean stream "
          f"{report['max_unflagged_deviation_n']:.3g} N (threshold {report['far_n']} N)")
    print("PASS: no exception, every estimate finite, every malformed sample refused, every far "
          "estimate flagged" if not failures else f"FAIL: {failures} {report['examples']}")
    if args.json:
        write_json(args.json, {"estimator": label, "config": CONFIG, "seconds": seconds,
                               "machine": platform.platform(), "passed": not failures,
                               **report})
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
