"""``python -m tests.robustness``: every robustness case, classified (the package docstring);
prints the counts and the cases that are not as expected, writes the JSON, exits 1 on any
SILENT, UNCLEAR, CRASH, ESCAPE or LOSS case or any verdict other than the expected one."""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

import torch  # noqa: E402

from psmforce.experiments.report import write_json  # noqa: E402
from tests.robustness.cases import all_cases  # noqa: E402
from tests.robustness.harness import EXPECTED, FAILING, SCALE, Shared, run_case  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the table here")
    parser.add_argument("--only", help="run the cases whose kind or name contains this")
    args = parser.parse_args()
    torch.set_num_threads(1)
    selected = [c for c in all_cases() if not args.only or args.only in f"{c.kind}: {c.name}"]
    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        shared = Shared(root / "inputs")
        setup_s = time.perf_counter() - started
        for k, case in enumerate(selected):
            outcome = run_case(case, shared, root / "cases" / f"{k:03d}")
            rows.append({"kind": case.kind, "case": case.name, "expected": case.expect,
                         "verdict": outcome.verdict, "detail": outcome.detail.replace(tmp, "TMP"),
                         "seconds": round(outcome.seconds, 3)})
    counts = Counter(r["verdict"] for r in rows)
    unexpected = [r for r in rows if r["verdict"] != r["expected"]]
    print(f"{len(rows)} cases in {time.perf_counter() - started:.0f} s (inputs {setup_s:.0f} s): "
          + ", ".join(f"{v} {counts.get(v, 0)}" for v in EXPECTED + FAILING))
    for r in rows:
        if r["verdict"] not in EXPECTED or r["verdict"] != r["expected"]:
            print(f"  {r['verdict']:8} (expected {r['expected']}) {r['kind']}: {r['case']}\n"
                  f"           {r['detail'][:400]}")
    if args.json:
        write_json(args.json, {"machine": platform.platform(), "scale": SCALE,
                               "counts": {v: counts.get(v, 0) for v in EXPECTED + FAILING},
                               "unexpected": len(unexpected), "cases": rows})
    failed = any(r["verdict"] in FAILING for r in rows) or unexpected
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
