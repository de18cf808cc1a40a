"""The blocks of ``docs/integrity.md``, rendered from the robustness run's JSON."""

from __future__ import annotations

from collections import Counter


def fuzz_counts(result: dict) -> str:
    """The robustness run: how many cases, each verdict's count, and the cases per kind of
    input, with any case that did not get its expected verdict named."""
    counts = result["counts"]
    rows = result["cases"]
    lines = ["", f"{len(rows)} cases: " + ", ".join(f"{v} {n}" for v, n in counts.items())
             + f"; {result['unexpected']} with a verdict other than the one it expects.", "",
             "| input | cases | REJECTED | HANDLED | other |", "|---|---|---|---|---|"]
    kinds = Counter(r["kind"].split(":")[0] for r in rows)
    for kind in sorted(kinds):
        mine = [r for r in rows if r["kind"].split(":")[0] == kind]
        other = [r for r in mine if r["verdict"] not in ("REJECTED", "HANDLED")]
        lines.append(f"| {kind} | {len(mine)} | "
                     f"{sum(r['verdict'] == 'REJECTED' for r in mine)} | "
                     f"{sum(r['verdict'] == 'HANDLED' for r in mine)} | "
                     + (", ".join(f"{r['verdict']}: {r['case']}" for r in other) or "none")
                     + " |")
    return "\n".join(lines) + "\n"
