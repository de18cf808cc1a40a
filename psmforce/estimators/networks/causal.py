"""The hybrid's network: a small causal transformer with sliding-window attention.

:class:`CausalTransformer` (``CausalTransformer(n_features, d_model=32, n_heads=4, n_layers=2,
d_ff=64, attention_window=50, dropout=0.1, uncertainty=False)``) maps a sequence of standard-scaled
input samples to a standard-scaled 3-vector per sample (the residual force, see
:mod:`psmforce.estimators.data.hybrid_inputs`); with ``uncertainty=True`` to 6 channels per sample,
C = 6 below: that mean, then its log-variance per axis, soft-clamped
(:mod:`psmforce.estimators.networks.uncertainty`; ``predicts_variance`` says which). C = 3
otherwise:

* ``forward(x: (B, T, F)) -> (B, T, C)``: chunk training and offline prediction (blocked
  sliding-window attention: O(T W) per layer, not the O(T^2) of a masked dense attention); output
  ``t`` depends on inputs ``t - window + 1 .. t`` only (causal), so every sample of a chunk can be
  supervised; the first ``window - 1`` outputs of a chunk see a truncated history (the training loop
  skips them: ``kind = "chunk"``, warm-up ``window``).
* ``stream_state(batch=1) -> (keys, values, n_valid)`` and ``stream_step(x: (B, F), keys, values,
  n_valid) -> (y: (B, C), keys, values, n_valid)``: the step protocol of
  :mod:`psmforce.estimators.runtime.steppers`, one new sample per call. ``keys``/``values`` are the
  per-layer caches (n_layers, B, attention_window, d_model), oldest sample first; ``n_valid``
  (int64, shape (1,)) counts the samples in the cache, ``min(samples seen, attention_window)``, and
  the step advances it, so a caller only feeds the state back. Pure function of its inputs (ONNX
  friendly). Equal to ``forward`` over the whole history up to floating-point rounding
  (tests/estimators/test_causal.py).
* ``predict_sequence(x: (N, F) array) -> (N, C)``: whole recordings, layer by layer with banded
  attention (offline), equal to stepping from an empty state.

A hand-vectorised numpy step of this network lives with the other step backends
(:class:`psmforce.estimators.runtime.steppers.NumpyStepper`).

Why this shape: each layer attends to the last ``attention_window`` (W) positions of the layer
below, with a learned additive bias per head and lag (relative positions: the score of key s
for query t depends on t - s only, never on absolute time), so keys and values can be cached
exactly and a new sample costs one token per layer. Stacking ``n_layers`` such layers gives a
receptive field ``window = n_layers * (W - 1) + 1`` samples (99 = 0.99 s at 100 Hz with the
defaults, inside the paper's 100-sample window). Pre-norm residual blocks; the decoder is the
paper's Linear d - ReLU - Linear 3 (Linear 6 with the log-variance; ``finetune_modules``: the
decoder, as for the paper's model, so finetuning adapts the variance too).

It is a :class:`psmforce.estimators.networks.contract.StreamableModel` (the contract says what each
member means): ``kind = "chunk"``, ``output_space = "scaled"``, ``window`` (receptive field,
samples), ``finetune_modules()``, ``n_features``, ``state_names`` and the step methods above; plus
``predicts_variance``.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from psmforce.estimators.networks.uncertainty import output_width, soft_clamp_logvar

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
        """h (B, d); keys/values (B, W, d) oldest first; n_valid: cached samples including this
        one -> (h, keys, values) with the new token."""
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

    def banded(self, h: torch.Tensor, block: int) -> torch.Tensor:
        """(N, d) -> (N, d) over one whole sequence: each query meets only its W keys (an
        ``unfold`` view of the keys padded with W - 1 zero rows in front), in blocks of
        ``block`` queries."""
        n, span, n_heads, head_dim = h.shape[0], self.span, self.n_heads, self.head_dim
        q, k, v = self.qkv(self.norm_attn(h)).chunk(3, dim=-1)
        q = q.reshape(n, n_heads, head_dim).transpose(0, 1) / math.sqrt(head_dim)  # (H, N, dh)
        # W - 1 zero rows in front: key row t + w of the padded keys is sample t - W + 1 + w
        keys, values = (F.pad(t, (0, 0, span - 1, 0)).reshape(n + span - 1, n_heads, head_dim)
                        .transpose(0, 1) for t in (k, v))
        mixed = torch.empty(n_heads, n, head_dim)
        for lo in range(0, n, block):
            hi = min(n, lo + block)
            key_win = keys[:, lo:hi + span - 1].unfold(1, span, 1)  # (H, rows, dh, W)
            scores = (q[:, lo:hi, None] @ key_win).squeeze(-2) + self.lag_bias[:, None, :]
            if lo < span - 1:  # the first W - 1 samples have fewer than W predecessors
                t = torch.arange(lo, min(hi, span - 1))[:, None]
                before_start = (t - span + 1 + torch.arange(span)[None]) < 0
                scores[:, :len(t)] = scores[:, :len(t)].masked_fill(before_start, float("-inf"))
            attn = torch.softmax(scores, dim=-1)
            value_win = values[:, lo:hi + span - 1].unfold(1, span, 1)
            mixed[:, lo:hi] = (value_win @ attn[..., None]).squeeze(-1)
        h = h + self.out(mixed.transpose(0, 1).reshape(n, n_heads * head_dim))
        return self._mlp(h)


class CausalTransformer(nn.Module):
    """Causal sliding-window transformer, (B, T, F) -> (B, T, 3), or (B, T, 6) with
    ``uncertainty``; see the module docstring."""

    kind = "chunk"
    output_space = "scaled"
    state_names = ("keys", "values", "n_valid")

    def __init__(self, n_features: int, d_model: int = 32, n_heads: int = 4, n_layers: int = 2,
                 d_ff: int = 64, attention_window: int = 50, dropout: float = 0.1,
                 uncertainty: bool = False):
        super().__init__()
        if d_model % n_heads:
            raise ValueError(f"d_model ({d_model}) must be a multiple of n_heads ({n_heads})")
        if not isinstance(uncertainty, bool):  # a JSON "false" string would read as true
            raise ValueError(f"uncertainty must be true or false, got {uncertainty!r}")
        if attention_window < 1 or n_layers < 1 or n_features < 1:
            raise ValueError(f"attention_window, n_layers and n_features must be >= 1, got "
                             f"{attention_window}, {n_layers}, {n_features}")
        self.n_features, self.d_model, self.n_layers = n_features, d_model, n_layers
        self.attention_window = attention_window
        self.predicts_variance = uncertainty
        self.window = n_layers * (attention_window - 1) + 1
        self.embed = nn.Linear(n_features, d_model)
        self.blocks = nn.ModuleList(_Block(d_model, n_heads, d_ff, attention_window, dropout)
                                    for _ in range(n_layers))
        self.norm = nn.LayerNorm(d_model, eps=_LN_EPS)
        self.decoder = nn.Sequential(nn.Linear(d_model, d_model), nn.ReLU(),
                                     nn.Linear(d_model, output_width(self)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.dim() != 3 or x.shape[-1] != self.n_features:
            raise ValueError(f"expected input (B, T, {self.n_features}), got {tuple(x.shape)}")
        h = self.embed(x)
        for block in self.blocks:
            h = block(h)
        return self._decode(h)

    def _decode(self, h: torch.Tensor) -> torch.Tensor:
        """(..., d) -> (..., C): the decoder, its log-variance channels soft-clamped."""
        y = self.decoder(self.norm(h))
        if not self.predicts_variance:
            return y
        return torch.cat([y[..., :3], soft_clamp_logvar(y[..., 3:])], dim=-1)

    def stream_state(self, batch: int = 1) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Empty (keys, values, n_valid) for :meth:`stream_step`: zeros, nothing seen."""
        shape = (self.n_layers, batch, self.attention_window, self.d_model)
        w = self.embed.weight
        return (torch.zeros(shape, dtype=w.dtype, device=w.device),
                torch.zeros(shape, dtype=w.dtype, device=w.device),
                torch.zeros(1, dtype=torch.int64, device=w.device))

    def stream_step(self, x: torch.Tensor, keys: torch.Tensor, values: torch.Tensor,
                    n_valid: torch.Tensor
                    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """One sample per batch row: (x (B, F), caches, n_valid) -> (y (B, C), new keys, new
        values, new n_valid). See the module docstring."""
        n_valid = torch.clamp(n_valid + 1, max=self.attention_window)  # this sample is cached
        h = self.embed(x)
        new_keys, new_values = [], []
        for i, block in enumerate(self.blocks):
            h, k, v = block.step(h, keys[i], values[i], n_valid)
            new_keys.append(k)
            new_values.append(v)
        return self._decode(h), torch.stack(new_keys), torch.stack(new_values), n_valid

    def predict_sequence(self, x: np.ndarray, *, block: int = 2048) -> np.ndarray:
        """Offline batch path: outputs for every sample of one long sequence x (N, F) -> (N, C),
        equal to running :meth:`stream_step` from :meth:`stream_state` (up to float rounding).

        Layer by layer over the whole sequence with banded attention (:meth:`_Block.banded`):
        O(N W) with no chunk overlap; queries go in blocks of ``block`` rows to bound memory."""
        self.eval()
        with torch.inference_mode():
            h = self.embed(torch.from_numpy(np.ascontiguousarray(x, dtype=np.float32)))
            for blk in self.blocks:
                h = blk.banded(h, block)
            return self._decode(h).numpy()

    def finetune_modules(self) -> list[nn.Module]:
        return [self.decoder]
