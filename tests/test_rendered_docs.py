"""The figures a reader sees in the rendered blocks (docs/identification.md, the README) are
their committed JSONs', rendered; the JSONs name no machine's absolute path."""

from __future__ import annotations

import copy
import importlib.util
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("rendered_docs",
                                               ROOT / "benchmarks" / "rendered_docs.py")
rendered = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rendered)


def test_pages_are_what_their_jsons_render():
    for page, text in rendered.pages().items():
        assert page.read_text() == text, (f"{page.relative_to(ROOT)} differs from its JSON: run "
                                          "python benchmarks/rendered_docs.py")


def test_a_changed_figure_shows_in_the_page():
    result = json.loads(rendered.TRANSMISSION.read_text())
    before = rendered.pages({rendered.TRANSMISSION: result})
    changed = copy.deepcopy(result)
    changed["summary"]["a_held_out_files"]["physics"]["whole"]["torque_rmse_mNm"]["mean"] += 1.0
    after = rendered.pages({rendered.TRANSMISSION: changed})
    assert after[rendered.IDENTIFICATION] != before[rendered.IDENTIFICATION]
    assert after[rendered.README] != before[rendered.README]


@pytest.mark.parametrize("path", sorted({b[2] for b in rendered.BLOCKS}))
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
