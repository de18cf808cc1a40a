"""What the studies share (psmforce/experiments/report.py): a kept step's JSON is read back, not
computed again."""

from __future__ import annotations

import json

import pytest

from psmforce.experiments.report import kept_json


def test_a_kept_step_is_computed_once_then_read_back(tmp_path):
    path = tmp_path / "records" / "step.json"
    calls = []

    def compute():
        calls.append(1)
        return {"nrmse_pct": 1.5}
    assert kept_json(path, compute) == {"nrmse_pct": 1.5}
    assert json.loads(path.read_text()) == {"nrmse_pct": 1.5}
    assert kept_json(path, compute) == {"nrmse_pct": 1.5} and len(calls) == 1


def test_a_step_that_fails_or_gives_nan_leaves_nothing_kept(tmp_path):
    path = tmp_path / "step.json"
    with pytest.raises(ValueError):
        kept_json(path, lambda: {"nrmse_pct": float("nan")})
    assert not path.exists()


@pytest.mark.parametrize("content", ['{"nrmse_pct": 1.5', '{"nrmse_pct": NaN}', "\xff"])
def test_a_kept_step_that_is_not_json_is_refused_naming_it_and_left_as_it_was(tmp_path, content):
    path = tmp_path / "step.json"
    path.write_bytes(content.encode("latin-1"))
    with pytest.raises(ValueError, match="step.json"):
        kept_json(path, lambda: {"nrmse_pct": 1.5})
    assert path.read_bytes() == content.encode("latin-1")


def test_a_kept_step_that_is_a_folder_is_refused_before_computing(tmp_path):
    (tmp_path / "step.json").mkdir()

    def compute():
        raise AssertionError("computed although the kept step cannot be read")
    with pytest.raises(ValueError, match="not a regular file"):
        kept_json(tmp_path / "step.json", compute)
