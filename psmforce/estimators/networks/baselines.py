"""The paper's estimators and their baselines as PyTorch modules.

Two model families share the training loop (:mod:`psmforce.estimators.training.train`), both
:class:`psmforce.estimators.networks.contract.TrainableNetwork` (the contract, written once there):

* window models, ``kind = "window"``: ``forward(x: (B, L, F)) -> (B, 3)``, one estimate for the
  last sample of each window (the paper's transformer, ``L = 100``; the FCN, ``L = 1``);
  Window models split into ``features(x) -> (B, d)`` and ``decode(features) -> (B, 3)``, the
  part finetuning trains, so finetuning can compute the frozen features once;
* chunk models, ``kind = "chunk"``: ``forward(x: (B, T, F)) -> (B, T, 3)``, an estimate for every
  sample of a chunk, causal, supervised after a warm-up of ``window`` samples (the per-joint LSTM
  here and the hybrid's causal transformer in :mod:`psmforce.estimators.networks.causal`).

``output_space`` says what the output means: ``"scaled"`` = standard-scaled targets (the loop
un-scales with the training target statistics), ``"newton"`` = force in N in the HEX10 frame
(the LSTM, whose output comes out of the Jacobian transpose).

Valid constructor arguments (sizes, windows) are stated in the recipe table
(:data:`psmforce.estimators.networks.recipes.TRANSFORMER_RANGES`, ``FCN_RANGES``, ``LSTM_RANGES``)
and checked by :func:`psmforce.estimators.networks.recipes.build_model` before anything is
allocated; built directly, a transformer still refuses heads that do not divide its width.

Every model has ``finetune_modules()``: the modules left trainable when finetuning ("the last
decoder block" of the paper: the transformer's two-layer decoder, 4.4K parameters; the FCN's last
layer, 0.2K; each joint LSTM's two-layer head, 49.9K in all).
"""

from __future__ import annotations

import math

import torch
from torch import nn
from torch.nn import functional as F

from psmforce.estimators.networks.attention import attention

LSTM_MAX_TORQUE = (10.0, 10.0, 10.0, 0.2, 0.2, 0.2)
"""Yang et al.'s output bound per chain joint (tanh x bound): Nm (revolute), N (insertion)."""


class _SinusoidalPositions(nn.Module):
    """Fixed sinusoidal positional encoding (Vaswani et al.), added to (B, L, d) inputs."""

    def __init__(self, d_model: int, max_len: int = 4096):
        super().__init__()
        position = torch.arange(max_len, dtype=torch.float32)[:, None]
        freq = torch.exp(torch.arange(0, d_model, 2, dtype=torch.float32)
                         * (-math.log(10000.0) / d_model))
        table = torch.zeros(max_len, d_model)
        table[:, 0::2] = torch.sin(position * freq)
        table[:, 1::2] = torch.cos(position * freq[: d_model // 2])
        self.register_buffer("table", table, persistent=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.shape[1] > self.table.shape[0]:
            raise ValueError(f"window of {x.shape[1]} samples exceeds the positional table "
                             f"({self.table.shape[0]})")
        return x + self.table[: x.shape[1]]


class PaperTransformer(nn.Module):
    """The seed paper's estimator: Linear(F -> 64) + sinusoidal positions + 3 encoder layers
    (8 heads, feed-forward 256, dropout 0.1, post-norm) -> last time step -> Linear 64 - ReLU -
    Linear 3. 155,715 parameters with the paper's 21 inputs.

    The layers are :class:`torch.nn.TransformerEncoderLayer` (their parameters and checkpoints),
    but :meth:`forward` runs them itself, for speed on a CPU and with the same function:

    * only the last sample's estimate is read, so the last layer computes its query, residual,
      norms and feed-forward for the last position only (its keys and values still span the
      window): one third of the work, and the same output as the full layer's last row;
    * attention goes through :func:`psmforce.estimators.networks.attention.attention`: torch's
      kernel in evaluation, and while training (dropout on the attention weights, as the stock layer
      does) a chunked path that keeps each chunk's weights in cache, the same function.

    ``tests/estimators/test_hybrid_pipeline.py`` checks it against the stock
    ``nn.TransformerEncoder``.
    """

    kind = "window"
    output_space = "scaled"

    def __init__(self, n_features: int, window: int = 100, d_model: int = 64, n_heads: int = 8,
                 n_layers: int = 3, d_ff: int = 256, dropout: float = 0.1):
        super().__init__()
        if n_heads < 1 or d_model % n_heads:
            raise ValueError(f"n_heads must divide d_model ({d_model}), got {n_heads}")
        self.window = window
        self.embed = nn.Linear(n_features, d_model)
        self.positions = _SinusoidalPositions(d_model, max_len=max(window, 1))
        layer = nn.TransformerEncoderLayer(d_model, n_heads, d_ff, dropout, batch_first=True)
        self.encoder = nn.TransformerEncoder(layer, n_layers, enable_nested_tensor=False)
        self.decoder = nn.Sequential(nn.Linear(d_model, d_model), nn.ReLU(), nn.Linear(d_model, 3))

    attend = staticmethod(attention)
    """(q, k, v, dropout_p) -> attention output; ``benchmarks/training.py`` swaps in torch's
    kernel to time what :mod:`psmforce.estimators.networks.attention` replaced."""

    def _layer(self, layer: nn.TransformerEncoderLayer, h: torch.Tensor,
               last_only: bool) -> torch.Tensor:
        """One post-norm encoder layer; ``last_only``: the output at the last position only."""
        mha = layer.self_attn
        d = h.shape[-1]
        heads = mha.num_heads
        w, b = mha.in_proj_weight, mha.in_proj_bias
        k, v = F.linear(h, w[d:], b[d:]).unflatten(-1, (2, heads, d // heads)).permute(
            2, 0, 3, 1, 4)
        hq = h[:, -1:] if last_only else h
        q = F.linear(hq, w[:d], b[:d]).unflatten(-1, (heads, d // heads)).transpose(1, 2)
        attn = self.attend(q, k, v, dropout_p=mha.dropout if layer.training else 0.0)
        h = layer.norm1(hq + layer.dropout1(mha.out_proj(attn.transpose(1, 2).flatten(-2))))
        ff = layer.linear2(layer.dropout(layer.activation(layer.linear1(h))))
        return layer.norm2(h + layer.dropout2(ff))

    def features(self, x: torch.Tensor) -> torch.Tensor:
        """(B, L, F) -> (B, d_model): the encoder's output at the last sample (the decoder's
        input; finetuning trains the decoder on these)."""
        h = self.positions(self.embed(x))
        layers = self.encoder.layers
        for i, layer in enumerate(layers):
            h = self._layer(layer, h, last_only=i == len(layers) - 1)
        return h[:, -1]

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.decoder(self.features(x))

    def decode(self, features: torch.Tensor) -> torch.Tensor:
        return self.decoder(features)

    def finetune_modules(self) -> list[nn.Module]:
        return [self.decoder]


class FCN(nn.Module):
    """The paper's non-temporal baseline: three linear layers (F -> 64 -> 64 -> 3, ReLU) on one
    sample. 5,763 parameters with 21 inputs. Takes (B, 1, F) windows like the other window
    models."""

    kind = "window"
    output_space = "scaled"

    def __init__(self, n_features: int, hidden: int = 64):
        super().__init__()
        self.window = 1
        self.body = nn.Sequential(nn.Linear(n_features, hidden), nn.ReLU(),
                                  nn.Linear(hidden, hidden), nn.ReLU())
        self.head = nn.Linear(hidden, 3)

    def features(self, x: torch.Tensor) -> torch.Tensor:
        return self.body(x[:, -1])

    def decode(self, features: torch.Tensor) -> torch.Tensor:
        return self.head(features)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.features(x))

    def finetune_modules(self) -> list[nn.Module]:
        return [self.head]


class JointLSTMForce(nn.Module):
    """Yang et al.'s inverse-dynamics baseline as the seed paper trains it (eq. 1-3).

    Six networks, one per chain joint: LSTM(12 -> 128) over (q, dq) of joints 1-6 -> Linear 64 ->
    ReLU -> Linear 1 -> tanh x max torque, giving the internal torque estimate tau_hat. The force
    follows through the Jacobian:

        F_hex10 = A(q) (tau - tau_hat),   A(q) = -[R_PSM_HEX10(q)^T  0] J_s(q)^-T   (3 x 6),

    i.e. F = J_s^-T (tau - tau_hat) in the base frame, its force rows rotated into the HEX10 frame
    (paper eq. 2; the minus because dVRK efforts are what the motors apply, see
    :func:`psmforce.estimators.data.lstm_inputs.lstm_columns`, which precomputes A per sample with
    the PSM model). A enters as input columns, so the whole map is differentiable and the loss is
    the MSE on the HEX10-frame force (eq. 3).

    Input columns, in order (see :data:`psmforce.estimators.data.lstm_inputs.LSTM_FEATURES`): 12
    standardised (q, dq) of joints 1-6, 6 raw measured efforts tau (Nm, N), 18 raw entries of A
    (row-major). A chunk model: (B, T, 36) -> (B, T, 3) in N, sequence-to-sequence as Yang et al.
    train it. 486,150 parameters.
    """

    kind = "chunk"
    output_space = "newton"

    def __init__(self, window: int = 100, hidden: int = 128, head: int = 64,
                 max_torque: tuple[float, ...] = LSTM_MAX_TORQUE):
        super().__init__()
        self.window = window
        self.lstms = nn.ModuleList(nn.LSTM(12, hidden, batch_first=True) for _ in range(6))
        self.heads = nn.ModuleList(nn.Sequential(nn.Linear(hidden, head), nn.ReLU(),
                                                 nn.Linear(head, 1)) for _ in range(6))
        self.register_buffer("max_torque", torch.tensor(max_torque, dtype=torch.float32))

    def internal_torques(self, x: torch.Tensor) -> torch.Tensor:
        """tau_hat (B, T, 6) from the (q, dq) columns."""
        state = x[..., :12]
        out = [head(lstm(state)[0]) for lstm, head in zip(self.lstms, self.heads)]
        return torch.tanh(torch.cat(out, dim=-1)) * self.max_torque

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        tau = x[..., 12:18]
        jacobian_map = x[..., 18:36].unflatten(-1, (3, 6))
        return (jacobian_map @ (tau - self.internal_torques(x)).unsqueeze(-1)).squeeze(-1)

    def step(self, x: torch.Tensor, state: list | None = None) -> tuple[torch.Tensor, list]:
        """Streaming: one sample (B, 36) and the six LSTMs' (h, c) -> (force (B, 3) in N, state)."""
        state = state or [None] * 6
        outs, new_state = [], []
        for lstm, head, s in zip(self.lstms, self.heads, state):
            h, s = lstm(x[:, None, :12], s)
            outs.append(head(h[:, 0]))
            new_state.append(s)
        tau_hat = torch.tanh(torch.cat(outs, dim=-1)) * self.max_torque
        force = (x[:, 18:36].unflatten(-1, (3, 6)) @ (x[:, 12:18] - tau_hat).unsqueeze(-1))
        return force.squeeze(-1), new_state

    def finetune_modules(self) -> list[nn.Module]:
        return list(self.heads)


def count_parameters(model: nn.Module, trainable_only: bool = False) -> int:
    return sum(p.numel() for p in model.parameters() if p.requires_grad or not trainable_only)


def freeze_for_finetuning(model: nn.Module) -> tuple[int, int]:
    """Freeze everything but ``model.finetune_modules()``; return (trainable, total) parameters."""
    for p in model.parameters():
        p.requires_grad_(False)
    for module in model.finetune_modules():
        for p in module.parameters():
            p.requires_grad_(True)
    return count_parameters(model, trainable_only=True), count_parameters(model)
