"""The paper's figures as PNG files (matplotlib, Agg backend, no display needed).

Segments are (post-processed prediction, truth) pairs of one trial from the evaluation start
(:func:`hybrid.evaluate.scored_segment`), forces in N in the HEX10 frame, 100 Hz.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hybrid.metrics import AXES  # noqa: E402
from psm_model.files import atomic_path  # noqa: E402
from psm_model.recording import HEX10_FORCE, TARGETS  # noqa: E402

Segments = Mapping[str, tuple[np.ndarray, np.ndarray]]


def _save(fig, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path, keep_suffix=True) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def plot_time_series(segments: Mapping[str, Segments], trials: Sequence, path,
                     rate_hz: float = 100.0, seconds: float = 30.0) -> Path:
    """Predicted vs ground truth over time: one representative trial per condition (columns),
    one axis per row, the first ``seconds`` of the scored part."""
    conditions = sorted({t.condition for t in trials})
    picks = {c: next(t for t in trials if t.condition == c) for c in conditions}
    fig, axes = plt.subplots(3, len(conditions), figsize=(4.5 * len(conditions), 7),
                             squeeze=False, sharex="col")
    n = int(seconds * rate_hz)
    for j, c in enumerate(conditions):
        trial = picks[c]
        for i, axis in enumerate(AXES):
            ax = axes[i, j]
            first = True
            for label, segs in segments.items():
                pred, truth = segs[trial.path]
                t = np.arange(min(n, len(truth))) / rate_hz
                if first:
                    ax.plot(t, truth[: len(t), i], color="k", lw=1.6, label="ATI (truth)")
                    first = False
                ax.plot(t, pred[: len(t), i], lw=1.0, label=label)
            ax.set_ylabel(f"{axis} (N)")
            if i == 0:
                ax.set_title(f"{c}: {Path(trial.path).name}", fontsize=9)
            if i == 2:
                ax.set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=7, loc="best")
    return _save(fig, path)


def plot_scatter(segments: Mapping[str, Segments], path, max_points: int = 20000) -> Path:
    """Predicted vs ground truth per axis (columns) for each model (rows), identity line dashed."""
    labels = list(segments)
    fig, axes = plt.subplots(len(labels), 3, figsize=(11, 3.4 * len(labels)), squeeze=False)
    rng = np.random.default_rng(0)
    for r, label in enumerate(labels):
        pred = np.concatenate([p for p, _ in segments[label].values()])
        truth = np.concatenate([y for _, y in segments[label].values()])
        keep = rng.permutation(len(pred))[:max_points]
        for i, axis in enumerate(AXES):
            ax = axes[r, i]
            ax.scatter(truth[keep, i], pred[keep, i], s=1, alpha=0.3)
            lo, hi = truth[:, i].min(), truth[:, i].max()
            ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
            ax.set_xlabel(f"ATI {axis} (N)")
            ax.set_ylabel(f"{label} {axis} (N)")
    return _save(fig, path)


def plot_hex10_vs_ati(trials: Sequence, path) -> Path:
    """Histograms of the HEX10 force reading vs the ATI ground truth per axis (paper Fig. 5)."""
    hex10 = np.concatenate([t.matrix(HEX10_FORCE, np.float64) for t in trials])
    ati = np.concatenate([t.matrix(TARGETS, np.float64) for t in trials])
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.4))
    for i, axis in enumerate(AXES):
        ax = axes[i]
        bins = np.linspace(min(hex10[:, i].min(), ati[:, i].min()),
                           max(hex10[:, i].max(), ati[:, i].max()), 80)
        ax.hist(hex10[:, i], bins=bins, alpha=0.6, label="HEX10", density=True)
        ax.hist(ati[:, i], bins=bins, alpha=0.6, label="ATI (in HEX10 frame)", density=True)
        ax.set_xlabel(f"{axis} (N)")
        ax.set_yscale("log")
    axes[0].set_ylabel("density")
    axes[0].legend(fontsize=8)
    return _save(fig, path)


def plot_ablation_boxes(per_trial: Mapping[str, Sequence[Mapping]], path) -> Path:
    """Horizontal box plots per ablation group (rows) of per-test-trial NRMSE and R^2 per axis.
    ``per_trial``: {group label: [axis_metrics of one test trial, ...]}."""
    labels = list(per_trial)
    fig, axes = plt.subplots(2, 3, figsize=(14, 1.2 + 0.5 * len(labels) * 2), squeeze=False)
    for k, (key, name) in enumerate((("nrmse_pct", "NRMSE (%)"), ("r2_pct", "R² (%)"))):
        for i, axis in enumerate(AXES):
            ax = axes[k, i]
            data = [[m[axis][key] for m in per_trial[g]] for g in labels]
            ax.boxplot(data, orientation="horizontal",
                       tick_labels=labels if i == 0 else [""] * len(labels))
            ax.set_xlabel(f"{axis} {name}")
    return _save(fig, path)


def plot_learning_curves(curves: Mapping[str, Sequence[Sequence[Mapping]]], path) -> Path:
    """Validation loss per model (columns) against optimiser steps (top) and wall-clock (bottom),
    one line per seed; a dot marks each run's best epoch (the weights kept). ``curves``:
    {label: [history of one run: [{"steps", "elapsed_s", "val_loss"}, ...], ...]}."""
    labels = list(curves)
    fig, axes = plt.subplots(2, len(labels), figsize=(3.6 * len(labels), 6), squeeze=False)
    for c, label in enumerate(labels):
        for run in curves[label]:
            val = np.array([h["val_loss"] for h in run])
            best = int(np.argmin(val))
            for r, key in enumerate(("steps", "elapsed_s")):
                x = np.array([h[key] for h in run])
                line, = axes[r, c].plot(x, val, lw=1)
                axes[r, c].plot(x[best], val[best], "o", color=line.get_color(), ms=4)
        axes[0, c].set_title(label, fontsize=9)
        axes[0, c].set_xlabel("optimiser steps")
        axes[1, c].set_xlabel("wall-clock (s)")
        for r in range(2):
            axes[r, c].set_yscale("log")
    axes[0, 0].set_ylabel("validation loss (scaled MSE)")
    axes[1, 0].set_ylabel("validation loss (scaled MSE)")
    return _save(fig, path)
