"""benchmarks/busy_poll_ab.py: the ratios pair each round of one way with the same round of the
other, and their median is over the rounds."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks.busy_poll_ab import FIGURES, ratios  # noqa: E402


def _run(scale: float) -> dict:
    return {f: {"median_ms": 0.1 * scale, "p99_ms": 0.4 * scale, "max_ms": 2.0} for f in FIGURES}


def test_the_ratios_pair_rounds_and_take_their_median():
    runs = {"busy_poll": [_run(1.0), _run(1.0), _run(3.0)],
            "sleeping": [_run(2.0), _run(4.0), _run(3.0)]}
    by = ratios(runs, "busy_poll", "sleeping")
    assert by["node_residence p99_ms"]["per_round"] == pytest.approx([0.5, 0.25, 1.0])
    assert by["node_residence p99_ms"]["median"] == pytest.approx(0.5)
    assert set(by) == {f"{f} {s}" for f in FIGURES[:2] for s in ("median_ms", "p99_ms")}
    runs["sleeping"][0]["node_residence"]["p99_ms"] = 0.0   # below the clock's resolution
    by = ratios(runs, "busy_poll", "sleeping")
    assert by["node_residence p99_ms"]["per_round"][0] is None
    assert by["node_residence p99_ms"]["median"] == pytest.approx(0.625)   # of 0.25 and 1.0
    runs["sleeping"].pop()
    with pytest.raises(ValueError):   # a round without its pair is not compared
        ratios(runs, "busy_poll", "sleeping")
