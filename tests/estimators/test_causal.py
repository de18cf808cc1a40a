"""The hybrid's causal transformer: exact incremental inference, causality, receptive field."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from psmforce.estimators.networks.causal import CausalTransformer
from psmforce.estimators.networks.baselines import freeze_for_finetuning
from psmforce.estimators.networks.recipes import build_model
from psmforce.estimators.runtime.steppers import NumpyStepper
from tests.estimators.test_streaming import one_thread  # noqa: F401  (autouse fixture)


def _model(window: int = 12, seed: int = 0, **kw) -> CausalTransformer:
    """A model with non-trivial lag biases (they start at zero) so position handling is tested."""
    torch.manual_seed(seed)
    model = CausalTransformer(7, attention_window=window, **kw).eval()
    with torch.no_grad():
        for block in model.blocks:
            block.lag_bias.normal_()
    return model


def _torch_steps(model, x: torch.Tensor) -> torch.Tensor:
    state = model.stream_state(x.shape[0])
    outs = []
    with torch.no_grad():
        for t in range(x.shape[1]):
            y, *state = model.stream_step(x[:, t], *state)
            outs.append(y)
    assert state[2].item() == min(x.shape[1], model.attention_window)  # the step counts
    return torch.stack(outs, dim=1)


def test_incremental_step_equals_full_forward():
    model = _model(window=12, n_layers=3)
    x = torch.randn(2, 80, 7)  # far beyond the receptive field: the caches wrap many times
    with torch.no_grad():
        full = model(x)
    incremental = _torch_steps(model, x)
    assert full.shape == (2, 80, 3)
    assert (incremental - full).abs().max().item() < 1e-5
    stepper = NumpyStepper(model)
    for b in range(2):
        stepper.reset()
        fast = np.stack([stepper.step(x[b, t].numpy()).copy() for t in range(80)])
        assert np.abs(fast - full[b].numpy()).max() < 1e-5


@pytest.mark.parametrize("length", [1, 5, 12, 13, 25])
def test_short_and_ragged_chunks_equal_the_incremental_path(length):
    model = _model(window=12)  # lengths below, at and off multiples of the attention window
    x = torch.randn(1, length, 7)
    with torch.no_grad():
        full = model(x)
    assert (_torch_steps(model, x) - full).abs().max().item() < 1e-5


def test_offline_sequence_path_equals_full_forward_for_any_block():
    model = _model(window=9)
    x = torch.randn(1, 150, 7)
    with torch.no_grad():
        full = model(x)[0].numpy()
    for block in (1, 7, 64, 1000):
        assert np.abs(model.predict_sequence(x[0].numpy(), block=block) - full).max() < 1e-5
    assert model.predict_sequence(x[0, :3].numpy()).shape == (3, 3)


def test_causal_and_receptive_field_is_window():
    model = _model(window=10)  # 2 layers: receptive field 2 * 9 + 1 = 19 samples
    assert model.window == 19
    x = torch.randn(1, 60, 7)
    changed = x.clone()
    changed[0, 30] += 5.0
    with torch.no_grad():
        a, b = model(x)[0], model(changed)[0]
    diff = (a - b).abs().amax(dim=1)
    assert diff[:30].max() == 0.0                          # nothing before the change moves
    assert diff[30:30 + model.window].min() > 0.0          # every output that sees it moves
    assert diff[30 + model.window:].max() == 0.0           # and none beyond the receptive field


def test_chunk_model_contract_and_finetuning_keeps_decoder():
    model = build_model("hybrid", 21, {"d_model": 32, "n_layers": 2, "attention_window": 50})
    assert (model.kind, model.output_space, model.window) == ("chunk", "scaled", 99)
    trainable, total = freeze_for_finetuning(model)
    assert trainable == sum(p.numel() for p in model.decoder.parameters()) and total > trainable
    with pytest.raises(ValueError, match="multiple of n_heads"):
        CausalTransformer(21, d_model=30, n_heads=4)
    with pytest.raises(ValueError, match=r"expected input \(B, T, 21\)"):
        model(torch.zeros(1, 5, 20))


def test_learns_a_lagged_difference_with_every_step_supervised():
    # target = x[t] - x[t-3] (a causal derivative-like map): needs attention across lags
    torch.manual_seed(0)
    model = CausalTransformer(1, d_model=16, n_heads=2, d_ff=32, attention_window=6, dropout=0.0)
    x = torch.randn(16, 30, 1)
    y = torch.zeros(16, 30, 3)
    y[:, 3:, 0] = x[:, 3:, 0] - x[:, :-3, 0]
    opt = torch.optim.Adam(model.parameters(), lr=1e-2)
    first = None
    for _ in range(150):
        opt.zero_grad()
        loss = torch.mean((model(x)[:, model.window:] - y[:, model.window:]) ** 2)
        loss.backward()
        opt.step()
        first = first if first is not None else loss.item()
    assert loss.item() < 0.1 * first
