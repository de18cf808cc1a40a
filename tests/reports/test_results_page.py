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


def test_the_network_orders_table_reads_both_orders_from_one_run_and_only_when_measured():
    streaming, live = _committed("streaming.json"), _committed("live.json")
    live["node_network_after_answer"]["all"]["p99_ms"] = 0.123456
    live["dds_network_after_answer"]["node_residence"]["p99_ms"] = 7.654321
    live["network_after_answer_accuracy"]["nrmse_percent"]["after_answer"][2] = 12.345
    text = latency(streaming, live)
    after = next(line for line in text.splitlines() if line.startswith("| after-answer |"))
    assert "/ 0.123 /" in after and "/ 7.654 /" in after
    accuracy = [line for line in text.splitlines() if line.startswith("| after-answer | ")][-1]
    assert accuracy.endswith("| 12.35 |")
    for key in ("dds_network_after_answer", "node_network_after_answer"):
        del live[key]   # a run made before the option existed
    del live["dds_busy_core_network_after_answer"], live["network_after_answer_accuracy"]
    assert "serve --network" not in latency(streaming, live)


def test_the_writes_share_of_the_residence_is_a_row_only_when_measured():
    streaming, live = _committed("streaming.json"), _committed("live.json")
    live["dds"]["node_residence_writes"] = {"median_ms": 0.25, "p99_ms": 0.5, "max_ms": 3.0}
    assert "| of which the four DDS writes per answer (the same answers) | p50 0.25 ms, p99 " \
           "0.50 ms, max 3.0 ms |" in latency(streaming, live)
    live["dds"].pop("node_residence_writes")
    assert "DDS writes per answer" not in latency(streaming, live)
