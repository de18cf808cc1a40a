"""The README's first screen (reports/readme_page.py)."""

from __future__ import annotations

import json
from pathlib import Path

from reports import readme_page

ROOT = Path(__file__).resolve().parents[2]


def test_the_calibration_sentence_marks_the_ratios_against_a_figure_no_publication_gives(
        monkeypatch):
    """Which robot figure is the paper's is one rule (studies.bench_paper_calibration.published),
    not the JSON's wording read again."""
    calibration = json.loads((ROOT / "results/benchmarks/bench_paper_calibration.json")
                             .read_text())
    version = next(r["candidate"] for r in calibration["rows"]
                   if r["paper_budget"] and r["model"] == "rocket")
    marked = " (against the issue's figure, which no publication gives)"
    text = readme_page._bench_over_robot(calibration, version)
    assert text.count(marked) == 1 and "MultiRocket-Hydra " in text.split(marked)[0]
    monkeypatch.setattr(readme_page, "published", lambda model: model != "fcn")
    text = readme_page._bench_over_robot(calibration, version)
    assert text.count(marked) == 1
    assert text.index("FCN ") < text.index(marked) < text.index("MultiRocket-Hydra ")
