"""The hybrid's network: a small causal transformer with sliding-window attention.

:class:`CausalTransformer` (``CausalTransformer(n_features, d_model=32, n_heads=4, n_layers=2,
d_ff=64, attention_window=50, dropout=0.1)``) maps a sequence of standard-scaled input samples to
a standard-scaled 3-vector per sample (the residual force, see :mod:`hybrid.inputs`):

* ``forward(x: (B, T, F)) -> (B, T, 3)``: chunk training and offline prediction (blocked
  sliding-window attention: O(T W) per layer, not the O(T^2) of a masked dense attention);
  output ``t`` depends on inputs ``t - window + 1 .. t`` only (causal), so every sample of a
  chunk can be supervised; the first ``window - 1`` outputs of a chunk see a truncated history (the training
  loop skips them: ``kind = "chunk"``, warm-up ``window``).
* ``step(x: (B, F), keys, values, n_valid) -> (y: (B, 3), keys, values)``: one new sample;
  ``keys``/``values`` are the per-layer caches (n_layers, B, attention_window, d_model), oldest
  sample first, from :meth:`CausalTransformer.init_cache`; ``n_valid`` (int64 tensor, shape (1,))
  counts the samples in the cache after this one (``min(samples seen, attention_window)``).
  Pure function of its inputs (ONNX / TorchScript friendly). Equal to ``forward`` over the whole
  history up to floating-point rounding (tests/test_causal.py).
* :class:`NumpyStepper`: the same step, hand-vectorised in numpy for batch 1 with preallocated
  buffers and a double-written ring buffer (no shifting, no allocation of arrays per step): a
  streaming backend that needs nothing but numpy.
* :func:`predict_sequence`: whole recordings, layer by layer with banded attention (offline).

Why this shape: each layer attends to the last ``attention_window`` (W) positions of the layer
below, with a learned additive bias per head and lag (relative positions: the score of key s
for query t depends on t - s only, never on absolute time), so keys and values can be cached
exactly and a new sample costs one token per layer. Stacking ``n_layers`` such layers gives a
receptive field ``window = n_layers * (W - 1) + 1`` samples (99 = 0.99 s at 100 Hz with the
defaults, inside the paper's 100-sample window). Pre-norm residual blocks; the decoder is the
paper's Linear d - ReLU - Linear 3 (``finetune_modules``: the decoder, as for the paper's model).

Attributes the training loop reads: ``kind = "chunk"``, ``output_space = "scaled"``,
``window`` (receptive field, samples), ``finetune_modules()``.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

_LN_EPS = 1e-5


class _Block(nn.Module):
    """Pre-norm block: sliding-window self-attention with a per-head lag bias, then an MLP."""

    def __init__(self, d_model: int, n_heads: int, d_ff: int, attention_window: int,
                 dropout: float):
        super().__init__()
        self.n_heads, self.head_dim, self.span = n_heads, d_model // n_heads, attention_window
        self.norm_attn = nn.LayerNorm(d_model, eps=_LN_EPS)
        self.qkv = nn.Linear(d_model, 3 * d_model)
        self.out = nn.Linear(d_model, d_model)
        # lag_bias[h, w]: bias of the key w places into the window, oldest (lag W-1) first, so
        # the cache's chronological order indexes it directly.
        self.lag_bias = nn.Parameter(torch.zeros(n_heads, attention_window))
        self.norm_ff = nn.LayerNorm(d_model, eps=_LN_EPS)
        self.ff_in = nn.Linear(d_model, d_ff)
        self.ff_out = nn.Linear(d_ff, d_model)
        self.dropout = dropout

    def _heads(self, t: torch.Tensor) -> torch.Tensor:
        """(B, T, d) -> (B, H, T, dh)."""
        return t.unflatten(-1, (self.n_heads, self.head_dim)).transpose(1, 2)

    def _mlp(self, h: torch.Tensor) -> torch.Tensor:
        z = F.relu(self.ff_in(self.norm_ff(h)))
        return h + F.dropout(self.ff_out(z), self.dropout, self.training)

    def _pair_bias(self) -> torch.Tensor:
        """(2, W, 2W) additive mask for a block of W queries against the previous and its own
        block of keys: the lag bias inside the causal band, -inf outside; entry 0 is for the
        first block, whose "previous block" lies before the sequence start."""
        span = self.span
        query = torch.arange(span, device=self.lag_bias.device)[:, None] + span
        lag = query - torch.arange(2 * span, device=self.lag_bias.device)[None, :]
        inside = (lag >= 0) & (lag < span)
        bias = self.lag_bias[:, (span - 1 - lag).clamp(0, span - 1)]  # (H, W, 2W)
        bias = bias.masked_fill(~inside, float("-inf"))
        first = bias.masked_fill(torch.arange(2 * span, device=bias.device) < span,
                                 float("-inf"))
        return torch.stack([first, bias])

    def forward(self, h: torch.Tensor) -> torch.Tensor:
        """(B, T, d) -> (B, T, d). Blocked sliding-window attention: the sequence is cut into
        blocks of W samples and each block's queries meet the keys of its own and the previous
        block (2W), which holds every key of their band, so the cost is O(T W), not O(T^2)."""
        batch, length, _ = h.shape
        span = self.span
        n_blocks = -(-length // span)
        q, k, v = (self._heads(F.pad(t, (0, 0, 0, n_blocks * span - length)))
                   for t in self.qkv(self.norm_attn(h)).chunk(3, dim=-1))
        shape = (batch, self.n_heads, n_blocks, span, self.head_dim)
        q, k, v = q.reshape(shape), k.reshape(shape), v.reshape(shape)
        k = torch.cat([F.pad(k, (0, 0, 0, 0, 1, 0))[:, :, :-1], k], dim=3)  # (B, H, n, 2W, dh)
        v = torch.cat([F.pad(v, (0, 0, 0, 0, 1, 0))[:, :, :-1], v], dim=3)
        scores = (q @ k.transpose(-1, -2)) / math.sqrt(self.head_dim)  # (B, H, n, W, 2W)
        pair = self._pair_bias().to(scores.dtype)
        bias = torch.cat([pair[0][:, None], pair[1][:, None].expand(-1, n_blocks - 1, -1, -1)],
                         dim=1)
        attn = F.dropout(torch.softmax(scores + bias, dim=-1), self.dropout, self.training)
        mixed = (attn @ v).flatten(2, 3)[:, :, :length]  # (B, H, T, dh)
        h = h + F.dropout(self.out(mixed.transpose(1, 2).flatten(2)), self.dropout,
                          self.training)
        return self._mlp(h)

    def step(self, h: torch.Tensor, keys: torch.Tensor, values: torch.Tensor,
             n_valid: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """h (B, d); keys/values (B, W, d) oldest first -> (h, keys, values) with the new token."""
        q, k, v = self.qkv(self.norm_attn(h)).chunk(3, dim=-1)
        keys = torch.cat([keys[:, 1:], k[:, None]], dim=1)
        values = torch.cat([values[:, 1:], v[:, None]], dim=1)
        heads = (h.shape[0], self.span, self.n_heads, self.head_dim)
        scores = torch.einsum("bhd,bwhd->bhw", q.unflatten(-1, heads[2:]),
                              keys.reshape(heads)) / math.sqrt(self.head_dim)
        lag = torch.arange(self.span - 1, -1, -1, device=h.device)
        bias = self.lag_bias.masked_fill((lag >= n_valid)[None, :], float("-inf"))
        attn = torch.softmax(scores + bias, dim=-1)
        mixed = torch.einsum("bhw,bwhd->bhd", attn, values.reshape(heads)).flatten(1)
        return self._mlp(h + self.out(mixed)), keys, values


class CausalTransformer(nn.Module):
    """Causal sliding-window transformer, (B, T, F) -> (B, T, 3); see the module docstring."""

    kind = "chunk"
    output_space = "scaled"

    def __init__(self, n_features: int, d_model: int = 32, n_heads: int = 4, n_layers: int = 2,
                 d_ff: int = 64, attention_window: int = 50, dropout: float = 0.1):
        super().__init__()
        if d_model % n_heads:
            raise ValueError(f"d_model ({d_model}) must be a multiple of n_heads ({n_heads})")
        if attention_window < 1 or n_layers < 1 or n_features < 1:
            raise ValueError(f"attention_window, n_layers and n_features must be >= 1, got "
                             f"{attention_window}, {n_layers}, {n_features}")
        self.n_features, self.d_model, self.n_layers = n_features, d_model, n_layers
        self.attention_window = attention_window
        self.window = n_layers * (attention_window - 1) + 1
        self.embed = nn.Linear(n_features, d_model)
        self.blocks = nn.ModuleList(_Block(d_model, n_heads, d_ff, attention_window, dropout)
                                    for _ in range(n_layers))
        self.norm = nn.LayerNorm(d_model, eps=_LN_EPS)
        self.decoder = nn.Sequential(nn.Linear(d_model, d_model), nn.ReLU(),
                                     nn.Linear(d_model, 3))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.dim() != 3 or x.shape[-1] != self.n_features:
            raise ValueError(f"expected input (B, T, {self.n_features}), got {tuple(x.shape)}")
        h = self.embed(x)
        for block in self.blocks:
            h = block(h)
        return self.decoder(self.norm(h))

    def init_cache(self, batch: int = 1) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Empty (keys, values, n_valid) for :meth:`step`."""
        shape = (self.n_layers, batch, self.attention_window, self.d_model)
        w = self.embed.weight
        return (torch.zeros(shape, dtype=w.dtype, device=w.device),
                torch.zeros(shape, dtype=w.dtype, device=w.device),
                torch.zeros(1, dtype=torch.int64, device=w.device))

    def step(self, x: torch.Tensor, keys: torch.Tensor, values: torch.Tensor,
             n_valid: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """One sample per batch row: (x (B, F), caches, n_valid after adding it) ->
        (y (B, 3), new keys, new values). See the module docstring."""
        h = self.embed(x)
        new_keys, new_values = [], []
        for i, block in enumerate(self.blocks):
            h, k, v = block.step(h, keys[i], values[i], n_valid)
            new_keys.append(k)
            new_values.append(v)
        return self.decoder(self.norm(h)), torch.stack(new_keys), torch.stack(new_values)

    def finetune_modules(self) -> list[nn.Module]:
        return [self.decoder]


class NumpyStepper:
    """Batch-1 incremental inference of a :class:`CausalTransformer` in float32 numpy.

    Weights are copied out of the module once; every intermediate lives in a buffer allocated
    here, written with ``out=``. Keys and values sit in a ring of length 2W where each token is
    written twice (slots ``p`` and ``p + W``), so the last W tokens are always the contiguous,
    oldest-first slice ``[p + 1, p + 1 + W)``: no shifting and no gather per step. The lag bias
    with the not-yet-filled slots masked is precomputed for every fill level.
    """

    def __init__(self, model: CausalTransformer):
        f32 = np.float32

        def arr(t: torch.Tensor) -> np.ndarray:
            return np.ascontiguousarray(t.detach().cpu().numpy(), dtype=f32)

        d, w_len = model.d_model, model.attention_window
        blocks = list(model.blocks)
        self._d, self._span = d, w_len
        n_heads, head_dim = blocks[0].n_heads, blocks[0].head_dim
        self._embed = (arr(model.embed.weight), arr(model.embed.bias))
        # head_mask[c, h] = 1 where feature c belongs to head h: turns per-head dot products into
        # one (W, d) @ (d, H) product and back.
        head_mask = np.repeat(np.eye(n_heads, dtype=f32), head_dim, axis=0)
        self._head_mask, self._head_mask_t = head_mask, np.ascontiguousarray(head_mask.T)
        scale = f32(1.0 / math.sqrt(head_dim))
        self._layers = []
        fill = np.arange(w_len)[None, :] < (w_len - np.arange(w_len + 1))[:, None]  # (W+1, W)
        for b in blocks:
            bias = arr(b.lag_bias).T  # (W, H)
            masked = np.where(fill[:, :, None], f32(-np.inf), bias[None]).astype(f32)
            self._layers.append({
                "ln1": (arr(b.norm_attn.weight), arr(b.norm_attn.bias)),
                "qkv": (arr(b.qkv.weight), arr(b.qkv.bias)),
                "out": (arr(b.out.weight), arr(b.out.bias)),
                "ln2": (arr(b.norm_ff.weight), arr(b.norm_ff.bias)),
                "ff_in": (arr(b.ff_in.weight), arr(b.ff_in.bias)),
                "ff_out": (arr(b.ff_out.weight), arr(b.ff_out.bias)),
                "bias": masked,  # (W+1, W, H): row c = c samples valid
                "keys": np.zeros((2 * w_len, d), f32), "values": np.zeros((2 * w_len, d), f32),
            })
        self._scale = scale
        self._norm = (arr(model.norm.weight), arr(model.norm.bias))
        dec = model.decoder
        self._dec = (arr(dec[0].weight), arr(dec[0].bias), arr(dec[2].weight), arr(dec[2].bias))
        d_ff = blocks[0].ff_in.out_features
        self._h = np.zeros(d, f32)
        self._a = np.zeros(d, f32)
        self._tmp = np.zeros(d, f32)
        self._qkv = np.zeros(3 * d, f32)
        self._qh = np.zeros((d, n_heads), f32)
        self._scores = np.zeros((w_len, n_heads), f32)
        self._colmax = np.zeros((1, n_heads), f32)
        self._colsum = np.zeros((1, n_heads), f32)
        self._mix = np.zeros((n_heads, d), f32)
        self._ff = np.zeros(d_ff, f32)
        self._dec_h = np.zeros(d, f32)
        self._y = np.zeros(3, f32)
        self._stat = np.zeros(1, f32)
        self.reset()

    def reset(self) -> None:
        """Forget the history (the next sample starts a new sequence)."""
        self._pos, self._count = 0, 0

    def _layer_norm(self, x: np.ndarray, params, out: np.ndarray) -> np.ndarray:
        np.subtract(x, x.mean(), out=out)
        np.multiply(out, out, out=self._tmp)
        denom = np.sqrt(self._tmp.mean() + _LN_EPS)
        np.divide(out, denom, out=out)
        np.multiply(out, params[0], out=out)
        np.add(out, params[1], out=out)
        return out

    def step(self, x: np.ndarray) -> np.ndarray:
        """x (F,) scaled inputs -> (3,) scaled output. Returns an internal buffer: copy to keep."""
        d, span = self._d, self._span
        h, a = self._h, self._a
        np.matmul(self._embed[0], x, out=h)
        np.add(h, self._embed[1], out=h)
        self._count = min(self._count + 1, span)
        pos = self._pos
        for layer in self._layers:
            self._layer_norm(h, layer["ln1"], a)
            qkv = np.matmul(layer["qkv"][0], a, out=self._qkv)
            np.add(qkv, layer["qkv"][1], out=qkv)
            keys, values = layer["keys"], layer["values"]
            keys[pos] = qkv[d:2 * d]
            keys[pos + span] = qkv[d:2 * d]
            values[pos] = qkv[2 * d:]
            values[pos + span] = qkv[2 * d:]
            # block-diagonal query (d, H): column h holds head h's query, scaled
            np.multiply(self._head_mask, qkv[:d, None], out=self._qh)
            np.multiply(self._qh, self._scale, out=self._qh)
            scores = np.matmul(keys[pos + 1:pos + 1 + span], self._qh, out=self._scores)
            np.add(scores, layer["bias"][self._count], out=scores)
            np.max(scores, axis=0, keepdims=True, out=self._colmax)
            np.subtract(scores, self._colmax, out=scores)
            np.exp(scores, out=scores)
            np.sum(scores, axis=0, keepdims=True, out=self._colsum)
            np.divide(scores, self._colsum, out=scores)
            # (H, W) @ (W, d) mixes every head's weights with every feature; keep each head's own
            mix = np.matmul(scores.T, values[pos + 1:pos + 1 + span], out=self._mix)
            np.multiply(mix, self._head_mask_t, out=mix)
            np.sum(mix, axis=0, out=a)
            np.matmul(layer["out"][0], a, out=self._tmp)
            np.add(h, self._tmp, out=h)
            np.add(h, layer["out"][1], out=h)
            self._layer_norm(h, layer["ln2"], a)
            np.matmul(layer["ff_in"][0], a, out=self._ff)
            np.add(self._ff, layer["ff_in"][1], out=self._ff)
            np.maximum(self._ff, 0, out=self._ff)
            np.matmul(layer["ff_out"][0], self._ff, out=self._tmp)
            np.add(h, self._tmp, out=h)
            np.add(h, layer["ff_out"][1], out=h)
        self._pos = (pos + 1) % span
        self._layer_norm(h, self._norm, a)
        np.matmul(self._dec[0], a, out=self._dec_h)
        np.add(self._dec_h, self._dec[1], out=self._dec_h)
        np.maximum(self._dec_h, 0, out=self._dec_h)
        np.matmul(self._dec[2], self._dec_h, out=self._y)
        np.add(self._y, self._dec[3], out=self._y)
        return self._y


def predict_sequence(model: CausalTransformer, x: np.ndarray, *, block: int = 2048) -> np.ndarray:
    """Offline batch path: outputs for every sample of one long sequence x (N, F) -> (N, 3),
    equal to running :meth:`CausalTransformer.step` from sample 0 (up to float rounding).

    Layer by layer over the whole sequence with banded attention: each query meets only its W
    keys (an ``unfold`` view of the padded keys), so the cost is O(N W) with no chunk overlap;
    queries go in blocks of ``block`` rows to bound memory."""
    model.eval()
    with torch.inference_mode():
        h = model.embed(torch.from_numpy(np.ascontiguousarray(x, dtype=np.float32)))
        for blk in model.blocks:
            h = _banded_block(blk, h, block)
        return model.decoder(model.norm(h)).numpy()


def _banded_block(blk: _Block, h: torch.Tensor, block: int) -> torch.Tensor:
    n, span, n_heads, head_dim = h.shape[0], blk.span, blk.n_heads, blk.head_dim
    q, k, v = blk.qkv(blk.norm_attn(h)).chunk(3, dim=-1)
    q = q.reshape(n, n_heads, head_dim).transpose(0, 1) / math.sqrt(head_dim)  # (H, N, dh)
    # W - 1 zero rows in front: key row t + w of the padded keys is sample t - W + 1 + w
    keys = F.pad(k, (0, 0, span - 1, 0)).reshape(n + span - 1, n_heads, head_dim).transpose(0, 1)
    values = F.pad(v, (0, 0, span - 1, 0)).reshape(n + span - 1, n_heads, head_dim).transpose(0, 1)
    mixed = torch.empty(n_heads, n, head_dim)
    for lo in range(0, n, block):
        hi = min(n, lo + block)
        key_win = keys[:, lo:hi + span - 1].unfold(1, span, 1)  # (H, rows, dh, W)
        scores = (q[:, lo:hi, None] @ key_win).squeeze(-2) + blk.lag_bias[:, None, :]
        if lo < span - 1:  # the first W - 1 samples have fewer than W predecessors
            t = torch.arange(lo, min(hi, span - 1))[:, None]
            before_start = (t - span + 1 + torch.arange(span)[None]) < 0
            scores[:, :len(t)] = scores[:, :len(t)].masked_fill(before_start, float("-inf"))
        attn = torch.softmax(scores, dim=-1)
        value_win = values[:, lo:hi + span - 1].unfold(1, span, 1)
        mixed[:, lo:hi] = (value_win @ attn[..., None]).squeeze(-1)
    h = h + blk.out(mixed.transpose(0, 1).reshape(n, n_heads * head_dim))
    return blk._mlp(h)
