"""studies/comparison.py: the point and its table from a reproduce result (nothing trained), and
the seeds it refuses."""

import pytest

from studies import comparison


def _result(seed: int, errors: dict, converged=None) -> dict:
    """A one-seed reproduce result: per model one causal error per axis (the paper metric
    twice it), its per-condition RMSE a hundredth of it."""
    from psmforce.experiments.plan import plan
    per_seed = {mt: {plan(m).label: [{a: k * v for a in comparison.AXES}]
                     for m, v in errors.items()} for mt, k in (("causal", 1), ("paper", 2))}
    training = {f"{m} full 1.0 seed {seed}": {"epochs_run": 30, "converged": (
        converged or {}).get(m, True), "stopped_by": "patience", "seconds": 5.0}
        for m in errors}
    by_condition = {"Free": {"causal": {plan(m).label: {a: {"rmse_n": {
        "mean": 0.01 * v, "std": 0.0}} for a in comparison.AXES} for m, v in errors.items()}}}
    return {"automated_nrmse_pct_per_seed": per_seed, "training": training,
            "automated_by_condition": by_condition,
            "call": {"models": list(errors), "seeds": [seed], "device": "cpu"},
            "benches": {f"automated seed {seed}": "2.3"},
            "code": {"psmforce": "0.0.test", "git_commit": "abc1234"},
            "machine": {"cpu": "a test CPU", "cpu_capability": "AVX2"}}


def _results(errors: dict, converged=None) -> dict:
    """``{seed: {model: record}}`` of seeds 101-103, each model's errors listed by seed."""
    records = {}
    for k, seed in enumerate((101, 102, 103)):
        records.update(comparison.records_from_results(_result(
            seed, {m: vals[k] for m, vals in errors.items()}, converged)))
    return records


def test_the_point_pairs_the_hybrid_with_each_model_and_keeps_the_unconverged_out():
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [2.0, 4.1, 2.9],
                    "fcn": [1.0, 2.1, 1.4]}, converged={"fcn": False})
    p = comparison.point(res, "2.3", 0.1)
    hybrid = p["models"]["hybrid"]["summary"]["causal"]["Fx"]
    assert hybrid["mean"] == pytest.approx(1.5) and hybrid["sd"] == pytest.approx(0.5)  # ddof 1
    t = p["paired"]["hybrid"]["transformer"]["causal"]["Fx"]
    assert t["verdict"] == "ahead" and t["high"] < 1.0            # about 0.5x on every seed
    assert p["not_converged"] == ["fcn"] and "fcn" not in p["paired"]["hybrid"]
    assert p["not_compared"] == ["fcn"]
    text = comparison.table({"points": {"2.3 scale 0.1": p}})
    assert "| hybrid / Transformer (paper) | 0.5" in text and "| FCN |" in text
    assert "| NO |" in text and "Not compared" in text
    assert "| model | Free Fx | Free Fy | Free Fz |" in text
    assert "| Transformer (paper) | 0.030 ± 0.011 |" in text        # 2.0, 4.1, 2.9 / 100


def test_a_tie_when_the_interval_holds_one():
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [0.8, 2.5, 1.5]})
    p = comparison.point(res, "2.3", 0.1)
    r = p["paired"]["hybrid"]["transformer"]["causal"]["Fx"]
    assert r["low"] < 1.0 < r["high"] and r["verdict"] == "tie"


def test_design_and_undeclared_seeds_are_refused(tmp_path):
    for seeds in (["1", "101"], ["999"]):
        with pytest.raises(SystemExit):
            comparison.main(["--scale", "0.1", "--seeds", *seeds, "--json",
                             str(tmp_path / "c.json"), "--work", str(tmp_path)])
    assert not (tmp_path / "c.json").exists()


def test_a_results_file_that_is_not_a_comparison_is_refused_in_one_line_and_kept(tmp_path,
                                                                                  capsys):
    bad = tmp_path / "c.json"
    for text in ('{"points": [1]', '{"points": [1]}', '[1]'):
        bad.write_text(text)
        assert comparison.main(["--scale", "0.1", "--json", str(bad), "--work",
                                str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert "c.json: not a comparison's results" in err and "Traceback" not in err
        assert bad.read_text() == text


def test_the_first_screen_states_each_point_with_its_interval_and_the_bench_against_the_robot():
    from reports.readme_page import fresh_comparison
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [0.8, 2.5, 1.5],
                    "fcn": [1.0, 2.1, 1.4]}, converged={"fcn": False})
    p = comparison.point(res, "2.3", 0.1)
    calibration = {"rows": [{"candidate": "2.3", "paper_budget": True, "label": "FCN",
                             "model": "fcn", "seeds": [1],
                             "ratio": {"Fx": 0.8, "Fy": 1.1, "Fz": 0.9}}],
                   "verdicts": {"2.3": {"transformer_held_out": "not checked"}}}
    text = fresh_comparison({"points": {"2.3 scale 0.1": p}}, calibration)
    assert "| hybrid / Transformer (paper) | 1.00x [" in text and "] tie" in text  # holds 1
    assert "| hybrid / FCN" not in text and "| FCN (NOT converged) |" in text
    assert ("The hybrid with its causal network (`hybrid`) is against the Transformer (paper) "
            "tied on every axis on both metrics.") in text
    assert "NOT converged: fcn" in text and "Not compared (a training did not stop early): fcn" \
        in text
    assert "FCN 0.80x / 1.10x / 0.90x" in text and "held-out check, not run yet" in text
    # MultiRocket-Hydra's robot figure is the issue's (studies.bench_paper_calibration.published)
    issue_given = {**calibration, "rows": calibration["rows"] + [
        {**calibration["rows"][0], "model": "rocket", "label": "MultiRocket-Hydra"}]}
    assert ("FCN 0.80x / 1.10x / 0.90x; MultiRocket-Hydra 0.80x / 1.10x / 0.90x (against the "
            "issue's figure, which no publication gives)") in fresh_comparison(
        {"points": {"2.3 scale 0.1": p}}, issue_given)
    assert "not measured yet, so nothing is claimed there: scale 0.25, 1 (" in text
    started = fresh_comparison({"points": {"2.3 scale 0.1": p},
                                "records": {"2.3": {"1": {"101": {"fcn": {}}}}}}, calibration)
    assert "In progress for simulator 2.3, nothing compared there yet: scale 1 (" in started
    assert "not measured yet, so nothing is claimed there: scale 0.25 (" in started
    assert "No comparison on fresh seeds yet" in fresh_comparison({"points": {}})


def test_the_first_screen_words_each_verdict_by_axis_and_metric():
    from reports.readme_page import fresh_comparison
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [2.0, 4.1, 2.9]})
    p = comparison.point(res, "2.3", 0.1)
    p["paired"]["hybrid"]["transformer"]["paper"]["Fy"]["verdict"] = "behind"
    text = fresh_comparison({"points": {"2.3 scale 0.1": p}})
    assert ("against the Transformer (paper) causal ahead on every axis; paper metric ahead on "
            "Fx and Fz, behind on Fy.") in text


def test_a_record_names_the_code_and_the_machine_that_trained_it():
    """The package version, commit and machine reproduce reports ride in each record; a result
    from before it reported them gives None, not an error."""
    result = _result(101, {"fcn": 1.0, "hybrid": 0.5})
    records = comparison.records_from_results(result)[101]
    assert {r["code"]["git_commit"] for r in records.values()} == {"abc1234"}
    assert {r["machine"]["cpu_capability"] for r in records.values()} == {"AVX2"}
    del result["code"], result["machine"]
    old = comparison.records_from_results(result)[101]["fcn"]
    assert old["code"] is None and old["machine"] is None


def test_records_add_up_across_fresh_work_folders_and_the_point_waits_for_every_one(
        tmp_path, monkeypatch, capsys):
    """Each (seed, model) training is kept in the JSON as it ends; a run on a machine without the
    work folder trains only what the JSON lacks; the point appears once all are in; a point built
    before records were kept stays."""
    import json

    import psmforce.experiments.reproduce as reproduce_module
    from psmforce.experiments.seeds import COMPARISON_SEEDS
    declared = list(COMPARISON_SEEDS[0.25])
    calls = []

    def fake_reproduce(out, scale, seeds, models, **kw):
        calls.append((seeds, models))
        return _result(seeds[0], {m: 1.0 + 0.1 * seeds[0] % 7 + (m == "hybrid") * -0.5
                                  for m in models})
    monkeypatch.setattr(reproduce_module, "reproduce", fake_reproduce)
    out = tmp_path / "c.json"
    old = comparison.point(_results({m: [1.0, 2.0, 1.5] for m in comparison.MODELS}), "2.3", 0.1)
    out.write_text(json.dumps({"points": {"2.3 scale 0.1": old}}))
    first = ["--scale", "0.25", "--json", str(out), "--work", str(tmp_path / "a")]
    assert comparison.main(first + ["--seeds", *map(str, declared[:2])]) == 0
    assert "part done" in capsys.readouterr().out
    saved = json.loads(out.read_text())
    assert sorted(saved["records"]["2.3"]["0.25"]) == sorted(map(str, declared[:2]))
    assert "2.3 scale 0.25" not in saved["points"]
    assert saved["points"]["2.3 scale 0.1"] == json.loads(json.dumps(old))
    calls.clear()   # another machine: no work folder; the first two seeds are in the JSON
    assert comparison.main(["--scale", "0.25", "--json", str(out), "--work",
                            str(tmp_path / "b"), "--models", "hybrid", "fcn"]) == 0
    assert [c[0] for c in calls] == [(s,) for s in declared[2:]]
    assert "2.3 scale 0.25" not in json.loads(out.read_text())["points"]   # models missing
    calls.clear()
    assert comparison.main(["--scale", "0.25", "--json", str(out), "--work",
                            str(tmp_path / "c")]) == 0
    assert all(set(models) == set(comparison.MODELS) - {"hybrid", "fcn"}
               for _, models in calls) and len(calls) == len(declared) - 2
    point = json.loads(out.read_text())["points"]["2.3 scale 0.25"]
    assert point["seeds"] == sorted(declared) and point["paired"]["hybrid"]["transformer"][
        "causal"]["Fx"]["verdict"] == "ahead"
    assert "| hybrid / Transformer (paper) |" in capsys.readouterr().out


def test_the_shipped_model_and_the_hybrid_are_each_paired_with_every_other_model_once():
    res = _results({"hybrid": [1.0, 2.0, 1.5], "transformer": [2.0, 4.1, 2.9],
                    "hybrid_transformer": [0.5, 1.0, 0.8], "fcn": [1.0, 2.1, 1.4]})
    p = comparison.point(res, "2.3", 0.25)
    assert list(p["paired"]) == ["hybrid_transformer", "hybrid"]
    assert set(p["paired"]["hybrid_transformer"]) == {"hybrid", "transformer", "fcn"}
    assert set(p["paired"]["hybrid"]) == {"transformer", "fcn"}    # its pair with ours is ours
    assert p["paired"]["hybrid_transformer"]["hybrid"]["causal"]["Fx"]["verdict"] == "ahead"
    text = comparison.table({"points": {"2.3 scale 0.25": p}})
    assert "| hybrid_transformer / Transformer (paper) | 0.2" in text
    assert "| hybrid / Transformer (paper) | 0.5" in text


def test_a_point_written_before_the_shipped_model_keeps_the_hybrids_pairs(tmp_path):
    """The scale 0.1 point held ``{model: pair}`` (the hybrid's); assembling reads it as the
    hybrid's pairs, its figures unchanged."""
    old = comparison.point(_results({"hybrid": [1.0, 2.0, 1.5],
                                     "transformer": [2.0, 4.1, 2.9]}), "2.3", 0.1)
    flat = {**old, "paired": old["paired"]["hybrid"]}
    out = comparison.assemble(tmp_path / "records", tmp_path / "none.json", "2.3",
                              {"points": {"2.3 scale 0.1": flat}})
    assert out["points"]["2.3 scale 0.1"]["paired"] == old["paired"]
    assert comparison.subject_keyed(old["paired"]) == old["paired"]


def test_a_scale_without_its_point_lists_what_is_trained_and_compares_nothing():
    record = comparison.records_from_results(_result(101, {"fcn": 1.0}))[101]["fcn"]
    text = comparison.table({"points": {}, "records": {"2.3": {"1": {"101": {"fcn": record},
                                                                     "999": {"lstm": record}}}}})
    assert ("Simulator 2.3, scale 1: in progress, no point yet (nothing compared). Trained so "
            "far: fcn on 101; declared seeds 101, 102, 103; no record yet: hybrid, transformer, "
            "rocket, lstm, hybrid_transformer.") in text      # an undeclared seed is not counted
    assert "| hybrid" not in text
    record = {**record, "training": {**record["training"], "converged": False}}
    assert "fcn on 101 (NOT converged on 101)" in comparison.table(
        {"points": {}, "records": {"2.3": {"1": {"101": {"fcn": record}}}}})
    # at the paper's amount of data, each model with a published figure against it (paper
    # metric 2.0 here over 1.93 / 1.59 / 2.99)
    assert ("against the paper's robot (its Table III; mean over the seeds so far over the "
            "robot's figure, Fx / Fy / Fz; the calibration's band [0.67, 1.5]): FCN 1.04x / "
            "1.26x / 0.67x (seed 101; Fz outside the band).") in text   # 0.669: out
    # a figure the paper does not publish (MultiRocket-Hydra's, the issue's) is shown as such
    text = comparison.table({"points": {}, "records": {"2.3": {"1": {"101": {
        "fcn": record, "rocket": {**record, "training": {**record["training"],
                                                          "converged": True}}}}}}})
    assert ("MultiRocket-Hydra 0.89x / 0.81x / 0.74x (seed 101; against the issue's figure, "
            "which no publication gives; in band).") in text
    far = {**record, "nrmse_pct": {**record["nrmse_pct"], "paper": {"Fx": 4.0, "Fy": 2.0,
                                                                     "Fz": 2.0}}}
    assert "FCN 2.07x / 1.26x / 0.67x (seed 101; Fx, Fz outside the band)" in comparison.table(
        {"points": {}, "records": {"2.3": {"1": {"101": {"fcn": far}}}}})


def test_a_point_being_retrained_with_records_says_so_and_stands():
    old = comparison.point(_results({"hybrid": [1.0, 2.0, 1.5],
                                     "transformer": [2.0, 4.1, 2.9]}), "2.3", 0.1)
    record = comparison.records_from_results(_result(101, {"fcn": 1.0}))[101]["fcn"]
    result = {"points": {"2.3 scale 0.1": old}, "records": {"2.3": {"0.1": {"101": {
        "fcn": record}}}}}
    text = comparison.table(result)
    assert ("Simulator 2.3, scale 0.1: being retrained with a record per training; its point "
            "above, from earlier trainings, stands until every model has a record on every "
            "declared seed. Trained so far: fcn on 101; no record on every declared seed yet: "
            "hybrid, transformer, fcn, rocket, lstm, hybrid_transformer.") in text
    assert "| hybrid / Transformer (paper) |" in text     # the point is still shown
    assert "Against the standing point's" not in text   # fcn is not in the old point
    # a rerun of the hybrid on 101: the same figures, then one 1 % off on one axis
    same = comparison.records_from_results(_result(101, {"hybrid": 1.0}))[101]["hybrid"]
    result["records"]["2.3"]["0.1"]["101"]["hybrid"] = same
    assert ("(largest relative difference over seeds, metrics and axes): hybrid 0.") \
        in comparison.table(result)
    same["nrmse_pct"]["paper"]["Fy"] *= 1.01
    assert "metrics and axes): hybrid 1.0e-02." in comparison.table(result)
