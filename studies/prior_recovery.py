"""Parameter recovery of the internal-force prior on an in-family bench, noise on (the figures of
docs/identification.md, section 2.1, "Parameter recovery on an in-family bench").

The automated protocol is simulated on the in-family bench
(``psmforce.experiments.prior_recovery``: the switches and instrument that put the bench's
HEX10 wrench inside the prior's family) for each seed, and the prior is fitted on the training
split in three variants: Free + Traction + Palpation (the recovery fit), the same with the cable
radius held at the datasheet's 1.2 mm, and Free trials only. Per parameter: truth, fitted value,
relative error, standard error and the identifiability report's verdict. Usage::

    python studies/prior_recovery.py [--scale 0.02] [--seeds 1 2 3] [--json PATH]

``--default-bench``: the default bench as a user runs it, ``psmforce simulate --seed S`` (scale
1, the default) then ``psmforce fit-prior`` (Free trials; what the identifiability report calls
unidentifiable held at design values), for each of ``--seeds`` (default 21 22) with the nominal
tool, and on seed 21 two variants: the second cable law (``pair_law="quadratic"``, outside the
prior's family) and a drawn tool (``InstrumentParams().sample(21)``: truth off the design values
the fit holds). Per parameter: truth, all-free fit, final fit, relative error, fixed / free, at a
bound::

    python studies/prior_recovery.py --default-bench --json results/benchmarks/prior_recovery_default.json

``--load-path`` (with ``--default-bench``): ``psmforce fit-prior --use-loaded --load-path``
instead, every training trial with the cables read from the known tip force
(:mod:`psmforce.identification.load_path`); its seeds default to the nominal tool's design seed
21, :data:`~psmforce.experiments.seeds.LOAD_PATH_SEEDS` and
:data:`~psmforce.experiments.seeds.CAPSTAN_GROWTH_SEEDS`, at scale 0.25 (with ``--json``, the
file is rewritten after every run and a rerun of the same command skips the runs it holds)::

    python studies/prior_recovery.py --default-bench --load-path \
        --json results/benchmarks/prior_recovery_load_path.json

``--rescore JSON``: the misses of a written ``--default-bench`` JSON judged again by today's rule
(:func:`psmforce.experiments.prior_recovery.judge`), the fits untouched; the JSON records it.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from psmforce.cli.options import CROSSTALK_OPTIONS
from psmforce.experiments.report import write_json

VARIANTS = {
    "loaded": {"conditions": ("Free", "Traction", "Palpation"), "fixed": None},
    "loaded, cable radius held at the datasheet": {
        "conditions": ("Free", "Traction", "Palpation"), "fixed": "datasheet_cable_radius"},
    "free only": {"conditions": ("Free",), "fixed": None},
}


DEFAULT_CASES = ("nominal", "quadratic pair law", "drawn tool")
"""The default-bench cases: the nominal tool on every seed, the variants on the first seed."""


def _instrument(case: str, seed: int):
    import dataclasses

    from psmforce.sim.params import InstrumentParams
    return {"nominal": InstrumentParams(),
            "quadratic pair law": dataclasses.replace(InstrumentParams(), pair_law="quadratic"),
            "drawn tool": InstrumentParams().sample(seed)}[case]


def default_bench(args) -> None:
    import time

    from psmforce.experiments.prior_recovery import recover_default

    command = ("python studies/prior_recovery.py --default-bench "
               + ("--load-path " if args.load_path else "")
               + ("" if args.crosstalk == "reading" else f"--crosstalk {args.crosstalk} ")
               + f"--scale {args.scale:g} --seeds " + " ".join(map(str, args.seeds)))
    runs, seconds = _done_runs(args.json, command)
    t0 = time.time() - seconds
    for k, seed in enumerate(args.seeds):
        for case in (DEFAULT_CASES if k == 0 else DEFAULT_CASES[:1]):
            if args.cases and case not in args.cases:
                continue
            if any(r["seed"] == seed and r["case"] == case for r in runs):
                print(f"seed {seed}, {case}: in {args.json}, skipped", flush=True)
                continue
            with tempfile.TemporaryDirectory() as tmp:
                rep = recover_default(Path(tmp), seed, args.scale, _instrument(case, seed),
                                      load_path=args.load_path,
                                      crosstalk=CROSSTALK_OPTIONS[args.crosstalk])
            runs.append({"case": case, **rep})
            if args.json:  # after every run: a stopped study resumes from here
                _write_default(args, command, runs, time.time() - t0)
            print(f"seed {seed}, {case}: {rep['fit_time_s']:.0f} s, misses {rep['misses']}\n"
                  f"  verdict: {rep['verdict']}", flush=True)
            for name, row in rep["parameters"].items():
                rel = row["relative_error"]
                print(f"  {name:22s} truth {row['truth']!s:>10.10s}  fitted {row['fitted']:>11.4g}"
                      f"  {'' if rel is None else f'{100 * rel:6.1f} %':>8s}  {row['status']}"
                      f"{'  AT BOUND' if row['at_bound'] else ''}", flush=True)
    if args.json:
        _write_default(args, command, runs, time.time() - t0)


def _write_default(args, command: str, runs: list, seconds: float) -> None:
    from psmforce.identification.prior_selection import DESIGN
    write_json(args.json, {"command": command, "load_path": args.load_path,
                           **({"crosstalk": args.crosstalk} if args.crosstalk != "reading"
                              else {}),
                           "scale": args.scale, "seeds": args.seeds, "design": DESIGN,
                           "runs": runs, "seconds": seconds})


def _done_runs(path: Path | None, command: str) -> tuple[list, float]:
    """The runs a ``--default-bench`` JSON at ``path`` already holds for the same ``command``
    and law (its design values), and the seconds they took; none where it holds another."""
    import json

    from psmforce.identification.prior_selection import DESIGN
    if path is None or not path.is_file():
        return [], 0.0
    try:
        done = json.loads(path.read_text())
    except (OSError, ValueError):
        return [], 0.0
    if not isinstance(done, dict) or done.get("command") != command \
            or done.get("design") != DESIGN or not isinstance(done.get("runs"), list):
        return [], 0.0
    return done["runs"], float(done.get("seconds", 0.0))


def _read_default(path: Path, option: str) -> dict:
    """A ``--default-bench`` JSON of this study, or a one-line refusal naming ``option``."""
    import json
    try:
        result = json.loads(path.read_text())
        runs = result["runs"]
        if not all(isinstance(r, dict) and "parameters" in r and "misses" in r for r in runs):
            raise KeyError("parameters")
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SystemExit(f"{option} {path}: not a --default-bench JSON of this study "
                         f"({type(exc).__name__}: {exc})") from None
    return result


def _rescore(path: Path) -> None:
    from psmforce.experiments.prior_recovery import rescore
    from psmforce.experiments.report import shown_path
    result = _read_default(path, "--rescore")
    runs = result["runs"]
    rescore(result, f"python studies/prior_recovery.py --rescore {shown_path(path)}")
    write_json(path, result)
    for change in result["rescored"]["changed"]:
        run = runs[change["run"]]
        print(f"{run['case']}, seed {run['seed']}: misses {change['misses_before']} -> "
              f"{change['misses']}")


def main() -> None:
    from psmforce.identification.prior import DATASHEET
    from psmforce.experiments.prior_recovery import IN_FAMILY_EFFECTS, SWITCHES, recover

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=None,
                    help="protocol scale (default 0.02; 1.0 with --default-bench)")
    ap.add_argument("--seeds", type=int, nargs="+", default=None,
                    help="bench seeds (default 1 2 3; 21 22 with --default-bench)")
    ap.add_argument("--default-bench", action="store_true")
    ap.add_argument("--cases", nargs="+", choices=DEFAULT_CASES, default=None,
                    help="with --default-bench: only these cases")
    ap.add_argument("--load-path", action="store_true",
                    help="with --default-bench: fit-prior --use-loaded --load-path")
    ap.add_argument("--crosstalk", choices=list(CROSSTALK_OPTIONS), default="reading",
                    help="with --default-bench: fit-prior --crosstalk (the HEX10's cross-talk "
                         "the law fits; full: its lateral columns too)")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--rescore", type=Path, default=None, metavar="JSON",
                    help="judge the misses of a --default-bench JSON again by today's rule "
                         "(experiments.prior_recovery.judge), the fits untouched; rewrites it")
    args = ap.parse_args()
    if args.rescore is not None:
        _rescore(args.rescore)
        return
    if args.default_bench:
        from psmforce.experiments.seeds import CAPSTAN_GROWTH_SEEDS, LOAD_PATH_SEEDS
        args.scale = (0.25 if args.load_path else 1.0) if args.scale is None else args.scale
        args.seeds = args.seeds or ([21, *LOAD_PATH_SEEDS, *CAPSTAN_GROWTH_SEEDS]
                                    if args.load_path else [21, 22])
        default_bench(args)
        return
    args.scale = 0.02 if args.scale is None else args.scale
    args.seeds = args.seeds or [1, 2, 3]
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
