"""The training recipe separated from the model: the hybrid, the paper's transformer and the FCN each
trained under the paper's regime and under the dense one, on fresh seeds, paired (issue 45).

The hybrid's own regime supervises every sample (short chunks, batches of 64, up to 300 epochs);
the paper's models train on one target every fifth sample in batches of 256, up to 100 epochs
(:mod:`psmforce.experiments.regimes`). Each model runs under both, to early stopping, on
the same benches (:data:`psmforce.experiments.seeds.RECIPE_SWAP_SEEDS`, never used while designing),
so the table says, per axis and metric:

- what the dense regime does to each model (its error under dense over its error under paper);
- the hybrid against the transformer (and the FCN) under the same regime, paper and dense;
- the comparison as published so far (each model under its own regime).

Every ratio is paired by seed, with a 95 % t interval on the log ratios
(:mod:`psmforce.experiments.paired`); "ahead" only when the interval excludes 1. A cell
whose trainings did not all stop early is reported and kept out of the verdicts.

    python studies/recipe_swap.py --scale 0.05 --json results/benchmarks/recipe_swap.json

The benches are those of one simulator version (``--version``, the default bench's unless
given); one JSON holds the cells of one version, and only cells on the same bench (scale, seeds,
version) are paired. Each (model, regime) cell is one resumable ``psmforce reproduce`` call into
``<work>/<version>/scale_<scale>`` (the benches simulated once); its results are kept under
``<work>/<version>/cells/`` as it finishes, so a killed run loses at most the training in
progress, and ``--render-only`` assembles what is finished. ``--cells hybrid:paper
transformer:dense`` runs some cells only (several processes on one ``--work`` must take
disjoint cells, after one has simulated the benches: ``--benches-only``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from psmforce.experiments.report import shown_path, write_json  # noqa: E402
from psmforce.experiments.seeds import RECIPE_SWAP_SEEDS, check_fresh  # noqa: E402
from psmforce.sim.versions import DEFAULT_VERSION, VERSIONS  # noqa: E402
from studies.records import read_json  # noqa: E402

MODELS = ("hybrid", "transformer", "fcn")
REGIMES = ("paper", "dense")
AXES = ("Fx", "Fy", "Fz")
METRICS = ("causal", "paper")
CELLS = tuple(f"{m}:{r}" for m in MODELS for r in REGIMES)
COST = {"hybrid:paper": 0, "hybrid:dense": 1, "fcn:paper": 2, "fcn:dense": 3,
        "transformer:paper": 4, "transformer:dense": 5}
"""Cheapest first: an interrupted run has the most cells soonest."""


def call_regime(model: str, regime: str) -> str:
    """The regime a cell's reproduce call is made under: ``"own"`` where the model's recipe
    already is that regime (the same TrainConfig), so its tasks are those of the published runs'
    settings and are not trained twice under two names."""
    from psmforce.estimators.networks.recipes import recipe
    from psmforce.experiments.regimes import regime_settings
    from psmforce.estimators.training.train import TrainConfig
    spec = recipe(model)
    same = TrainConfig(**regime_settings("own", spec)) == TrainConfig(
        **regime_settings(regime, spec))
    return "own" if same else regime


def run_dir(work: Path, sim: str, scale: float) -> Path:
    return work / sim / f"scale_{scale:g}"


def cell_path(work: Path, sim: str, cell: str) -> Path:
    return work / sim / "cells" / f"{cell.replace(':', '_')}.json"


def run_cell(work: Path, sim: str, scale: float, seeds, cell: str, threads: int, device: str,
             budget: str = "full") -> None:
    """Run (or resume) one cell on simulator version ``sim``'s benches and keep its per-seed
    figures under ``<work>/<sim>/cells/``."""
    from psmforce.experiments.reproduce import reproduce
    model, regime = cell.split(":")
    results = reproduce(run_dir(work, sim, scale), scale=scale, seeds=seeds, device=device,
                        threads=threads, models=(model,), ablations=False, efficiency=False,
                        teleop=False, regime=call_regime(model, regime), budget=budget,
                        sim_version=None if sim == DEFAULT_VERSION else sim)
    label = next(iter(results["automated_nrmse_pct_per_seed"]["causal"]))
    training = [t for key, t in results["training"].items() if key.startswith(model + " ")]
    kept = {"cell": cell, "model": model, "label": label, "regime": regime,
            "call_regime": call_regime(model, regime), "scale": scale, "seeds": list(seeds),
            "per_seed": {m: results["automated_nrmse_pct_per_seed"][m][label] for m in METRICS},
            "converged": [bool(t["converged"]) for t in training],
            "stopped": [f"{t['epochs_run']} epochs, {t['stopped_by']}" for t in training],
            "optimiser": training[0].get("optimiser"), "budget": budget,
            "simulator_versions": sorted(set(results["benches"].values())),
            "run": shown_path(work)}
    write_json(cell_path(work, sim, cell), kept)


def _pair(a: dict, b: dict, metric: str) -> dict:
    from psmforce.experiments.paired import paired_record
    return paired_record(a["per_seed"][metric], b["per_seed"][metric], AXES)


def bench(cell: dict) -> tuple:
    """What a cell was trained and scored on: only cells on the same bench are paired."""
    return cell["scale"], tuple(cell["seeds"]), tuple(cell["simulator_versions"])


def comparisons(cells: dict) -> dict:
    """The paired ratios the table shows, from the finished, converged cells."""
    ok = {c: v for c, v in cells.items() if all(v["converged"])}
    rows = {}

    def add(name: str, a: str, b: str) -> None:
        if a in ok and b in ok and bench(ok[a]) == bench(ok[b]):
            rows[name] = {"a": a, "b": b, **{m: _pair(ok[a], ok[b], m) for m in METRICS}}
    for m in MODELS:
        add(f"{m}: dense over paper", f"{m}:dense", f"{m}:paper")
    for other in ("transformer", "fcn"):
        for r in REGIMES:
            add(f"hybrid over {other}, both {r}", f"hybrid:{r}", f"{other}:{r}")
        add(f"hybrid over {other}, each its own", "hybrid:dense", f"{other}:paper")
    return rows


CELL_KEYS = ("cell", "model", "label", "scale", "seeds", "simulator_versions", "per_seed",
             "converged", "stopped")
"""What a finished cell holds that the table reads."""


def _cell(record, where: str) -> dict:
    """A finished cell read back, checked (:func:`studies.records.check_record`)."""
    from studies.records import check_record
    name = record.get("cell") if isinstance(record, dict) else None
    return check_record(record, where, name, CELLS, CELL_KEYS)


def kept_cells(json_path: Path, sim: str) -> dict:
    """The finished cells the study's JSON at ``json_path`` holds (none if it is absent),
    checked, all on simulator version ``sim`` (one JSON holds one version's cells)."""
    if not json_path.exists():
        return {}
    old = read_json(json_path, "recipe swap results")
    if not isinstance(old, dict) or not isinstance(old.get("cells", {}), dict):
        raise ValueError(f"{json_path}: not the recipe swap's results; move it aside")
    cells = {c: _cell(v, f"{json_path}: cell {c}") for c, v in old.get("cells", {}).items()}
    other = sorted({v for c in cells.values() for v in c["simulator_versions"]} - {sim})
    if other:
        raise ValueError(f"{json_path}: holds cells on simulator {', '.join(other)}, not {sim}; "
                         f"give --version {other[0]} or another --json")
    return cells


def assemble(work: Path, json_path: Path, sim: str = DEFAULT_VERSION) -> dict:
    """The study's JSON from its finished cells on simulator version ``sim``: those under
    ``work`` over those the JSON at ``json_path`` already holds (``runs/`` is not committed: a
    rerun on a fresh checkout adds to the committed cells instead of dropping them)."""
    cells = kept_cells(json_path, sim)
    for c in CELLS:
        if cell_path(work, sim, c).is_file():
            cells[c] = _cell(read_json(cell_path(work, sim, c), "cell"),
                             str(cell_path(work, sim, c)))
    cells = {c: cells[c] for c in CELLS if c in cells}
    first = bench(next(iter(cells.values()))) if cells else None
    version_flag = "" if sim == DEFAULT_VERSION else f" --version {sim}"
    figures = {
        "command": f"python studies/recipe_swap.py{version_flag} --work {shown_path(work)} "
                   f"--json {shown_path(json_path)}",
        "interval": "95 % Student t on the log of the per-seed ratios (ddof 1), mapped back",
        "cells": cells, "missing_cells": [c for c in CELLS if c not in cells],
        "other_bench": [c for c, v in cells.items() if bench(v) != first],
        "not_converged": [c for c, v in cells.items() if not all(v["converged"])],
        "comparisons": comparisons(cells)}
    write_json(json_path, figures)
    return figures


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scale", type=float, default=0.05)
    ap.add_argument("--seeds", type=int, nargs="+", default=list(RECIPE_SWAP_SEEDS))
    ap.add_argument("--cells", nargs="+", default=list(CELLS), choices=CELLS)
    ap.add_argument("--version", default=DEFAULT_VERSION, choices=VERSIONS,
                    help="the simulator version of the benches (default: the default bench's)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--budget", default="full",
                    help="reproduce's budget; anything but full caps epochs (a smoke run, "
                         "never converged)")
    ap.add_argument("--work", type=Path, default=Path("runs/recipe_swap"))
    ap.add_argument("--json", type=Path, default=ROOT / "results" / "benchmarks"
                    / "recipe_swap.json")
    ap.add_argument("--render-only", action="store_true", help="assemble the finished cells")
    ap.add_argument("--benches-only", action="store_true",
                    help="simulate each seed's bench and fit its prior, train nothing")
    args = ap.parse_args(argv)
    try:
        check_fresh(args.seeds, "recipe swap")
    except ValueError as e:
        ap.error(str(e))
    if len(set(args.seeds)) != len(args.seeds) or len(args.seeds) < 2:
        ap.error(f"--seeds: at least two distinct seeds for an interval, got {args.seeds}")
    before = args.work / f"scale_{args.scale:g}"   # the layout before --version (the default's)
    if before.is_dir() and not run_dir(args.work, DEFAULT_VERSION, args.scale).exists():
        ap.error(f"{before} is a run of the layout before --version: move it, and "
                 f"{args.work / 'cells'} with it, into {args.work / DEFAULT_VERSION}/")
    if args.benches_only:
        from psmforce.experiments.reproduce import prepare_benches
        prepare_benches(run_dir(args.work, args.version, args.scale), args.scale, args.seeds,
                        teleop=False,
                        sim_version=None if args.version == DEFAULT_VERSION else args.version)
        return 0
    try:
        if not args.render_only:
            kept = kept_cells(args.json, args.version)
            wanted = (args.scale, tuple(args.seeds), (args.version,))
            for cell in sorted(args.cells, key=COST.get):
                if cell in kept and bench(kept[cell]) == wanted:
                    continue   # finished in an earlier run (perhaps on another machine)
                run_cell(args.work, args.version, args.scale, args.seeds, cell, args.threads,
                         args.device, args.budget)
                assemble(args.work, args.json, args.version)
        assemble(args.work, args.json, args.version)
    except ValueError as err:   # a cell read back, or an output the guard refuses
        print(f"error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
