"""The figures a reviewer reads: every axis names the force's frame and unit, no label runs into
a neighbouring panel, and each scatter panel states its RMSE and R^2."""

from __future__ import annotations

import numpy as np
import pytest

from psmforce.estimators.evaluation.plots import scatter_figure, time_series_figure

plt = pytest.importorskip("matplotlib.pyplot")


class _Trial:
    def __init__(self, path: str, condition: str):
        self.path, self.condition = path, condition


def _segments(labels, trials, n=400, scale=13.7):
    """Forces of a few N with decimals: tick labels as wide as a real bench's."""
    rng = np.random.default_rng(0)
    truth = {t.path: scale * rng.normal(size=(n, 3)) for t in trials}
    return {label: {t.path: (truth[t.path] + 0.1 * scale * rng.normal(size=(n, 3)),
                             truth[t.path]) for t in trials} for label in labels}


def _overlaps(fig) -> list[str]:
    """Each panel's y label that runs into another panel (its box, ticks and labels). Without
    constrained layout the previous scatter's middle and right labels did."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    return [ax.get_ylabel() for ax in fig.axes for other in fig.axes if other is not ax
            and ax.yaxis.label.get_window_extent(renderer).overlaps(
                other.get_tightbbox(renderer))]


def test_scatter_names_frame_and_unit_and_states_rmse_and_r2():
    trials = [_Trial("a.csv", "Traction"), _Trial("b.csv", "Free")]
    segments = _segments(["Hybrid (ours)", "FCN"], trials)
    fig = scatter_figure(segments)
    try:
        for ax in fig.axes:
            assert ax.get_xlabel().startswith("ATI (truth) F_")
            assert ax.get_xlabel().endswith(", HEX10 frame [N]")
            assert ax.get_ylabel().endswith(", HEX10 frame [N]")
            text = " ".join(t.get_text() for t in ax.texts)
            assert "RMSE" in text and " N" in text and "R²" in text
        assert fig.axes[0].get_ylabel() == "Hybrid (ours) F_x, HEX10 frame [N]"
        assert not _overlaps(fig)
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_time_series_names_frame_and_unit_without_overlap():
    trials = [_Trial("a.csv", "Traction"), _Trial("b.csv", "Free"), _Trial("c.csv", "Soft")]
    fig = time_series_figure(_segments(["Hybrid (ours)"], trials), trials)
    try:
        assert {ax.get_ylabel() for ax in fig.axes} == {
            f"F_{a}, HEX10 frame [N]" for a in "xyz"}
        assert fig.axes[-1].get_xlabel().endswith("[s]")
        assert not _overlaps(fig)
    finally:
        plt.close(fig)
