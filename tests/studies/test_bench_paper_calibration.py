"""studies/bench_paper_calibration.py: rows, verdicts and the rendered block (:func:`table`)
from a reproduce result, without training anything."""

import copy

import pytest

from studies import bench_paper_calibration as cal


def _result(label_values: dict, seeds=(1,)) -> dict:
    paper = {}
    for label, values in label_values.items():
        paper[label] = {a: {"nrmse_pct": {"mean": v, "std": 0.0, "n": 1},
                            "rmse_n": {"mean": v / 100 * 8.0, "std": 0.0, "n": 1},
                            "range_n": {"mean": 8.0, "std": 0.0, "n": 1}}
                        for a, v in zip(cal.AXES, values)}
    return {"automated": {"paper": paper}, "call": {"seeds": list(seeds)},
            "training": {}, "floor": {"automated": {"paper": {
                a: {"nrmse_pct": {"mean": 0.5}, "range_n": {"mean": 8.0}} for a in cal.AXES}}}}


def test_rows_score_the_calibration_models_only_against_their_family():
    res = _result({"FCN": (1.93, 1.0, 4.6), "Hybrid (ours)": (0.1, 0.1, 0.1),
                   "Transformer (paper)": (1.0, 1.0, 1.0)})
    rows = cal.rows("x", 1.0, res)
    assert [r["model"] for r in rows] == ["fcn", "transformer"]        # never the hybrid
    assert [r["role"] for r in rows] == ["calibration", "held_out"]
    r = rows[0]
    assert r["ratio"]["Fx"] == pytest.approx(1.0)
    assert r["in_band"] == {"Fx": True, "Fy": False, "Fz": False}   # 1.0/1.59 = 0.63, 4.6/2.99 = 1.54


def test_verdict_and_block():
    data = {}
    good = _result({"FCN": (1.9, 1.6, 3.0), "MultiRocket-Hydra": (2.2, 2.5, 2.7)})
    data = cal.merge(data, cal.rows("2.3", 1.0, good), cal.floor_rows("2.3", 1.0, good))
    lstm = _result({"LSTM (Yang et al.)": (4.0, 4.4, 4.0)})
    data = cal.merge(data, cal.rows("2.3b", 0.25, lstm), cal.floor_rows("2.3b", 0.25, lstm))
    v = cal.verdict(data, "2.3")
    assert v["models_in_band"] and not v["met_at_paper_budget"]
    assert v["not_at_paper_budget"] == ["lstm"] and "lstm" in v["substituted"]
    data.update({"paper": cal.PAPER, "band": list(cal.BAND), "verdicts": {"2.3": v},
                 "substitutes": cal.SUBSTITUTES})
    text = cal.table(data)
    assert "| LSTM (Yang et al.), on 2.3b's bench | 0.25 (below the paper's budget)" in text
    assert "no published source" in text
    # the version's own row at the paper's budget replaces the substitute, in verdict and table
    own = _result({"LSTM (Yang et al.)": (5.0, 5.0, 3.0)})
    data = cal.merge(data, cal.rows("2.3", 1.0, own), cal.floor_rows("2.3", 1.0, own))
    v = cal.verdict(data, "2.3")
    assert v["met_at_paper_budget"] and v["substituted"] == {}
    text = cal.table({**data, "verdicts": {"2.3": v}})
    assert "on 2.3b's bench" not in text and "| LSTM (Yang et al.) | 1 |" in text
    with pytest.raises(SystemExit, match="design seeds"):
        cal.main(["--version", "2.3", "--seeds", "101", "--json", "/nonexistent/x.json"])


def test_every_write_stamps_the_command_settings_and_verdicts():
    good = _result({"FCN": (1.9, 1.6, 3.0)})
    data = cal.merge({}, cal.rows("2.3", 1.0, good), cal.floor_rows("2.3", 1.0, good))
    out = cal.stamped(data, ["--render-only", "--json", "x.json"])
    assert out is data
    assert data["command"] == "python studies/bench_paper_calibration.py --render-only --json x.json"
    assert data["band"] == list(cal.BAND) and data["paper"] == cal.PAPER
    assert {"reference_2.1", "substitutes", "notes", "candidates", "remount_ranges",
            "registered"} <= set(data)
    assert data["verdicts"] == {"2.3": cal.verdict(data, "2.3")}


def test_the_held_out_transformer_is_checked_but_never_enters_the_band_rule():
    fcn = _result({"FCN": (1.9, 1.6, 3.0), "MultiRocket-Hydra": (2.2, 2.5, 2.7),
                   "LSTM (Yang et al.)": (4.0, 4.4, 4.0)})
    data = cal.merge({}, cal.rows("2.3", 1.0, fcn), cal.floor_rows("2.3", 1.0, fcn))
    v = cal.verdict(data, "2.3")
    assert v["met_at_paper_budget"] and v["transformer_held_out"].startswith("not checked")
    # far outside the band: reported as a miss of the check, the calibration verdict unchanged
    tr = _result({"Transformer (paper)": (0.5, 1.3, 2.2)})
    data = cal.merge(data, cal.rows("2.3", 1.0, tr), cal.floor_rows("2.3", 1.0, tr))
    v = cal.verdict(data, "2.3")
    assert v["met_at_paper_budget"] and v["misses"] == []
    check = v["transformer_held_out"]
    assert check["misses"] == ["Fx (0.34x)"] and not check["met"]
    lateral = v["fcn_worse_than_transformer_laterally"]
    assert lateral["fcn_over_transformer"]["Fx"] == pytest.approx(3.8)
    assert lateral["fcn_over_transformer"]["Fy"] == pytest.approx(1.6 / 1.3)
    assert lateral["met"]
    data.update({"paper": cal.PAPER, "band": list(cal.BAND), "verdicts": {"2.3": v}})
    text = cal.table(data)
    assert "| Transformer (paper) (held out) | 1 |" in text
    assert "outside the band: Fx (0.34x)" in text
    assert "(the robot's 1.33x / 1.21x): worse laterally, as on the robot." in text
    # the FCN level with it laterally: not as on the robot
    tr = _result({"Transformer (paper)": (1.9, 1.7, 2.2)})
    data = cal.merge(data, cal.rows("2.3", 1.0, tr), cal.floor_rows("2.3", 1.0, tr))
    assert not cal.verdict(data, "2.3")["fcn_worse_than_transformer_laterally"]["met"]
    with pytest.raises(SystemExit, match="never on candidates"):
        cal.main(["--candidates", "2.3a", "--models", "transformer", "--json",
                  "/nonexistent/x.json"])


def _comparison(by_seed: dict) -> dict:
    """A published comparison's records of simulator 2.3 at the paper's budget: seed -> model ->
    paper-metric NRMSE (Fx, Fy, Fz)."""
    return {"records": {"2.3": {"1": {str(seed): {m: {"nrmse_pct": {"paper": dict(zip(
        cal.AXES, values))}} for m, values in models.items()}
        for seed, models in by_seed.items()}}}}


def test_without_its_own_row_the_held_out_check_reads_the_published_comparisons_records(
        tmp_path, capsys):
    fcn = _result({"FCN": (1.9, 1.6, 3.0), "MultiRocket-Hydra": (2.2, 2.5, 2.7),
                   "LSTM (Yang et al.)": (4.0, 4.4, 4.0)})
    data = cal.merge({}, cal.rows("2.3", 1.0, fcn), cal.floor_rows("2.3", 1.0, fcn))
    # seed 103 has no transformer yet: only 101 and 102 are paired
    comparison = _comparison({101: {"transformer": (1.0, 1.2, 2.0), "fcn": (2.0, 1.0, 3.0)},
                              102: {"transformer": (2.0, 1.4, 2.4), "fcn": (2.0, 2.0, 3.0)},
                              103: {"fcn": (9.0, 9.0, 9.0)}})
    v = cal.verdict(data, "2.3", comparison)
    check = v["transformer_held_out"]
    assert check["seeds"] == [101, 102] and check["source"] == cal.COMPARISON_SOURCE
    assert check["ratio"]["Fx"] == pytest.approx(1.5 / 1.45)
    assert check["ratio"]["Fy"] == pytest.approx(1.3 / 1.31) and check["met"]
    lateral = v["fcn_worse_than_transformer_laterally"]
    assert lateral["fcn_over_transformer"]["Fx"] == pytest.approx(2.0 / 1.5)
    assert lateral["fcn_over_transformer"]["Fy"] == pytest.approx(1.5 / 1.3) and lateral["met"]
    assert v["met_at_paper_budget"]            # the band rule reads the calibration rows only
    # no seed with both: not checked, and says what is missing
    v = cal.verdict(data, "2.3", _comparison({103: {"fcn": (2.0, 2.0, 3.0)}}))
    assert "nor has the published comparison a record of it" in v["transformer_held_out"]
    # a row of the calibration's own wins over the records
    tr = _result({"Transformer (paper)": (0.5, 1.3, 2.2)})
    own = cal.merge(copy.deepcopy(data), cal.rows("2.3", 1.0, tr),
                    cal.floor_rows("2.3", 1.0, tr))
    assert cal.verdict(own, "2.3", comparison)["transformer_held_out"]["seeds"] == [1]
    # --verdicts-only: drawn again and written, the command that wrote the rows kept
    path, records = tmp_path / "cal.json", tmp_path / "comparison.json"
    cal.write_json(path, cal.stamped(data, ["--merge", "part.json"]))
    cal.write_json(records, comparison)
    cal.main(["--verdicts-only", "--json", str(path), "--comparison", str(records)])
    written = cal.read_json(path, "x")
    assert written["verdicts"]["2.3"]["transformer_held_out"]["seeds"] == [101, 102]
    assert "python studies/bench_paper_calibration.py --merge part.json" in written["commands"]
    assert "; the published comparison's records (fresh seeds)): 1.03x" in capsys.readouterr().out
    records.write_text("{")
    with pytest.raises(SystemExit, match="comparison.json: not JSON"):
        cal.main(["--verdicts-only", "--json", str(path), "--comparison", str(records)])
    before = path.read_text()
    for bad, says in (({"records": {"2.3": {"1": []}}}, "not seed -> model -> record"),
                      ({"records": {"2.3": {"1": {"101": {"transformer": {}, "fcn": {}}}}}},
                       "lacks its paper-metric NRMSE")):
        cal.write_json(records, bad)
        with pytest.raises(SystemExit, match=says):
            cal.main(["--verdicts-only", "--json", str(path), "--comparison", str(records)])
        assert path.read_text() == before                 # nothing written
