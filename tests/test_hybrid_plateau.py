"""benchmarks/hybrid_plateau.py: each variant changes the hybrid it names and nothing else, and a
missing learning-curve run is refused with a message, not a traceback."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.hybrid_plateau import (  # noqa: E402
    INSERTION_STATE,
    RAW_HEX10,
    VARIANTS,
    _inputs,
    main,
)
from hybrid.data import NO_BASE  # noqa: E402
from hybrid.recipes import recipe  # noqa: E402

DEFAULT = recipe("hybrid").inputs(None, True)


def test_unchanged_inputs_are_the_recipes():
    assert _inputs({}) is None
    for name in ("default", "wide_64", "dropout_0", "attention_window_1", "batch_4_chunks"):
        assert VARIANTS[name][2] == {}


def test_input_changes_touch_only_what_they_name():
    dropped = _inputs(VARIANTS["no_insertion_state"][2])
    assert set(DEFAULT.features) - set(dropped.features) == set(INSERTION_STATE)
    assert dropped.base == DEFAULT.base
    added = _inputs(VARIANTS["plus_raw_hex10"][2])
    assert added.features == DEFAULT.features + RAW_HEX10 and added.base == DEFAULT.base
    no_base = _inputs(VARIANTS["no_lateral_base"][2])
    assert no_base.features == DEFAULT.features
    assert no_base.base[:2] == (NO_BASE, NO_BASE) and no_base.base[2] == DEFAULT.base[2]


def test_missing_run_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--work", str(tmp_path), "--json", str(tmp_path / "out.json")])
    assert exit_.value.code == 2
    assert "no learning-curve run at scale 0.5" in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()
