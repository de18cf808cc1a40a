"""Why the hybrid's lateral error stops improving with more data: variants on one learning-curve bench.

    python studies/hybrid_plateau.py --scale 0.5 --seed 1 --variants default wide_64 \
        --json results/benchmarks/hybrid_plateau.json
    python studies/hybrid_plateau.py --render-only   # the table of the JSON (docs/results.md)

Reads a finished learning-curve run (``studies/learning_curve.py``) under ``--work``: its bench
of ``--seed`` (prior and derived columns included) and its checkpoints. Each variant is a hybrid
trained as the curve's hybrid was first trained (:data:`CURVE_HYBRID_TRAINING`: the full budget,
early stopping, one thread; before short chunks became the recipe's default) but one change
(:data:`VARIANTS`: its width, dropout, attention span, batch, inputs or base; or the FCN's
network on the hybrid's inputs, trained on one-sample windows as the FCN is or on chunks as the
hybrid is, which tells the inputs, the network and the training path apart), or one of the run's
own checkpoints scored again (``existing_*``). Each is scored by the causal NRMSE % per axis on the
validation trials (the selection criterion) and, for information only, on the test trials. A
variant already in ``--json`` is kept, not retrained, so the script resumes variant by variant,
and a training killed midway resumes from its last epoch (its state under
``--work/plateau_resume/``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import torch  # noqa: E402
from torch import nn  # noqa: E402

from psmforce.experiments.report import write_json  # noqa: E402
from studies.learning_curve import AXES, run_dir  # noqa: E402
from psmforce.estimators.training.checkpoint import load_checkpoint  # noqa: E402
from psmforce.estimators.data.dataset import NO_BASE  # noqa: E402
from psmforce.estimators.data.hybrid_inputs import select_base  # noqa: E402
from psmforce.estimators.evaluation.tables import mean_std, spread_text  # noqa: E402
from psmforce.estimators.networks.baselines import FCN  # noqa: E402
from psmforce.estimators.networks.recipes import (RECIPES, Inputs, Recipe, recipe, register)  # noqa: E402
from psmforce.experiments.reproduce import (  # noqa: E402
    _automated_split,
    _checkpoint,
    _config,
    _load,
    _prior_path,
    _scores,
)
from psmforce.estimators.training.resume import clear_state  # noqa: E402
from psmforce.estimators.training.train import TrainConfig, make_setup, train_model  # noqa: E402

RAW_HEX10 = ("fx", "fy", "fz", "tx", "ty", "tz")
INSERTION_STATE = ("insertion_velocity", "insertion_position")
LATERAL_BASE_OFF = (NO_BASE, NO_BASE, "insertion_fz")
LATERAL = (0, 1)
"""Fx and Fy: their places in a row of per-axis errors."""
CURVE_HYBRID_RECIPE = {"max_epochs": 300}
"""The hybrid recipe's optimiser settings when the curve's hybrid checkpoints compared here were
trained (the ``existing_hybrid`` rows; checked against each checkpoint's provenance)."""
CURVE_HYBRID_TRAINING = {**CURVE_HYBRID_RECIPE, "chunk": 400, "chunk_supervised": None,
                         "chunk_batch_size": 16}
"""What they trained with in full (the chunk settings were :class:`psmforce.estimators.training.train.TrainConfig`'s
defaults then). Every hybrid variant is one change from these, not from the recipe's present
settings, so a row stays one change from the checkpoint it is compared with."""


class ChunkFCN(nn.Module):
    """The FCN's network (F -> 64 -> 64 -> 3, ReLU) on every sample of a chunk: a per-sample
    network trained through the hybrid's chunk path (16 chunks of 300 consecutive samples per
    batch), to tell the chunk path from the network."""

    kind = "chunk"
    output_space = "scaled"

    def __init__(self, n_features: int, hidden: int = 64):
        super().__init__()
        self.window = 1  # no warm-up needed; the trainer wants one sample
        self.fcn = FCN(n_features, hidden)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fcn.head(self.fcn.body(x))

    def finetune_modules(self) -> list[nn.Module]:
        return [self.fcn.head]


def _register_chunk_fcn() -> None:
    """Registered when a variant needs it, not on import: tests that import this module and
    loop over every registered model must not meet it."""
    if "chunk_fcn" not in RECIPES:
        register(Recipe("chunk_fcn", lambda n, config: ChunkFCN(n, **config),
                        optimiser=CURVE_HYBRID_TRAINING))


@dataclass(frozen=True)
class Variant:
    """One change from the hybrid the learning curve trains: another model trained on the
    hybrid's inputs (``model``: the FCN trains on one-sample windows, batches of 256, where the
    hybrid trains on chunks), its constructor arguments (``config``), training settings
    (``training``: :class:`psmforce.estimators.training.train.TrainConfig` overrides), or inputs
    (``drop`` / ``add`` columns, ``base`` replaced, or ``paper_inputs``: the paper's 21 recorded
    columns, no prior and no base, what the FCN and the transformer read)."""

    what: str
    """The change in words (tables)."""
    model: str = "hybrid"
    config: dict = field(default_factory=dict)
    training: dict = field(default_factory=dict)
    drop: tuple[str, ...] = ()
    add: tuple[str, ...] = ()
    base: tuple[str, ...] | None = None
    paper_inputs: bool = False

    def inputs(self, train) -> Inputs:
        """The inputs it trains on: the hybrid's (base selected on ``train`` as the trainer does)
        with its changes, or the paper's."""
        if self.paper_inputs:
            return recipe("fcn").inputs(None, True)
        inputs = recipe("hybrid").inputs(None, True)
        features = tuple(f for f in inputs.features if f not in self.drop) + self.add
        base = self.base if self.base is not None else select_base(train, inputs.base)
        return dataclasses.replace(inputs, features=features, base=tuple(base))

    def to_dict(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v
                for k, v in dataclasses.asdict(self).items() if k != "what"}


VARIANTS = {
    "default": Variant("the hybrid as the curve trains it, trained again"),
    "wide_64": Variant("width 64, feed-forward 128", config={"d_model": 64, "d_ff": 128}),
    "dropout_0": Variant("dropout 0", config={"dropout": 0.0}),
    "attention_window_1": Variant("attention window 1 (no temporal context)",
                                  config={"attention_window": 1}),
    "batch_4_chunks": Variant("4 chunks per batch (4x the steps)",
                              training={"chunk_batch_size": 4}),
    "no_lateral_base": Variant("no lateral base (the network predicts Fx, Fy)",
                               base=LATERAL_BASE_OFF),
    "plus_raw_hex10": Variant("+ the raw HEX10 columns", add=RAW_HEX10),
    "no_insertion_state": Variant("without the insertion state", drop=INSERTION_STATE),
    "paper_inputs": Variant("the paper's 21 inputs (no prior, no base)", paper_inputs=True),
    "fcn_hybrid_inputs": Variant("the FCN's network on the hybrid's inputs and base, "
                                 "one-sample windows, 256 per batch", model="fcn"),
    "fcn_hybrid_inputs_no_lateral_base": Variant(
        "the same without the lateral base", model="fcn", base=LATERAL_BASE_OFF),
    "fcn_hybrid_inputs_chunks": Variant(
        "the FCN's network on the hybrid's inputs and base, the hybrid's chunks "
        "(16 x 300 consecutive samples per batch)", model="chunk_fcn"),
    "fcn_hybrid_inputs_chunks_of_2": Variant(
        "the same, chunks of 2 (one supervised sample), 256 per batch", model="chunk_fcn",
        training={"chunk": 2, "chunk_batch_size": 256}),
    "short_chunks_64": Variant(
        "chunks of 124 (25 supervised after the 99-sample warm-up), 64 per batch",
        training={"chunk": 124, "chunk_batch_size": 64}),
    "attention_window_1_chunks_of_2": Variant(
        "attention window 1, chunks of 2 (one supervised sample), 256 per batch",
        config={"attention_window": 1}, training={"chunk": 2, "chunk_batch_size": 256}),
}
"""One change each from the hybrid the learning curve trains."""
EXISTING = {"existing_hybrid": "the hybrid's own checkpoint (as trained by the curve)",
            "existing_fcn": "the FCN's own checkpoint (the paper's inputs)",
            "existing_transformer": "the paper transformer's own checkpoint"}
"""The run's own checkpoints, scored on the same trials."""


def _causal(setup, trials) -> list[float]:
    c = _scores(setup, trials, "cpu")["overall"]["causal"]
    return [round(c[a]["nrmse_pct"], 3) for a in AXES]


def _resume_path(work: Path, scale: float, seed: int, name: str) -> Path:
    """Where a variant's training keeps its per-epoch state (:mod:`psmforce.estimators.training.resume`) until its
    result is in the JSON: a killed run goes on from its last epoch."""
    return work / "plateau_resume" / f"{name}_scale{scale:g}_seed{seed}.state"


def check_first_training(provenance: dict, path: Path) -> None:
    """Refuse a curve hybrid checkpoint trained with other settings than
    :data:`CURVE_HYBRID_RECIPE` (one retrained after the recipe changed): the variants are one
    change from those settings, not from whatever the checkpoint had."""
    trained = provenance.get("reproduce", {}).get("recipe", {}).get("optimiser")
    if trained != CURVE_HYBRID_RECIPE:
        raise SystemExit(f"existing_hybrid: {path} was trained with the optimiser settings "
                         f"{trained}, not the ones the variants change ({CURVE_HYBRID_RECIPE})")


def training(change: Variant, seed: int) -> TrainConfig:
    """A variant's training settings: the run's own (the full budget) for the FCN's network on
    windows; for the hybrid and the FCN's network on chunks, :data:`CURVE_HYBRID_TRAINING`; then
    the variant's own change."""
    base = (TrainConfig(**CURVE_HYBRID_TRAINING, seed=seed, progress=False)
            if change.model in ("hybrid", "chunk_fcn")
            else _config("full", "pretrain", seed, "cpu", change.model,
                         recipe(change.model).optimiser))
    return dataclasses.replace(base, **change.training)


def variant(work: Path, scale: float, seed: int, name: str) -> dict:
    run = str(run_dir(work, scale) / "work")
    ds = _load(run, "automated", seed)
    train, val = _automated_split(ds, seed)
    result = {"name": name, "scale": scale, "seed": seed}
    if name in EXISTING:
        model = name.removeprefix("existing_")
        path = _checkpoint(run, {"model": model, "variant": "full", "fraction": 1.0, "seed": seed,
                                 "budget": "full", "device": "cpu"})
        if not path.is_file():
            raise SystemExit(f"{name}: the run has not trained {model} seed {seed} yet ({path})")
        setup = load_checkpoint(path)
        if model == "hybrid":
            check_first_training(setup.provenance, path)
    else:
        change = VARIANTS[name]
        _register_chunk_fcn()
        inputs = change.inputs(train)
        prior = _prior_path(run, seed).read_text() if inputs.uses_prior else None
        setup = make_setup(change.model, train, prior_json=prior, config=change.config,
                           inputs=inputs)
        rep = train_model(setup, train, val, training(change, seed), desc=name,
                          resume=_resume_path(work, scale, seed, name))
        result |= {"change": change.to_dict(),
                   **{k: rep.get(k) for k in ("epochs_run", "stopped_by", "converged", "parameters")},
                   "seconds": round(rep["seconds"])}
    return result | {"validation": _causal(setup, val), "test": _causal(setup, ds.select(split="test"))}


def _cell(values: list[float]) -> str:
    """Mean ± the sample std over seeds (ddof 1), the value alone for one seed."""
    return spread_text(mean_std(values))


def table(result: dict) -> str:
    """The variants as a Markdown table: per scale (largest first), each variant's causal NRMSE %
    on the validation and the test trials, mean ± std over the seeds measured (the sample std,
    ddof 1; the value alone where one seed was)."""
    what = EXISTING | {k: v.what for k, v in VARIANTS.items()}
    lines = ["| scale | variant | the change | seeds | validation Fx / Fy / Fz | "
             "test Fx / Fy / Fz |", "|---|---|---|---|---|---|"]
    rows = result["variants"]
    for scale in sorted({r["scale"] for r in rows}, reverse=True):
        for name in what:
            runs = sorted((r for r in rows if r["scale"] == scale and r["name"] == name),
                          key=lambda r: r["seed"])
            if not runs:
                continue
            cells = [" / ".join(_cell([r[split][k] for r in runs]) for k in range(len(AXES)))
                     for split in ("validation", "test")]
            lines.append(f"| {scale:g} | `{name}` | {what[name]} | "
                         f"{', '.join(str(r['seed']) for r in runs)} | {cells[0]} | {cells[1]} |")
    lines += ["", "Seed by seed on the validation trials, against the hybrid's own checkpoint:", ""]
    lines += [_paired(rows, name, "existing_hybrid") for name in PAIRED]
    return "\n".join(lines)


PAIRED = ("fcn_hybrid_inputs", "short_chunks_64", "attention_window_1_chunks_of_2")
"""Variants compared seed by seed with the hybrid's own checkpoint under the table."""


def _paired(rows: list[dict], name: str, reference: str) -> str:
    """Per scale, the seeds on which ``name`` has a lower validation error than ``reference``
    on both lateral axes, out of the seeds where both were measured."""
    found = []
    for scale in sorted({r["scale"] for r in rows}, reverse=True):
        val = {(r["name"], r["seed"]): r["validation"] for r in rows if r["scale"] == scale}
        seeds = sorted(s for n, s in val if n == name and (reference, s) in val)
        if seeds:
            lower = [s for s in seeds if all(val[name, s][k] < val[reference, s][k]
                                             for k in LATERAL)]
            found.append(f"at scale {scale:g} on {len(lower)} of {len(seeds)} seeds "
                         f"({', '.join(map(str, seeds))})")
    return (f"- `{name}` lower on Fx and Fy " + "; ".join(found) + "." if found
            else f"- `{name}`: not measured beside it yet.")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", type=Path, default=ROOT / "runs" / "learning_curve")
    ap.add_argument("--scale", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--variants", nargs="+", default=list(EXISTING) + list(VARIANTS),
                    choices=list(EXISTING) + list(VARIANTS))
    ap.add_argument("--json", type=Path, default=ROOT / "results" / "benchmarks" / "hybrid_plateau.json")
    ap.add_argument("--render-only", action="store_true",
                    help="print the table of --json and train nothing")
    args = ap.parse_args(argv)
    if args.render_only:
        if not args.json.is_file():
            ap.error(f"no results at {args.json}")
        print(table(json.loads(args.json.read_text())))
        return 0
    if not (run_dir(args.work, args.scale) / "work" / "checkpoints").is_dir():
        ap.error(f"no learning-curve run at scale {args.scale:g} under {args.work}")
    torch.set_num_threads(1)
    done = json.loads(args.json.read_text())["variants"] if args.json.exists() else []
    for name in args.variants:
        if any(d["name"] == name and d["scale"] == args.scale and d["seed"] == args.seed for d in done):
            continue
        done.append(variant(args.work, args.scale, args.seed, name))
        print(f"{name}: validation {done[-1]['validation']}  test {done[-1]['test']}  (causal NRMSE %, "
              f"{' / '.join(AXES)})")
        write_json(args.json, {"metric": "causal NRMSE %, Fx / Fy / Fz", "variants": done})
        clear_state(_resume_path(args.work, args.scale, args.seed, name))
    return 0


if __name__ == "__main__":
    sys.exit(main())
