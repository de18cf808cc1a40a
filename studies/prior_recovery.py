"""Parameter recovery of the internal-force prior on an in-family bench, noise on (the figures of
docs/identification.md, section 2.1, "Parameter recovery on an in-family bench").

The automated protocol is simulated on the in-family bench
(``psmforce.experiments.prior_recovery``: the switches and instrument that put the bench's
HEX10 wrench inside the prior's family) for each seed, and the prior is fitted on the training
split in three variants: Free + Traction + Palpation (the recovery fit), the same with the cable
radius held at the datasheet's 1.2 mm, and Free trials only. Per parameter: truth, fitted value,
relative error, standard error and the identifiability report's verdict. Usage::

    python studies/prior_recovery.py [--scale 0.02] [--seeds 1 2 3] [--json PATH]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from psmforce.experiments.report import write_json

VARIANTS = {
    "loaded": {"conditions": ("Free", "Traction", "Palpation"), "fixed": None},
    "loaded, cable radius held at the datasheet": {
        "conditions": ("Free", "Traction", "Palpation"), "fixed": "datasheet_cable_radius"},
    "free only": {"conditions": ("Free",), "fixed": None},
}


def main() -> None:
    from psmforce.identification.prior import DATASHEET
    from psmforce.experiments.prior_recovery import IN_FAMILY_EFFECTS, SWITCHES, recover

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=0.02)
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    runs = []
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            for label, v in VARIANTS.items():
                fixed = {"cable_radius": DATASHEET["cable_radius"]} if v["fixed"] else None
                rep = recover(Path(tmp) / "d", args.scale, seed, fixed=fixed,
                              conditions=v["conditions"])
                runs.append({"variant": label, **rep})
                ident = rep["identifiability"]
                print(f"seed {seed}, {label}: converged {rep['converged']}, "
                      f"{rep['n_samples']} samples, condition number "
                      f"{ident['condition_number']:.3g}, clear slack samples "
                      f"{ident['clear_slack_samples']}, failures {rep['failures']}")
                for name, row in rep["parameters"].items():
                    rel = row["relative_error"]
                    print(f"  {name:22s} truth {row['truth']:>10.4g}  fitted {row['fitted']:>11.4g}"
                          f"  {'' if rel is None else f'{100 * rel:6.1f} %':>8s}  {row['status']}")
    if args.json:
        write_json(args.json, {"scale": args.scale, "seeds": args.seeds,
                               "effects": IN_FAMILY_EFFECTS.to_dict(), "switches": SWITCHES,
                               "runs": runs})


if __name__ == "__main__":
    main()
