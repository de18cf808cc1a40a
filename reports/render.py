"""Blocks of the docs and the README, and whole result pages, rendered from committed result
JSONs, so that no figure a reader sees there is typed by hand.

    python -m reports            # rewrite every block and page from its JSON
    python -m reports --check    # exit 1 if a page differs from its JSON, write nothing

Each block sits between ``<!-- NAME: rendered by python -m reports -->`` and
``<!-- end NAME -->`` (:data:`BLOCKS`: page, JSON or tuple of JSONs, render function; one
module of render functions per page: :mod:`reports.readme_page`,
:mod:`reports.identification_page`, :mod:`reports.results_page`,
:mod:`reports.simulator_page`, :mod:`reports.ati_free_page`; a study that prints its own
table, ``--render-only``, keeps it, and its block calls it there, so studies never import
reports); nothing outside the markers is touched. :data:`WHOLE_PAGES` are rewritten whole.
Every block and page ends with a visible line naming its JSON and the command that wrote it
(:func:`source_line`), so a reader finds where a figure came from in one hop.
``tests/reports/test_rendered_docs.py`` holds every page equal to what its JSON renders.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from reports import ati_free_page  # noqa: E402
from reports import identification_page  # noqa: E402
from reports import integrity_page  # noqa: E402
from reports import readme_page  # noqa: E402
from reports import results_page  # noqa: E402
from reports import simulator_page  # noqa: E402
from psmforce.core.files import write_text_atomic  # noqa: E402

TRANSMISSION = ROOT / "results" / "benchmarks" / "transmission.json"
TRANSMISSION_TRANSFER = ROOT / "results" / "benchmarks" / "transmission_transfer.json"
TRANSMISSION_PITCH_WRAP = ROOT / "results" / "benchmarks" / "transmission_transfer_pitch_wrap.json"
TRANSMISSION_PITCH_WRAP_SYMMETRIC = (ROOT / "results" / "benchmarks"
                                     / "transmission_transfer_pitch_wrap_symmetric.json")
TRANSMISSION_LEARNED = ROOT / "results" / "benchmarks" / "transmission_transfer_learned.json"
TRANSMISSION_LEARNED_FILE = (ROOT / "results" / "benchmarks"
                             / "transmission_transfer_learned_file.json")
PRIOR_RECOVERY = ROOT / "results" / "benchmarks" / "prior_recovery.json"
PRIOR_ABLATION = ROOT / "results" / "benchmarks" / "prior_ablation.json"
PRIOR_RECOVERY_DEFAULT = ROOT / "results" / "benchmarks" / "prior_recovery_default.json"
PRIOR_RECOVERY_LOAD_PATH = ROOT / "results" / "benchmarks" / "prior_recovery_load_path.json"
PRIOR_DRAWN_TRACE = ROOT / "results" / "benchmarks" / "prior_recovery_drawn_trace.json"
PRIOR_RECOVERY_LOAD_PATH_LATERAL = (ROOT / "results" / "benchmarks"
                                    / "prior_recovery_load_path_lateral.json")
ATI_FREE_IDENTIFICATION_LATERAL = (ROOT / "results" / "benchmarks"
                                   / "ati_free_identification_lateral.json")
ATI_FREE_IDENTIFICATION = ROOT / "results" / "benchmarks" / "ati_free_identification.json"
LOAD_PATH_HOLDS = ROOT / "results" / "benchmarks" / "load_path_holds.json"
ATI_FREE_IDENTIFICATION_CHECKED = (ROOT / "results" / "benchmarks"
                                   / "ati_free_identification_checked.json")
ATI_FREE_IDENTIFICATION_BLIND_CHECKED = (ROOT / "results" / "benchmarks"
                                         / "ati_free_identification_blind_checked.json")
ATI_FREE_IDENTIFICATION_BLIND = (ROOT / "results" / "benchmarks"
                                 / "ati_free_identification_blind.json")
ATI_FREE_IDENTIFICATION_PAIRS = (ROOT / "results" / "benchmarks"
                                 / "ati_free_identification_pairs.json")
ATI_FREE_IDENTIFICATION_BLIND_PAIRS = (ROOT / "results" / "benchmarks"
                                       / "ati_free_identification_blind_pairs.json")
ATI_FREE_IDENTIFIED = ROOT / "results" / "benchmarks" / "ati_free_identified.json"
ATI_FREE_IDENTIFIED_PAIRS = ROOT / "results" / "benchmarks" / "ati_free_identified_pairs.json"
ATI_FREE_IDENTIFIED_FRESH = ROOT / "results" / "benchmarks" / "ati_free_identified_fresh.json"
ATI_FREE_UNRESOLVED = ROOT / "results" / "benchmarks" / "ati_free_unresolved.json"
ATI_FREE_NETWORK_OFF = ROOT / "results" / "benchmarks" / "ati_free_network_off.json"
ATI_FREE_PRIOR_ONLY = ROOT / "results" / "benchmarks" / "ati_free_prior_only.json"
ATI_FREE_NETWORK_PRIOR = ROOT / "results" / "benchmarks" / "ati_free_network_prior.json"
ATI_FREE_SELF_LOADING = ROOT / "results" / "benchmarks" / "ati_free_self_loading.json"
ATI_FREE_IDENTIFICATION_BLIND_PAIRS_CHECKED = (
    ROOT / "results" / "benchmarks" / "ati_free_identification_blind_pairs_checked.json")
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
NODE_AB = ROOT / "results" / "benchmarks" / "node_ab.json"
BUSY_POLL_AB = ROOT / "results" / "benchmarks" / "busy_poll_ab.json"
RESULTS = ROOT / "docs" / "results.md"
IDENTIFICATION = ROOT / "docs" / "identification.md"
README = ROOT / "README.md"
INTEGRITY = ROOT / "docs" / "integrity.md"
FUZZ = ROOT / "results" / "benchmarks" / "fuzz.json"
SIM_CABLE_LAW = ROOT / "results" / "benchmarks" / "sim_calibration_cable_law.json"
SIMULATOR = ROOT / "docs" / "simulator.md"
REMOUNT = ROOT / "results" / "benchmarks" / "remount.json"
REMOUNT_FRESH = ROOT / "results" / "benchmarks" / "remount_fresh.json"
ATI_FREE_RESULT = ROOT / "results" / "benchmarks" / "ati_free.json"
ATI_FREE_CROSSTALK = ROOT / "results" / "benchmarks" / "ati_free_crosstalk.json"
HEX10_COMPRESSION = ROOT / "results" / "benchmarks" / "hex10_compression.json"
EXCITATION = ROOT / "results" / "benchmarks" / "excitation.json"
EXCITATION_PAIRED = ROOT / "results" / "benchmarks" / "excitation_paired.json"
RECIPE_SWAP = ROOT / "results" / "benchmarks" / "recipe_swap.json"
BENCH_PAPER_CALIBRATION = ROOT / "results" / "benchmarks" / "bench_paper_calibration.json"
FRESH_COMPARISON = ROOT / "results" / "benchmarks" / "comparison.json"
BENCH_AGREEMENT = ROOT / "results" / "benchmarks" / "bench_agreement.json"
HYBRID_CALIBRATED_DESIGN = ROOT / "results" / "benchmarks" / "hybrid_calibrated_design.json"
HYBRID_WIDE_CONFIRM = ROOT / "results" / "benchmarks" / "hybrid_wide_confirm.json"
ATI_FREE = ROOT / "docs" / "ati_free.md"


WRITERS = {
    TRANSMISSION: "python studies/transmission.py --seeds 1 2 3 --jobs 2",
    PRIOR_RECOVERY: "python studies/prior_recovery.py",
    PRIOR_ABLATION: "python studies/prior_ablation.py",
    COMPARISON: "psmforce reproduce --port none",
    PORTS: "python studies/port_comparison.py",
    ANOTHER_TOOL: "python studies/another_tool.py",
    PORT_DESIGN: "python studies/hybrid_port_design.py",
    PORT_DESIGN_NOTCH: "python studies/hybrid_port_design.py",
    LEARNING_CURVE: "python studies/learning_curve.py",
    HYBRID_PLATEAU: "python studies/hybrid_plateau.py",
    TRAINING: "python benchmarks/training.py",
    TRAINING_CONVERGENCE: "python benchmarks/training.py --converge-scale 0.1",
    TRAINING_OPTIONS: "python benchmarks/training.py --speed-options",
    TRAINING_GPU: "python benchmarks/training.py (on a lent GPU)",
    STREAMING: "python benchmarks/streaming.py",
    LIVE: "python benchmarks/live.py",
    FUZZ: "python -m tests.robustness --json results/benchmarks/fuzz.json",
}
"""The script that writes each JSON a page renders, where the JSON does not record the command
it was written by (:func:`writer`)."""


def writer(path: Path, result: dict) -> str:
    """The command that wrote ``result`` (the JSON at ``path``): the one it records, with the
    script's path as it is today, else :data:`WRITERS`'s."""
    recorded = result.get("command") if isinstance(result, dict) else None
    if not isinstance(recorded, str):
        recorded = next((v["command"] for v in result.values()
                         if isinstance(v, dict) and isinstance(v.get("command"), str)), None)
    if isinstance(recorded, str):
        for old in ("benchmarks/", "tests/robustness/"):
            name = recorded.split(old, 1)[-1].split(" ", 1)[0] if old in recorded else None
            if name and not (ROOT / old / name).exists() and (ROOT / "studies" / name).exists():
                recorded = recorded.replace(old + name, "studies/" + name)
        return recorded
    if path not in WRITERS:
        raise SystemExit(f"{path.relative_to(ROOT)} records no command and WRITERS names none")
    return WRITERS[path]


def source_line(paths: tuple[Path, ...], results: list[dict]) -> str:
    """The visible line under a rendered block: its JSONs and the commands that wrote them."""
    parts = [f"`{p.relative_to(ROOT).as_posix()}` (written by `{writer(p, r)}`)"
             for p, r in zip(paths, results)]
    return f"<sub>Source: {'; '.join(parts)}; rendered by `python -m reports`.</sub>"


def _hybrid_plateau_table(result: dict) -> str:
    from studies.hybrid_plateau import table
    return "\n" + table(result) + "\n"


def _fresh_comparison_table(result: dict) -> str:
    from studies.comparison import table
    return table(result)


def _bench_agreement(result: dict) -> str:
    from studies.bench_agreement import summary
    return summary(result)


def _hybrid_calibrated_design_table(result: dict) -> str:
    from studies.hybrid_calibrated_design import table
    return table(result)


def _hybrid_wide_confirm_table(result: dict) -> str:
    from studies.hybrid_wide_confirm import table
    return table(result)


def _bench_paper_calibration_table(result: dict) -> str:
    from studies.bench_paper_calibration import table
    return table(result)


BLOCKS = (
    (README, "fresh-comparison", (FRESH_COMPARISON, BENCH_PAPER_CALIBRATION),
     readme_page.fresh_comparison),
    (README, "shipped-model", HYBRID_WIDE_CONFIRM, readme_page.shipped_model),
    (README, "transmission-summary", TRANSMISSION, readme_page.transmission_summary),
    (RESULTS, "prior-ablation-summary", PRIOR_ABLATION, results_page.prior_ablation_summary),
    (IDENTIFICATION, "prior-recovery-table", PRIOR_RECOVERY,
     identification_page.prior_recovery_table),
    (IDENTIFICATION, "prior-default-recovery-table", PRIOR_RECOVERY_DEFAULT,
     identification_page.prior_default_recovery_table),
    (IDENTIFICATION, "prior-load-path-recovery-table", PRIOR_RECOVERY_LOAD_PATH,
     identification_page.prior_default_recovery_table),
    (IDENTIFICATION, "prior-drawn-trace", PRIOR_DRAWN_TRACE,
     identification_page.prior_drawn_trace_table),
    (IDENTIFICATION, "prior-load-path-lateral",
     (PRIOR_RECOVERY_LOAD_PATH, PRIOR_RECOVERY_LOAD_PATH_LATERAL),
     identification_page.lateral_crosstalk_table),
    (IDENTIFICATION, "prior-load-path-lateral-table", PRIOR_RECOVERY_LOAD_PATH_LATERAL,
     identification_page.prior_default_recovery_table),
    (IDENTIFICATION, "transmission-tables", TRANSMISSION, identification_page.transmission_tables),
    (IDENTIFICATION, "transmission-transfer-tables", TRANSMISSION_TRANSFER,
     identification_page.transmission_transfer_tables),
    (IDENTIFICATION, "transmission-per-session", TRANSMISSION_TRANSFER,
     identification_page.transmission_per_session_table),
    (IDENTIFICATION, "transmission-pitch-wrap",
     (TRANSMISSION_TRANSFER, TRANSMISSION_PITCH_WRAP, TRANSMISSION_PITCH_WRAP_SYMMETRIC),
     identification_page.transmission_pitch_wrap_table),
    (IDENTIFICATION, "transmission-transfer-learned", TRANSMISSION_LEARNED,
     identification_page.transmission_transfer_learned_tables),
    (IDENTIFICATION, "transmission-transfer-learned-file", TRANSMISSION_LEARNED_FILE,
     identification_page.transmission_transfer_learned_tables),
    (RESULTS, "results-status",
     (LEARNING_CURVE, PRIOR_ABLATION, PORTS, COMPARISON, PORT_DESIGN, ANOTHER_TOOL),
     results_page.status),
    (RESULTS, "headline", LEARNING_CURVE, readme_page.headline),
    (RESULTS, "learning-curve", LEARNING_CURVE, results_page.learning_curve),
    (RESULTS, "bench-against-robot", LEARNING_CURVE, results_page.bench_against_robot),
    (RESULTS, "recipe-swap", RECIPE_SWAP, results_page.recipe_swap_tables),
    (RESULTS, "comparison-fresh-seeds", FRESH_COMPARISON, _fresh_comparison_table),
    (RESULTS, "bench-agreement", BENCH_AGREEMENT, _bench_agreement),
    (RESULTS, "hybrid-calibrated-design", HYBRID_CALIBRATED_DESIGN,
     _hybrid_calibrated_design_table),
    (RESULTS, "hybrid-wide-confirm", HYBRID_WIDE_CONFIRM, _hybrid_wide_confirm_table),
    (SIMULATOR, "bench-paper-calibration", BENCH_PAPER_CALIBRATION,
     _bench_paper_calibration_table),
    (ATI_FREE, "excitation-tables", EXCITATION, ati_free_page.excitation_tables),
    (ATI_FREE, "excitation-paired", EXCITATION_PAIRED, ati_free_page.excitation_paired_summary),
    (ATI_FREE, "remount-tables", REMOUNT, ati_free_page.remount_tables),
    (ATI_FREE, "remount-fresh-tables", REMOUNT_FRESH, ati_free_page.remount_tables),
    (ATI_FREE, "ati-free-tables", ATI_FREE_RESULT, ati_free_page.ati_free_tables),
    (ATI_FREE, "ati-free-crosstalk-tables", ATI_FREE_CROSSTALK, ati_free_page.ati_free_tables),
    (ATI_FREE, "ati-free-crosstalk-effect", (ATI_FREE_RESULT, ATI_FREE_CROSSTALK),
     ati_free_page.crosstalk_effect_table),
    (ATI_FREE, "ati-free-identified-tables", ATI_FREE_IDENTIFIED, ati_free_page.ati_free_tables),
    (ATI_FREE, "ati-free-identified-effect", ATI_FREE_IDENTIFIED,
     ati_free_page.identified_effect_table),
    (ATI_FREE, "ati-free-identified-pairs-effect", ATI_FREE_IDENTIFIED_PAIRS,
     ati_free_page.identified_effect_table),
    (ATI_FREE, "ati-free-unresolved-tables", ATI_FREE_UNRESOLVED, ati_free_page.ati_free_tables),
    (ATI_FREE, "ati-free-hold-rule",
     (ATI_FREE_UNRESOLVED, ATI_FREE_IDENTIFIED, ATI_FREE_IDENTIFIED_FRESH),
     ati_free_page.hold_rule_table),
    (ATI_FREE, "ati-free-network-off", ATI_FREE_NETWORK_OFF, ati_free_page.network_off_table),
    (ATI_FREE, "ati-free-prior-only", ATI_FREE_PRIOR_ONLY, ati_free_page.prior_only_table),
    (ATI_FREE, "ati-free-network-prior", ATI_FREE_NETWORK_PRIOR,
     ati_free_page.network_prior_table),
    (ATI_FREE, "ati-free-self-loading", ATI_FREE_SELF_LOADING,
     ati_free_page.self_loading_table),
    (ATI_FREE, "ati-free-self-offsets", ATI_FREE_SELF_LOADING,
     ati_free_page.self_offsets_table),
    (ATI_FREE, "ati-free-self-least", ATI_FREE_SELF_LOADING,
     ati_free_page.self_least_table),
    (ATI_FREE, "instrument-identification-tables", ATI_FREE_IDENTIFICATION,
     ati_free_page.instrument_identification_tables),
    (ATI_FREE, "load-path-holds", LOAD_PATH_HOLDS, ati_free_page.load_path_holds_table),
    (ATI_FREE, "instrument-identification-blind", ATI_FREE_IDENTIFICATION_BLIND,
     ati_free_page.instrument_identification_tables),
    (ATI_FREE, "instrument-identification-lateral",
     (ATI_FREE_IDENTIFICATION, ATI_FREE_IDENTIFICATION_BLIND, ATI_FREE_IDENTIFICATION_LATERAL),
     identification_page.lateral_crosstalk_table),
    (ATI_FREE, "instrument-identification-held-check",
     (ATI_FREE_IDENTIFICATION_CHECKED, ATI_FREE_IDENTIFICATION),
     ati_free_page.held_values_check_table),
    (ATI_FREE, "instrument-identification-held-check-blind",
     (ATI_FREE_IDENTIFICATION_BLIND_CHECKED, ATI_FREE_IDENTIFICATION_BLIND),
     ati_free_page.held_values_check_table),
    (ATI_FREE, "instrument-identification-sign-pairs",
     (ATI_FREE_IDENTIFICATION_PAIRS, ATI_FREE_IDENTIFICATION),
     ati_free_page.sign_pair_jackknife_table),
    (ATI_FREE, "instrument-identification-sign-pairs-blind",
     (ATI_FREE_IDENTIFICATION_BLIND_PAIRS, ATI_FREE_IDENTIFICATION_BLIND),
     ati_free_page.sign_pair_jackknife_table),
    (ATI_FREE, "instrument-identification-both-guards-blind",
     (ATI_FREE_IDENTIFICATION_BLIND_PAIRS_CHECKED, ATI_FREE_IDENTIFICATION_BLIND_PAIRS),
     ati_free_page.both_guards_table),
    (ATI_FREE, "hex10-compression", HEX10_COMPRESSION, ati_free_page.hex10_compression_table),
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
    (RESULTS, "node-ab", NODE_AB, results_page.node_ab),
    (RESULTS, "busy-poll-ab", BUSY_POLL_AB, results_page.busy_poll_ab),
    (RESULTS, "status-table", COMPARISON, readme_page.status_table),
    (INTEGRITY, "fuzz-counts", FUZZ, integrity_page.fuzz_counts),
    (SIMULATOR, "cable-law-tables", SIM_CABLE_LAW, simulator_page.cable_law_tables),
)


def _run_page(result: dict) -> str:
    from psmforce.estimators.evaluation.tables import results_markdown
    return results_markdown(result)


def _learning_curve_page(result: dict) -> str:
    from studies.learning_curve import table
    return table(result)


WHOLE_PAGES = tuple(
    [(ROOT / "results" / run / "results.md", ROOT / "results" / run / "results.json", _run_page)
     for run in ("ports/none", "ports/cannula", "ports/abdominal-wall",
                 "history/previous_hybrid")]
    + [(LEARNING_CURVE.parent / "README.md", LEARNING_CURVE, _learning_curve_page)])
"""Pages rendered whole from one JSON: each committed run's page, and the learning curve's
table (its figures are drawn by ``studies/learning_curve.py --render-only``). Run D's page
is not here: its JSON predates today's format, and the page is the run's own output."""


def markers(name: str) -> tuple[str, str]:
    return f"<!-- {name}: rendered by python -m reports -->", f"<!-- end {name} -->"


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
        body = render(*found).rstrip("\n") + "\n\n" + source_line(block_jsons(json_paths), found)
        out[doc] = splice(out.get(doc, doc.read_text()), name, body + "\n")
    for doc, json_path, render in WHOLE_PAGES:
        found = (results or {}).get(json_path) or json.loads(json_path.read_text())
        out[doc] = render(found).rstrip("\n") + "\n\n" + source_line((json_path,), [found]) + "\n"
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
                  "python -m reports")
        return 1 if stale else 0
    for p in stale:
        write_text_atomic(p, rendered[p])
    return 0


if __name__ == "__main__":
    sys.exit(main())
