"""studies/sim_calibration.py writes standard JSON: a folder driven at one frequency has no
friction frequency ratio, written null with its reason (never the non-standard ``NaN``), and the
committed cable-law JSON holds no ``NaN``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from studies.sim_calibration import json_ready

ROOT = Path(__file__).resolve().parents[2]
CABLE_LAW_JSON = ROOT / "results" / "benchmarks" / "sim_calibration_cable_law.json"


def _figures(ratio, hz):
    return {"friction_frequency_ratio": ratio, "frequencies_hz": hz, "loop_width_fraction": 0.05}


def test_one_frequency_folder_writes_null_with_its_reason():
    c = {"sessions": {
        "roll": {"real": _figures(math.nan, [0.3, 0.3]),
                 "sim": {"2.2": _figures(math.nan, [0.3, 0.3])}},
        "flat": {"real": _figures(0.98, [0.1, 0.5]), "sim": {"2.2": _figures(1.0, [0.1, 0.5])}}}}
    out = json_ready(c)
    for figs in (out["sessions"]["roll"]["real"], out["sessions"]["roll"]["sim"]["2.2"]):
        assert figs["friction_frequency_ratio"] is None
        assert "one drive frequency" in figs["friction_frequency_ratio_note"]
        assert "0.3 Hz" in figs["friction_frequency_ratio_note"]
    assert out["sessions"]["flat"] == c["sessions"]["flat"]          # measured ratios untouched
    json.dumps(out, allow_nan=False)                                 # standard JSON
    assert math.isnan(c["sessions"]["roll"]["real"]["friction_frequency_ratio"])  # not mutated


def test_any_other_non_finite_number_is_refused():
    c = {"sessions": {"x": {"real": {**_figures(1.0, [0.1, 0.5]), "slope": math.inf},
                            "sim": {}}}}
    with pytest.raises(ValueError, match="slope"):
        json_ready(c)


@pytest.mark.skipif(not CABLE_LAW_JSON.is_file(), reason="no committed cable-law JSON")
def test_the_committed_json_is_standard():
    def refuse(name):
        raise ValueError(f"{CABLE_LAW_JSON.name} holds {name}")

    json.loads(CABLE_LAW_JSON.read_text(), parse_constant=refuse)
