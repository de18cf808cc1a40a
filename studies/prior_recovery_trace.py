"""Why the drawn tool's load-path recovery misses (docs/identification.md section 2.3): the fit
of ``studies/prior_recovery.py --default-bench --load-path`` on the drawn tool, redone on the
same bench with one of the tool's departures from the prior's law removed at a time.

The miss is judged against the bench's law projected onto the law as the run held it
(``experiments.prior_recovery.projected_truth``), a law-to-law figure; what is left is the bench's
departure from the law on that tool. Each variant simulates the drawn tool (seed 21, the run's
scale) with one departure removed, then fits once as the run's last round did (what it held held
at the same values, the rest warm-started at its values, the wrist sagged as it was) and
projects again on the variant's own trials. Departures tried: the HEX10's cross-talk outside its
fz column (the law models the axial force's leak only), at the nominal tool's and at none; the
blade pairs' two asymmetries (the law ties them); the cable stiffness (the sag takes the
design's). Last, the bench unchanged and the law changed instead: the drawn tool with the law's
lateral cross-talk columns free (``crosstalk="full"``, from 0; the projection then carries the
bench's lateral leaks too). Usage::

    python studies/prior_recovery_trace.py --json results/benchmarks/prior_recovery_drawn_trace.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path

RUN_JSON = Path(__file__).resolve().parents[1] / "results" / "benchmarks" / \
    "prior_recovery_load_path.json"
CASE = "drawn tool"


LAW_VARIANTS = {"the drawn tool, the law's lateral cross-talk free": "full"}
"""Label -> the fit's ``crosstalk`` for a variant that changes the law, not the bench (the
drawn tool); every other variant fits the law as the run did (None: the reading's)."""


def variants(seed: int) -> dict:
    """Label -> the drawn tool with one departure from the law removed (the first: none), then
    the drawn tool again for each of :data:`LAW_VARIANTS`."""
    from psmforce.sim.params import InstrumentParams
    nominal, drawn = InstrumentParams(), InstrumentParams().sample(seed)

    def with_fz_column(base):  # the drawn tool's fz column (the law's) on ``base``'s others
        rows = [list(r) for r in base]
        for i, row in enumerate(rows):
            row[2] = drawn.hex10_crosstalk[i][2]
        return tuple(map(tuple, rows))

    identity = tuple(tuple(float(i == j) for j in range(6)) for i in range(6))
    a = drawn.cable_asymmetry
    tied = 0.5 * (a[1] + a[2])
    return {
        "the drawn tool": drawn,
        "cross-talk outside the fz column at the nominal tool's": dataclasses.replace(
            drawn, hex10_crosstalk=with_fz_column(nominal.hex10_crosstalk)),
        "no cross-talk outside the fz column": dataclasses.replace(
            drawn, hex10_crosstalk=with_fz_column(identity)),
        "blade asymmetries tied (their mean)": dataclasses.replace(
            drawn, cable_asymmetry=(a[0], tied, tied)),
        "cable stiffness at the design's": dataclasses.replace(
            drawn, cable_stiffness_n_per_m=nominal.cable_stiffness_n_per_m),
        **dict.fromkeys(LAW_VARIANTS, drawn),
    }


def trace(run: dict, label: str, instrument, workdir: Path) -> dict:
    """One variant: simulate, refit as the run's last round (with the law of
    :data:`LAW_VARIANTS` where it names one), project; name -> SI values."""
    from psmforce.experiments.prior_recovery import default_bench_truth, projected_truth
    from psmforce.identification.load_path import WristCompliance
    from psmforce.identification.prior import InternalForcePrior, held_by_reading
    from psmforce.identification.prior_law import NAMES
    from psmforce.io.recording import list_recordings, read_recording
    from psmforce.sim import simulate

    rows = run["parameters"]
    fixed = {n: r["fitted"] for n, r in rows.items() if r["status"] == "fixed"}
    start = {n: r["fitted"] for n, r in rows.items() if r["status"] != "fixed"}
    sag = WristCompliance.from_law({n: r["fitted"] for n, r in rows.items()})
    crosstalk = LAW_VARIANTS.get(label)
    t0 = time.time()
    simulate("automated", scale=run["scale"], seed=run["seed"], out=str(workdir),
             instrument=instrument)
    train = [read_recording(r.path) for r in list_recordings(workdir)
             if r.split == "train" and r.condition in run["conditions"]]
    fit = InternalForcePrior.fit(train, fixed=fixed, initial=start, report=False,
                                 inputs="load_path", compliance=sag, crosstalk=crosstalk)
    # the law's terms the run did not have are free in the projection where the fit frees them
    free = {n: {"status": "free", "fitted": 0.0} for n in NAMES
            if n not in rows and n not in held_by_reading("load_path", crosstalk)}
    projected = projected_truth(default_bench_truth(instrument), {**rows, **free}, train,
                                "load_path", sag, crosstalk=crosstalk)
    return {"variant": label, **({"crosstalk": crosstalk} if crosstalk else {}),
            "fitted": dict(zip(NAMES, map(float, fit.params))),
            "projected_truth": {n: float(v) for n, v in projected.items()},
            "identified": sorted(n for n, r in rows.items() if r["status"] == "identified"),
            **({"freed": sorted(free)} if free else {}),
            "seconds": time.time() - t0}


def main() -> None:
    from psmforce.experiments.report import write_json
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    run = next(r for r in json.loads(RUN_JSON.read_text())["runs"] if r["case"] == CASE)
    out = []
    for label, instrument in variants(run["seed"]).items():
        with tempfile.TemporaryDirectory() as tmp:
            out.append(trace(run, label, instrument, Path(tmp) / "data"))
        f, p = out[-1]["fitted"], out[-1]["projected_truth"]
        print(f"{label}: capstan_pitch_gain {f['capstan_pitch_gain']:.4f} (projection "
              f"{p['capstan_pitch_gain']:.4f}), capstan_mu {f['capstan_mu']:.4f} "
              f"({p['capstan_mu']:.4f}), {out[-1]['seconds']:.0f} s", flush=True)
    if args.json:
        write_json(args.json, {
            "command": "python studies/prior_recovery_trace.py --json "
                       "results/benchmarks/prior_recovery_drawn_trace.json",
            "run": {"json": "results/benchmarks/prior_recovery_load_path.json", "case": CASE,
                    "seed": run["seed"], "scale": run["scale"], "misses": run["misses"]},
            "variants": out})


if __name__ == "__main__":
    main()
