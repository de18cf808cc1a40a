"""The paper's figures as PNG files (matplotlib, Agg backend, no display needed).

Segments are (post-processed prediction, truth) pairs of one trial from the evaluation start
(:func:`psmforce.estimators.evaluation.evaluate.scored_segment`), forces in N in the HEX10 frame,
100 Hz.

Every axis label names the quantity, its frame and its unit (:func:`force_label`: ``"F_x, HEX10
frame [N]"``); the panels use matplotlib's constrained layout, so no label runs into its
neighbour; each scatter panel states its RMSE and R^2. :func:`scatter_figure` and
:func:`time_series_figure` return the open figure (what the tests read).
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from psmforce.estimators.evaluation.metrics import AXES, axis_metrics  # noqa: E402
from psmforce.core.files import atomic_path  # noqa: E402
from psmforce.io.recording import HEX10_FORCE, TARGETS  # noqa: E402

Segments = Mapping[str, tuple[np.ndarray, np.ndarray]]

FRAME = "HEX10 frame"
"""The frame every force in these figures is expressed in (the targets' frame)."""


def force_label(axis: str, what: str = "") -> str:
    """An axis label naming the force component, its frame and unit: ``"F_x, HEX10 frame [N]"``
    (``what`` first where given: ``"ATI F_x, HEX10 frame [N]"``)."""
    return f"{what + ' ' if what else ''}F_{axis[-1].lower()}, {FRAME} [N]"


def _figure(rows: int, cols: int, size: tuple[float, float], **kwargs):
    # constrained layout keeps each panel's labels clear of its neighbours'
    return plt.subplots(rows, cols, figsize=size, squeeze=False, layout="constrained", **kwargs)


def _save(fig, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path, keep_suffix=True) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def time_series_figure(segments: Mapping[str, Segments], trials: Sequence,
                       rate_hz: float = 100.0, seconds: float = 30.0):
    """The figure of :func:`plot_time_series` (open: the caller saves or closes it)."""
    conditions = sorted({t.condition for t in trials})
    picks = {c: next(t for t in trials if t.condition == c) for c in conditions}
    fig, axes = _figure(3, len(conditions), (4.5 * len(conditions), 7), sharex="col")
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
            ax.set_ylabel(force_label(axis))
            if i == 0:
                ax.set_title(f"{c}: {Path(trial.path).name}", fontsize=9)
            if i == 2:
                ax.set_xlabel("time from the evaluation start [s]")
    axes[0, 0].legend(fontsize=7, loc="best")
    return fig


def plot_time_series(segments: Mapping[str, Segments], trials: Sequence, path,
                     rate_hz: float = 100.0, seconds: float = 30.0) -> Path:
    """Predicted vs ground truth over time: one representative trial per condition (columns),
    one axis per row, the first ``seconds`` of the scored part."""
    return _save(time_series_figure(segments, trials, rate_hz, seconds), path)


def scatter_figure(segments: Mapping[str, Segments], max_points: int = 20000):
    """The figure of :func:`plot_scatter` (open: the caller saves or closes it)."""
    labels = list(segments)
    fig, axes = _figure(len(labels), 3, (12, 3.6 * len(labels)))
    rng = np.random.default_rng(0)
    for r, label in enumerate(labels):
        pred = np.concatenate([p for p, _ in segments[label].values()])
        truth = np.concatenate([y for _, y in segments[label].values()])
        scores = axis_metrics(pred, truth)  # over every sample, not only those drawn
        keep = rng.permutation(len(pred))[:max_points]
        for i, axis in enumerate(AXES):
            ax = axes[r, i]
            ax.scatter(truth[keep, i], pred[keep, i], s=1, alpha=0.3)
            lo, hi = truth[:, i].min(), truth[:, i].max()
            ax.plot([lo, hi], [lo, hi], "k--", lw=0.8)
            ax.text(0.03, 0.97, f"RMSE {scores[axis]['rmse_n']:.3f} N\n"
                                f"R² {scores[axis]['r2_pct'] / 100:.3f}",
                    transform=ax.transAxes, va="top", fontsize=8,
                    bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.8})
            ax.set_xlabel(force_label(axis, "ATI (truth)"))
            ax.set_ylabel(force_label(axis, label))
    return fig


def plot_scatter(segments: Mapping[str, Segments], path, max_points: int = 20000) -> Path:
    """Predicted vs ground truth per axis (columns) for each model (rows), identity line dashed,
    each panel's RMSE (N) and R^2 over all its samples (at most ``max_points`` drawn)."""
    return _save(scatter_figure(segments, max_points), path)


def plot_hex10_vs_ati(trials: Sequence, path) -> Path:
    """Histograms of the HEX10 force reading vs the ATI ground truth per axis (paper Fig. 5)."""
    hex10 = np.concatenate([t.matrix(HEX10_FORCE, np.float64) for t in trials])
    ati = np.concatenate([t.matrix(TARGETS, np.float64) for t in trials])
    fig, axes = _figure(1, 3, (13, 3.4))
    axes = axes[0]
    for i, axis in enumerate(AXES):
        ax = axes[i]
        bins = np.linspace(min(hex10[:, i].min(), ati[:, i].min()),
                           max(hex10[:, i].max(), ati[:, i].max()), 80)
        ax.hist(hex10[:, i], bins=bins, alpha=0.6, label="HEX10", density=True)
        ax.hist(ati[:, i], bins=bins, alpha=0.6, label="ATI (in HEX10 frame)", density=True)
        ax.set_xlabel(force_label(axis))
        ax.set_yscale("log")
    axes[0].set_ylabel("probability density [1/N]")
    axes[0].legend(fontsize=8)
    return _save(fig, path)


def plot_ablation_boxes(per_trial: Mapping[str, Sequence[Mapping]], path) -> Path:
    """Horizontal box plots per ablation group (rows) of per-test-trial NRMSE and R^2 per axis.
    ``per_trial``: {group label: [axis_metrics of one test trial, ...]}."""
    labels = list(per_trial)
    fig, axes = _figure(2, 3, (14, 1.2 + 0.5 * len(labels) * 2))
    for k, (key, name) in enumerate((("nrmse_pct", "NRMSE per test trial [%]"),
                                     ("r2_pct", "R² per test trial [%]"))):
        for i, axis in enumerate(AXES):
            ax = axes[k, i]
            data = [[m[axis][key] for m in per_trial[g]] for g in labels]
            ax.boxplot(data, orientation="horizontal",
                       tick_labels=labels if i == 0 else [""] * len(labels))
            ax.set_xlabel(f"F_{axis[-1].lower()}, {FRAME}: {name}")
    return _save(fig, path)


def plot_learning_curves(curves: Mapping[str, Sequence[Sequence[Mapping]]], path) -> Path:
    """Validation loss per model (columns) against optimiser steps (top) and wall-clock (bottom),
    one line per seed; a dot marks each run's best epoch (the weights kept). ``curves``:
    {label: [history of one run: [{"steps", "elapsed_s", "val_loss"}, ...], ...]}."""
    labels = list(curves)
    fig, axes = _figure(2, len(labels), (3.6 * len(labels), 6))
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
        axes[1, c].set_xlabel("wall-clock [s]")
        for r in range(2):
            axes[r, c].set_yscale("log")
    for r in range(2):
        axes[r, 0].set_ylabel(f"validation loss: MSE of the\nstandard-scaled F, {FRAME} [-]")
    return _save(fig, path)
