"""The figures a reader sees in the rendered blocks (docs/identification.md, the README) are
their committed JSONs', rendered; the JSONs name no machine's absolute path."""

from __future__ import annotations

import copy
import importlib.util
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("rendered_docs",
                                               ROOT / "reports" / "render.py")
rendered = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rendered)


def test_pages_are_what_their_jsons_render():
    for page, text in rendered.pages().items():
        assert page.read_text() == text, (f"{page.relative_to(ROOT)} differs from its JSON: run "
                                          "python -m reports")


def test_a_changed_figure_shows_in_the_page():
    result = json.loads(rendered.TRANSMISSION.read_text())
    before = rendered.pages({rendered.TRANSMISSION: result})
    changed = copy.deepcopy(result)
    changed["summary"]["a_held_out_files"]["physics"]["whole"]["torque_rmse_mNm"]["mean"] += 1.0
    after = rendered.pages({rendered.TRANSMISSION: changed})
    assert after[rendered.IDENTIFICATION] != before[rendered.IDENTIFICATION]
    assert after[rendered.README] != before[rendered.README]


@pytest.mark.parametrize("path", sorted({p for b in rendered.BLOCKS
                                         for p in rendered.block_jsons(b[2])}))
def test_rendered_jsons_name_no_absolute_path(path):
    text = path.read_text()
    for marker in ('"/work/', '"/home/', '"/tmp/', '"/root/'):
        assert marker not in text, f"{path.name} names an absolute path ({marker})"


def test_missing_markers_are_refused():
    with pytest.raises(SystemExit, match="marker"):
        rendered.splice("no markers here", "transmission-tables", "body")


def _committed_text_files():
    for folder in ("results", "docs"):
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix in (".json", ".md", ".txt"):
                yield path
    yield ROOT / "README.md"


@pytest.mark.parametrize("path", list(_committed_text_files()), ids=lambda p: p.name)
def test_committed_results_and_docs_name_no_machine_path(path):
    found = MACHINE_PATH.search(path.read_text())
    assert found is None, f"{path.relative_to(ROOT)} names a machine path ({found.group()})"


MACHINE_PATH = re.compile(r"(?<![\w.])/(work|tmp|home|root)/")
"""An absolute path into a machine's folders (not a relative one that has such a folder in it,
like ``runs/x/work/data``)."""


def test_the_machine_path_pattern_tells_absolute_from_relative():
    assert MACHINE_PATH.search('"data": "/tmp/tmpcanm8kxs/sim"')
    assert MACHINE_PATH.search("read from `/work/main/results`")
    assert not MACHINE_PATH.search('"data": "runs/learning_curve/scale_0.05/work/data"')
    assert not MACHINE_PATH.search("../shared/data/wpi_psm")


TYPED_FIGURE = re.compile(r"(?<![\w.])(?<!simulator )\d+\.\d+|\d+(?:\.\d+)? ?%|\b\d+(?:\.\d+)?x\b")
"""A measured figure as the pages write one: a decimal, a percentage or a ratio. Integers
(seeds, sections, patience) and simulator versions are settings, not figures."""


def typed_figures(text: str) -> list[str]:
    """Lines of a page that carry a figure outside its rendered blocks, its code fences and its
    inline code."""
    found, in_block, in_fence = [], False, False
    for line in text.splitlines():
        if line.startswith("```"):
            in_fence = not in_fence
        elif re.match(r"<!-- [\w-]+: rendered by ", line):
            in_block = True
        elif line.startswith("<!-- end "):
            in_block = False
        elif not (in_block or in_fence) and TYPED_FIGURE.search(re.sub(r"`[^`]*`", "", line)):
            found.append(line)
    return found


@pytest.mark.parametrize("page", [rendered.RESULTS, rendered.README, ROOT / "docs" / "history.md",
                                  ROOT / "results" / "README.md"],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_no_figure_is_typed_outside_a_rendered_block(page):
    typed = typed_figures(page.read_text())
    assert not typed, (f"{page.relative_to(ROOT)} types figures outside its rendered blocks; "
                       "render them from their JSON (reports/results_page.py):\n"
                       + "\n".join(typed))


def test_a_planted_figure_is_found_and_a_rendered_one_is_not():
    name = "ports-findings"
    begin, end = rendered.markers(name)
    page = f"Prose.\n{begin}\nFz 2.56 ± 0.31 %, 0.84x\n{end}\nSeeds 1 2 3, patience 10.\n"
    assert typed_figures(page) == []
    assert typed_figures(page + "The hybrid's Fz is 2.56 %.\n") == ["The hybrid's Fz is 2.56 %."]
    assert typed_figures(page + "Laterally 0.34x the transformer.\n")
    assert typed_figures(page + "On simulator 2.1 the bench...\n") == []
    assert typed_figures("```bash\npsmforce reproduce --scale 0.05\n```\n`--scale 0.05`\n") == []


def test_a_stale_figure_in_a_block_fails_the_render_check():
    doc = rendered.RESULTS.read_text()
    begin, _ = rendered.markers("ports-findings")
    planted = doc.replace(begin, begin + "\n- planted: Fz 9.99 %", 1)
    assert planted != doc
    assert rendered.pages()[rendered.RESULTS] == doc != planted


def test_every_committed_run_page_is_rendered_whole():
    whole = {page.relative_to(ROOT).as_posix() for page, _, _ in rendered.WHOLE_PAGES}
    committed = {p.relative_to(ROOT).as_posix() for p in (ROOT / "results").rglob("results.md")}
    assert committed - whole == {"results/history/run_D/results.md"}  # its JSON is older
    assert "results/learning_curve/README.md" in whole


def test_a_stale_run_page_fails_the_render_check():
    page, json_path, _ = rendered.WHOLE_PAGES[0]
    result = json.loads(json_path.read_text())
    changed = copy.deepcopy(result)
    changed["automated"]["causal"]["Hybrid (ours)"]["Fz"]["nrmse_pct"]["mean"] += 1.0
    assert rendered.pages({json_path: changed})[page] != page.read_text()


def test_the_learning_curve_figures_are_the_ones_its_json_names():
    folder = ROOT / "results" / "learning_curve"
    curve = json.loads((folder / "learning_curve.json").read_text())
    assert sorted(curve["figures"]) == sorted(p.name for p in folder.glob("*.png"))
