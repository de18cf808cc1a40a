"""The figures behind the hybrid's design choices (docs/results.md, psmforce/estimators/data/hybrid_inputs.py docstring).

    python studies/hybrid_design.py --data DIR [--seed 0] [--json OUT.json]

``DIR``: a simulated automated dataset (``psmforce simulate --protocol automated --scale 0.05
--seed 0 --out DIR`` for the committed figures). The validation trials are the 10 % of the
training trials that ``psmforce reproduce`` holds out with the same seed. Prints and writes:

1. per condition of the training trials, the standard deviation (N) of the ATI force and of the
   residual ``ati - comp`` (the force minus the prior-compensated HEX10 reading), per axis:
   where the residual is not smaller, a residual target is harder than the force itself
   (:func:`psmforce.estimators.data.hybrid_inputs.select_base`);
   Also the residual ``ati_fz - insertion_fz`` (the axial force from the insertion effort).
2. five hybrid variants trained with the ``cpu`` budget of ``psmforce reproduce`` and scored
   (paper post-processing, NRMSE %) on the validation trials - the selection criterion - and,
   for information only, on the test trials: residual on every axis (no ``prior_fz``), no base
   on z, no base on z + ``prior_fz`` input, + ``insertion_fz`` input, + ``insertion_fz`` input and
   z base (the default, :data:`psmforce.estimators.data.hybrid_inputs.BASE_COLUMNS`).
"""

from __future__ import annotations


import numpy as np
import torch

from psmforce.estimators.data.dataset import NO_BASE, load_dataset, split_validation, target_matrix
from psmforce.estimators.data.hybrid_inputs import (COMPENSATED_HEX10, HYBRID_FEATURES,
                           HYBRID_FEATURES_PRIOR_FZ, INSERTION_FZ, add_prior_columns, prior_to_json)
from psmforce.estimators.evaluation.metrics import AXES
from psmforce.experiments.reproduce import _config, _scores
from psmforce.estimators.networks.recipes import Inputs, recipe
from psmforce.estimators.training.train import fit_prior, make_setup, train_model
from psmforce.experiments.report import dataset_arguments, write_json

VARIANTS = {
    "residual on every axis": (HYBRID_FEATURES, COMPENSATED_HEX10[:3]),
    "no base on z": (HYBRID_FEATURES, COMPENSATED_HEX10[:2] + (NO_BASE,)),
    "no base on z + prior_fz input": (HYBRID_FEATURES_PRIOR_FZ, COMPENSATED_HEX10[:2] + (NO_BASE,)),
    "+ insertion_fz input": (HYBRID_FEATURES_PRIOR_FZ + (INSERTION_FZ,),
                             COMPENSATED_HEX10[:2] + (NO_BASE,)),
    "+ insertion_fz input and base on z": (HYBRID_FEATURES_PRIOR_FZ + (INSERTION_FZ,),
                                           COMPENSATED_HEX10[:2] + (INSERTION_FZ,)),
}


def main() -> dict:
    args = dataset_arguments(__doc__)
    torch.set_num_threads(2)
    ds = load_dataset(args.data)
    train, val = split_validation(ds.select(split="train"), 0.1, args.seed)
    test = ds.select(split="test")
    prior = fit_prior(train)
    add_prior_columns(ds, prior)
    result = {"data": str(args.data), "seed": args.seed, "spread_N": {}, "variants": {}}

    print("training trials: std (N) of the ATI force / of ati - comp, per axis")
    for cond in sorted({t.condition for t in train}):
        trials = [t for t in train if t.condition == cond]
        force = np.concatenate([target_matrix(t, (), np.float64) for t in trials]).std(axis=0)
        resid = np.concatenate([target_matrix(t, COMPENSATED_HEX10[:3], np.float64)
                                for t in trials]).std(axis=0)
        axial = np.concatenate([target_matrix(t, (NO_BASE, NO_BASE, INSERTION_FZ), np.float64)
                                [:, 2] for t in trials]).std()
        result["spread_N"][cond] = {"ati": force.tolist(), "ati_minus_comp": resid.tolist(),
                                    "ati_fz_minus_insertion_fz": float(axial)}
        print(f"  {cond:10s} " + "   ".join(f"{a} {f:.3f} / {r:.3f}"
                                           for a, f, r in zip(AXES, force, resid))
              + f"   (Fz - insertion_fz {axial:.3f})")

    cfg = _config("cpu", "pretrain", args.seed, "cpu", "hybrid", recipe("hybrid").optimiser)
    print(f"hybrid variants (budget {cfg.max_epochs} epochs x {cfg.max_batches_per_epoch} batches)"
          ": NRMSE % Fx / Fy / Fz on validation | test")
    for name, (features, base) in VARIANTS.items():
        setup = make_setup("hybrid", train, prior_json=prior_to_json(prior),
                           inputs=Inputs(features, base, derivation="prior"))
        report = train_model(setup, train, val, cfg)
        scores = {split: _scores(setup, trials, "cpu")["overall"]["paper"]
                  for split, trials in (("validation", val), ("test", test))}
        result["variants"][name] = {"epochs": report["epochs_run"],
                                    "seconds": report["seconds"], **scores}
        print(f"  {name:32s} " + " | ".join(
            " / ".join(f"{scores[s][a]['nrmse_pct']:5.2f}" for a in AXES)
            for s in ("validation", "test")) + f"   ({report['epochs_run']} epochs)")
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
