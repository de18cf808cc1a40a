"""The small hybrid checkpoint shipped with psmforce (``studies/bench_model.py`` builds it): live
forces from ``psmforce serve --sim`` without training first, and never, unasked, on a robot.

It was trained on the simulated bench only, and says so in its sealed provenance
(:data:`BENCH_MODEL_KEY`). :func:`check_use` is the rule every live command applies: a bench
model (this one, or any checkpoint marked so) runs against the simulated robot (``--sim``), and
against a real robot's topics only when the user says ``--bench-model``: its forces are the
simulator's instrument's, not theirs.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

BENCH_MODEL_KEY = "bench_model"
"""The provenance entry that marks a checkpoint as trained on the simulated bench only."""


def shipped_checkpoint() -> Path:
    """The path of the shipped checkpoint (package data)."""
    path = Path(str(resources.files("psmforce.live") / "data" / "bench_hybrid.pt"))
    if not path.is_file():
        raise FileNotFoundError(f"{path}: the shipped bench model is missing from this "
                                f"installation; give a checkpoint of your own")
    return path


def check_use(provenance: dict, checkpoint, *, simulated: bool, allowed: bool) -> None:
    """Refuse (ValueError, one line) a bench model on a real robot's topics unless
    ``allowed`` (``--bench-model``); any other checkpoint passes."""
    if BENCH_MODEL_KEY in provenance and not simulated and not allowed:
        raise ValueError(f"{checkpoint}: trained on the simulated bench only "
                         f"({provenance[BENCH_MODEL_KEY].get('trained_on', 'the bench')}); it "
                         f"knows no real instrument: train your own (docs/own_robot.md), run "
                         f"it with --sim, or say --bench-model to run it on these topics anyway")
