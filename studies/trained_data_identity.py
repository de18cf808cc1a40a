"""Did a run's networks that trained on another machine train on this machine's data?

A run moved to a GPU travels without its benches, which are simulated again there from their seeds
(:func:`psmforce.experiments.reproduce.prepare_benches`), possibly under other library versions.
What comes back holds the evidence: each checkpoint keeps the input and target scalers fitted on the
training trials it saw and, for a model reading the prior, the prior fitted on that bench. This
script rebuilds both from this machine's bench for every network checkpoint of a run and compares
them: bit for bit, else the largest difference. A checkpoint trained here is the control (it must
come out identical).

    python studies/trained_data_identity.py --run runs/learning_curve/scale_1 \
        --json results/learning_curve/trained_data_identity.json

A scaler is a mean and a standard deviation per column over every training sample, so identical
scalers say the training split's columns sum to the same bits on both machines; a difference at
rounding level in the hybrid's target scaler alone comes from its derived base (the prior's
output, computed on each machine), not from the bench.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402


def _scaler_difference(a, b) -> float:
    """0.0 for bit-identical scalers, else the largest difference of their means or stds."""
    da, db = a.to_dict(), b.to_dict()
    return float(max(np.max(np.abs(np.asarray(da[k], float) - np.asarray(db[k], float)))
                     for k in ("mean", "std")))


def compare_run(run: Path) -> dict:
    """{checkpoint name: its scalers' and prior's largest difference from this machine's}."""
    from psmforce.estimators.training.checkpoint import load_checkpoint
    from psmforce.estimators.networks.recipes import recipe
    from psmforce.experiments.reproduce import (_automated_split, _derivation, _load, _prior_path,
                                                _setup)
    work = run / "work"
    out = {}
    for path in sorted((work / "checkpoints").glob("*_full_f1.0_*.pt")):
        trained = load_checkpoint(path)
        if recipe(trained.model_name).closed_form:
            continue
        seed = int(path.name.split("_seed")[1].split("_")[0])
        ds = _load(str(work), "automated", seed, (_derivation(trained.model_name, "full"),))
        train, _ = _automated_split(ds, seed)
        prior_json = _prior_path(str(work), seed).read_text()
        here = _setup(trained.model_name, train, prior_json, "full")
        history = trained.provenance.get("history", [])
        ran = [h["device"] for h in history if "device" in h] or [
            trained.provenance.get("reproduce", {}).get("device")]
        row = {"trained_on": list(dict.fromkeys(ran)),
               "input_scaler": _scaler_difference(trained.input_scaler, here.input_scaler),
               "target_scaler": _scaler_difference(trained.target_scaler, here.target_scaler)}
        if trained.prior_json is not None:
            theirs = json.loads(trained.prior_json)["parameters"]
            ours = json.loads(prior_json)["parameters"]
            row["prior_parameters"] = max(abs(theirs[k]["value"] - ours[k]["value"])
                                          for k in ours)
        out[path.name] = row
        print(path.name, row, flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, required=True, help="a reproduce run folder")
    ap.add_argument("--json", type=Path, required=True)
    args = ap.parse_args(argv)
    if not (args.run / "work" / "checkpoints").is_dir():
        ap.error(f"--run: {args.run} holds no reproduce run (no work/checkpoints)")
    write_json(args.json, {"run": shown_path(args.run),
                           "largest_difference": compare_run(args.run)})
    return 0


if __name__ == "__main__":
    sys.exit(main())
