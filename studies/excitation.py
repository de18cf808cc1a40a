"""The free-space excitation for calibrating the internal-force prior without an ATI, and what
known weights add (docs/ati_free.md): the report ``psmforce excitation`` writes, for one
duration and seed, kept as a committed JSON. Usage::

    python studies/excitation.py [--minutes 5] [--seed 0] [--known-weights 0.02 0.05]
                                 [--paired-poses] --json results/benchmarks/excitation.json

``--paired-poses``: the weights in the sixteen paired orientations that identifying the
instrument through the load path uses (``psmforce excitation --paired-poses``)::

    python studies/excitation.py --known-weights 0.05 0.1 0.2 --paired-poses \
        --json results/benchmarks/excitation_paired.json

The setpoints themselves are not kept (the command writes them; the same arguments give the
same file).
"""

from __future__ import annotations

import argparse
import time

from psmforce.cli.excitation import WEIGHT_WRIST_POSES, WEIGHT_WRIST_POSES_PAIRED, build
from psmforce.experiments.report import write_json


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--known-weights", type=float, nargs="*", default=[0.02, 0.05])
    ap.add_argument("--paired-poses", action="store_true")
    ap.add_argument("--json")
    args = ap.parse_args()
    start = time.perf_counter()
    _, report = build(args.minutes, args.seed, tuple(args.known_weights),
                      poses=WEIGHT_WRIST_POSES_PAIRED if args.paired_poses else WEIGHT_WRIST_POSES)
    weights = " ".join(f"{x:g}" for x in args.known_weights)
    report["command"] = (f"python studies/excitation.py --minutes {args.minutes:g} --seed "
                         f"{args.seed} --known-weights {weights}"
                         + (" --paired-poses" if args.paired_poses else ""))
    report["wall_s"] = time.perf_counter() - start
    cn = report["condition_number"]
    print("condition numbers:", {k: round(v, 1) if v else v for k, v in cn.items()})
    if args.json:
        write_json(args.json, report)
    return report


if __name__ == "__main__":
    main()
