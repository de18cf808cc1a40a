"""The live node's time per HEX10 message, this checkout against an earlier revision, in one run.

    python benchmarks/node_ab.py --before REV [--pairs 7] [--busy-pairs 2] [--json OUT.json]

A speed claim on a shared machine holds as a ratio measured in one run, not as two absolute
figures from different days: the host's speed moves between runs by more than a change does.
``--before`` is exported (``git archive``) into a temporary folder, and each of ``--pairs``
rounds runs :func:`benchmarks.live.node_figures` (the shipped bench checkpoint at 1 kHz, the
simulated robot's recording, :class:`psmforce.live.node.ForceNode` in process) in a fresh
process on the earlier revision, then on this checkout, two measurements each. Per split (all
messages, network steps, physics and filter only): each side's median over its runs of the
median and p99 per message (wall and thread CPU time), and the median of the ratios
this / before taken pair by pair (the pairs share the host's state of the moment).

Then, ``--busy-pairs`` rounds of the node over DDS with one core busy
(:func:`benchmarks.live.dds_figures`, :data:`BUSY_SECONDS` at 1 kHz, a hybrid trained once here
as ``benchmarks/live.py`` trains it), alternating the two revisions the same way: whether the
node keeps up when it shares the cores (the transport alone beside it, measured in the same run).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPLITS = ("all", "network_steps", "physics_and_filter_only")
STATS = {"median_ms": ("median_ms",), "p99_ms": ("p99_ms",),
         "cpu_median_ms": ("cpu", "median_ms"), "cpu_p99_ms": ("cpu", "p99_ms")}
MEASUREMENTS = 2
"""node_figures runs per process (the first warms nothing up between them: each is a fresh
node over the whole recording)."""

BUSY_SECONDS = 20.0
BUSY_FIGURES = ("latency", "node_residence", "transport_latency")

_CHILD = """
import json, sys, tempfile
from pathlib import Path
sys.path.insert(0, {benchmarks!r})
import torch
torch.set_num_threads(1)
import live
import psmforce
from psmforce.live.bench_model import shipped_checkpoint
from psmforce.live.sim_robot import bench_recording
frame = bench_recording(1000.0)
if {busy_checkpoint!r} is None:
    runs = [live.node_figures(shipped_checkpoint(), frame) for _ in range({n})]
else:
    with tempfile.TemporaryDirectory() as tmp:
        runs = [live.dds_figures(Path({busy_checkpoint!r}), frame, {seconds!r}, Path(tmp),
                                 busy_core=True)]
print(json.dumps({{"package": psmforce.__file__, "runs": runs}}))
"""


def _export(rev: str, into: Path) -> str:
    """The ``psmforce`` package of ``rev`` unpacked under ``into``; its full commit hash."""
    commit = subprocess.run(["git", "rev-parse", "--verify", f"{rev}^{{commit}}"], cwd=ROOT,
                            capture_output=True, text=True)
    if commit.returncode:
        raise SystemExit(f"--before {rev}: not a revision of this repository "
                         f"({commit.stderr.strip()})")
    archive = into / "before.tar"
    subprocess.run(["git", "archive", "--format=tar", "-o", str(archive), commit.stdout.strip(),
                    "psmforce"], cwd=ROOT, check=True)
    with tarfile.open(archive) as tar:  # the data filter where this Python has it (3.11.4+)
        tar.extractall(into, **({"filter": "data"} if hasattr(tarfile, "data_filter") else {}))
    return commit.stdout.strip()


def _measure(package_root: Path | None, busy_checkpoint: Path | None = None) -> list[dict]:
    """node_figures (with ``busy_checkpoint``: dds_figures with a core busy) in a fresh process,
    importing psmforce from ``package_root`` (None: this checkout), as does the node it starts."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    if package_root is not None:
        env["PYTHONPATH"] = str(package_root)
    code = _CHILD.format(benchmarks=str(ROOT / "benchmarks"), n=MEASUREMENTS,
                         busy_checkpoint=None if busy_checkpoint is None else str(busy_checkpoint),
                         seconds=BUSY_SECONDS)
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          cwd=package_root or ROOT)
    if done.returncode:
        raise SystemExit(f"node_figures failed:\n{done.stderr[-2000:]}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    where = Path(out["package"]).resolve()
    expected = (package_root or ROOT).resolve()
    if expected not in where.parents:  # the revision must be the code that ran
        raise SystemExit(f"measured {where}, expected a package under {expected}")
    return out["runs"]


def _stat(run: dict, split: str, path: tuple[str, ...]) -> float:
    value = run[split]
    for key in path:
        value = value[key]
    return float(value)


def main() -> tuple[dict, str | None]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="the revision to compare against")
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--busy-pairs", type=int, default=2)
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.pairs < 1 or args.busy_pairs < 0:
        raise SystemExit(f"--pairs must be at least 1 and --busy-pairs at least 0, got "
                         f"{args.pairs} and {args.busy_pairs}")
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True,
                          text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "status", "--porcelain", "psmforce"], cwd=ROOT,
                                capture_output=True, text=True).stdout.strip())
    runs = {"before": [], "this": []}
    busy = {"before": [], "this": []}
    with tempfile.TemporaryDirectory() as tmp:
        before = _export(args.before, Path(tmp))
        for k in range(args.pairs):
            runs["before"] += _measure(Path(tmp))
            runs["this"] += _measure(None)
            print(f"pair {k + 1}/{args.pairs} done", flush=True)
        if args.busy_pairs:
            sys.path.insert(0, str(ROOT / "benchmarks"))
            from live import _checkpoint  # the hybrid benchmarks/live.py trains, here
            checkpoint, what = _checkpoint(Path(tmp) / "trained")
            for k in range(args.busy_pairs):
                busy["before"] += _measure(Path(tmp), checkpoint)
                busy["this"] += _measure(None, checkpoint)
                print(f"busy pair {k + 1}/{args.busy_pairs} done", flush=True)
    result = {"command": f"python benchmarks/node_ab.py --before {args.before} --pairs "
                         f"{args.pairs} --busy-pairs {args.busy_pairs}"
                         + (f" --json {args.json}" if args.json else ""),
              "before": before, "this": head + (" with uncommitted changes" if dirty else ""),
              "pairs": args.pairs, "measurements_per_process": MEASUREMENTS,
              "machine": {"cpus": os.cpu_count(), "load_average": list(os.getloadavg())},
              "splits": {}}
    for split in SPLITS:
        result["splits"][split] = {}
        for name, path in STATS.items():
            b = np.array([_stat(r, split, path) for r in runs["before"]])
            t = np.array([_stat(r, split, path) for r in runs["this"]])
            result["splits"][split][name] = {"before": float(np.median(b)),
                                             "this": float(np.median(t)),
                                             "ratio": float(np.median(t / b))}
    if args.busy_pairs:
        result["busy_core"] = {
            "checkpoint": what, "seconds": BUSY_SECONDS,
            **{side: [{"sent": r["hex10_sent"], "node_lost": r["node_lost"],
                       **{f: {k: r[f][k] for k in ("median_ms", "p99_ms", "max_ms")}
                          for f in BUSY_FIGURES}} for r in busy[side]]
               for side in ("before", "this")}}
    return result, args.json


if __name__ == "__main__":
    result, path = main()
    for split, stats in result["splits"].items():
        print(f"{split:24s} " + "; ".join(f"{n} {s['before']:.3f} -> {s['this']:.3f} "
                                          f"({s['ratio']:.2f}x)" for n, s in stats.items()))
    for side in ("before", "this"):
        for r in result.get("busy_core", {}).get(side, []):
            print(f"busy core, {side}: " + "; ".join(
                f"{f} p50 {r[f]['median_ms']:.3g} / p99 {r[f]['p99_ms']:.3g} ms"
                for f in BUSY_FIGURES) + f"; lost {r['node_lost']}")
    if path:
        sys.path.insert(0, str(ROOT))
        from psmforce.experiments.report import write_json
        write_json(path, result)
