"""reports/results_page.py: blocks whose sentences are computed from their JSON."""

import json
from pathlib import Path

from reports.results_page import busy_poll_ab, latency

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


def test_the_floor_table_reads_the_floor_runs_beside_the_node_and_only_when_measured():
    streaming, live = _committed("streaming.json"), _committed("live.json")
    live["dds_floor_realtime"]["node_residence"]["p99_ms"] = 0.0987
    live["dds_realtime_network_after_answer"]["node_residence"]["p99_ms"] = 0.8766
    live["node_network_after_answer_paced"]["all"]["median_ms"] = \
        3 * live["node_network_after_answer"]["all"]["median_ms"]
    text = latency(streaming, live).splitlines()
    floor = next(line for line in text if line.startswith("| no estimator (the floor), SCHED"))
    node = next(line for line in text if line.startswith("| `serve`, network after the answer, S"))
    assert "/ 0.099 /" in floor
    assert "/ 0.877 /" in node
    assert any("(3.0x at the median; woken from sleep" in line for line in text)
    del live["node_network_after_answer_paced"]
    assert not any("at the median; woken" in line for line in latency(streaming, live).splitlines())
    del live["dds_floor"], live["dds_floor_realtime"]   # a run made before the floor
    assert "no estimator (the floor)" not in latency(streaming, live)


def test_the_busy_poll_rows_read_their_runs_and_only_when_measured():
    import copy
    streaming, live = _committed("streaming.json"), _committed("live.json")
    quiet, busy = ("dds_busy_poll_network_after_answer",
                   "dds_busy_core_busy_poll_network_after_answer")
    live[quiet] = copy.deepcopy(live["dds_network_after_answer"])
    live[busy] = copy.deepcopy(live["dds_busy_core_network_after_answer"])
    live[quiet]["node_residence"]["p99_ms"] = 0.2345
    live[busy]["node_added_latency"]["p99_ms"] = 4.321
    text = latency(streaming, live).splitlines()
    head = "| `serve --busy-poll`, network after the answer, normal"
    assert "/ 0.234 /" in next(line for line in text if line.startswith(head + " |"))
    assert "/ 4.321 /" in next(line for line in text
                               if line.startswith(head + ", one core busy |"))
    del live[quiet], live[busy]   # a run made before the option
    assert "--busy-poll" not in latency(streaming, live)


def test_the_writes_share_of_the_residence_is_a_row_only_when_measured():
    streaming, live = _committed("streaming.json"), _committed("live.json")
    live["dds"]["node_residence_writes"] = {"median_ms": 0.25, "p99_ms": 0.5, "max_ms": 3.0}
    assert "| of which the four DDS writes per answer (the same answers) | p50 0.25 ms, p99 " \
           "0.50 ms, max 3.0 ms |" in latency(streaming, live)
    live["dds"].pop("node_residence_writes")
    assert "DDS writes per answer" not in latency(streaming, live)


def test_the_scheduling_table_reads_each_run_marks_the_goal_and_says_when_refused():
    import copy
    streaming, live = _committed("streaming.json"), _committed("live.json")
    for key in [k for k in live if "realtime" in k]:
        del live[key]
    assert "serve --rt-priority" not in latency(streaming, live)   # a run made before it
    for key in ("dds", "dds_busy_core", "dds_network_after_answer",
                "dds_busy_core_network_after_answer"):
        run = copy.deepcopy(live[key])
        run["scheduling"] = "SCHED_FIFO 50"
        live[key.replace("dds", "dds_realtime", 1).replace("dds_realtime_busy_core",
                                                             "dds_busy_core_realtime")] = run
    live["dds_realtime"]["node_residence"] = {"median_ms": 0.1, "p99_ms": 0.25, "max_ms": 1.0}
    live["dds_busy_core_realtime"]["node_residence"] = {"median_ms": 0.1, "p99_ms": 0.35,
                                                        "max_ms": 1.0}
    rows = {line.split(" | ")[0]: line for line in latency(streaming, live).splitlines()
            if line.startswith("| SCHED_FIFO 50, ") or line.startswith("| normal, ")}
    assert len(rows) == 4
    fifo = rows["| SCHED_FIFO 50, before-answer"]
    assert "| 0.100 / 0.250 / 1.00 (goal met) |" in fifo          # 0.25 <= 0.3
    assert "| 0.100 / 0.350 / 1.00 |" in fifo                      # 0.35 > 0.3: no mark
    live = {k: v for k, v in live.items() if "realtime" not in k}
    live["realtime_refused"] = "the system refused real-time priority 50 (Operation not permitted)"
    assert ("`serve --rt-priority` was not measured: the system refused real-time priority 50"
            in latency(streaming, live))


def test_the_busy_poll_table_reads_each_ways_rounds_and_the_paired_ratios():
    def run(p99, lost=0):
        t = {"median_ms": 0.1, "p99_ms": p99, "max_ms": 2.0}
        return {"node_residence": t, "node_added_latency": t, "transport_latency": t,
                "node_lost": lost, "hex10_sent": 1000, "node_cpu_fraction": 0.5}
    result = {"command": "python benchmarks/busy_poll_ab.py", "rounds": 3, "seconds": 20,
              "checkpoint": "a hybrid", "machine": {"cpus": 2}, "realtime_refused": "no rtprio",
              "runs": {"sleeping": [run(0.4), run(0.8), run(0.6, lost=2)],
                       "busy_poll": [run(0.2), run(0.3), run(0.9)]},
              "ratios": {"busy_poll / sleeping": {
                  f"{f} {s}": {"per_round": [0.5, 0.375, 1.5], "median": 0.5}
                  for f in ("node_residence", "node_added_latency")
                  for s in ("median_ms", "p99_ms")}}}
    text = busy_poll_ab(result).splitlines()
    sleeping = next(line for line in text if line.startswith("| asleep between messages, normal"))
    assert "| 0.100 / 0.600 |" in sleeping and "| 2 of 3,000 |" in sleeping
    polling = next(line for line in text if line.startswith("| `--busy-poll`, normal"))
    assert "| 0.100 / 0.300 |" in polling
    ratio = next(line for line in text if line.startswith("| polling over asleep"))
    assert ratio.count("0.50 [0.50, 0.38, 1.50]") == 4
    assert any("SCHED_FIFO was not measured: no rtprio" in line for line in text)
