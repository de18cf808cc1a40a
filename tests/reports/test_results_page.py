"""reports/results_page.py: blocks whose sentences are computed from their JSON."""

import json
from pathlib import Path

from reports.results_page import latency

ROOT = Path(__file__).resolve().parents[2]


def _committed(name: str) -> dict:
    return json.loads((ROOT / "results" / "benchmarks" / name).read_text())


def test_the_window_steps_cost_is_the_ratio_of_the_runs_medians_and_only_when_measured():
    streaming, live = _committed("streaming.json"), _committed("live.json")
    streaming["hybrid_pipeline"]["median_ms"] = 0.5
    streaming["paper_transformer_pipeline"]["median_ms"] = 1.6
    text = latency(streaming, live)
    assert "costs 3.2x the hybrid's cached step at the median" in text
    assert f"`{streaming['command']}`" in text
    del streaming["paper_transformer_pipeline"]   # a run made before window models streamed
    older = latency(streaming, live)
    assert "window model's step" not in older and "paper transformer pipeline" not in older
