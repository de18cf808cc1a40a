"""What the paper's evaluation allows on a dataset, before any network is trained.

    python studies/evaluation_floor.py --data DIR [--seed 0] [--json OUT.json]

``DIR``: a dataset in the recording layout with ``train`` and ``test`` splits (for example
``psmforce simulate --protocol automated ...`` or ``DIR/data/automated`` of a reproduce run).
Prints and writes (JSON), on the test trials, overall and per condition, RMSE / NRMSE / R^2 per
axis of:

* ``truth through post-processing``: the ATI ground truth itself put through the paper's
  post-processing (bidirectional median filter, k = 71; the 0.5 s bias step removes nothing from
  the truth). The median filter also removes what changes faster than 0.71 s in the *truth*, so
  no estimator scored this way can do much better: the floor of the paper's metric on this data.
* ``prior only``: the HEX10 force minus the internal-force prior (fitted here on the training
  trials, 10 % held out, ``seed``: the same prior as ``psmforce reproduce``), post-processed as
  the models are - the hybrid's base without its network.
* ``prior only, raw``: the same without post-processing.
"""

from __future__ import annotations

import sys

import numpy as np

from psmforce.estimators.data.dataset import load_dataset, split_validation
from psmforce.estimators.evaluation.evaluate import EVAL_START, NO_FREE_START
from psmforce.estimators.data.hybrid_inputs import BASE_COLUMNS, add_prior_columns
from psmforce.estimators.evaluation.metrics import AXES, axis_metrics, postprocess
from psmforce.estimators.training.train import fit_prior
from psmforce.io.recording import TARGETS
from psmforce.experiments.report import dataset_arguments, write_json


def _scores(trials, estimate) -> dict:
    pred, truth = zip(*[(estimate(t), t.matrix(TARGETS, np.float64)[EVAL_START:]) for t in trials])
    return axis_metrics(np.concatenate(pred), np.concatenate(truth))


def main() -> dict:
    args = dataset_arguments(__doc__)
    ds = load_dataset(args.data)
    train, _ = split_validation(ds.select(split="train"), 0.1, args.seed)
    test = ds.select(split="test")
    if not test:
        sys.exit(f"{args.data}: no test trials")
    add_prior_columns(ds, fit_prior(train))

    def truth(t):
        return postprocess(t.matrix(TARGETS, np.float64)[EVAL_START:], bias=False)

    def prior_only(t):
        base = t.matrix(BASE_COLUMNS, np.float64)[EVAL_START:]
        return postprocess(base, bias=t.condition not in NO_FREE_START)

    def prior_only_raw(t):
        return t.matrix(BASE_COLUMNS, np.float64)[EVAL_START:]

    rows = {"truth through post-processing": truth, "prior only": prior_only,
            "prior only, raw": prior_only_raw}
    groups = {"all": test} | {c: [t for t in test if t.condition == c]
                              for c in sorted({t.condition for t in test})}
    result = {"data": str(args.data), "seed": args.seed, "test_trials": len(test), "scores": {}}
    print(f"{'test trials':10s} {'estimate':32s} " + " ".join(f"NRMSE {a} %" for a in AXES)
          + "   " + " ".join(f"RMSE {a} N" for a in AXES))
    for group, trials in groups.items():
        for name, fn in rows.items():
            m = _scores(trials, fn)
            result["scores"].setdefault(group, {})[name] = m
            print(f"{group:10s} {name:32s} "
                  + " ".join(f"{m[a]['nrmse_pct']:10.2f}" for a in AXES) + "   "
                  + " ".join(f"{m[a]['rmse_n']:9.3f}" for a in AXES))
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
