"""psmforce.estimators.networks.attention: the chunked attention with dropout computes the stock function."""

from __future__ import annotations

import math

import pytest
import torch

from psmforce.estimators.networks.attention import attention
from psmforce.estimators.networks.baselines import PaperTransformer


def _reference(q, k, v, p, chunk, seed):
    """Plain autograd attention, with the keep mask redrawn as the function draws it: the default
    generator, ``rand >= p``, one chunk of windows after another."""
    torch.manual_seed(seed)
    shape = q.shape[1:-1] + (k.shape[-2],)
    keep = torch.cat([torch.rand((min(chunk, q.shape[0] - i),) + shape, dtype=q.dtype) >= p
                      for i in range(0, q.shape[0], chunk)])
    a = torch.softmax(q @ k.transpose(-2, -1) / math.sqrt(q.shape[-1]), -1)
    return (a * keep / (1 - p)) @ v, keep


@pytest.mark.parametrize("chunk, l_q", [(3, 7), (10, 7), (3, 1)])
def test_dropped_attention_equals_autograd_with_the_same_mask(chunk, l_q):
    torch.manual_seed(0)
    # (B, L, H, d) transposed to (B, H, L, d): strided like the model's heads
    leaves = [torch.randn(10, n, 2, 4, dtype=torch.float64, requires_grad=True)
              for n in (l_q, 7, 7)]
    q, k, v = (t.transpose(1, 2) for t in leaves)
    torch.manual_seed(5)
    out = attention(q, k, v, dropout_p=0.3, chunk=chunk)
    ref, keep = _reference(q, k, v, 0.3, chunk, seed=5)
    torch.testing.assert_close(out, ref)
    assert 0.15 < 1 - keep.double().mean() < 0.45   # some weights dropped, not all
    g = torch.randn_like(out)
    for a, b in zip(torch.autograd.grad(out, leaves, g), torch.autograd.grad(ref, leaves, g)):
        torch.testing.assert_close(a, b)


def test_dropout_rate_and_scale_are_the_stated_ones():
    """Over many weights the kept fraction is 1 - p and the kept weights are scaled by 1/(1-p), so
    the output's expectation is the attention without dropout. The mean of 400 draws sits about
    1.5 % off it; a missing 1/(1-p) scale would put it 10 % off."""
    torch.manual_seed(1)
    q, k, v = torch.randn(64, 4, 20, 8), torch.randn(64, 4, 20, 8), torch.randn(64, 4, 20, 8)
    p = 0.1
    mean = torch.stack([attention(q, k, v, dropout_p=p) for _ in range(400)]).mean(0)
    exact = torch.nn.functional.scaled_dot_product_attention(q, k, v)
    assert (mean - exact).abs().mean() < 0.05 * exact.abs().mean()


def test_dropout_zero_and_bad_rates():
    q = torch.randn(2, 1, 3, 4)
    torch.testing.assert_close(attention(q, q, q),
                               torch.nn.functional.scaled_dot_product_attention(q, q, q))
    for bad in (-0.1, 1.0):
        with pytest.raises(ValueError, match="dropout_p"):
            attention(q, q, q, dropout_p=bad)


def test_other_devices_use_torchs_kernel(monkeypatch):
    """The chunk loop is for a CPU's caches: on another device (here the meta device, which
    computes shapes only) attention with dropout goes to torch's fused kernel."""
    import psmforce.estimators.networks.attention as mod

    def chunked(*_):
        raise AssertionError("the CPU's chunked path ran on another device")
    monkeypatch.setattr(mod._DroppedAttention, "apply", chunked)
    q = torch.empty(2, 1, 3, 4, device="meta")
    assert attention(q, q, q, dropout_p=0.1).shape == (2, 1, 3, 4)
    with pytest.raises(AssertionError, match="chunked"):
        attention(torch.randn(2, 1, 3, 4), torch.randn(2, 1, 3, 4), torch.randn(2, 1, 3, 4),
                  dropout_p=0.1)


def test_paper_transformer_trains_through_it_deterministically():
    """Train mode with dropout: seeded, so two runs give the same loss and gradients."""
    x = torch.randn(6, 12, 21)

    def run():
        torch.manual_seed(2)
        model = PaperTransformer(21, window=12).train()
        loss = model(x).square().sum()
        return loss, torch.autograd.grad(loss, list(model.parameters()), allow_unused=True)
    (l1, g1), (l2, g2) = run(), run()
    assert l1 == l2
    for a, b in zip(g1, g2):
        assert (a is None and b is None) or torch.equal(a, b)
