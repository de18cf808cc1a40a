"""``serve --busy-poll`` against the node that sleeps between messages, alternating in one run.

    python benchmarks/busy_poll_ab.py [--rounds 3] [--seconds 20] [--json OUT.json]

A latency claim on a shared machine holds as a ratio measured in one run, not as two absolute
figures from different days (``benchmarks/node_ab.py`` says why). Each round runs
:func:`benchmarks.live.dds_figures` (robot, node and subscriber in three processes over DDS on
loopback, 1 kHz, the network after the answer, a hybrid trained here as ``benchmarks/live.py``
trains it) once per way of waiting, in an order rotated from round to round so that none is
always first:

* ``sleeping``: the node as a normal process, asleep in the wait set between messages;
* ``sleeping_realtime``: the same under SCHED_FIFO (``serve --rt-priority``
  :data:`benchmarks.live.RT_PRIORITY`), left out with the one line where the system refuses it;
* ``busy_poll``: ``serve --busy-poll``, a normal process (with SCHED_FIFO it is refused).

Writes, per way and round, the node's residence, its added latency and the transport alone
(p50 / p99 / max, ms), the messages it lost and its CPU use; and per pair of ways, the ratios
``busy_poll`` over each other way of the residence's and the added latency's p50 and p99, each
round's ratio and their median, the figure that carries over to another machine.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from psmforce.experiments.report import write_json  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import live  # noqa: E402

WAYS = {"sleeping": {}, "sleeping_realtime": {"rt_priority": live.RT_PRIORITY},
        "busy_poll": {"busy_poll": True}}
"""Each way of waiting: the keyword arguments of :func:`benchmarks.live.dds_figures`."""
FIGURES = ("node_residence", "node_added_latency", "transport_latency")
STATS = ("median_ms", "p99_ms")


def _kept(r: dict) -> dict:
    return {**{f: {k: r[f][k] for k in ("median_ms", "p99_ms", "max_ms")} for f in FIGURES},
            "node_lost": r["node_lost"], "hex10_sent": r["hex10_sent"],
            "node_cpu_fraction": r["node_cpu_fraction"], "scheduling": r["scheduling"]}


def ratios(runs: dict, a: str, b: str) -> dict:
    """``a`` over ``b`` per round (the rounds pair them) and the median of those, per figure
    and statistic; a round whose ``b`` figure is 0 (below the clocks' resolution) has no ratio
    (None), and the median is over the rounds that have one (None if none has)."""
    out = {}
    for f in FIGURES[:2]:
        for s in STATS:
            per_round = [x[f][s] / y[f][s] if y[f][s] > 0 else None
                         for x, y in zip(runs[a], runs[b], strict=True)]
            defined = [r for r in per_round if r is not None]
            out[f"{f} {s}"] = {"per_round": per_round,
                               "median": float(np.median(defined)) if defined else None}
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    if args.rounds < 1 or not 1.0 <= args.seconds <= 600.0:
        ap.error("--rounds at least 1, --seconds in [1, 600]")
    import torch
    torch.set_num_threads(1)
    from psmforce.live.sim_robot import bench_recording
    refused = live.realtime_refusal()
    ways = [w for w in WAYS if not (refused and w == "sleeping_realtime")]
    runs: dict[str, list] = {w: [] for w in ways}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ckpt, label = live._checkpoint(tmp)
        frame = bench_recording(1000.0)
        for k in range(args.rounds):
            for way in ways[k % len(ways):] + ways[:k % len(ways)]:
                r = live.dds_figures(ckpt, frame, args.seconds, tmp, network="after-answer",
                                     **WAYS[way])
                runs[way].append(_kept(r))
                print(f"round {k + 1} {way}: residence p99 {r['node_residence']['p99_ms']:.3f}"
                      f" ms, added p99 {r['node_added_latency']['p99_ms']:.3f} ms, lost "
                      f"{r['node_lost']}", flush=True)
    result = {"command": "python benchmarks/busy_poll_ab.py --rounds "
                         f"{args.rounds} --seconds {args.seconds:g}"
                         + (f" --json {args.json}" if args.json else ""),
              "machine": {"platform": platform.platform(), "cpus": os.cpu_count(),
                          "load_average_after": list(os.getloadavg())},
              "checkpoint": label, "seconds": args.seconds, "rounds": args.rounds,
              "network": "after-answer", "realtime_refused": refused, "runs": runs,
              "ratios": {f"busy_poll / {w}": ratios(runs, "busy_poll", w)
                         for w in ways if w != "busy_poll"}}
    if args.json:
        write_json(args.json, result)
    return result


if __name__ == "__main__":
    main()
