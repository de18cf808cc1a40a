"""Learned estimators of an EndoWrist's jaw torque and jaw angle from its motor signals
(``studies/transmission.py``; data: :mod:`psmforce.identification.transmission.recording`, 100 Hz).

A *series* is one file as arrays: ``x`` (N, F) inputs, ``y`` (N, 2) targets, ``mask`` (N,) bool:
the samples whose targets count (all, except in a validation split cut out of one file, where
the inputs before the cut are history only). Inputs: :data:`INPUTS` (A, rad at the spindle,
rad/s; the hybrid appends the physics model's jaw torque [Nm] and angle [rad]); targets
:data:`TARGETS` (Nm, rad; the hybrid's: truth minus physics). Both are standard-scaled with the
training statistics (:class:`Scaler`) before any model sees them.

Models (:func:`build_network`), all causal, the estimate at sample t reading inputs up to t only:

* window models (``fcn``, ``transformer``, ``hybrid``, ``rocket``): the last ``window``
  samples -> the last sample's estimate; a file's first samples see its first sample repeated
  before it;
* chunk models (``lstm``): a whole file from an empty state; trained on random
  chunks, the loss on the samples after a warm-up of ``warmup`` samples.

Training (:func:`train`) follows :mod:`psmforce.estimators.training.train`: Adam, LR x0.1 after 3
stale epochs (ReduceLROnPlateau patience 3), early stop after 10 epochs without a better validation
loss, the best epoch's weights kept; ``converged`` = stopped by patience, not by the epoch cap. Each
epoch draws its windows (chunk starts) afresh with the seed; ``windows_per_epoch`` bounds how many.
:class:`RocketModel` is fitted in closed form (ridge penalty on validation).
"""

from __future__ import annotations

import copy
import math
import time
import warnings
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import torch
from torch import nn

from psmforce.estimators.networks.causal import CausalTransformer
from psmforce.estimators.networks.baselines import FCN, PaperTransformer
from psmforce.estimators.networks.rocket import RocketRegressor

INPUTS = ("motor_current_a", "motor_angle_rad", "motor_velocity_rad_s")
TARGETS = ("jaw_torque_nm", "jaw_angle_rad")


@dataclass
class Series:
    x: np.ndarray
    y: np.ndarray
    mask: np.ndarray

    @classmethod
    def of(cls, x, y, mask=None) -> Series:
        x, y = np.asarray(x, np.float32), np.asarray(y, np.float32)
        mask = np.ones(len(x), bool) if mask is None else np.asarray(mask, bool)
        return cls(x, y, mask)


@dataclass
class Scaler:
    mean: np.ndarray
    std: np.ndarray

    @classmethod
    def fit(cls, arrays: list[np.ndarray]) -> Scaler:
        a = np.concatenate(arrays)
        return cls(a.mean(0).astype(np.float32), (a.std(0) + 1e-8).astype(np.float32))

    def __call__(self, a: np.ndarray) -> np.ndarray:
        return ((a - self.mean) / self.std).astype(np.float32)

    def invert(self, a: np.ndarray) -> np.ndarray:
        return a * self.std + self.mean

    def to_dict(self) -> dict:
        return {"mean": self.mean.tolist(), "std": self.std.tolist()}


class SequenceLSTM(nn.Module):
    """Causal LSTM: (B, T, F) -> (B, T, 2); two layers, then Linear - ReLU - Linear."""

    def __init__(self, n_features: int, hidden: int = 64, layers: int = 2):
        super().__init__()
        self.lstm = nn.LSTM(n_features, hidden, layers, batch_first=True)
        self.head = nn.Sequential(nn.Linear(hidden, hidden), nn.ReLU(), nn.Linear(hidden, 2))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.lstm(x)[0])


def _two_outputs(last: nn.Linear) -> nn.Linear:
    return nn.Linear(last.in_features, 2)


def _fcn(n_features: int) -> tuple[nn.Module, dict]:
    """psmforce/estimators/networks/baselines.py FCN (3 layers, 64 wide), its head made 2-wide."""
    net = FCN(n_features)
    net.head = _two_outputs(net.head)
    return net, {"kind": "window", "window": 1, "windows_per_epoch": None, "batch": 256}


def _paper_transformer(n_features: int) -> tuple[nn.Module, dict]:
    """The paper's transformer on a 64-sample (0.64 s) window, chosen on validation (a) over 16
    and 32; 8,192 windows drawn afresh each epoch. The hybrid's residual network is the same (chosen
    on validation (a) over psmforce/estimators/networks/causal.py's transformer, an LSTM and an FCN:
    studies/transmission.py DESIGN), so the paper transformer is also the hybrid without its
    physics."""
    net = PaperTransformer(n_features, window=64)
    net.decoder[-1] = _two_outputs(net.decoder[-1])
    return net, {"kind": "window", "window": 64, "windows_per_epoch": 8192, "batch": 128}


def _lstm(n_features: int) -> tuple[nn.Module, dict]:
    """Hidden 64 and 4 chunks a batch, chosen on validation (a)."""
    return SequenceLSTM(n_features), {"kind": "chunk", "warmup": 50, "supervised": 128,
                                      "windows_per_epoch": None, "batch": 4}


NETWORKS = {"fcn": _fcn, "transformer": _paper_transformer, "hybrid": _paper_transformer,
            "lstm": _lstm}
"""The transmission benchmark's networks by model name: (n_features) -> (network with two
outputs, its training settings)."""


def build_network(name: str, n_features: int) -> tuple[nn.Module, dict]:
    """The network of model ``name`` with two outputs, and its training settings."""
    if name not in NETWORKS:
        raise ValueError(f"unknown network {name!r}; known: {sorted(NETWORKS)}")
    return NETWORKS[name](n_features)


def _padded(x: np.ndarray, window: int) -> np.ndarray:
    return np.concatenate([np.repeat(x[:1], window - 1, axis=0), x]) if window > 1 else x


def window_view(x: np.ndarray, window: int) -> np.ndarray:
    """(N, F) -> (N, window, F) causal windows (a view), the first sample repeated before t=0."""
    p = np.ascontiguousarray(_padded(x, window))
    return np.lib.stride_tricks.sliding_window_view(p, window, axis=0).transpose(0, 2, 1)


@torch.inference_mode()
def predict_scaled(net: nn.Module, settings: dict, x: np.ndarray) -> np.ndarray:
    """Scaled (N, 2) estimates for one whole file of scaled inputs (N, F), causal."""
    net.eval()
    if settings["kind"] == "chunk":
        if isinstance(net, CausalTransformer):
            return net.predict_sequence(x)
        return net(torch.from_numpy(x)[None])[0].numpy()
    windows = window_view(x, settings["window"])
    out = [net(torch.from_numpy(np.array(windows[i:i + 4096]))).numpy()
           for i in range(0, len(windows), 4096)]
    return np.concatenate(out)


def _val_loss(net, settings, val: list[Series]) -> float:
    err = [((predict_scaled(net, settings, s.x) - s.y) ** 2)[s.mask] for s in val]
    return float(np.concatenate(err).mean())


def _epoch_batches(settings: dict, data: list[Series], rng: np.random.Generator):
    """One epoch's (x, y, weight) batches as tensors, drawn with ``rng``."""
    if settings["kind"] == "window":
        w = settings["window"]
        big = np.concatenate([_padded(s.x, w) for s in data])
        offsets = np.cumsum([0] + [len(s.x) + w - 1 for s in data])[:-1]
        pool = np.concatenate([o + np.flatnonzero(s.mask) for o, s in zip(offsets, data)])
        ys = np.concatenate([s.y[s.mask] for s in data])
        pick = rng.permutation(len(pool))
        if settings["windows_per_epoch"]:
            pick = pick[:settings["windows_per_epoch"]]
        for i in range(0, len(pick), settings["batch"]):
            idx = pick[i:i + settings["batch"]]
            xb = big[pool[idx][:, None] + np.arange(w)]
            yield torch.from_numpy(xb), torch.from_numpy(ys[idx][:, None]), None
        return
    warm, sup = settings["warmup"], settings["supervised"]
    length = warm + sup
    usable = [s for s in data if len(s.x) >= length]
    if not usable:
        raise ValueError(f"every training series is shorter than a chunk ({length} samples)")
    n_chunks = math.ceil(sum(int(s.mask.sum()) for s in usable) / sup)
    which = rng.integers(len(usable), size=n_chunks)
    starts = [rng.integers(len(usable[f].x) - length + 1) for f in which]
    for i in range(0, n_chunks, settings["batch"]):
        sel = list(zip(which[i:i + settings["batch"]], starts[i:i + settings["batch"]]))
        xb = np.stack([usable[f].x[a:a + length] for f, a in sel])
        yb = np.stack([usable[f].y[a + warm:a + length] for f, a in sel])
        mb = np.stack([usable[f].mask[a + warm:a + length] for f, a in sel])
        yield torch.from_numpy(xb), torch.from_numpy(yb), torch.from_numpy(mb)


def train(net: nn.Module, settings: dict, data: list[Series], val: list[Series], *, seed: int,
          lr: float = 1e-3, max_epochs: int = 150, patience: int = 10,
          lr_patience: int = 3, time_limit_s: float | None = None) -> dict:
    """Train ``net`` in place on scaled series, early-stopped on ``val``; leaves the best
    weights in it and returns the report (epochs run, stopped by, converged, losses)."""
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    sched = torch.optim.lr_scheduler.ReduceLROnPlateau(opt, factor=0.1, patience=lr_patience)
    best, best_state, stale, history = _val_loss(net, settings, val), None, 0, []
    best_state = copy.deepcopy(net.state_dict())  # a finetune that never improves keeps these
    initial, started, stopped_by = best, time.perf_counter(), "epoch_limit"
    for epoch in range(max_epochs):
        net.train()
        losses = []
        for xb, yb, mb in _epoch_batches(settings, data, rng):
            out = net(xb)
            if settings["kind"] == "window":
                loss = ((out - yb[:, 0]) ** 2).mean()
            else:
                err = ((out[:, settings["warmup"]:] - yb) ** 2).mean(-1)
                loss = (err * mb).sum() / mb.sum().clamp(min=1)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            losses.append(loss.item())
        v = _val_loss(net, settings, val)
        history.append({"epoch": epoch + 1, "train_loss": float(np.mean(losses)), "val_loss": v,
                        "lr": opt.param_groups[0]["lr"]})
        sched.step(v)
        if v < best:
            best, best_state, stale = v, copy.deepcopy(net.state_dict()), 0
        else:
            stale += 1
            if stale >= patience:
                stopped_by = "patience"
                break
        if time_limit_s and time.perf_counter() - started > time_limit_s:
            stopped_by = "time_limit"
            break
    net.load_state_dict(best_state)
    net.eval()
    return {"epochs_run": len(history), "stopped_by": stopped_by,
            "converged": stopped_by == "patience", "best_val_loss": best,
            "initial_val_loss": initial, "seconds": round(time.perf_counter() - started, 1),
            "val_history": [round(h["val_loss"], 5) for h in history]}


class RocketModel:
    """MultiRocket-Hydra (:class:`psmforce.estimators.networks.rocket.RocketRegressor`) on causal windows; its three
    output columns carry the two targets and a zero column (ignored)."""

    settings: ClassVar[dict] = {"kind": "rocket", "window": 32}

    def __init__(self, seed: int, max_train_windows: int = 20_000):
        self.reg = RocketRegressor(window=self.settings["window"], seed=seed,
                                   max_train_windows=max_train_windows)

    def _windows(self, data: list[Series]):
        w = self.settings["window"]
        x = np.concatenate([window_view(s.x, w)[s.mask] for s in data])
        y = np.concatenate([s.y[s.mask] for s in data])
        return x, np.concatenate([y, np.zeros((len(y), 1), np.float32)], axis=1)

    def fit(self, data: list[Series], val: list[Series], *, refit: bool = False) -> dict:
        x, y = self._windows(data)
        vx, vy = self._windows(val)
        with warnings.catch_warnings():  # constant windows (the jaw at rest) are expected
            warnings.filterwarnings("ignore", message=".*very little variation")
            report = (self.reg.refit_head if refit else self.reg.fit)(x, y, vx, vy)
        return {"epochs_run": 1, "stopped_by": "closed form", "converged": True,
                "best_val_loss": report["criterion_rmse"] ** 2 * 1.5,  # mean over the 2 targets
                "alpha": report["alpha"], "seconds": report["seconds"],
                "windows_used": report["n_windows_used"]}

    def predict_scaled(self, x: np.ndarray) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*very little variation")
            return self.reg.predict(window_view(x, self.settings["window"]))[:, :2]
