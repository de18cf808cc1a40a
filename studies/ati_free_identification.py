"""The instrument identified without an ATI (issue 44, items 2 and 3): free space, the designed
excitation and known weights, read through the load path, against the bench's truth.

Per bench seed, the lab's tool is the ATI-free study's drawn instrument
(``InstrumentParams().sample(TOOL_SEED_OFFSET + seed)``, :mod:`studies.ati_free`) and its
ATI-free recordings are simulated as that study does (:func:`psmforce.sim.ati_free.
simulate_ati_free`: the paper's free-space motion, ``psmforce excitation``'s design with its
clenches, known weights hung at the tip). For each case (:data:`CASES`: no weight, the ATI-free
study's 0.05 kg in the eight poses of ``psmforce excitation --known-weights``, heavier ones
beside it, the same in sixteen poses in sign pairs, and those approached by a wrist move as an
arm moves into them) ``psmforce calibrate --free-space
--known-loads`` identifies the instrument as it does
(:func:`psmforce.estimators.training.calibrate.identify_instrument`: every recording through the
load path, external force 0 in free space and the weight on a hold, clenched samples out, what
the data cannot pin down held at design values), and each parameter is compared with the
bench's own (:func:`psmforce.experiments.prior_recovery.compare_selection`,
:func:`~psmforce.experiments.prior_recovery.default_bench_truth` of the drawn tool; the capstan
also against its mean over the recordings' configurations; where the fit holds the pins at 0,
the capstan against the bench's law projected onto the held law on the fit's recordings,
:func:`~psmforce.experiments.prior_recovery.with_projection`). Physics only: no network is
trained. Usage::

    python studies/ati_free_identification.py --json results/benchmarks/ati_free_identification.json

Seeds: 201 is the design seed (the load path with known weights was tried on its ATI-free
recordings before this study existed); ``ATI_FREE_IDENTIFICATION_SEEDS`` in
``psmforce/experiments/seeds.py`` are fresh, declared before the run. Resumable: the recordings
are kept under ``--work`` and reused, and so is each case's row, by the library's code that
wrote it only (seeds can run in separate processes sharing ``--work``, and a last command with
every seed assembles the JSON from their rows). ``--held-values checked`` also holds what the
held design values, each off by its tolerance, would move beyond its needed precision
(``fit_identified(design_tolerance=DESIGN_TOLERANCE)``; its rows are kept apart and record the
tolerances). ``--jackknife-unit sign_pair`` leaves each sign pair of orientations out together in
the jackknife over the weights' orientations, instead of each orientation alone (the paired
designs' unit; rows kept apart as well). ``--rescore --json PATH`` judges a written JSON's misses
again by today's rule (:func:`psmforce.experiments.prior_recovery.judge`), the fits untouched.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.cli.options import CROSSTALK_OPTIONS, HELD_VALUES, JACKKNIFE_UNITS  # noqa: E402
from psmforce.experiments.report import kept_json  # noqa: E402
from studies.ati_free import MINUTES_SLACK, TOOL_SEED_OFFSET, _excitation  # noqa: E402

CASES = {"free space and excitation only": ((), "none"),
         "0.05 kg, 8 poses": ((0.05,), "eight"),
         "0.05, 0.1, 0.2 kg, 8 poses": ((0.05, 0.1, 0.2), "eight"),
         "0.05, 0.1, 0.2 kg, 16 paired poses": ((0.05, 0.1, 0.2), "paired"),
         "0.05, 0.1, 0.2 kg, 16 paired poses, approached": ((0.05, 0.1, 0.2),
                                                            "paired_approached")}
"""Label -> (the masses (kg) hung, the poses each hangs in): none (what free space and the
clenches give the load path); the ATI-free study's one weight in ``psmforce excitation``'s eight
orientations (:data:`~psmforce.cli.excitation.WEIGHT_WRIST_POSES`); two heavier ones beside it
(0.2 kg at the 9 mm jaw is 2 N at the tip, below the 4.6 N the paper's trials reach); the same
in sixteen orientations in sign pairs (:data:`~psmforce.cli.excitation.
WEIGHT_WRIST_POSES_PAIRED`); the same, each hold's recording starting with the wrist's move into
the pose (:data:`~psmforce.sim.excitation.APPROACH_RAD`, from alternate sides), as an arm moving
into it leaves the cables' friction pointing one way: hung from rest, a hold shows no friction
direction, so nothing of the capstan's growth with the configuration."""
DESIGN_SEED = 201


def all_free_residual(prior, trials) -> dict:
    """Per HEX10 channel, RMS and R^2 of the all-free round's law (the selection's first round)
    on the recordings it was fitted on, through the load path with the fit's sample mask: how
    much of the data the law's family leaves unexplained, before anything is held."""
    import numpy as np

    from psmforce.identification.prior import InternalForcePrior
    from psmforce.identification.prior_law import NAMES
    first = prior.info["selection"]["rounds"][0]["parameters"]
    law = InternalForcePrior(params=np.array([first[n] for n in NAMES]),
                             info={"inputs": "load_path"})
    return law.fit_metrics([t.frame for t in trials])


POSE_SETS = {"none": None, "eight": "WEIGHT_WRIST_POSES", "paired": "WEIGHT_WRIST_POSES_PAIRED",
             "paired_approached": "WEIGHT_WRIST_POSES_PAIRED"}
"""A case's poses -> the orientations of :mod:`psmforce.cli.excitation` its weights hang in."""


def case_recordings(seed: int, label: str, args, q_exc):
    """One case's ATI-free recordings on one seed, simulated into ``args.work`` unless kept
    there: (free-space trials, known-load trials, the simulation's record)."""
    import psmforce.cli.excitation as cli_excitation
    from psmforce.estimators.data.dataset import load_dataset
    from psmforce.estimators.training.ati_free import free_space_trials, known_load_trials
    from psmforce.sim.ati_free import FREE_SPACE, KNOWN_LOADS, simulate_ati_free
    from psmforce.sim.excitation import APPROACH_RAD

    masses, poses = CASES[label]
    pose_set = (None if POSE_SETS[poses] is None else
                cli_excitation.weight_poses(getattr(cli_excitation, POSE_SETS[poses])))
    folder = args.work / f"scale{args.scale:g}" / f"seed{seed}" / (
        "-".join(f"{m:g}" for m in masses or (0,)) + f"_{poses}")
    made = kept_json(folder / "made.json", lambda: simulate_ati_free(
        folder / "data", seed=seed, scale=args.scale, free_minutes=args.free_minutes,
        excitation_q=q_exc, weight_poses=pose_set, masses_kg=masses,
        hold_s=args.hold_s, tool_seed=TOOL_SEED_OFFSET + seed,
        approach_rad=APPROACH_RAD if poses.endswith("approached") else 0.0))
    free = free_space_trials(load_dataset(folder / "data" / FREE_SPACE, require_targets=False),
                             made["minutes"]["paper_free"] + made["minutes"]["excitation"]
                             + MINUTES_SLACK)
    loads = (known_load_trials(load_dataset(folder / "data" / KNOWN_LOADS,
                                            require_targets=False)) if masses else [])
    return free, loads, made


def _seed(seed: int, args, q_exc) -> list[dict]:
    """Every case's row on one seed; a case row kept under ``args.work`` by the same code
    (:func:`_code_digest`) is read back instead of fitted again."""
    from psmforce.experiments.prior_recovery import default_bench_truth
    from psmforce.sim.params import InstrumentParams

    tool = InstrumentParams().sample(TOOL_SEED_OFFSET + seed, 1.0)
    truth = default_bench_truth(tool)
    rows = []
    for label, (masses, poses) in CASES.items():
        if args.cases and label not in args.cases:
            continue
        free, loads, made = case_recordings(seed, label, args, q_exc)
        held = "_checked" if args.held_values == "checked" else ""
        unit = "" if args.jackknife_unit == "orientation" else f"_{args.jackknife_unit}"
        kept = Path(made["out"]).parent / (f"row_{args.crosstalk}{held}{unit}_"
                                           f"{_code_digest()}.json")
        rows.append(kept_json(kept, lambda: _case(seed, label, args, free, loads, made, tool,
                                                  truth)))
    return rows


def _code_digest() -> str:
    """12 hex digits of the library's source: a kept case row is reused only by the code that
    wrote it."""
    import hashlib

    import psmforce
    digest = hashlib.sha256()
    for path in sorted(Path(psmforce.__file__).parent.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def _case(seed: int, label: str, args, free, loads, made, tool, truth) -> dict:
    """One case's identification on one seed, compared with the drawn tool's truth."""
    from psmforce.estimators.training.calibrate import identify_instrument, instrument_frames
    from psmforce.experiments.prior_recovery import (bench_capstan_over, compare_selection,
                                                     with_projection)
    masses, poses = CASES[label]
    started = time.perf_counter()
    from psmforce.identification.prior_selection import DESIGN_TOLERANCE
    checked = args.held_values == "checked"
    prior = identify_instrument(free + loads, crosstalk=CROSSTALK_OPTIONS[args.crosstalk],
                                design_tolerance=DESIGN_TOLERANCE if checked else None,
                                jackknife_unit=args.jackknife_unit)
    row = {**compare_selection(prior, truth), "inputs": prior.inputs,
           **({"crosstalk": CROSSTALK_OPTIONS[args.crosstalk]}
              if args.crosstalk != "reading" else {}),
           **({"design_tolerance": DESIGN_TOLERANCE} if checked else {})}
    with_projection(row, truth, instrument_frames(free + loads), prior.wrist_compliance)
    row.update({
        "seed": seed, "case": label, "masses_kg": list(masses), "poses": poses,
        "weight_poses": list(_poses(poses)), "minutes": made["minutes"],
        "left_out_unsafe": made["left_out_unsafe"], "verdict": prior.info["verdict"],
        "converged": prior.converged, "fit_time_s": time.perf_counter() - started,
        "n_samples": prior.info["n_samples"], "rounds": prior.info["selection"]["rounds"],
        "sag": prior.info["selection"]["sag"],
        "orientation_jackknife_groups": prior.info["selection"][
            "orientation_jackknife_groups"],
        "orientation_jackknife_unit": prior.info["selection"]["orientation_jackknife_unit"],
        "capstan_mu_over_training": bench_capstan_over([t.frame for t in free + loads],
                                                       tool),
        "all_free_residual": all_free_residual(prior, free + loads)})
    print(f"seed {seed}, {label}: {row['fit_time_s']:.0f} s, misses {row['misses']}\n"
          f"  verdict: {row['verdict']}", flush=True)
    for name, r in row["parameters"].items():
        rel = r["relative_error"]
        print(f"  {name:22s} truth {r['truth']!s:>10.10s}  fitted {r['fitted']:>11.4g}"
              f"  {'' if rel is None else f'{100 * rel:6.1f} %':>8s}  {r['status']}",
              flush=True)
    return row


def _poses(poses: str) -> list[str]:
    """The orientation labels of a case's weights (none without weights)."""
    import psmforce.cli.excitation as cli_excitation
    name = POSE_SETS[poses]
    return [] if name is None else list(cli_excitation.weight_poses(
        getattr(cli_excitation, name)))


def _rescore(path: Path | None) -> dict:
    import json

    from psmforce.experiments.prior_recovery import rescore
    from psmforce.experiments.report import shown_path, write_json
    if path is None:
        raise SystemExit("--rescore needs --json: the study's JSON to judge again")
    try:
        result = json.loads(path.read_text())
        if not all("parameters" in r and "misses" in r for r in result["runs"]):
            raise KeyError("parameters")
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SystemExit(f"--rescore --json {path}: not a JSON of this study "
                         f"({type(exc).__name__}: {exc})") from None
    rescore(result, f"python studies/ati_free_identification.py --rescore --json "
                    f"{shown_path(path)}")
    write_json(path, result)
    return result


def main(argv=None) -> dict:
    from psmforce.experiments.report import shown_path, write_json
    from psmforce.experiments.seeds import ATI_FREE_IDENTIFICATION_SEEDS
    from psmforce.identification.prior_selection import DESIGN
    from psmforce.sim.dataset import SIM_VERSION
    from psmforce.sim.excitation import APPROACH_RAD

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+",
                    default=[DESIGN_SEED, *ATI_FREE_IDENTIFICATION_SEEDS])
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--free-minutes", type=float, default=1.5,
                    help="minutes of the paper's free-space motion (default 1.5)")
    ap.add_argument("--excitation-minutes", type=float, default=1.5)
    ap.add_argument("--excitation-seed", type=int, default=0)
    ap.add_argument("--hold-s", type=float, default=10.0)
    ap.add_argument("--work", type=Path, default=Path("runs/ati_free_identification"))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--cases", nargs="+", choices=list(CASES),
                    help="only these cases (default: every one of CASES)")
    ap.add_argument("--crosstalk", choices=list(CROSSTALK_OPTIONS), default="reading",
                    help="the HEX10's cross-talk the identification fits (default: the load "
                         "path's, the axial column; full: its lateral columns too)")
    ap.add_argument("--held-values", choices=HELD_VALUES, default="as-held",
                    help="checked: also hold what the held design values, each off by its "
                         "tolerance (prior_selection.DESIGN_TOLERANCE), would move beyond its "
                         "needed precision (default as-held: no such check)")
    ap.add_argument("--jackknife-unit", choices=JACKKNIFE_UNITS, default="orientation",
                    help="what the jackknife over the weights' orientations leaves out at a "
                         "time: each orientation (default) or each sign pair of them")
    ap.add_argument("--rescore", action="store_true",
                    help="judge the misses of --json again by today's rule "
                         "(experiments.prior_recovery.judge), the fits untouched; rewrites it")
    args = ap.parse_args(argv)
    if args.rescore:
        return _rescore(args.json)
    started = time.perf_counter()
    q_exc = _excitation(args.work, args)
    runs = [row for seed in args.seeds for row in _seed(seed, args, q_exc)]
    figures = {
        "command": "python studies/ati_free_identification.py " + " ".join(
            shlex.quote(a if not args.json or a != str(args.json) else shown_path(args.json))
            for a in (argv if argv is not None else sys.argv[1:])),
        "simulator_version": SIM_VERSION, "design_seed": DESIGN_SEED,
        "settings": {k: (shown_path(v) if isinstance(v, Path) else v)
                     for k, v in vars(args).items()},
        "cases": {k: {"masses_kg": list(m), "poses": p,
                      "approach_rad": APPROACH_RAD if p.endswith("approached") else 0.0}
                  for k, (m, p) in CASES.items() if not args.cases or k in args.cases},
        "design": DESIGN,
        "runs": runs, "seconds": time.perf_counter() - started}
    if args.json:
        write_json(args.json, figures)
    return figures


if __name__ == "__main__":
    main()
