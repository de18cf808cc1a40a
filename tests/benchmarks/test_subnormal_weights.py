"""benchmarks/subnormal_weights.py: the subnormal share is counted exactly, and timing a model
(which trains it for a few steps) leaves its weights as they were."""

from __future__ import annotations

import sys
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.subnormal_weights import subnormal_share, time_model  # noqa: E402
from psmforce.estimators.networks.recipes import build_model  # noqa: E402


def _tiny_transformer():
    torch.manual_seed(0)
    return build_model("transformer", 4, {"window": 8, "d_model": 8, "n_heads": 2,
                                          "n_layers": 1, "d_ff": 16})


def test_the_subnormal_share_counts_values_below_the_smallest_normal_float():
    model = _tiny_transformer()
    total = sum(p.numel() for p in model.parameters())
    assert subnormal_share(model) == 0.0
    first = next(model.parameters())
    with torch.no_grad():
        first.view(-1)[:3] = torch.tensor([1e-40, -1e-39, 0.0])   # two subnormal, one zero
        first.view(-1)[3] = torch.finfo(torch.float32).tiny           # the smallest normal
    assert subnormal_share(model) == 2 / total


def test_timing_leaves_the_weights_as_they_were():
    model = _tiny_transformer()
    before = {k: v.clone() for k, v in model.state_dict().items()}
    out = time_model(model, 4, steps=1)
    assert set(out) == {"batch_1_forward_s", "batch_256_forward_s",
                        "batch_256_training_step_s"} and all(v > 0 for v in out.values())
    for k, v in model.state_dict().items():
        assert torch.equal(v, before[k]), k
