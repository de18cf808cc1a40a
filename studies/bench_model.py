"""Build the small hybrid checkpoint psmforce ships, so that ``psmforce serve --sim`` shows live
forces minutes after installing, with no training first.

    python studies/bench_model.py [--out psmforce/live/data/bench_hybrid.pt]

The recipe is the demo's, smaller: the paper's automated protocol simulated at
:data:`SCALE` (seed :data:`SEED`), the internal-force prior fitted on its training trials with
the loaded ones, the hybrid (its default architecture, at the bench's 100 Hz) trained with its
own optimiser for at most :data:`EPOCHS` epochs, seed 0. Its provenance is marked
``"bench_model"`` (what it was trained on, and that it knows no real instrument), sealed in the
checkpoint's envelope: ``psmforce serve`` runs it with ``--sim`` and refuses it on a robot
unless given ``--bench-model`` (``psmforce/live/bench_model.py``). Deterministic given the seeds
on one machine; a rebuild elsewhere may differ in the last bits (threads, BLAS).
"""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import torch  # noqa: E402

SCALE = 0.02
SEED = 7
EPOCHS = 40
OUT = Path(__file__).resolve().parents[1] / "psmforce" / "live" / "data" / "bench_hybrid.pt"


def build(out: Path) -> dict:
    from psmforce.estimators.networks.recipes import recipe
    from psmforce.estimators.training.checkpoint import load_checkpoint
    from psmforce.estimators.training.train import TrainConfig, train
    from psmforce.identification import fit_prior_cli
    from psmforce.live.bench_model import BENCH_MODEL_KEY
    from psmforce.sim import simulate
    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        data, prior = Path(tmp) / "bench", Path(tmp) / "prior.json"
        simulate("automated", scale=SCALE, seed=SEED, out=data)
        fit_prior_cli(data, prior, use_loaded=True)
        config = TrainConfig(**{**recipe("hybrid").optimiser, "max_epochs": EPOCHS}, seed=0,
                             progress=False)
        result = train(data, "hybrid", Path(tmp) / "hybrid.pt", epochs=EPOCHS, seed=0,
                       prior=prior, train_config=config)
        record = load_checkpoint(result["checkpoint"])
    record.provenance = {**record.provenance, BENCH_MODEL_KEY: {
        "trained_on": f"the simulated bench (automated protocol, scale {SCALE:g}, seed {SEED})",
        "not_for": "a real instrument: its prior and network know only the simulator",
        "built_by": "python studies/bench_model.py"}}
    record.save(out)
    return {"checkpoint": str(out), "bytes": out.stat().st_size,
            "epochs_run": result.get("epochs_run"), "best_val_loss": result.get("best_val_loss")}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(OUT))
    print(build(Path(parser.parse_args().out)))
