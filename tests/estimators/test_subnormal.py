"""Subnormal weights are flushed before a network streams (psmforce.estimators.runtime.steppers):
the caller's model untouched, every backend's outputs those of the weights as saved to float32
rounding, and the ONNX graph free of them."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import onnx
import onnx.numpy_helper
import pytest
import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.subnormal_streaming import make_subnormal  # noqa: E402
from psmforce.estimators.networks.causal import CausalTransformer  # noqa: E402
from psmforce.estimators.runtime.steppers import (TorchStepper, flush_subnormal,  # noqa: E402
                                                  make_backend, step_onnx_bytes, subnormal_count)

from tests.estimators.test_streaming import one_thread  # noqa: E402,F401  (autouse fixture)

TINY = torch.finfo(torch.float32).tiny


def with_subnormals(share: float = 0.1, seed: int = 0) -> CausalTransformer:
    """A small hybrid network with ``share`` of its weights subnormal."""
    torch.manual_seed(seed)
    model = CausalTransformer(9, d_model=16, n_heads=2, d_ff=32, attention_window=8).eval()
    return make_subnormal(model, share, seed)


def test_flushing_copies_zeroes_the_subnormals_and_leaves_the_callers_model():
    model = with_subnormals()
    before = {k: v.clone() for k, v in model.state_dict().items()}
    count = subnormal_count(model)
    assert count > 0.05 * sum(p.numel() for p in model.parameters())
    flushed, n = flush_subnormal(model)
    assert n == count and flushed is not model and subnormal_count(flushed) == 0
    for k, v in model.state_dict().items():  # the caller's weights as saved
        assert torch.equal(v, before[k]), k
    for (k, a), b in zip(model.state_dict().items(), flushed.state_dict().values()):
        small = (a.abs() < TINY) if a.is_floating_point() else torch.zeros_like(a, dtype=bool)
        assert torch.equal(b[small], torch.zeros_like(b[small])), k  # flushed to zero
        assert torch.equal(b[~small], a[~small]), k  # nothing else moved
    clean = CausalTransformer(9, d_model=16, n_heads=2, d_ff=32, attention_window=8)
    assert flush_subnormal(clean) == (clean, 0)  # no copy when there is nothing to flush


@pytest.mark.parametrize("backend", ["numpy", "onnx", "torch"])
def test_every_backend_streams_the_weights_as_saved_to_float32_rounding(backend):
    model = with_subnormals()
    reference = TorchStepper(model)  # the weights as saved, subnormals and all
    stepper = make_backend(model, backend)
    x = np.random.default_rng(1).standard_normal((40, 9)).astype(np.float32)
    for row in x:
        want = reference.step(row).copy()
        got = stepper.step(row)
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


def test_the_onnx_graph_holds_no_subnormal_unless_asked_to_keep_them():
    model = with_subnormals()

    def subnormals(graph: bytes) -> int:
        weights = onnx.load_model(io.BytesIO(graph)).graph.initializer
        return sum(int(((a != 0) & (np.abs(a) < np.finfo(np.float32).tiny)).sum())
                   for a in (onnx.numpy_helper.to_array(w) for w in weights)
                   if a.dtype == np.float32)

    assert subnormals(step_onnx_bytes(model)) == 0
    assert subnormals(step_onnx_bytes(model, flush=False)) > 0  # the check can see them
