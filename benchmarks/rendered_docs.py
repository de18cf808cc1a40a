"""Blocks of the docs and the README, and whole result pages, rendered from committed result
JSONs, so that no figure a reader sees there is typed by hand.

    python benchmarks/rendered_docs.py            # rewrite every block from its JSON
    python benchmarks/rendered_docs.py --check    # exit 1 if a page differs from its JSON

Each block sits between ``<!-- NAME: rendered by benchmarks/rendered_docs.py -->`` and
``<!-- end NAME -->`` (:data:`BLOCKS`: page, JSON or tuple of JSONs, render function; one
module of render functions per page: :mod:`benchmarks._readme_page`,
:mod:`benchmarks._identification_page`, :mod:`benchmarks._results_page`); nothing outside the
markers is touched. :data:`WHOLE_PAGES` are rewritten whole.
``tests/test_rendered_docs.py`` holds every page equal to what its JSON renders.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks import _identification_page as identification_page  # noqa: E402
from benchmarks import _readme_page as readme_page  # noqa: E402
from benchmarks import _results_page as results_page  # noqa: E402
from psm_model.files import write_text_atomic  # noqa: E402

TRANSMISSION = ROOT / "results" / "benchmarks" / "transmission.json"
PRIOR_RECOVERY = ROOT / "results" / "benchmarks" / "prior_recovery.json"
PRIOR_ABLATION = ROOT / "results" / "benchmarks" / "prior_ablation.json"
COMPARISON = ROOT / "results" / "ports" / "none" / "results.json"
PORTS = ROOT / "results" / "benchmarks" / "port_comparison.json"
ANOTHER_TOOL = ROOT / "results" / "benchmarks" / "another_tool.json"
PORT_DESIGN = ROOT / "results" / "benchmarks" / "hybrid_port_design.json"
LEARNING_CURVE = ROOT / "results" / "learning_curve" / "learning_curve.json"
HYBRID_PLATEAU = ROOT / "results" / "benchmarks" / "hybrid_plateau.json"
PORT_DESIGN_NOTCH = ROOT / "results" / "benchmarks" / "hybrid_port_design_notch.json"
TRAINING = ROOT / "results" / "benchmarks" / "training.json"
TRAINING_CONVERGENCE = ROOT / "results" / "benchmarks" / "training_convergence.json"
TRAINING_OPTIONS = ROOT / "results" / "benchmarks" / "training_speed_options.json"
TRAINING_GPU = ROOT / "results" / "benchmarks" / "training_gpu.json"
STREAMING = ROOT / "results" / "benchmarks" / "streaming.json"
LIVE = ROOT / "results" / "benchmarks" / "live.json"
RESULTS = ROOT / "docs" / "results.md"
IDENTIFICATION = ROOT / "docs" / "identification.md"
README = ROOT / "README.md"


def _hybrid_plateau_table(result: dict) -> str:
    from benchmarks.hybrid_plateau import table
    return "\n" + table(result) + "\n"


BLOCKS = (
    (README, "status-table", COMPARISON, readme_page.status_table),
    (README, "current-bench-summary", LEARNING_CURVE, readme_page.current_bench_summary),
    (README, "transmission-summary", TRANSMISSION, readme_page.transmission_summary),
    (README, "prior-ablation-summary", PRIOR_ABLATION, readme_page.prior_ablation_summary),
    (IDENTIFICATION, "prior-recovery-table", PRIOR_RECOVERY,
     identification_page.prior_recovery_table),
    (IDENTIFICATION, "transmission-tables", TRANSMISSION, identification_page.transmission_tables),
    (RESULTS, "results-status",
     (LEARNING_CURVE, PRIOR_ABLATION, PORTS, COMPARISON, PORT_DESIGN, ANOTHER_TOOL),
     results_page.status),
    (RESULTS, "learning-curve", LEARNING_CURVE, results_page.learning_curve),
    (RESULTS, "hybrid-plateau", HYBRID_PLATEAU, _hybrid_plateau_table),
    (RESULTS, "prior-ablation-tables", PRIOR_ABLATION, results_page.prior_ablation_tables),
    (RESULTS, "ports-table", PORTS, results_page.ports_table),
    (RESULTS, "ports-findings", (PORTS, COMPARISON), results_page.ports_findings),
    (RESULTS, "port-design-table", PORT_DESIGN, results_page.port_design_table),
    (RESULTS, "port-design-findings", (PORT_DESIGN, PORT_DESIGN_NOTCH),
     results_page.port_design_findings),
    (RESULTS, "axial-channels-table", PORTS, results_page.axial_channels_table),
    (RESULTS, "axial-findings", PORTS, results_page.axial_findings),
    (RESULTS, "another-tool-table", ANOTHER_TOOL, results_page.another_tool_table),
    (RESULTS, "another-tool-findings", ANOTHER_TOOL, results_page.another_tool_findings),
    (RESULTS, "training-speed", (TRAINING, TRAINING_CONVERGENCE, TRAINING_OPTIONS),
     results_page.training_speed),
    (RESULTS, "training-gpu", TRAINING_GPU, results_page.training_gpu),
    (RESULTS, "latency", (STREAMING, LIVE), results_page.latency),
)


def _run_page(result: dict) -> str:
    from hybrid.tables import results_markdown
    return results_markdown(result)


def _learning_curve_page(result: dict) -> str:
    from benchmarks.learning_curve import table
    return table(result)


WHOLE_PAGES = tuple(
    [(ROOT / "results" / run / "results.md", ROOT / "results" / run / "results.json", _run_page)
     for run in ("ports/none", "ports/cannula", "ports/abdominal-wall",
                 "history/previous_hybrid")]
    + [(LEARNING_CURVE.parent / "README.md", LEARNING_CURVE, _learning_curve_page)])
"""Pages rendered whole from one JSON: each committed run's page, and the learning curve's
table (its figures are drawn by ``benchmarks/learning_curve.py --render-only``). Run D's page
is not here: its JSON predates today's format, and the page is the run's own output."""


def markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}: rendered by benchmarks/rendered_docs.py -->", f"<!-- end {name} -->"


def splice(doc: str, name: str, body: str) -> str:
    """``doc`` with block ``name``'s content replaced by ``body``."""
    begin, end = markers(name)
    if doc.count(begin) != 1 or doc.count(end) != 1:
        raise SystemExit(f"expected one '{begin}' and one '{end}' marker")
    head, rest = doc.split(begin)
    return head + begin + body + end + rest.split(end, 1)[1]


def pages(results: dict[Path, dict] | None = None) -> dict[Path, str]:
    """Each page with every block rendered from its JSON (``results`` overrides a JSON's
    content, for tests)."""
    out: dict[Path, str] = {}
    for doc, name, json_paths, render in BLOCKS:
        found = [(results or {}).get(p) or json.loads(p.read_text())
                 for p in block_jsons(json_paths)]
        out[doc] = splice(out.get(doc, doc.read_text()), name, render(*found))
    for doc, json_path, render in WHOLE_PAGES:
        out[doc] = render((results or {}).get(json_path) or json.loads(json_path.read_text()))
    return out


def block_jsons(json_paths: Path | tuple[Path, ...]) -> tuple[Path, ...]:
    """A block's JSONs: one path, or a tuple when it renders from several."""
    return json_paths if isinstance(json_paths, tuple) else (json_paths,)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="compare, write nothing")
    args = ap.parse_args(argv)
    rendered = pages()
    stale = [p for p, text in rendered.items() if text != p.read_text()]
    if args.check:
        for p in stale:
            print(f"{p.relative_to(ROOT)} differs from what its JSON renders: rerun "
                  "benchmarks/rendered_docs.py")
        return 1 if stale else 0
    for p in stale:
        write_text_atomic(p, rendered[p])
    return 0


if __name__ == "__main__":
    sys.exit(main())
