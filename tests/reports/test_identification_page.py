"""The transmission's per-session table: every set tried, the worst ratio, the bound named."""

from __future__ import annotations

import pytest

from reports.identification_page import transmission_per_session_table


def _score(v):
    return {"whole": {"torque_rmse_mNm": v}, "closing": {"torque_rmse_mNm": v}}


def _result():
    kept = ["pretension_torque", "pair_asymmetry", "torque_bias", "angle_offset"]
    folders = {"src": {"in_session": _score(5.0)},
               "a": {"recalibrated": _score(6.0), "in_session": _score(5.0),
                     "per_session": dict.fromkeys(kept, 0.1), "per_session_at_bound": []},
               "b": {"recalibrated": _score(9.0), "in_session": _score(4.0),
                     "per_session": {**dict.fromkeys(kept, 0.1), "pair_asymmetry": 0.95},
                     "per_session_at_bound": ["pair_asymmetry"]}}
    row = {"recalibrated": _score(8.0), "calibration_leave_one_file_out": _score(3.0)}
    cands = {"before": {"per_session": ["pretension_torque", "torque_bias", "angle_offset"],
                        "folders": {"a": row, "b": row}},
             "kept": {"per_session": kept, "folders": {"a": row, "b": {**row, "recalibrated":
                                                                       _score(6.0)}}}}
    return {"folders": folders, "per_session_candidates": cands, "model": {"per_session": kept}}


def test_each_set_gets_its_ratios_and_the_bound_is_named():
    text = transmission_per_session_table(_result())
    before = next(line for line in text.splitlines() if line.startswith("| before: pretension"))
    assert "1.60x / 1.60x | 2.00x / 2.00x | 2.00x |" in before        # worst of 8/5 and 8/4
    kept = next(line for line in text.splitlines() if line.startswith("| kept: + pair_asym"))
    assert kept.endswith("| 1.60x / 1.60x | 1.50x / 1.50x | 1.60x |")
    assert "| b | 0.1 | 0.95 | 0.1 | 0.1 | pair_asymmetry |" in text
    assert "| a | 0.1 | 0.1 | 0.1 | 0.1 | none |" in text
    assert "| src" not in text                                   # the source has no recalibration


def test_a_json_without_the_candidates_is_refused_with_the_command():
    result = _result()
    result["per_session_candidates"] = None
    with pytest.raises(ValueError, match="rerun `python studies/transmission_transfer.py"):
        transmission_per_session_table(result)
