"""Scaled dot-product attention with dropout on the attention weights, for training on a CPU.

The function is the stock one (``torch.nn.functional.scaled_dot_product_attention`` with
``dropout_p``, as ``nn.TransformerEncoderLayer`` trains):

    A = softmax(Q K^T / sqrt(d_head))            (..., L_q, L_k)
    out = (A * keep / (1 - p)) V,                 keep ~ Bernoulli(1 - p) per weight, i.i.d.

Why a second implementation: with dropout, torch's CPU attention falls back to its math path,
which writes the (batch, heads, L_q, L_k) weights, a float mask and their products to memory
several times (82 MB each for the paper transformer's batch of 256 windows of 100 samples) and
reads them back in the backward pass; on a 2-core CPU that memory traffic, not the
arithmetic, was most of the training step. Here the batch is processed a few windows at a time,
so each chunk's weights stay in cache, and only the keep mask (one byte per weight) is saved for
the backward pass, which recomputes the chunk's softmax (cheaper than reading it back).

The mask is ``torch.rand(chunk) >= p``: the same Bernoulli law as ``bernoulli_(1 - p)``, drawn
from the default generator chunk after chunk in batch order, so a seed fixes it (a test redraws
it to check output and gradients against plain autograd).
"""

from __future__ import annotations

import math

import torch

CHUNK_WINDOWS = 4
"""Windows per chunk: 4 x 8 heads x 100 x 100 float32 weights = 1.3 MB, inside a core's L2."""


class _DroppedAttention(torch.autograd.Function):
    @staticmethod
    def forward(ctx, q, k, v, p: float, chunk: int):
        scale, keep_scale = 1.0 / math.sqrt(q.shape[-1]), 1.0 / (1.0 - p)
        out = q.new_empty(q.shape[:-1] + (v.shape[-1],))
        keep = torch.empty(q.shape[:-1] + (k.shape[-2],), dtype=torch.bool, device=q.device)
        for i in range(0, q.shape[0], chunk):
            c = slice(i, i + chunk)
            a = torch.softmax(torch.matmul(q[c], k[c].transpose(-2, -1)).mul_(scale), -1)
            keep[c] = torch.rand_like(a) >= p
            torch.matmul(a.mul_(keep[c]).mul_(keep_scale), v[c], out=out[c])
        ctx.save_for_backward(q, k, v, keep)
        ctx.scale, ctx.keep_scale, ctx.chunk = scale, keep_scale, chunk
        return out

    @staticmethod
    def backward(ctx, grad_out):
        q, k, v, keep = ctx.saved_tensors
        scale, keep_scale = ctx.scale, ctx.keep_scale
        dq, dk, dv = torch.empty_like(q), torch.empty_like(k), torch.empty_like(v)
        for i in range(0, q.shape[0], ctx.chunk):
            c = slice(i, i + ctx.chunk)
            g = grad_out[c]
            a = torch.softmax(torch.matmul(q[c], k[c].transpose(-2, -1)).mul_(scale), -1)
            torch.matmul((a * keep[c]).mul_(keep_scale).transpose(-2, -1), g, out=dv[c])
            g_a = torch.matmul(g, v[c].transpose(-2, -1)).mul_(keep[c]).mul_(keep_scale)
            # softmax backward: dS = A * (dA - sum(dA * A)), then through the 1/sqrt(d) scale
            g_s = g_a.sub_((g_a * a).sum(-1, keepdim=True)).mul_(a).mul_(scale)
            torch.matmul(g_s, k[c], out=dq[c])
            torch.matmul(g_s.transpose(-2, -1), q[c], out=dk[c])
        return dq, dk, dv, None, None


def attention(q: torch.Tensor, k: torch.Tensor, v: torch.Tensor, dropout_p: float = 0.0,
              chunk: int = CHUNK_WINDOWS) -> torch.Tensor:
    """Attention of ``q`` (B, H, L_q, d) over ``k``, ``v`` (B, H, L_k, d) -> (B, H, L_q, d).

    ``dropout_p = 0`` (evaluation, or a model without dropout) is torch's own kernel; ``> 0``
    on a CPU the chunked path above, the same function with its dropout. Torch's kernel does both
    under ``torch.compile`` (the compiler cannot fuse the chunk loop and traced it 5x slower) and
    on any other device: the chunk loop exists for a CPU's caches, and on a GPU it turns one fused
    kernel into dozens of small launches per batch."""
    if not 0.0 <= dropout_p < 1.0:
        raise ValueError(f"dropout_p must be in [0, 1), got {dropout_p}")
    if dropout_p == 0.0 or q.device.type != "cpu" or torch.compiler.is_compiling():
        return torch.nn.functional.scaled_dot_product_attention(q, k, v, dropout_p=dropout_p)
    return _DroppedAttention.apply(q, k, v, dropout_p, chunk)
